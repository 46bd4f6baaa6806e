//! The [`Canvas`] that writes Rerun entities (docs/visualization.md), to an .rrd file, a
//! running viewer, or both.
//!
//! Robots produce most of the rows (a pose per event and per animation frame), so their
//! entities are buffered as columns and sent with `send_columns` in chunks of [`FLUSH_ROWS`]
//! rows: one chunk per entity per flush instead of one message per row. Rare drawings
//! (spawns, collisions, messages, queries) are logged row by row. When a viewer is connected,
//! every buffer is also flushed each simulated second so the live view keeps up.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use nekosim_actors::world::geometry::{heading_vector, Point};
use nekosim_actors::world::RobotId;
use rerun::external::arrow::array::{ArrayRef, Float64Array};
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

/// One robot's buffered entities; frame rows are on `sim_time` only, so they are kept apart
/// from the event rows, which are on both timelines.
#[derive(Debug, Default)]
struct RobotRows {
    pose: Rows<(Point, f64)>,
    pose_frames: Rows<(Point, f64)>,
    sensor: Rows<Option<(Point, f64)>>,
    sensor_frames: Rows<Option<(Point, f64)>>,
    path: Rows<Vec<Point>>,
    dest: Rows<Option<Point>>,
    radius: f64,
}

impl RobotRows {
    fn len(&self) -> usize {
        self.pose.len()
            + self.pose_frames.len()
            + self.sensor.len()
            + self.sensor_frames.len()
            + self.path.len()
            + self.dest.len()
    }
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

    fn flush_poses(&mut self, i: usize, frames: bool) {
        let rows = &mut self.robots[i];
        let (times, data) = if frames {
            rows.pose_frames.take()
        } else {
            rows.pose.take()
        };
        if data.is_empty() {
            return;
        }
        let radius = rows.radius;
        let positions: Vec<[f32; 2]> = data.iter().map(|(p, _)| p32(*p)).collect();
        let exact: Vec<f64> = data.iter().flat_map(|(p, a)| [p.x, p.y, *a]).collect();
        let exact = SerializedComponentBatch::new(
            Arc::new(Float64Array::from(exact)) as ArrayRef,
            pose_descriptor(),
        )
        .partitioned(std::iter::repeat_n(3, data.len()));
        let points = archetypes::Points2D::update_fields()
            .with_positions(positions.clone())
            .columns_of_unit_batches()
            .map(|c| c.collect::<Vec<_>>());
        let columns = points.and_then(|mut c| {
            c.push(exact?);
            Ok(c)
        });
        let id = i as RobotId;
        self.send(&robot_entity(id), times.clone(), columns);
        let vectors: Vec<[f32; 2]> = data
            .iter()
            .map(|(_, a)| {
                let v = heading_vector(*a) * (1.5 * radius);
                [v.x as f32, v.y as f32]
            })
            .collect();
        let arrows = archetypes::Arrows2D::update_fields()
            .with_origins(positions)
            .with_vectors(vectors)
            .columns_of_unit_batches()
            .map(|c| c.collect());
        self.send(&format!("world/headings/{id}"), times, arrows);
    }

    fn flush_circles(&mut self, i: usize, frames: bool) {
        let rows = &mut self.robots[i];
        let (times, data) = if frames {
            rows.sensor_frames.take()
        } else {
            rows.sensor.take()
        };
        if data.is_empty() {
            return;
        }
        let lengths: Vec<usize> = data.iter().map(|c| usize::from(c.is_some())).collect();
        let (centers, half): (Vec<[f32; 2]>, Vec<[f32; 2]>) = data
            .iter()
            .flatten()
            .map(|(p, r)| (p32(*p), [*r as f32, *r as f32]))
            .unzip();
        let columns = archetypes::Ellipses2D::update_fields()
            .with_centers(centers)
            .with_half_sizes(half)
            .columns(lengths)
            .map(|c| c.collect());
        self.send(&format!("world/sensors/{i}"), times, columns);
    }

    fn flush_robot(&mut self, i: usize) {
        self.flush_poses(i, false);
        self.flush_poses(i, true);
        self.flush_circles(i, false);
        self.flush_circles(i, true);
        let (times, data) = self.robots[i].path.take();
        if !data.is_empty() {
            let strips: Vec<Vec<[f32; 2]>> = data
                .iter()
                .map(|s| s.iter().map(|p| p32(*p)).collect())
                .collect();
            let columns = archetypes::LineStrips2D::update_fields()
                .with_strips(strips)
                .columns_of_unit_batches()
                .map(|c| c.collect());
            self.send(&format!("world/paths/{i}"), times, columns);
        }
        let (times, data) = self.robots[i].dest.take();
        if !data.is_empty() {
            let lengths: Vec<usize> = data.iter().map(|d| usize::from(d.is_some())).collect();
            let points: Vec<[f32; 2]> = data.iter().flatten().map(|p| p32(*p)).collect();
            let columns = archetypes::Points2D::update_fields()
                .with_positions(points)
                .columns(lengths)
                .map(|c| c.collect());
            self.send(&format!("world/destinations/{i}"), times, columns);
        }
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
        self.robot(robot).radius = radius;
        let label = format!("p{robot}");
        self.log_at(
            at,
            &robot_entity(robot),
            &archetypes::Points2D::update_fields()
                .with_radii([radius as f32])
                .with_colors([colour])
                .with_labels([label]),
        );
        self.log_at(
            at,
            &format!("world/headings/{robot}"),
            &archetypes::Arrows2D::update_fields().with_colors([colour]),
        );
        self.log_at(
            at,
            &format!("world/paths/{robot}"),
            &archetypes::LineStrips2D::update_fields()
                .with_colors([colour])
                .with_radii([(radius / 10.0) as f32]),
        );
        self.log_at(
            at,
            &format!("world/destinations/{robot}"),
            &archetypes::Points2D::update_fields()
                .with_colors([colour])
                .with_radii([(radius / 3.0) as f32]),
        );
    }

    fn pose(&mut self, at: Stamp, robot: RobotId, pos: Point, angle: f64) {
        let rows = self.robot(robot);
        if at.seq.is_some() {
            rows.pose.push(at, (pos, angle));
        } else {
            rows.pose_frames.push(at, (pos, angle));
        }
        self.maybe_flush(robot);
    }

    fn colour(&mut self, at: Stamp, robot: RobotId, colour: Rgb) {
        self.log_at(
            at,
            &robot_entity(robot),
            &archetypes::Points2D::update_fields().with_colors([colour]),
        );
        self.log_at(
            at,
            &format!("world/headings/{robot}"),
            &archetypes::Arrows2D::update_fields().with_colors([colour]),
        );
    }

    fn path(&mut self, at: Stamp, robot: RobotId, corners: &[Point]) {
        self.robot(robot).path.push(at, corners.to_vec());
        self.maybe_flush(robot);
    }

    fn destination(&mut self, at: Stamp, robot: RobotId, dest: Option<Point>) {
        self.robot(robot).dest.push(at, dest);
        self.maybe_flush(robot);
    }

    fn sensor(&mut self, at: Stamp, robot: RobotId, circle: Option<(Point, f64)>) {
        let rows = self.robot(robot);
        if at.seq.is_some() {
            rows.sensor.push(at, circle);
        } else {
            rows.sensor_frames.push(at, circle);
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
        self.log_at(
            at,
            &format!("world/collisions/{k}"),
            &archetypes::Points2D::new([p32(point)])
                .with_colors([[255, 40, 40]])
                .with_radii([2.0])
                .with_labels([label]),
        );
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
