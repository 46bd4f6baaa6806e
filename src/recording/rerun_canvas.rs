//! The [`Canvas`] that writes Rerun entities (docs/visualization.md), to an .rrd file, a
//! running viewer, or both.
//!
//! Robots produce most of the rows (a pose per event and per animation frame). Each robot is
//! one entity carrying several archetypes (marker, heading, trail, sensor), buffered as columns
//! and sent with `send_columns` in chunks of up to [`FLUSH_ROWS`] rows: a chunk costs a fixed
//! overhead in time and bytes, so a 1k-robot run must not make thousands of them per entity
//! family. A row only carries what changed; the other components are null there, so Rerun's
//! latest-at keeps showing their earlier values. Collision markers are grouped in entities of
//! [`COLLISION_GROUP`]. Rare drawings (messages, queries) are logged row by row. When a viewer
//! is connected, every buffer is also flushed each simulated second so the live view keeps up.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use nekosim_actors::world::geometry::{heading_vector, Point};
use nekosim_actors::world::RobotId;
use rerun::external::arrow::array::{ArrayRef, Float64Array, ListArray};
use rerun::external::arrow::buffer::NullBuffer;
use rerun::{
    archetypes, blueprint, ComponentDescriptor, RecordingStream, RecordingStreamBuilder,
    SerializedComponentBatch, SerializedComponentColumn, TimeColumn,
};

use super::{Canvas, Flight, Metrics, RecordingError, Rgb, Stamp, Target};

/// Rows buffered per entity before they are sent as one chunk.
pub const FLUSH_ROWS: usize = 4096;

/// Entity of robot `i`'s marker (`world/robots/3`).
pub fn robot_entity(i: RobotId) -> String {
    format!("world/robots/{i}")
}

/// The metric entities, in the order of [`Metrics`]' fields.
pub const METRICS: [&str; 4] = [
    "metrics/collisions",
    "metrics/messages_in_flight",
    "metrics/deliveries",
    "metrics/events_per_second",
];

/// The component holding a robot's exact pose `[x, y, angle]` as 64-bit floats (the drawn
/// positions are 32-bit, Rerun's point type).
pub fn pose_descriptor() -> ComponentDescriptor {
    ComponentDescriptor::partial("nekosim.Pose:pose").with_archetype("nekosim.Pose".into())
}

/// Rows of one entity: simulated times, trace sequence numbers (when on the `event` timeline)
/// and data.
#[derive(Debug)]
struct Rows<T> {
    sim: Vec<f64>,
    seq: Vec<i64>,
    data: Vec<T>,
}

impl<T> Default for Rows<T> {
    fn default() -> Self {
        Self {
            sim: Vec::new(),
            seq: Vec::new(),
            data: Vec::new(),
        }
    }
}

impl<T> Rows<T> {
    fn push(&mut self, at: Stamp, v: T) {
        self.sim.push(at.t);
        if let Some(s) = at.seq {
            self.seq.push(s as i64);
        }
        self.data.push(v);
    }

    /// The time columns and the data, leaving the buffer empty.
    fn take(&mut self) -> (Vec<TimeColumn>, Vec<T>) {
        let mut times = vec![TimeColumn::new_duration_secs(
            "sim_time",
            std::mem::take(&mut self.sim),
        )];
        if !self.seq.is_empty() {
            times.push(TimeColumn::new_sequence(
                "event",
                std::mem::take(&mut self.seq),
            ));
        }
        (times, std::mem::take(&mut self.data))
    }

    fn len(&self) -> usize {
        self.data.len()
    }
}

/// Style of a robot's drawings: radius, colour, label.
#[derive(Clone, Debug)]
struct Style {
    radius: f64,
    colour: Rgb,
}

/// What one row of a robot's entity changes; `None` leaves a component null on that row.
#[derive(Clone, Debug, Default)]
struct RobotRow {
    pose: Option<(Point, f64)>,
    style: Option<Style>,
    /// The trail's corners.
    path: Option<Vec<Point>>,
    /// The current motion's destination (`Some(None)`: no motion).
    dest: Option<Option<Point>>,
    /// A push sensor's reach (`Some(None)`: none active).
    sensor: Option<Option<(Point, f64)>>,
}

/// One robot's buffered rows: event rows (on both timelines) and animation frames (on
/// `sim_time` only) are kept apart, since a chunk's rows share their timelines.
#[derive(Debug, Default)]
struct RobotRows {
    events: Rows<RobotRow>,
    /// Poses and sensors at animation frames, the bulk of a recording's rows.
    anim: Frames,
    /// Other drawings between events (none from [`super::Recorder`]).
    frames: Rows<RobotRow>,
    radius: f64,
}

/// A robot's animation frames (on `sim_time` only), buffered as the columns they are sent as:
/// they are most of a recording's rows, so they get no per-row struct.
#[derive(Debug, Default)]
struct Frames {
    sim: Vec<f64>,
    /// Whether a frame row has a pose (all of them, unless a sensor came alone).
    posed: Vec<bool>,
    positions: Vec<[f32; 2]>,
    vectors: Vec<[f32; 2]>,
    /// Exact poses `[x, y, angle]`, three per row.
    exact: Vec<f64>,
    /// Push sensor reaches on the rows that have one: `(row, circle)`.
    sensors: Vec<(usize, Option<(Point, f64)>)>,
}

impl Frames {
    fn len(&self) -> usize {
        self.sim.len()
    }

    /// The row at `t`: the last one if it is at `t`.
    fn open(&mut self, t: f64) -> usize {
        if self.sim.last() != Some(&t) {
            self.sim.push(t);
            self.posed.push(false);
            self.positions.push([0.0; 2]);
            self.vectors.push([0.0; 2]);
            self.exact.extend([0.0; 3]);
        }
        self.sim.len() - 1
    }

    fn pose(&mut self, t: f64, pos: Point, angle: f64, radius: f64) {
        let i = self.open(t);
        self.posed[i] = true;
        self.positions[i] = p32(pos);
        let v = heading_vector(angle) * (1.5 * radius);
        self.vectors[i] = [v.x as f32, v.y as f32];
        self.exact[3 * i..3 * i + 3].copy_from_slice(&[pos.x, pos.y, angle]);
    }

    fn sensor(&mut self, t: f64, circle: Option<(Point, f64)>) {
        let i = self.open(t);
        match self.sensors.last_mut() {
            Some((j, c)) if *j == i => *c = circle,
            _ => self.sensors.push((i, circle)),
        }
    }

    /// The time column and the components, leaving the buffer empty.
    fn take(
        &mut self,
    ) -> (
        Vec<TimeColumn>,
        Result<Vec<SerializedComponentColumn>, rerun::SerializationError>,
    ) {
        let f = std::mem::take(self);
        let times = vec![TimeColumn::new_duration_secs("sim_time", f.sim)];
        (
            times,
            frame_columns(f.posed, f.positions, f.vectors, f.exact, f.sensors),
        )
    }
}

/// The columns of animation frames: marker positions, heading arrows, exact poses and push
/// sensors.
fn frame_columns(
    posed: Vec<bool>,
    mut positions: Vec<[f32; 2]>,
    mut vectors: Vec<[f32; 2]>,
    mut exact: Vec<f64>,
    sensors: Vec<(usize, Option<(Point, f64)>)>,
) -> Result<Vec<SerializedComponentColumn>, rerun::SerializationError> {
    let rows = posed.len();
    if posed.contains(&false) {
        let keep = |i: usize| posed[i];
        positions = positions
            .into_iter()
            .enumerate()
            .filter(|(i, _)| keep(*i))
            .map(|(_, v)| v)
            .collect();
        vectors = vectors
            .into_iter()
            .enumerate()
            .filter(|(i, _)| keep(*i))
            .map(|(_, v)| v)
            .collect();
        exact = exact
            .chunks(3)
            .enumerate()
            .filter(|(i, _)| keep(*i))
            .flat_map(|(_, v)| v.to_vec())
            .collect();
    }
    let lengths = || posed.iter().map(|p| usize::from(*p));
    let mut out = Vec::new();
    if posed.contains(&true) {
        let points =
            archetypes::Points2D::update_fields().with_positions(positions.iter().copied());
        for c in points.columns(lengths())? {
            out.push(sparse(Ok(c), &posed)?);
        }
        let arrows = archetypes::Arrows2D::update_fields()
            .with_origins(positions)
            .with_vectors(vectors);
        for c in arrows.columns(lengths())? {
            out.push(sparse(Ok(c), &posed)?);
        }
        let exact = SerializedComponentBatch::new(
            Arc::new(Float64Array::from(exact)) as ArrayRef,
            pose_descriptor(),
        )
        .partitioned(lengths().map(|n| 3 * n));
        out.push(sparse(exact, &posed)?);
    }
    if !sensors.is_empty() {
        let mut present = vec![false; rows];
        let mut lengths = vec![0; rows];
        let mut centers = Vec::new();
        let mut half = Vec::new();
        for (i, c) in sensors {
            present[i] = true;
            if let Some((p, r)) = c {
                lengths[i] = 1;
                centers.push(p32(p));
                half.push([r as f32, r as f32]);
            }
        }
        let ellipses = archetypes::Ellipses2D::update_fields()
            .with_centers(centers)
            .with_half_sizes(half);
        for c in ellipses.columns(lengths)? {
            out.push(sparse(Ok(c), &present)?);
        }
    }
    Ok(out)
}

impl RobotRows {
    fn len(&self) -> usize {
        self.events.len() + self.anim.len() + self.frames.len()
    }

    /// The row for `at`: the buffer's last row if it is for the same instant and event.
    fn row(&mut self, at: Stamp) -> &mut RobotRow {
        let rows = if at.seq.is_some() {
            &mut self.events
        } else {
            &mut self.frames
        };
        let same = rows.sim.last() == Some(&at.t)
            && (at.seq.is_none() || rows.seq.last() == at.seq.map(|s| s as i64).as_ref());
        if !same {
            rows.push(at, RobotRow::default());
        }
        rows.data.last_mut().expect("a row")
    }
}

/// Collision markers per entity (`world/collisions/<k / COLLISION_GROUP>`): each row shows the
/// group's markers so far, so every marker stays visible from its instant on.
pub const COLLISION_GROUP: u64 = 64;

/// A column with a value (possibly an empty list) on rows where `present`, null elsewhere.
fn sparse(
    column: Result<SerializedComponentColumn, rerun::SerializationError>,
    present: &[bool],
) -> Result<SerializedComponentColumn, rerun::SerializationError> {
    let column = column?;
    if !present.contains(&false) {
        // Every row has a value: no validity bitmap.
        return Ok(column);
    }
    let (field, offsets, values, _) = column.list_array.into_parts();
    let list = ListArray::try_new(
        field,
        offsets,
        values,
        Some(NullBuffer::from(present.to_vec())),
    )
    .map_err(|e| rerun::SerializationError::Context {
        location: "sparse column".into(),
        source: Box::new(e.into()),
    })?;
    Ok(SerializedComponentColumn {
        list_array: list,
        descriptor: column.descriptor,
    })
}

/// The components of one archetype field: its batch, and how many instances each row has.
fn parts<T>(
    rows: &[RobotRow],
    pick: impl Fn(&RobotRow) -> Option<Vec<T>>,
) -> (Vec<T>, Vec<usize>, Vec<bool>) {
    let mut all = Vec::new();
    let mut lengths = Vec::with_capacity(rows.len());
    let mut present = Vec::with_capacity(rows.len());
    for r in rows {
        match pick(r) {
            Some(v) => {
                lengths.push(v.len());
                present.push(true);
                all.extend(v);
            }
            None => {
                lengths.push(0);
                present.push(false);
            }
        }
    }
    (all, lengths, present)
}

fn p32(p: Point) -> [f32; 2] {
    [p.x as f32, p.y as f32]
}

/// A [`Canvas`] writing a Rerun recording.
pub struct RerunCanvas {
    rec: Option<RecordingStream>,
    robots: Vec<RobotRows>,
    log: Rows<String>,
    metrics: Rows<Metrics>,
    /// Markers of the current collision group so far, and its rows.
    collision_group: Vec<([f32; 2], String)>,
    collision_count: u64,
    collisions: Rows<Vec<([f32; 2], String)>>,
    /// Flush everything at every whole simulated second (a viewer is connected).
    live: bool,
    next_live_flush: f64,
    /// The viewer's URL, when streaming to one.
    url: Option<String>,
    /// `(temporary file, target)` of the .rrd being written.
    file: Option<(PathBuf, PathBuf)>,
    error: Option<RecordingError>,
}

impl std::fmt::Debug for RerunCanvas {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RerunCanvas")
            .field("file", &self.file)
            .field("live", &self.live)
            .finish()
    }
}

fn rerun_err(e: impl std::fmt::Display) -> RecordingError {
    RecordingError::Rerun(e.to_string())
}

/// The default layout: the 2D world beside the log above the metrics.
fn default_blueprint() -> blueprint::Blueprint {
    blueprint::Blueprint::new(blueprint::Horizontal::new([
        blueprint::Spatial2DView::new("world")
            .with_origin("world")
            .into(),
        blueprint::Vertical::new([
            blueprint::TextLogView::new("log").with_origin("log").into(),
            blueprint::TimeSeriesView::new("metrics")
                .with_origin("metrics")
                .into(),
        ])
        .into(),
    ]))
}

impl RerunCanvas {
    /// Starts a recording named `name` to `target`. The .rrd file is written beside its target
    /// under a hidden temporary name and moved into place by [`RerunCanvas::finish`] (or when
    /// the canvas is dropped, so a failed run still leaves a complete recording).
    pub fn start(name: &str, target: &Target) -> Result<Self, RecordingError> {
        let builder = RecordingStreamBuilder::new("nekosim").recording_name(name);
        let mut sinks: Vec<Box<dyn rerun::sink::LogSink>> = Vec::new();
        let mut file = None;
        let mut viewer = None;
        if let Some(path) = &target.rrd {
            let temp = temp_path(path).map_err(|e| RecordingError::Create {
                path: path.display().to_string(),
                message: e.to_string(),
            })?;
            let sink = rerun::sink::FileSink::new(&temp).map_err(|e| RecordingError::Create {
                path: path.display().to_string(),
                message: e.to_string(),
            })?;
            sinks.push(Box::new(sink));
            file = Some((temp, path.clone()));
        }
        if let Some(url) = &target.connect {
            let url = url
                .clone()
                .unwrap_or_else(|| rerun::DEFAULT_CONNECT_URL.to_string());
            viewer = Some(url.clone());
            let uri = match url.parse::<rerun::external::re_uri::RedapUri>() {
                Ok(rerun::external::re_uri::RedapUri::Proxy(uri)) => uri,
                Ok(_) => {
                    return Err(RecordingError::Url {
                        url,
                        message: "not a /proxy endpoint".into(),
                    })
                }
                Err(e) => {
                    return Err(RecordingError::Url {
                        url,
                        message: e.to_string(),
                    })
                }
            };
            sinks.push(Box::new(rerun::sink::GrpcSink::new(uri)));
        }
        let rec = builder.set_sinks(sinks).map_err(rerun_err)?;
        default_blueprint()
            .send(&rec, blueprint::BlueprintActivation::default())
            .map_err(rerun_err)?;
        Ok(Self {
            rec: Some(rec),
            robots: Vec::new(),
            log: Rows::default(),
            metrics: Rows::default(),
            collision_group: Vec::new(),
            collision_count: 0,
            collisions: Rows::default(),
            live: viewer.is_some(),
            url: viewer,
            next_live_flush: 1.0,
            file,
            error: None,
        })
    }

    fn keep(&mut self, r: Result<(), RecordingError>) {
        if let Err(e) = r {
            self.error.get_or_insert(e);
        }
    }

    fn rec(&self) -> &RecordingStream {
        self.rec.as_ref().expect("recording open until finished")
    }

    fn set_time(&self, at: Stamp) {
        let rec = self.rec();
        rec.set_duration_secs("sim_time", at.t);
        match at.seq {
            Some(s) => rec.set_time_sequence("event", s as i64),
            None => rec.disable_timeline("event"),
        }
    }

    fn log_at(&mut self, at: Stamp, entity: &str, what: &dyn rerun::AsComponents) {
        self.set_time(at);
        let r = self.rec().log(entity, what).map_err(rerun_err);
        self.keep(r);
    }

    fn send(
        &mut self,
        entity: &str,
        times: Vec<TimeColumn>,
        columns: Result<Vec<SerializedComponentColumn>, rerun::SerializationError>,
    ) {
        let r = columns
            .map_err(rerun_err)
            .and_then(|c| self.rec().send_columns(entity, times, c).map_err(rerun_err));
        self.keep(r);
    }

    fn flush_robot(&mut self, i: usize) {
        if self.robots[i].anim.len() > 0 {
            let (times, columns) = self.robots[i].anim.take();
            self.send(&robot_entity(i as RobotId), times, columns);
        }
        for frames in [false, true] {
            let rows = &mut self.robots[i];
            let radius = rows.radius;
            let (times, data) = if frames {
                rows.frames.take()
            } else {
                rows.events.take()
            };
            if data.is_empty() {
                continue;
            }
            let columns = robot_columns(i as RobotId, &data, radius);
            self.send(&robot_entity(i as RobotId), times, columns);
        }
    }

    fn flush_collisions(&mut self, group: u64) {
        let (times, data) = self.collisions.take();
        if data.is_empty() {
            return;
        }
        let lengths: Vec<usize> = data.iter().map(Vec::len).collect();
        let (points, labels): (Vec<[f32; 2]>, Vec<String>) = data.into_iter().flatten().unzip();
        let columns = archetypes::Points2D::update_fields()
            .with_positions(points)
            .with_labels(labels)
            .columns(lengths)
            .map(|c| c.collect::<Vec<_>>());
        let style = archetypes::Points2D::update_fields()
            .with_colors([[255, 40, 40]])
            .with_radii([2.0]);
        let entity = format!("world/collisions/{group}");
        let r = self
            .rec()
            .log_static(entity.as_str(), &style)
            .map_err(rerun_err);
        self.keep(r);
        self.send(&entity, times, columns);
    }

    fn flush_log(&mut self) {
        let (times, lines) = self.log.take();
        if lines.is_empty() {
            return;
        }
        let columns = archetypes::TextLog::update_fields()
            .with_many_text(lines)
            .columns_of_unit_batches()
            .map(|c| c.collect());
        self.send("log", times, columns);
    }

    fn flush_metrics(&mut self) {
        let (times, data) = self.metrics.take();
        if data.is_empty() {
            return;
        }
        let series: [Vec<f64>; 4] = [
            data.iter().map(|m| m.collisions as f64).collect(),
            data.iter().map(|m| m.in_flight as f64).collect(),
            data.iter().map(|m| m.deliveries as f64).collect(),
            data.iter().map(|m| m.events_per_second).collect(),
        ];
        for (entity, values) in METRICS.iter().zip(series) {
            let columns = archetypes::Scalars::update_fields()
                .with_scalars(values)
                .columns_of_unit_batches()
                .map(|c| c.collect());
            self.send(entity, times.clone(), columns);
        }
    }

    fn flush_all(&mut self) {
        for i in 0..self.robots.len() {
            self.flush_robot(i);
        }
        self.flush_log();
        self.flush_metrics();
        if let Some(k) = self.collision_count.checked_sub(1) {
            self.flush_collisions(k / COLLISION_GROUP);
        }
    }

    fn robot(&mut self, robot: RobotId) -> &mut RobotRows {
        let i = robot as usize;
        if self.robots.len() <= i {
            self.robots.resize_with(i + 1, RobotRows::default);
        }
        &mut self.robots[i]
    }

    fn maybe_flush(&mut self, robot: RobotId) {
        if self.robot(robot).len() >= FLUSH_ROWS {
            self.flush_robot(robot as usize);
        }
    }

    /// Sends what is buffered, ends the stream (the .rrd file gets its footer) and moves the
    /// file into place. The first error of the recording, if any, is returned.
    pub fn finish(&mut self) -> Result<(), RecordingError> {
        if self.rec.is_some() {
            self.flush_all();
            let rec = self.rec.take().expect("checked");
            if let Err(e) = rec.flush_blocking() {
                // The file sink cannot fail to flush short of an I/O error, which it reports
                // when written; a failed flush is the viewer not answering.
                let e = match &self.url {
                    Some(url) => RecordingError::Unreachable {
                        url: url.clone(),
                        message: e.to_string(),
                    },
                    None => rerun_err(e),
                };
                self.error.get_or_insert(e);
            }
            // Dropping the last handle joins the file writer, which writes the footer.
            drop(rec);
            if let Some((temp, target)) = self.file.take() {
                if let Err(source) = std::fs::rename(&temp, &target) {
                    self.error.get_or_insert(RecordingError::Write {
                        path: target.display().to_string(),
                        source,
                    });
                }
            }
        }
        match self.error.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

impl Drop for RerunCanvas {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

/// The columns of a robot's rows: marker (`Points2D`), heading (`Arrows2D`), trail and route
/// to the destination (`LineStrips2D`), push sensor (`Ellipses2D`) and the exact pose.
fn robot_columns(
    id: RobotId,
    rows: &[RobotRow],
    radius: f64,
) -> Result<Vec<SerializedComponentColumn>, rerun::SerializationError> {
    let mut out = Vec::new();
    // The pose components, in one pass and without an allocation per row.
    let mut positions = Vec::with_capacity(rows.len());
    let mut vectors = Vec::with_capacity(rows.len());
    let mut exact = Vec::with_capacity(3 * rows.len());
    let mut lengths = Vec::with_capacity(rows.len());
    let mut present = Vec::with_capacity(rows.len());
    for r in rows {
        match r.pose {
            Some((p, a)) => {
                positions.push(p32(p));
                let v = heading_vector(a) * (1.5 * radius);
                vectors.push([v.x as f32, v.y as f32]);
                exact.extend([p.x, p.y, a]);
                lengths.push(1);
                present.push(true);
            }
            None => {
                lengths.push(0);
                present.push(false);
            }
        }
    }
    let points = archetypes::Points2D::update_fields().with_positions(positions.iter().copied());
    for c in points.columns(lengths.iter().copied())? {
        out.push(sparse(Ok(c), &present)?);
    }
    let arrows = archetypes::Arrows2D::update_fields()
        .with_origins(positions)
        .with_vectors(vectors);
    for c in arrows.columns(lengths.iter().copied())? {
        out.push(sparse(Ok(c), &present)?);
    }
    let exact = SerializedComponentBatch::new(
        Arc::new(Float64Array::from(exact)) as ArrayRef,
        pose_descriptor(),
    )
    .partitioned(lengths.iter().map(|n| 3 * n));
    out.push(sparse(exact, &present)?);

    let (styles, lengths, present) = parts(rows, |r| r.style.clone().map(|s| vec![s]));
    if !styles.is_empty() {
        let radii: Vec<f32> = styles.iter().map(|s| s.radius as f32).collect();
        let colours: Vec<Rgb> = styles.iter().map(|s| s.colour).collect();
        let labels = vec![format!("p{id}"); styles.len()];
        let points = archetypes::Points2D::update_fields()
            .with_labels(labels)
            .with_radii(radii.clone())
            .with_colors(colours.clone());
        for c in points.columns(lengths.clone())? {
            out.push(sparse(Ok(c), &present)?);
        }
        let arrows = archetypes::Arrows2D::update_fields().with_colors(colours.clone());
        for c in arrows.columns(lengths.clone())? {
            out.push(sparse(Ok(c), &present)?);
        }
        let strips = archetypes::LineStrips2D::update_fields()
            .with_colors(colours)
            .with_radii(radii.iter().map(|r| r / 10.0).collect::<Vec<_>>());
        for c in strips.columns(lengths)? {
            out.push(sparse(Ok(c), &present)?);
        }
    }

    let (strips, lengths, present) = parts(rows, |r| {
        r.path.as_ref().map(|trail| {
            let mut v = vec![trail.iter().map(|p| p32(*p)).collect::<Vec<_>>()];
            if let (Some(Some(dest)), Some(last)) = (r.dest, trail.last()) {
                v.push(vec![p32(*last), p32(dest)]);
            }
            v
        })
    });
    if present.contains(&true) {
        let strips = archetypes::LineStrips2D::update_fields().with_strips(strips);
        for c in strips.columns(lengths)? {
            out.push(sparse(Ok(c), &present)?);
        }
    }

    let (circles, lengths, present) = parts(rows, |r| r.sensor.map(|c| c.into_iter().collect()));
    if present.contains(&true) {
        let (centers, half): (Vec<[f32; 2]>, Vec<[f32; 2]>) = circles
            .iter()
            .map(|(p, r)| (p32(*p), [*r as f32, *r as f32]))
            .unzip();
        let ellipses = archetypes::Ellipses2D::update_fields()
            .with_centers(centers)
            .with_half_sizes(half);
        for c in ellipses.columns(lengths)? {
            out.push(sparse(Ok(c), &present)?);
        }
    }
    Ok(out)
}

fn temp_path(target: &Path) -> std::io::Result<PathBuf> {
    let dir = target
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = target.file_name().ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "output path has no file name",
        )
    })?;
    std::fs::create_dir_all(dir)?;
    Ok(dir.join(format!(
        ".{}.partial-{}",
        name.to_string_lossy(),
        std::process::id()
    )))
}

impl Canvas for RerunCanvas {
    fn world(&mut self, bounds: Option<(Point, Point)>) {
        if let Some((min, max)) = bounds {
            let size = max - min;
            let boxes = archetypes::Boxes2D::from_mins_and_sizes(
                [p32(min)],
                [[size.x as f32, size.y as f32]],
            );
            let r = self
                .rec()
                .log_static("world/bounds", &boxes)
                .map_err(rerun_err);
            self.keep(r);
        }
    }

    fn spawn(&mut self, at: Stamp, robot: RobotId, radius: f64, colour: Rgb) {
        let rows = self.robot(robot);
        rows.radius = radius;
        rows.row(at).style = Some(Style { radius, colour });
        self.maybe_flush(robot);
    }

    fn pose(&mut self, at: Stamp, robot: RobotId, pos: Point, angle: f64) {
        let rows = self.robot(robot);
        if at.seq.is_none() {
            let radius = rows.radius;
            rows.anim.pose(at.t, pos, angle, radius);
        } else {
            rows.row(at).pose = Some((pos, angle));
        }
        self.maybe_flush(robot);
    }

    fn colour(&mut self, at: Stamp, robot: RobotId, colour: Rgb) {
        let rows = self.robot(robot);
        let radius = rows.radius;
        rows.row(at).style = Some(Style { radius, colour });
        self.maybe_flush(robot);
    }

    fn path(&mut self, at: Stamp, robot: RobotId, corners: &[Point]) {
        self.robot(robot).row(at).path = Some(corners.to_vec());
        self.maybe_flush(robot);
    }

    fn destination(&mut self, at: Stamp, robot: RobotId, dest: Option<Point>) {
        self.robot(robot).row(at).dest = Some(dest);
        self.maybe_flush(robot);
    }

    fn sensor(&mut self, at: Stamp, robot: RobotId, circle: Option<(Point, f64)>) {
        let rows = self.robot(robot);
        if at.seq.is_none() {
            rows.anim.sensor(at.t, circle);
        } else {
            rows.row(at).sensor = Some(circle);
        }
        self.maybe_flush(robot);
    }

    fn query(&mut self, at: Stamp, robot: RobotId, circle: Option<(Point, f64)>) {
        let entity = format!("world/queries/{robot}");
        let e = match circle {
            Some((p, r)) => archetypes::Ellipses2D::from_centers_and_half_sizes(
                [p32(p)],
                [[r as f32, r as f32]],
            )
            .with_colors([[200, 200, 200]]),
            None => archetypes::Ellipses2D::clear_fields(),
        };
        self.log_at(at, &entity, &e);
    }

    fn collision(&mut self, at: Stamp, k: u64, point: Point, label: &str) {
        let group = k / COLLISION_GROUP;
        if k % COLLISION_GROUP == 0 && k > 0 {
            self.flush_collisions(group - 1);
            self.collision_group.clear();
        }
        self.collision_group.push((p32(point), label.to_string()));
        self.collisions.push(at, self.collision_group.clone());
        self.collision_count = k + 1;
    }

    fn messages(&mut self, at: Stamp, layer: &str, colour: Rgb, flights: &[Flight]) {
        let arrows = archetypes::Arrows2D::from_vectors(flights.iter().map(|f| {
            let v = f.target - f.origin;
            [v.x as f32, v.y as f32]
        }))
        .with_origins(flights.iter().map(|f| p32(f.origin)))
        .with_colors([colour])
        .with_labels(flights.iter().map(|f| f.label.clone()));
        self.log_at(at, &format!("world/messages/{layer}"), &arrows);
    }

    fn log(&mut self, at: Stamp, line: &str) {
        self.log.push(at, line.to_string());
        if self.log.len() >= FLUSH_ROWS {
            self.flush_log();
        }
        if self.live && at.t >= self.next_live_flush {
            self.flush_all();
            self.next_live_flush = at.t.floor() + 1.0;
        }
    }

    fn metrics(&mut self, at: Stamp, m: &Metrics) {
        self.metrics.push(at, *m);
        if self.metrics.len() >= FLUSH_ROWS {
            self.flush_metrics();
        }
    }
}
