//! The [`Canvas`] that writes Rerun entities (docs/visualization.md), to an .rrd file
//! ([`super::rrd_file`]), a running viewer, or both.
//!
//! Robots produce most of the rows (a row per event and per animation frame). They are drawn
//! in groups of [`ROBOT_GROUP`] per entity, one entity per group and family (markers,
//! headings, destinations, sensors): a Rerun row replaces a whole batch, so a row
//! carries the group's robots, and a chunk costs a fixed overhead in time and bytes, so a
//! 1k-robot run must not make thousands of entities. Rows are buffered as columns and sent in
//! chunks of up to [`FLUSH_INSTANCES`] robot instances (other entities: [`FLUSH_ROWS`] rows).
//! A row only carries what changed; the other components are null there, so Rerun's latest-at
//! keeps showing their earlier values. Path legs and collision markers are one row each, kept
//! on screen by visible time ranges in the default blueprint. Rare drawings (messages,
//! queries) are single rows. When a viewer is connected, every buffer is also flushed each
//! simulated second so the live view keeps up.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use nekosim_actors::world::geometry::{heading_vector, Point, Vector};
use nekosim_actors::world::RobotId;
use rerun::external::arrow::array::{
    Array as _, ArrayRef, FixedSizeListArray, Float32Array, Float64Array, ListArray, UInt32Array,
};
use rerun::external::arrow::buffer::NullBuffer;
use rerun::external::arrow::datatypes::{DataType, Field};
use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg, StoreId, StoreKind};
use rerun::log::Chunk;
use rerun::{
    archetypes, ComponentDescriptor, RecordingStream, RecordingStreamBuilder,
    SerializedComponentBatch, SerializedComponentColumn, TimeColumn,
};

use super::rrd_file::{Ids, RrdFile};
use super::{
    Canvas, Flight, Level, Mark, Metrics, RecordingError, Rgb, Stamp, Target, ROBOT_GROUP,
};

/// Rows buffered per entity (log, metrics, collisions) before they are sent as one chunk.
pub const FLUSH_ROWS: usize = 4096;

/// Robot instances (rows × robots of the group) buffered per group entity before they are
/// sent as one chunk. Measured at 25 frames per simulated second with 1,000 robots
/// (docs/performance.md): 8 k instances 351 ms, 16 k 299 ms, 32 k 292 ms; fewer, larger chunks
/// save Rerun's per-chunk cost. A group's frames are also sent whenever its event rows are
/// (see [`EVENT_FLUSH_INSTANCES`]), so they are encoded during the run.
pub const FLUSH_INSTANCES: usize = 1 << 15;

/// Robot instances of event rows buffered per group before they are sent: groups fill with
/// event rows much more slowly than with frames, and sending them during the run leaves less
/// to encode at its end. Measured (docs/performance.md): 1,024 is worse (more chunks), 1,536
/// best, 2,048 and 4,096 slightly worse.
pub const EVENT_FLUSH_INSTANCES: usize = 1536;

/// Runs with more robots than this draw their markers without labels unless the scenario asks
/// for them (`animation: (labels: true)`): by 40 s of the seed's 100-robot example the labels
/// cover the middle of the world.
pub const LABELLED_ROBOTS: usize = 20;

/// The colour of robots' names: a light grey, readable on the black background.
pub const NAME_COLOUR: Rgb = [200, 200, 200];

/// The colour of obstacles' outlines: a light grey, apart from every robot's hue.
pub const OBSTACLE_COLOUR: Rgb = [150, 150, 150];

/// The opacity of a run's message arrows (their packets are opaque).
pub const MESSAGE_ALPHA: u8 = 100;

/// The colour of collision crosses (amber).
pub const COLLISION_COLOUR: Rgb = [255, 176, 0];

/// A heading arrow's length in robot radii, from the centre: it sticks out of the disc by
/// one radius.
pub const HEADING_RADII: f64 = 2.0;

/// A destination marker: the robot's colour at this opacity, at this fraction of its radius.
pub const DESTINATION_ALPHA: u8 = 110;
pub const DESTINATION_RADII: f64 = 0.4;

/// How long a collision marker stays drawn after its instant [simulated s].
pub const COLLISION_SECONDS: f64 = 3.0;

/// The margin around the world in the 2D view, as a fraction of its larger side.
pub const WORLD_MARGIN: f64 = 0.03;

/// What the default layout shows, decided from the run's setting before it starts.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// The world's bounds, which the 2D view frames with a small margin ([`WORLD_MARGIN`];
    /// `None`: an infinite world, framed by the viewer).
    pub world: Option<(Point, Point)>,
    /// The metric entities of [`METRICS`] that can change in this run: one plot each, and
    /// only these are logged.
    pub metrics: Vec<&'static str>,
    /// Whether robot markers carry labels.
    pub labels: bool,
    /// The space-time diagram, for runs whose robots can exchange messages and for check
    /// recordings.
    pub spacetime: Option<SpaceTime>,
    /// Draw world message arrows between the markers' rims rather than their centres: each
    /// starts and ends this far from the centres, and is shifted by half of it to the right
    /// of its direction so the two directions between a pair of processes stay apart (check
    /// recordings, where the markers are large beside the distances). `None`: centre to centre.
    pub inset: Option<f64>,
}

/// The space-time diagram's geometry: one vertical lane per process, `LANE_GAP` apart, time
/// running down from 0 to `span` over [`SpaceTime::height`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpaceTime {
    pub lanes: usize,
    /// The simulated time (or checker steps) the diagram spans.
    pub span: f64,
    /// Label messages with their whole rendering (`FIFO#0(LAMPORT(ts 1, 1:0, M 1))`) rather
    /// than their type, and show each lane's delivered sequence (check recordings).
    pub full: bool,
}

/// Distance between two lanes of the space-time diagram.
pub const LANE_GAP: f64 = 10.0;

impl SpaceTime {
    /// The diagram's height: one and a half times its width (at least two lanes wide).
    pub fn height(&self) -> f64 {
        LANE_GAP * self.lanes.max(2) as f64 * 1.5
    }

    /// Where `(robot, t)` is drawn.
    pub fn at(&self, robot: RobotId, t: f64) -> [f32; 2] {
        let scale = self.height() / self.span.max(1e-9);
        [(LANE_GAP * f64::from(robot)) as f32, (t * scale) as f32]
    }
}

impl Layout {
    /// The layout of a simulated run of `robots` robots in a world of `world`: collisions
    /// and the event rate always, messages in flight when the run has a network or a stack
    /// (`messages`), deliveries when it has a stack (`deliveries`); labels up to
    /// [`LABELLED_ROBOTS`] robots unless `labels` says.
    pub fn run(
        world: Option<(Point, Point)>,
        robots: usize,
        (messages, deliveries): (bool, bool),
        labels: Option<bool>,
        until: f64,
    ) -> Self {
        let metrics = METRICS
            .iter()
            .copied()
            .filter(|m| match *m {
                "metrics/messages_in_flight" => messages,
                "metrics/deliveries" => deliveries,
                _ => true,
            })
            .collect();
        Self {
            world,
            metrics,
            labels: labels.unwrap_or(robots <= LABELLED_ROBOTS),
            spacetime: messages.then_some(SpaceTime {
                lanes: robots,
                span: until,
                full: false,
            }),
            inset: None,
        }
    }

    /// The layout of a model checker's path of `processes` lanes in `world`: messages only
    /// (no collisions, and an event rate means nothing there), labelled, arrows between the
    /// rims of markers of radius `radius`.
    pub fn check(world: (Point, Point), processes: usize, steps: usize, radius: f64) -> Self {
        Self {
            world: Some(world),
            metrics: vec!["metrics/messages_in_flight", "metrics/deliveries"],
            labels: true,
            spacetime: Some(SpaceTime {
                lanes: processes,
                span: steps.max(1) as f64,
                full: true,
            }),
            inset: Some(radius),
        }
    }

    /// The 2D view's bounds: the world with its margin, `[x_min, x_max, y_min, y_max]`.
    pub fn view_bounds(&self) -> Option<[f64; 4]> {
        let (min, max) = self.world?;
        let m = WORLD_MARGIN * (max.x - min.x).max(max.y - min.y);
        Some([min.x - m, max.x + m, min.y - m, max.y + m])
    }
}

/// A static `show_labels: false` for a Points2D entity.
fn hidden_labels() -> archetypes::Points2D {
    archetypes::Points2D::update_fields().with_show_labels(false)
}

/// Name of the group of robot `robot` under an entity family: `world/robots/0-31`.
pub fn group_entity(family: &str, robot: RobotId) -> String {
    let first = robot - robot % ROBOT_GROUP;
    format!("world/{family}/{first}-{}", first + ROBOT_GROUP - 1)
}

/// The metric entities, in the order of [`Metrics`]' fields.
pub const METRICS: [&str; 4] = [
    "metrics/collisions",
    "metrics/messages_in_flight",
    "metrics/deliveries",
    "metrics/events_per_second",
];

/// The component holding a robot's exact pose, `[x, y, angle]` as 64-bit floats (the drawn
/// positions are 32-bit, Rerun's point type).
pub fn pose_descriptor() -> ComponentDescriptor {
    ComponentDescriptor::partial("nekosim.Pose:pose").with_archetype("nekosim.Pose".into())
}

/// The component naming the robot of an exact pose.
pub fn pose_robot_descriptor() -> ComponentDescriptor {
    ComponentDescriptor::partial("nekosim.Pose:robot").with_archetype("nekosim.Pose".into())
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
        let seq = std::mem::take(&mut self.seq);
        (
            time_columns(std::mem::take(&mut self.sim), seq),
            std::mem::take(&mut self.data),
        )
    }

    fn len(&self) -> usize {
        self.data.len()
    }
}

/// `sim_time`, and `event` when the rows are at events.
fn time_columns(sim: Vec<f64>, seq: Vec<i64>) -> Vec<TimeColumn> {
    let mut times = vec![TimeColumn::new_duration_secs("sim_time", sim)];
    if !seq.is_empty() {
        times.push(TimeColumn::new_sequence("event", seq));
    }
    times
}

/// One component's values over buffered rows: the flat values, how many each row has, and
/// whether the row has the component at all (a row without it leaves it null, so Rerun's
/// latest-at keeps showing the earlier value).
#[derive(Clone, Debug)]
struct Col<T> {
    values: Vec<T>,
    lengths: Vec<usize>,
    present: Vec<bool>,
    /// Rows without the component before its first value, not yet in `lengths` and `present`
    /// (most components are on few rows, and many buffers have none: they cost nothing then).
    leading: usize,
}

impl<T> Default for Col<T> {
    fn default() -> Self {
        Self {
            values: Vec::new(),
            lengths: Vec::new(),
            present: Vec::new(),
            leading: 0,
        }
    }
}

impl<T> Col<T> {
    fn push(&mut self, values: impl IntoIterator<Item = T>) {
        if self.leading > 0 {
            self.lengths.resize(self.leading, 0);
            self.present.resize(self.leading, false);
            self.leading = 0;
        }
        let before = self.values.len();
        self.values.extend(values);
        self.lengths.push(self.values.len() - before);
        self.present.push(true);
    }

    fn skip(&mut self) {
        if self.present.is_empty() {
            self.leading += 1;
        } else {
            self.lengths.push(0);
            self.present.push(false);
        }
    }

    fn any(&self) -> bool {
        // Rows are listed from the first value on.
        !self.present.is_empty()
    }

    /// The columns `build` makes of the values, null on the rows without them.
    fn columns<I>(
        self,
        build: impl FnOnce(Vec<T>, Vec<usize>) -> Result<I, rerun::SerializationError>,
    ) -> Result<Vec<SerializedComponentColumn>, rerun::SerializationError>
    where
        I: IntoIterator<Item = SerializedComponentColumn>,
    {
        if !self.any() {
            return Ok(Vec::new());
        }
        let present = self.present;
        build(self.values, self.lengths)?
            .into_iter()
            .map(|c| sparse(c, &present))
            .collect()
    }
}

/// An entity's rows as columns: `(entity, times, components)`.
type EntityChunk = (String, Vec<TimeColumn>, Vec<SerializedComponentColumn>);

/// Rows of a robot group's entities on one set of timelines (events, or animation frames).
#[derive(Debug, Default)]
struct GroupRows {
    sim: Vec<f64>,
    seq: Vec<i64>,
    positions: Col<[f32; 2]>,
    /// Heading arrows' vectors.
    vectors: Col<[f32; 2]>,
    /// Radii, colours and labels, on rows where a robot spawned or changed colour.
    radii: Col<f32>,
    colours: Col<Rgb>,
    labels: Col<String>,
    /// Destinations of current motions with their robots' colours, on rows where one changed.
    dests: Col<[f32; 2]>,
    dest_colours: Col<[u8; 4]>,
    dest_radii: Col<f32>,
    /// Each robot's current leg, from its last kinematic record to where it is: the trail
    /// growing behind it (completed legs are `world/paths`).
    trails: Col<[[f32; 2]; 2]>,
    /// Robots' names in world units ([`super::names`]), on every row when names are drawn.
    names: Col<Vec<[f32; 2]>>,
    /// Push sensor circles, on rows where one is active or one was switched off.
    centres: Col<[f32; 2]>,
    half_sizes: Col<[f32; 2]>,
}

impl GroupRows {
    fn rows(&self) -> usize {
        self.sim.len()
    }

    /// Values buffered, to decide when to send.
    fn size(&self) -> usize {
        self.positions.values.len()
    }

    /// The chunks of the group whose first robot is `first`: `(entity, times, columns)`.
    fn take(&mut self, first: RobotId) -> Result<Vec<EntityChunk>, rerun::SerializationError> {
        let rows = std::mem::take(self);
        let times = time_columns(rows.sim, rows.seq);
        let mut out = Vec::new();

        // Markers and heading arrows share one array of positions.
        let positions = vec2_array(rows.positions.values);
        let mut robots = Vec::new();
        if rows.positions.present.contains(&true) {
            robots.push(sparse(
                SerializedComponentBatch::new(
                    positions.clone(),
                    archetypes::Points2D::descriptor_positions(),
                )
                .partitioned(rows.positions.lengths.iter().copied())?,
                &rows.positions.present,
            )?);
        }
        robots.extend(rows.radii.columns(|v, n| {
            archetypes::Points2D::update_fields()
                .with_radii(v)
                .columns(n)
        })?);
        let heading_colours = rows.colours.clone();
        let trail_colours = rows.colours.clone();
        robots.extend(rows.colours.columns(|v, n| {
            archetypes::Points2D::update_fields()
                .with_colors(v)
                .columns(n)
        })?);
        robots.extend(rows.labels.columns(|v, n| {
            archetypes::Points2D::update_fields()
                .with_labels(v)
                .columns(n)
        })?);
        if !robots.is_empty() {
            out.push((group_entity("robots", first), times.clone(), robots));
        }
        let mut headings = Vec::new();
        if rows.vectors.present.contains(&true) {
            headings.push(sparse(
                SerializedComponentBatch::new(
                    positions,
                    archetypes::Arrows2D::descriptor_origins(),
                )
                .partitioned(rows.vectors.lengths.iter().copied())?,
                &rows.vectors.present,
            )?);
        }
        headings.extend(
            rows.vectors
                .columns(|v, n| vec2_column(v, archetypes::Arrows2D::descriptor_vectors(), n))?,
        );
        headings.extend(heading_colours.columns(|v, n| {
            archetypes::Arrows2D::update_fields()
                .with_colors(v)
                .columns(n)
        })?);
        if !headings.is_empty() {
            out.push((group_entity("headings", first), times.clone(), headings));
        }
        let mut trails = rows.trails.columns(|v, n| {
            archetypes::LineStrips2D::update_fields()
                .with_strips(v)
                .columns(n)
        })?;
        if !trails.is_empty() {
            trails.extend(trail_colours.columns(|v, n| {
                archetypes::LineStrips2D::update_fields()
                    .with_colors(v)
                    .columns(n)
            })?);
            out.push((group_entity("trails", first), times.clone(), trails));
        }

        let mut dests = rows
            .dests
            .columns(|v, n| vec2_column(v, archetypes::Points2D::descriptor_positions(), n))?;
        dests.extend(rows.dest_colours.columns(|v, n| {
            archetypes::Points2D::update_fields()
                .with_colors(
                    v.into_iter()
                        .map(|[r, g, b, a]| rerun::Color::from_unmultiplied_rgba(r, g, b, a)),
                )
                .columns(n)
        })?);
        dests.extend(rows.dest_radii.columns(|v, n| {
            archetypes::Points2D::update_fields()
                .with_radii(v)
                .columns(n)
        })?);
        if !dests.is_empty() {
            out.push((group_entity("destinations", first), times.clone(), dests));
        }

        let names = rows.names.columns(|v, n| {
            archetypes::LineStrips2D::update_fields()
                .with_strips(v)
                .columns(n)
        })?;
        if !names.is_empty() {
            out.push((group_entity("names", first), times.clone(), names));
        }

        let mut sensors = rows
            .centres
            .columns(|v, n| vec2_column(v, archetypes::Ellipses2D::descriptor_centers(), n))?;
        sensors.extend(
            rows.half_sizes.columns(|v, n| {
                vec2_column(v, archetypes::Ellipses2D::descriptor_half_sizes(), n)
            })?,
        );
        if !sensors.is_empty() {
            out.push((group_entity("sensors", first), times, sensors));
        }
        Ok(out)
    }
}

/// What a group of robots shows besides its poses, and its buffered rows.
#[derive(Debug, Default)]
struct Group {
    radius: Vec<f64>,
    colour: Vec<Rgb>,
    /// Where each robot's current motion ends.
    dest: Vec<Option<[f32; 2]>>,
    /// Active push sensors' reach.
    reach: Vec<Option<f64>>,
    /// Where each robot was at its latest kinematic record: where its trail starts.
    corner: Vec<Option<[f32; 2]>>,
    /// The headings last drawn and their arrows.
    angle: Vec<f64>,
    vector: Vec<[f32; 2]>,
    /// Each robot's name relative to its centre, when names are drawn (`Some`).
    names: Option<Vec<Vec<Vec<[f32; 2]>>>>,
    /// What changed since the group's last row.
    style_changed: bool,
    dests_changed: bool,
    sensors_changed: bool,
    events: GroupRows,
    frames: GroupRows,
}

impl Group {
    fn fit(&mut self, n: usize) {
        if self.radius.len() < n {
            self.radius.resize(n, 0.0);
            self.colour.resize(n, super::GREY);
            self.dest.resize(n, None);
            self.reach.resize(n, None);
            self.corner.resize(n, None);
            self.angle.resize(n, f64::NAN);
            self.vector.resize(n, [0.0; 2]);
            if let Some(names) = &mut self.names {
                names.resize(n, Vec::new());
            }
        }
    }

    /// A row at `at` with the exact poses of the group's robots (`first` is the first's id).
    fn row(&mut self, at: Stamp, first: RobotId, poses: &[(Point, f64)]) {
        self.fit(poses.len());
        let rows = match at.seq {
            Some(s) => {
                self.events.seq.push(s as i64);
                &mut self.events
            }
            None => &mut self.frames,
        };
        rows.sim.push(at.t);
        rows.positions.push(poses.iter().map(|(p, _)| p32(*p)));
        // Trails grow with the animation frames; at event instants the leg that ended is
        // drawn in `world/paths`, and a recording without frames has no trails.
        if at.seq.is_none() {
            rows.trails.push(
                poses
                    .iter()
                    .zip(&self.corner)
                    .map(|((p, _), c)| [c.unwrap_or(p32(*p)), p32(*p)]),
            );
        } else {
            rows.trails.skip();
        }
        // A heading arrow is recomputed only when the heading changed.
        for (i, (_, a)) in poses.iter().enumerate() {
            if self.angle[i] != *a {
                self.angle[i] = *a;
                let v = heading_vector(*a) * (HEADING_RADII * self.radius[i]);
                self.vector[i] = [v.x as f32, v.y as f32];
            }
        }
        rows.vectors
            .push(self.vector[..poses.len()].iter().copied());
        if let Some(names) = &self.names {
            rows.names
                .push(poses.iter().zip(names).flat_map(|((p, _), strokes)| {
                    let c = p32(*p);
                    strokes
                        .iter()
                        .map(move |s| s.iter().map(|q| [q[0] + c[0], q[1] + c[1]]).collect())
                }));
        } else {
            rows.names.skip();
        }
        if std::mem::take(&mut self.style_changed) {
            let n = poses.len();
            rows.radii.push(self.radius[..n].iter().map(|r| *r as f32));
            rows.colours.push(self.colour[..n].iter().copied());
            rows.labels
                .push((0..n).map(|i| format!("p{}", first as usize + i)));
        } else {
            rows.radii.skip();
            rows.colours.skip();
            rows.labels.skip();
        }
        if std::mem::take(&mut self.dests_changed) {
            let n = poses.len();
            let dests = self.dest[..n].iter().zip(&self.colour[..n]);
            rows.dests.push(dests.clone().filter_map(|(d, _)| *d));
            rows.dest_colours.push(
                dests
                    .clone()
                    .filter_map(|(d, c)| d.map(|_| [c[0], c[1], c[2], DESTINATION_ALPHA])),
            );
            rows.dest_radii.push(
                self.dest[..n]
                    .iter()
                    .zip(&self.radius[..n])
                    .filter_map(|(d, r)| d.map(|_| (DESTINATION_RADII * r) as f32)),
            );
        } else {
            rows.dests.skip();
            rows.dest_colours.skip();
            rows.dest_radii.skip();
        }
        let active = self.reach.iter().any(Option::is_some);
        if std::mem::take(&mut self.sensors_changed) || active {
            let circles: Vec<_> = poses
                .iter()
                .zip(&self.reach)
                .filter_map(|((p, _), r)| r.map(|r| (p32(*p), [r as f32, r as f32])))
                .collect();
            rows.centres.push(circles.iter().map(|c| c.0));
            rows.half_sizes.push(circles.iter().map(|c| c.1));
        } else {
            rows.centres.skip();
            rows.half_sizes.skip();
        }
    }
}

/// A column with a value (possibly an empty list) on rows where `present`, null elsewhere.
fn sparse(
    column: SerializedComponentColumn,
    present: &[bool],
) -> Result<SerializedComponentColumn, rerun::SerializationError> {
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

/// 2D vectors as the Arrow array of Rerun's `Vec2D`-based components (positions, origins,
/// vectors, centres, half sizes: a fixed-size list of two 32-bit floats), built without copying
/// or going through the archetype builders, which convert value by value.
/// The arrow from the rim of a marker of radius `r` at `a` to the rim of one at `b`, shifted by
/// `r / 2` to the right of its direction (so `b -> a` runs beside it); centre to centre when
/// the markers overlap.
fn rim_to_rim(a: Point, b: Point, r: f64) -> (Point, Point) {
    let d = b - a;
    let len = d.norm();
    if len <= 2.0 * r {
        return (a, b);
    }
    let u = d / len;
    let right = Vector::new(u.y, -u.x) * (r / 2.0);
    // The shifted ends stay on the rims: step in by the chord's half-length there.
    let inner = (r * r - (r / 2.0) * (r / 2.0)).sqrt();
    (a + u * inner + right, b - u * inner + right)
}

fn vec2_array(values: Vec<[f32; 2]>) -> ArrayRef {
    let floats = Float32Array::from(values.into_flattened());
    Arc::new(FixedSizeListArray::new(
        Arc::new(Field::new("item", DataType::Float32, false)),
        2,
        Arc::new(floats),
        None,
    ))
}

/// A component column of 2D vectors, `lengths` of them per row.
fn vec2_column(
    values: Vec<[f32; 2]>,
    descriptor: ComponentDescriptor,
    lengths: Vec<usize>,
) -> Result<[SerializedComponentColumn; 1], rerun::SerializationError> {
    SerializedComponentBatch::new(vec2_array(values), descriptor)
        .partitioned(lengths)
        .map(|c| [c])
}

fn p32(p: Point) -> [f32; 2] {
    [p.x as f32, p.y as f32]
}

/// A [`Canvas`] writing a Rerun recording.
///
/// Every chunk is built here with row and chunk ids numbered in the order they are sent (no
/// wall-clock ids, no batching on Rerun's timer), so the recording's rows depend on the run
/// alone.
pub struct RerunCanvas {
    /// The stream to a viewer, when one is connected.
    live: Option<RecordingStream>,
    /// Robot groups, by group number.
    groups: Vec<Group>,
    log: Rows<(Level, String)>,
    metrics: Rows<Metrics>,
    /// Exact poses at kinematic records: `(robot, [x, y, angle])`.
    exact: Rows<(RobotId, [f64; 3])>,
    /// Legs of the robots' paths: `(from, to, colour)`.
    legs: Rows<([f32; 2], [f32; 2], Rgb)>,
    /// Collision markers, one per row: `(contact point, half size)`.
    collisions: Rows<([f32; 2], f32)>,
    /// The half size of a collision cross: the largest robot radius so far.
    marker: f32,
    ids: Ids,
    /// With a viewer connected, everything is flushed at every whole simulated second.
    next_live_flush: f64,
    /// The viewer's URL, when streaming to one.
    url: Option<String>,
    /// The .rrd being written, its temporary name and its target.
    file: Option<(RrdFile, PathBuf, PathBuf)>,
    error: Option<RecordingError>,
    /// Whether robot markers show their labels ([`Layout::labels`]).
    labels: bool,
    /// The blueprint's store, for the axes settled at the end ([`RerunCanvas::finish`]).
    blueprint: StoreId,
    /// Each metric's least and greatest value so far, in [`METRICS`]' order.
    extent: [Option<(f64, f64)>; 4],
    /// The metric entities logged ([`Layout::metrics`]).
    plotted: Vec<&'static str>,
    /// The space-time diagram, if drawn.
    spacetime: Option<SpaceTime>,
    /// [`Layout::inset`].
    inset: Option<f64>,
    /// Where each crashed lane ends.
    lane_end: Vec<Option<f32>>,
    /// Arrows of the diagram, one per row: `(origin, vector, colour, label)`.
    st_messages: Rows<([f32; 2], [f32; 2], Rgb, String)>,
    /// Marks on the lanes, one per row: `(position, colour, label)`.
    st_marks: Rows<([f32; 2], Rgb, String)>,
    /// Each lane's deliveries so far (full diagrams).
    delivered: Vec<Vec<String>>,
    /// Packets in flight per layer, a row per event or frame.
    packets: BTreeMap<String, Rows<Vec<[f32; 2]>>>,
}

impl std::fmt::Debug for RerunCanvas {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RerunCanvas")
            .field("file", &self.file)
            .field("url", &self.url)
            .finish()
    }
}

fn rerun_err(e: impl std::fmt::Display) -> RecordingError {
    RecordingError::Rerun(e.to_string())
}

/// FNV-1a, 64 bits: a recording id that is a function of the run.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The application id of recordings.
const APP: &str = "nekosim";

/// How long a viewer has to answer `--connect`, and to take the rest of the stream at the end.
pub const VIEWER_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(5);

/// A gRPC sink connected to the viewer at `url`, or why there is none. Waiting on the wall
/// clock here is about the network, not the simulation.
fn connect(
    url: &str,
    uri: rerun::external::re_uri::ProxyUri,
) -> Result<rerun::sink::GrpcSink, RecordingError> {
    use rerun::sink::GrpcSinkConnectionState as State;
    let sink = rerun::sink::GrpcSink::new(uri);
    let start = std::time::Instant::now();
    loop {
        match sink.status() {
            State::Connected => return Ok(sink),
            State::Disconnected(r) => {
                return Err(RecordingError::Unreachable {
                    url: url.to_string(),
                    message: match r {
                        Err(e) => e.to_string(),
                        Ok(()) => "disconnected".into(),
                    },
                })
            }
            State::Connecting { .. } if start.elapsed() > VIEWER_TIMEOUT => {
                return Err(RecordingError::Unreachable {
                    url: url.to_string(),
                    message: format!("no answer in {} s", VIEWER_TIMEOUT.as_secs()),
                })
            }
            State::Connecting { .. } => std::thread::sleep(std::time::Duration::from_millis(20)),
        }
    }
}

/// The default layout: the 2D world beside the log above a grid of metric plots, as blueprint
/// messages (header and chunks) and its activation, with fixed view and container ids and the
/// next row and chunk ids, so that it is the same in every recording. (The SDK's `Blueprint`
/// builder makes the same layout with random ids and wall-clock times.)
/// The blueprint store of the recording `recording_id`.
fn blueprint_store(recording_id: &str) -> StoreId {
    StoreId::new(
        StoreKind::Blueprint,
        APP,
        format!("{recording_id}-blueprint"),
    )
}

/// The fixed UUID of blueprint item `n` (a view or a container).
fn blueprint_uuid(n: u8) -> [u8; 16] {
    let mut bytes = [0u8; 16];
    bytes[6] = 0x40; // version 4
    bytes[8] = 0x80; // RFC 4122 variant
    bytes[15] = n;
    bytes
}

/// The entity path of blueprint item `n` of `kind` (`view`, `container`).
fn blueprint_path(kind: &str, n: u8) -> String {
    let u = blueprint_uuid(n);
    let hex: String = u.iter().map(|b| format!("{b:02x}")).collect();
    format!(
        "{kind}/{}-{}-{}-{}-{}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

/// One static-free blueprint chunk per `(entity, components)` at blueprint time `time`.
fn blueprint_rows(
    store: &StoreId,
    ids: &mut Ids,
    time: i64,
    rows: Vec<(String, Box<dyn rerun::AsComponents>)>,
) -> Result<Vec<LogMsg>, RecordingError> {
    let mut msgs = Vec::new();
    for (entity, what) in rows {
        let times = [TimeColumn::new_sequence("blueprint", [time])];
        let columns = what
            .as_serialized_batches()
            .into_iter()
            .map(|b| {
                let n = b.array.len();
                b.partitioned([n]).map(|c| (c.descriptor, c.list_array))
            })
            .collect::<Result<_, _>>()
            .map_err(rerun_err)?;
        let chunk = Chunk::from_native_row_ids(
            ids.chunk(),
            entity.as_str().into(),
            Some(true),
            &ids.rows(1),
            times
                .into_iter()
                .map(|c| (*c.timeline().name(), c))
                .collect(),
            columns,
        )
        .map_err(rerun_err)?;
        let arrow = chunk.to_arrow_msg().map_err(rerun_err)?;
        msgs.push(LogMsg::ArrowMsg(store.clone(), arrow));
    }
    Ok(msgs)
}

/// The metric views' numbers in the blueprint: [`METRICS`]' `i`-th is view `3 + i`.
fn metric_view(i: usize) -> u8 {
    3 + i as u8
}

fn blueprint_msgs(
    recording_id: &str,
    ids: &mut Ids,
    layout: &Layout,
) -> Result<(Vec<LogMsg>, BlueprintActivationCommand), RecordingError> {
    use rerun::external::re_sdk_types::blueprint::archetypes::{
        ContainerBlueprint, PanelBlueprint, PlotLegend, ViewBlueprint, ViewContents,
        ViewportBlueprint, VisibleTimeRanges, VisualBounds2D,
    };
    use rerun::external::re_sdk_types::blueprint::components::{
        ColumnShare, ContainerKind, IncludedContent, PanelState, QueryExpression, RootContainer,
        RowShare, ViewClass,
    };
    use rerun::external::re_sdk_types::datatypes::{
        Range1D, Range2D, TimeInt, TimeRange, TimeRangeBoundary, VisibleTimeRange,
    };

    let store = blueprint_store(recording_id);
    let uuid = blueprint_uuid;
    let path = blueprint_path;
    // Views 1-2 and 3.. (one per metric, so that each plot has its own scale: events per
    // second run to thousands while collisions count in tens), containers from 10.
    let (world, log, root, right, plots) = (1, 2, 10, 11, 12);
    let (spacetime, verdict) = (7, 8);
    let full = layout.spacetime.is_some_and(|s| s.full);
    let metric_views: Vec<(u8, &str)> = METRICS
        .iter()
        .enumerate()
        .filter(|(_, m)| layout.metrics.contains(*m))
        .map(|(i, m)| (metric_view(i), *m))
        .collect();
    let mut rows: Vec<(String, Box<dyn rerun::AsComponents>)> = Vec::new();
    let views = [
        (world, "2D", "world", "/world".to_owned()),
        (log, "TextLog", "log", "/log".to_owned()),
    ]
    .into_iter()
    .chain(
        layout
            .spacetime
            .map(|_| (spacetime, "2D", "space-time", "/spacetime".to_owned())),
    )
    .chain(full.then(|| (verdict, "TextDocument", "verdict", "/verdict".to_owned())))
    .chain(metric_views.iter().map(|(n, entity)| {
        let name = entity.rsplit('/').next().unwrap_or(entity);
        (*n, "TimeSeries", name, format!("/{entity}"))
    }));
    for (n, class, name, origin) in views {
        rows.push((
            format!("{}/ViewContents", path("view", n)),
            Box::new(ViewContents::new([QueryExpression("$origin/**".into())])),
        ));
        rows.push((
            path("view", n),
            Box::new(
                ViewBlueprint::new(ViewClass(class.into()))
                    .with_display_name(name)
                    .with_space_origin(origin.as_str()),
            ),
        ));
    }
    // Legs of the robots' paths stay drawn for the last TRAIL_SECONDS of simulated time (a
    // per-entity visible time range, where the Python SDK's `overrides=` puts it).
    let trail = VisibleTimeRange {
        timeline: "sim_time".into(),
        range: TimeRange {
            start: TimeRangeBoundary::CursorRelative(TimeInt(-(super::TRAIL_SECONDS * 1e9) as i64)),
            end: TimeRangeBoundary::CursorRelative(TimeInt(0)),
        },
    };
    rows.push((
        format!(
            "{}/ViewContents/overrides/world/paths/visualizers",
            path("view", world)
        ),
        Box::new(VisibleTimeRanges::new([
            rerun::external::re_sdk_types::blueprint::components::VisibleTimeRange(trail),
        ])),
    ));
    // Collision markers stay for COLLISION_SECONDS after their instant.
    let collisions = VisibleTimeRange {
        timeline: "sim_time".into(),
        range: TimeRange {
            start: TimeRangeBoundary::CursorRelative(TimeInt(-(COLLISION_SECONDS * 1e9) as i64)),
            end: TimeRangeBoundary::CursorRelative(TimeInt(0)),
        },
    };
    rows.push((
        format!(
            "{}/ViewContents/overrides/world/collisions/visualizers",
            path("view", world)
        ),
        Box::new(VisibleTimeRanges::new([
            rerun::external::re_sdk_types::blueprint::components::VisibleTimeRange(collisions),
        ])),
    ));
    // The space-time diagram keeps every arrow and mark from its instant on, and frames its
    // lanes.
    if let Some(st) = layout.spacetime {
        let always = VisibleTimeRange {
            timeline: "sim_time".into(),
            range: TimeRange {
                start: TimeRangeBoundary::Infinite,
                end: TimeRangeBoundary::CursorRelative(TimeInt(0)),
            },
        };
        for entity in ["messages", "marks"] {
            rows.push((
                format!(
                    "{}/ViewContents/overrides/spacetime/{entity}/visualizers",
                    path("view", spacetime)
                ),
                Box::new(VisibleTimeRanges::new([
                    rerun::external::re_sdk_types::blueprint::components::VisibleTimeRange(
                        always.clone(),
                    ),
                ])),
            ));
        }
        let right_edge = LANE_GAP * st.lanes.max(2) as f64;
        rows.push((
            format!("{}/VisualBounds2D", path("view", spacetime)),
            Box::new(VisualBounds2D::new(Range2D {
                x_range: Range1D([-LANE_GAP, right_edge]),
                y_range: Range1D([-LANE_GAP, st.height() + 2.0 * LANE_GAP]),
            })),
        ));
    }
    // The 2D view frames the world, not whatever was drawn so far.
    if let Some([x0, x1, y0, y1]) = layout.view_bounds() {
        rows.push((
            format!("{}/VisualBounds2D", path("view", world)),
            Box::new(VisualBounds2D::new(Range2D {
                x_range: Range1D([x0, x1]),
                y_range: Range1D([y0, y1]),
            })),
        ));
    }
    // The log shows time, level and text: its entity path is always `/log`.
    {
        use rerun::external::re_sdk_types::blueprint::archetypes::TextLogColumns;
        use rerun::external::re_sdk_types::blueprint::datatypes::{
            TextLogColumn, TextLogColumnKind, TimelineColumn,
        };
        rows.push((
            format!("{}/TextLogColumns", path("view", log)),
            Box::new(
                TextLogColumns::new()
                    .with_timeline_columns([
                        TimelineColumn {
                            visible: true.into(),
                            timeline: "sim_time".into(),
                        },
                        TimelineColumn {
                            visible: false.into(),
                            timeline: "event".into(),
                        },
                    ])
                    .with_text_log_columns([
                        TextLogColumn {
                            kind: TextLogColumnKind::EntityPath,
                            visible: false.into(),
                        },
                        TextLogColumn {
                            kind: TextLogColumnKind::LogLevel,
                            visible: true.into(),
                        },
                        TextLogColumn {
                            kind: TextLogColumnKind::Body,
                            visible: true.into(),
                        },
                    ]),
            ),
        ));
    }
    // One series per plot: no legend over the data.
    for (n, _) in &metric_views {
        rows.push((
            format!("{}/PlotLegend", path("view", *n)),
            Box::new(PlotLegend::new().with_visible(false)),
        ));
    }
    // The world gets the window: the blueprint and selection panels start collapsed, and the
    // time panel to its bar (play, speed and the time cursor stay, for scrubbing).
    for panel in ["blueprint_panel", "selection_panel"] {
        rows.push((
            panel.into(),
            Box::new(PanelBlueprint::new().with_state(PanelState::Collapsed)),
        ));
    }
    rows.push((
        "time_panel".into(),
        Box::new(
            rerun::external::re_sdk_types::blueprint::archetypes::TimePanelBlueprint::new()
                .with_state(PanelState::Collapsed)
                .with_timeline("sim_time")
                .with_play_state(
                    rerun::external::re_sdk_types::blueprint::components::PlayState::Playing,
                ),
        ),
    ));
    let contents = |children: &[(&str, u8)]| -> Vec<IncludedContent> {
        children
            .iter()
            .map(|(kind, n)| IncludedContent(format!("/{}", path(kind, *n)).into()))
            .collect()
    };
    let plot_views: Vec<(&str, u8)> = metric_views.iter().map(|(n, _)| ("view", *n)).collect();
    rows.push((
        path("container", plots),
        Box::new(ContainerBlueprint::new(ContainerKind::Grid).with_contents(contents(&plot_views))),
    ));
    // A run: the world (two thirds), then the space-time diagram when messages flow, then
    // the log above the plots. A check: the space-time diagram is the main view; the verdict,
    // the lanes' world and the log above the plots beside it.
    let share = |v: &[f32]| v.iter().map(|s| RowShare((*s).into())).collect::<Vec<_>>();
    let col_share = |v: &[f32]| {
        v.iter()
            .map(|s| ColumnShare((*s).into()))
            .collect::<Vec<_>>()
    };
    let (right_children, right_shares): (Vec<(&str, u8)>, Vec<f32>) = if full {
        (
            vec![
                ("view", verdict),
                ("view", log),
                ("view", world),
                ("container", plots),
            ],
            vec![0.8, 1.5, 0.8, 0.8],
        )
    } else {
        (vec![("view", log), ("container", plots)], vec![1.0, 1.0])
    };
    rows.push((
        path("container", right),
        Box::new(
            ContainerBlueprint::new(ContainerKind::Vertical)
                .with_contents(contents(&right_children))
                .with_row_shares(share(&right_shares)),
        ),
    ));
    let (root_children, root_shares): (Vec<(&str, u8)>, Vec<f32>) = match layout.spacetime {
        Some(_) if full => (
            vec![("view", spacetime), ("container", right)],
            vec![2.0, 1.0],
        ),
        Some(_) => (
            vec![("view", world), ("view", spacetime), ("container", right)],
            vec![2.0, 1.0, 1.0],
        ),
        None => (vec![("view", world), ("container", right)], vec![2.0, 1.0]),
    };
    rows.push((
        path("container", root),
        Box::new(
            ContainerBlueprint::new(ContainerKind::Horizontal)
                .with_contents(contents(&root_children))
                .with_col_shares(col_share(&root_shares)),
        ),
    ));
    rows.push((
        "viewport".into(),
        Box::new(ViewportBlueprint::new().with_root_container(RootContainer(uuid(root).into()))),
    ));

    let mut msgs = vec![ids.store_info(store.clone())];
    msgs.extend(blueprint_rows(&store, ids, 0, rows)?);
    let activation = BlueprintActivationCommand {
        blueprint_id: store,
        make_active: true,
        make_default: true,
    };
    Ok((msgs, activation))
}

impl RerunCanvas {
    /// Starts a recording named `name` to `target`. The .rrd file is written beside its target
    /// under a hidden temporary name and moved into place by [`RerunCanvas::finish`] (or when
    /// the canvas is dropped, so a failed run still leaves a complete recording).
    ///
    /// The recording's id is derived from `id` (what makes the run: the scenario and its
    /// seed), so the same run gives the same recording.
    ///
    /// `layout` says what the default blueprint shows ([`Layout`]).
    pub fn start(
        name: &str,
        id: &str,
        target: &Target,
        layout: &Layout,
    ) -> Result<Self, RecordingError> {
        let recording_id = format!("nekosim-{:016x}", fnv1a(id.as_bytes()));
        let store = StoreId::recording(APP, recording_id.clone());
        let mut ids = Ids::default();
        // The viewer's URL first: a bad one must not leave a file behind.
        let viewer = match &target.connect {
            Some(url) => {
                let url = url
                    .clone()
                    .unwrap_or_else(|| rerun::DEFAULT_CONNECT_URL.to_string());
                match url.parse::<rerun::external::re_uri::RedapUri>() {
                    Ok(rerun::external::re_uri::RedapUri::Proxy(uri)) => Some((url, uri)),
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
                }
            }
            None => None,
        };
        // A viewer must answer before the run starts: the SDK would otherwise queue the
        // recording and block once its queue is full.
        let viewer = match viewer {
            Some((url, uri)) => Some((url.clone(), connect(&url, uri)?)),
            None => None,
        };
        let (blueprint, activation) = blueprint_msgs(&recording_id, &mut ids, layout)?;
        let mut file = None;
        if let Some(path) = &target.rrd {
            let create = |e: &dyn std::fmt::Display| RecordingError::Create {
                path: path.display().to_string(),
                message: e.to_string(),
            };
            let temp = temp_path(path).map_err(|e| create(&e))?;
            let mut prelude = blueprint.clone();
            prelude.push(LogMsg::BlueprintActivationCommand(activation.clone()));
            let rrd = RrdFile::create(&temp, store.clone(), &prelude, &mut ids)
                .map_err(|e| create(&e))?;
            file = Some((rrd, temp, path.clone()));
        }
        let mut canvas = Self {
            live: None,
            groups: Vec::new(),
            log: Rows::default(),
            metrics: Rows::default(),
            legs: Rows::default(),
            exact: Rows::default(),
            collisions: Rows::default(),
            marker: 1.0,
            ids,
            next_live_flush: 1.0,
            url: viewer.as_ref().map(|v| v.0.clone()),
            file,
            error: None,
            labels: layout.labels,
            plotted: layout.metrics.clone(),
            blueprint: activation.blueprint_id.clone(),
            extent: [None; 4],
            spacetime: layout.spacetime,
            inset: layout.inset,
            lane_end: layout.spacetime.map_or(Vec::new(), |s| vec![None; s.lanes]),
            st_messages: Rows::default(),
            st_marks: Rows::default(),
            delivered: layout
                .spacetime
                .map_or(Vec::new(), |s| vec![Vec::new(); s.lanes]),
            packets: BTreeMap::new(),
        };
        // From here on, dropping the canvas on an error finishes and places the file.
        if let Some((_, sink)) = viewer {
            let rec = RecordingStreamBuilder::new(APP)
                .recording_id(recording_id)
                .set_sinks(vec![Box::new(sink) as Box<dyn rerun::sink::LogSink>])
                .map_err(rerun_err)?;
            rec.send_blueprint(blueprint, activation);
            canvas.live = Some(rec);
        }
        canvas.row(
            "__properties",
            None,
            &rerun::RecordingInfo::new().with_name(name),
        );
        // A collision is a cross, in a colour no robot has (robots' hues are saturated at
        // 0.75 and 0.9 brightness; this is a full amber with thick strokes), unlabelled.
        let collisions = archetypes::LineStrips2D::update_fields()
            .with_colors([COLLISION_COLOUR])
            .with_radii([rerun::Radius::new_ui_points(2.5)])
            .with_show_labels(false);
        canvas.row("world/collisions", None, &collisions);
        if let Some(st) = canvas.spacetime {
            let labelled = st.full || st.lanes <= LABELLED_ROBOTS;
            canvas.draw_lanes(Stamp {
                t: 0.0,
                seq: Some(0),
            });
            let names = archetypes::Points2D::new(
                (0..st.lanes as RobotId)
                    .map(|p| st.at(p, 0.0))
                    .map(|[x, y]| [x, y - 0.4 * LANE_GAP as f32]),
            )
            .with_radii([0.1])
            .with_colors([[170, 170, 170]])
            .with_labels((0..st.lanes).map(|p| format!("p{p}")))
            .with_show_labels(labelled);
            canvas.row("spacetime/names", None, &names);
            canvas.row(
                "spacetime/messages",
                None,
                // Runs colour arrows by layer and name types in the log; a check labels each
                // arrow with its whole message.
                &archetypes::Arrows2D::update_fields()
                    .with_radii([rerun::Radius::new_ui_points(1.0)])
                    .with_show_labels(st.full),
            );
            canvas.row(
                "spacetime/marks",
                None,
                &archetypes::Points2D::update_fields()
                    .with_radii([rerun::Radius::new_ui_points(5.0)])
                    .with_show_labels(st.full),
            );
        }
        Ok(canvas)
    }

    fn keep(&mut self, r: Result<(), RecordingError>) {
        if let Err(e) = r {
            self.error.get_or_insert(e);
        }
    }

    /// Sends rows of `entity` as one chunk, with the next row and chunk ids.
    fn send(
        &mut self,
        entity: &str,
        times: Vec<TimeColumn>,
        columns: Result<Vec<SerializedComponentColumn>, rerun::SerializationError>,
    ) {
        let r = columns.map_err(rerun_err).and_then(|columns| {
            let Some(rows) = columns.first().map(|c| c.list_array.len()) else {
                return Ok(());
            };
            let row_ids = self.ids.rows(rows);
            let chunk = Chunk::from_native_row_ids(
                self.ids.chunk(),
                entity.into(),
                // Row ids count up, so the rows are sorted by them.
                Some(true),
                &row_ids,
                times
                    .into_iter()
                    .map(|c| (*c.timeline().name(), c))
                    .collect(),
                columns
                    .into_iter()
                    .map(|c| (c.descriptor, c.list_array))
                    .collect(),
            )
            .map_err(rerun_err)?;
            if let Some((rrd, _, _)) = &self.file {
                rrd.chunk(&chunk).map_err(rerun_err)?;
            }
            if let Some(rec) = &self.live {
                rec.send_chunk(chunk);
            }
            Ok(())
        });
        self.keep(r);
    }

    /// One row of `entity` at `at` (`None`: static).
    fn row(&mut self, entity: &str, at: Option<Stamp>, what: &dyn rerun::AsComponents) {
        let times = match at {
            Some(at) => time_columns(vec![at.t], at.seq.map(|s| s as i64).into_iter().collect()),
            None => Vec::new(),
        };
        let columns = what
            .as_serialized_batches()
            .into_iter()
            .map(|b| {
                let n = b.array.len();
                b.partitioned([n])
            })
            .collect();
        self.send(entity, times, columns);
    }

    fn flush_group(&mut self, g: usize) {
        let first = g as RobotId * ROBOT_GROUP;
        for frames in [false, true] {
            let rows = if frames {
                &mut self.groups[g].frames
            } else {
                &mut self.groups[g].events
            };
            if rows.rows() == 0 {
                continue;
            }
            match rows.take(first) {
                Ok(chunks) => {
                    for (entity, times, columns) in chunks {
                        self.send(&entity, times, Ok(columns));
                    }
                }
                Err(e) => self.keep(Err(rerun_err(e))),
            }
        }
    }

    fn flush_collisions(&mut self) {
        let (times, data) = self.collisions.take();
        if data.is_empty() {
            return;
        }
        let n = data.len();
        // Two strokes per collision: the diagonals of a square of side 2h on the contact
        // point.
        let strips = data.into_iter().flat_map(|([x, y], h)| {
            [
                [[x - h, y - h], [x + h, y + h]],
                [[x - h, y + h], [x + h, y - h]],
            ]
        });
        let columns = archetypes::LineStrips2D::update_fields()
            .with_strips(strips)
            .columns(std::iter::repeat_n(2, n))
            .map(|c| c.collect::<Vec<_>>());
        self.send("world/collisions", times, columns);
    }

    fn flush_exact(&mut self) {
        let (times, poses) = self.exact.take();
        if poses.is_empty() {
            return;
        }
        let (robots, poses): (Vec<RobotId>, Vec<[f64; 3]>) = poses.into_iter().unzip();
        let n = robots.len();
        let columns = SerializedComponentBatch::new(
            Arc::new(UInt32Array::from(robots)) as ArrayRef,
            pose_robot_descriptor(),
        )
        .partitioned(std::iter::repeat_n(1, n))
        .and_then(|robots| {
            SerializedComponentBatch::new(
                Arc::new(Float64Array::from(poses.into_flattened())) as ArrayRef,
                pose_descriptor(),
            )
            .partitioned(std::iter::repeat_n(3, n))
            .map(|poses| vec![robots, poses])
        });
        self.send("world/poses", times, columns);
    }

    fn flush_legs(&mut self) {
        let (times, legs) = self.legs.take();
        if legs.is_empty() {
            return;
        }
        let (strips, colours): (Vec<[[f32; 2]; 2]>, Vec<Rgb>) =
            legs.into_iter().map(|(a, b, c)| ([a, b], c)).unzip();
        let columns = archetypes::LineStrips2D::update_fields()
            .with_strips(strips)
            .with_colors(colours)
            .columns_of_unit_batches()
            .map(|c| c.collect());
        self.send("world/paths", times, columns);
    }

    fn flush_log(&mut self) {
        let (times, lines) = self.log.take();
        if lines.is_empty() {
            return;
        }
        let (levels, lines): (Vec<Level>, Vec<String>) = lines.into_iter().unzip();
        let columns = archetypes::TextLog::update_fields()
            .with_many_text(lines)
            .with_many_level(
                levels
                    .into_iter()
                    .map(|l| rerun::TextLogLevel::from(l.name())),
            )
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
        for (i, (entity, values)) in METRICS.iter().zip(series).enumerate() {
            if !self.plotted.contains(entity) {
                continue;
            }
            for &v in &values {
                let (lo, hi) = self.extent[i].get_or_insert((v, v));
                *lo = lo.min(v);
                *hi = hi.max(v);
            }
            let columns = archetypes::Scalars::update_fields()
                .with_scalars(values)
                .columns_of_unit_batches()
                .map(|c| c.collect());
            self.send(entity, times.clone(), columns);
        }
    }

    /// The diagram's lanes at `at`: each from the top to the bottom, or to where its process
    /// crashed.
    fn draw_lanes(&mut self, at: Stamp) {
        let Some(st) = self.spacetime else { return };
        let bottom = st.height() as f32;
        let strips: Vec<[[f32; 2]; 2]> = (0..st.lanes)
            .map(|p| {
                let [x, _] = st.at(p as RobotId, 0.0);
                [[x, 0.0], [x, self.lane_end[p].unwrap_or(bottom)]]
            })
            .collect();
        let lanes = archetypes::LineStrips2D::new(strips)
            .with_colors([[120, 120, 120]])
            .with_radii([rerun::Radius::new_ui_points(1.0)]);
        self.row("spacetime/lanes", Some(at), &lanes);
    }

    fn flush_spacetime(&mut self) {
        let (times, arrows) = self.st_messages.take();
        if !arrows.is_empty() {
            let n = arrows.len();
            let mut origins = Vec::with_capacity(n);
            let mut vectors = Vec::with_capacity(n);
            let mut colours = Vec::with_capacity(n);
            let mut labels = Vec::with_capacity(n);
            for (o, v, c, l) in arrows {
                origins.push(o);
                vectors.push(v);
                colours.push(c);
                labels.push(l);
            }
            let columns = archetypes::Arrows2D::update_fields()
                .with_origins(origins)
                .with_vectors(vectors)
                .with_colors(colours)
                .with_labels(labels)
                .columns_of_unit_batches()
                .map(|c| c.collect::<Vec<_>>());
            self.send("spacetime/messages", times, columns);
        }
        let (times, marks) = self.st_marks.take();
        if !marks.is_empty() {
            let mut positions = Vec::new();
            let mut colours = Vec::new();
            let mut labels = Vec::new();
            for (p, c, l) in marks {
                positions.push(p);
                colours.push(c);
                labels.push(l);
            }
            let columns = archetypes::Points2D::update_fields()
                .with_positions(positions)
                .with_colors(colours)
                .with_labels(labels)
                .columns_of_unit_batches()
                .map(|c| c.collect::<Vec<_>>());
            self.send("spacetime/marks", times, columns);
        }
    }

    fn flush_packets(&mut self) {
        let layers: Vec<String> = self.packets.keys().cloned().collect();
        for layer in layers {
            let (times, rows) = self.packets.get_mut(&layer).expect("listed").take();
            if rows.is_empty() {
                continue;
            }
            let lengths: Vec<usize> = rows.iter().map(Vec::len).collect();
            let columns = archetypes::Points2D::update_fields()
                .with_positions(rows.into_iter().flatten())
                .columns(lengths)
                .map(|c| c.collect::<Vec<_>>());
            self.send(&format!("world/packets/{layer}"), times, columns);
        }
    }

    fn flush_all(&mut self) {
        self.flush_packets();
        self.flush_spacetime();
        for g in 0..self.groups.len() {
            self.flush_group(g);
        }
        self.flush_log();
        self.flush_exact();
        self.flush_legs();
        self.flush_metrics();
        self.flush_collisions();
    }

    /// The group of `robot` and the robot's index in it.
    fn group(&mut self, robot: RobotId) -> (&mut Group, usize) {
        let g = (robot / ROBOT_GROUP) as usize;
        if self.groups.len() <= g {
            let new = self.groups.len()..=g;
            self.groups.resize_with(g + 1, Group::default);
            // Markers never show Rerun's labels (a fixed screen size, larger than the
            // robots); names are drawn in world units instead, up to LABELLED_ROBOTS robots.
            for n in new {
                if self.labels {
                    self.groups[n].names = Some(Vec::new());
                    let style = archetypes::LineStrips2D::update_fields()
                        .with_colors([NAME_COLOUR])
                        .with_radii([rerun::Radius::new_ui_points(0.6)]);
                    let entity = group_entity("names", n as RobotId * ROBOT_GROUP);
                    self.row(&entity, None, &style);
                }
                let entity = group_entity("robots", n as RobotId * ROBOT_GROUP);
                self.row(&entity, None, &hidden_labels());
            }
        }
        let i = (robot % ROBOT_GROUP) as usize;
        let group = &mut self.groups[g];
        group.fit(i + 1);
        (group, i)
    }

    /// Sends what is buffered, ends the stream (the .rrd file gets its footer) and moves the
    /// file into place; a plot whose metric never changed gets an axis from its value to one
    /// more (a lone tick at its value says nothing). The first error of the recording, if any, is returned.
    pub fn finish(&mut self) -> Result<(), RecordingError> {
        if self.live.is_some() || self.file.is_some() {
            self.flush_all();
        }
        if let Some(rec) = self.live.take() {
            match rec.flush_with_timeout(VIEWER_TIMEOUT) {
                Ok(()) => drop(rec),
                Err(e) => {
                    // The viewer went away during the run. The SDK's sending thread may be
                    // blocked on it for good, and dropping the stream would wait for that
                    // thread: the stream is leaked instead, on this error path only.
                    self.error.get_or_insert(RecordingError::Unreachable {
                        url: self.url.clone().unwrap_or_default(),
                        message: e.to_string(),
                    });
                    std::mem::forget(rec);
                }
            }
        }
        if let Some((mut rrd, temp, target)) = self.file.take() {
            match self.flat_axes() {
                Ok(msgs) => rrd.messages(msgs),
                Err(e) => {
                    self.error.get_or_insert(e);
                }
            }
            if let Err(e) = rrd.finish() {
                self.error.get_or_insert(RecordingError::Write {
                    path: target.display().to_string(),
                    error: std::io::Error::other(e),
                });
            }
            if let Err(error) = std::fs::rename(&temp, &target) {
                self.error.get_or_insert(RecordingError::Write {
                    path: target.display().to_string(),
                    error,
                });
            }
        }
        match self.error.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

impl RerunCanvas {
    /// The blueprint's last word, once the run is over: each plotted metric that kept one
    /// value `v` gets the y range `[v - 1, v + 1]`, clamped at 0 for counts, so its plot reads
    /// as a flat line on a scale, followed by the blueprint's activation again.
    fn flat_axes(&mut self) -> Result<Vec<LogMsg>, RecordingError> {
        use rerun::external::re_sdk_types::blueprint::archetypes::ScalarAxis;
        use rerun::external::re_sdk_types::datatypes::Range1D;
        let rows: Vec<(String, Box<dyn rerun::AsComponents>)> = METRICS
            .iter()
            .zip(self.extent)
            .enumerate()
            .filter_map(|(i, (_, extent))| {
                let (lo, hi) = extent?;
                (lo == hi).then(|| {
                    let range = Range1D([(lo - 1.0).max(0.0_f64.min(lo)), hi + 1.0]);
                    (
                        format!("{}/ScalarAxis", blueprint_path("view", metric_view(i))),
                        Box::new(ScalarAxis::new().with_range(range))
                            as Box<dyn rerun::AsComponents>,
                    )
                })
            })
            .collect();
        if rows.is_empty() {
            return Ok(Vec::new());
        }
        let store = self.blueprint.clone();
        let mut msgs = blueprint_rows(&store, &mut self.ids, 1, rows)?;
        msgs.push(LogMsg::BlueprintActivationCommand(
            BlueprintActivationCommand {
                blueprint_id: store,
                make_active: true,
                make_default: true,
            },
        ));
        Ok(msgs)
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
    if target.is_dir() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "is a directory; expected a file name such as run.rrd",
        ));
    }
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
            self.row("world/bounds", None, &boxes);
        }
    }

    fn obstacles(&mut self, outlines: &[Vec<Point>]) {
        // Static grey outlines, numbered as in the scenario (`obstacle:K`).
        let strips = archetypes::LineStrips2D::new(
            outlines
                .iter()
                .map(|o| o.iter().map(|p| p32(*p)).collect::<Vec<_>>()),
        )
        .with_colors([OBSTACLE_COLOUR])
        .with_radii([rerun::Radius::new_ui_points(1.5)])
        .with_labels((0..outlines.len()).map(|k| format!("obstacle:{k}")))
        .with_show_labels(false);
        self.row("world/obstacles", None, &strips);
    }

    fn spawn(&mut self, robot: RobotId, radius: f64, colour: Rgb) {
        self.marker = self.marker.max(radius as f32);
        let (group, i) = self.group(robot);
        group.radius[i] = radius;
        group.colour[i] = colour;
        group.angle[i] = f64::NAN;
        if let Some(names) = &mut group.names {
            names[i] = super::names::robot_name(&format!("p{robot}"), radius as f32);
        }
        group.style_changed = true;
    }

    fn colour(&mut self, robot: RobotId, colour: Rgb) {
        let (group, i) = self.group(robot);
        group.colour[i] = colour;
        group.style_changed = true;
        group.dests_changed |= group.dest[i].is_some();
    }

    fn leg(&mut self, at: Stamp, robot: RobotId, from: Point, to: Point) {
        let (group, i) = self.group(robot);
        let colour = group.colour[i];
        self.legs.push(at, (p32(from), p32(to), colour));
        if self.legs.len() >= FLUSH_ROWS {
            self.flush_legs();
        }
    }

    fn destination(&mut self, robot: RobotId, dest: Option<Point>) {
        let (group, i) = self.group(robot);
        let dest = dest.map(p32);
        if group.dest[i] != dest {
            group.dest[i] = dest;
            group.dests_changed = true;
        }
    }

    fn sensor(&mut self, robot: RobotId, reach: Option<f64>) {
        let (group, i) = self.group(robot);
        group.reach[i] = reach;
        group.sensors_changed = true;
    }

    fn pose(&mut self, at: Stamp, robot: RobotId, pos: Point, angle: f64) {
        let (group, i) = self.group(robot);
        group.corner[i] = Some(p32(pos));
        self.exact.push(at, (robot, [pos.x, pos.y, angle]));
        if self.exact.len() >= FLUSH_ROWS {
            self.flush_exact();
        }
    }

    fn poses(&mut self, at: Stamp, first: RobotId, poses: &[(Point, f64)]) {
        let g = (first / ROBOT_GROUP) as usize;
        let (group, _) = self.group(first);
        group.row(at, first, poses);
        if group.events.size() >= EVENT_FLUSH_INSTANCES
            || group.events.size() + group.frames.size() >= FLUSH_INSTANCES
        {
            self.flush_group(g);
        }
        self.live_flush(at.t);
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
        self.row(&entity, Some(at), &e);
    }

    fn collision(&mut self, at: Stamp, _: u64, point: Point, _label: &str) {
        self.collisions.push(at, (p32(point), self.marker));
        if self.collisions.len() >= FLUSH_ROWS {
            self.flush_collisions();
        }
    }

    fn messages(&mut self, at: Stamp, layer: &str, colour: Rgb, flights: &[Flight]) {
        let ends: Vec<(Point, Point)> = flights
            .iter()
            .map(|f| match self.inset {
                Some(r) => rim_to_rim(f.origin, f.target, r),
                None => (f.origin, f.target),
            })
            .collect();
        let full = self.spacetime.is_some_and(|s| s.full);
        let arrows = archetypes::Arrows2D::from_vectors(ends.iter().map(|(a, b)| {
            let v = *b - *a;
            [v.x as f32, v.y as f32]
        }))
        .with_origins(ends.iter().map(|(a, _)| p32(*a)))
        // A run's arrows are thin and translucent: a broadcast to every robot draws dozens at
        // once, and the packets travelling along them (full colour) show where each message
        // is. A counterexample has a few, drawn in full.
        .with_colors([if full {
            rerun::Color::from_rgb(colour[0], colour[1], colour[2])
        } else {
            rerun::Color::from_unmultiplied_rgba(colour[0], colour[1], colour[2], MESSAGE_ALPHA)
        }])
        .with_radii([rerun::Radius::new_ui_points(if full { 1.5 } else { 0.75 })])
        .with_labels(flights.iter().map(|f| {
            if full {
                f.text.clone()
            } else {
                f.label.clone()
            }
        }));
        self.row(&format!("world/messages/{layer}"), Some(at), &arrows);
    }

    fn log(&mut self, at: Stamp, level: Level, line: &str) {
        self.log.push(at, (level, line.to_string()));
        if self.log.len() >= FLUSH_ROWS {
            self.flush_log();
        }
        self.live_flush(at.t);
    }

    fn exchange(&mut self, at: Stamp, _layer: &str, colour: Rgb, f: &Flight) {
        let Some(st) = self.spacetime else { return };
        let from = st.at(f.from, f.sent);
        let to = st.at(f.to, at.t);
        let label = if st.full {
            f.text.clone()
        } else {
            f.label.clone()
        };
        self.st_messages.push(
            at,
            (from, [to[0] - from[0], to[1] - from[1]], colour, label),
        );
        if self.st_messages.len() >= FLUSH_ROWS {
            self.flush_spacetime();
        }
    }

    fn mark(&mut self, at: Stamp, robot: RobotId, mark: Mark, label: &str) {
        let Some(st) = self.spacetime else { return };
        let p = st.at(robot, at.t);
        let colour = match mark {
            Mark::Deliver => [60, 200, 90],
            Mark::Decide => [70, 140, 255],
            Mark::Crash => [230, 40, 40],
        };
        self.st_marks.push(at, (p, colour, label.to_string()));
        if mark == Mark::Crash {
            if let Some(end) = self.lane_end.get_mut(robot as usize) {
                *end = Some(p[1]);
                self.draw_lanes(at);
            }
        }
        if mark == Mark::Deliver && st.full {
            if let Some(seq) = self.delivered.get_mut(robot as usize) {
                seq.push(label.to_string());
            }
            // Each lane's delivered sequence under it, as it grows.
            let below = st.height() as f32 + LANE_GAP as f32;
            let positions: Vec<[f32; 2]> = (0..st.lanes)
                .map(|q| [st.at(q as RobotId, 0.0)[0], below])
                .collect();
            let labels: Vec<String> = self
                .delivered
                .iter()
                .map(|seq| format!("[{}]", seq.join(", ")))
                .collect();
            let seqs = archetypes::Points2D::new(positions)
                .with_radii([0.1])
                .with_labels(labels);
            self.row("spacetime/delivered", Some(at), &seqs);
        }
        if self.st_marks.len() >= FLUSH_ROWS {
            self.flush_spacetime();
        }
    }

    fn packets(&mut self, at: Stamp, layer: &str, colour: Rgb, packets: &[Point]) {
        if !self.packets.contains_key(layer) {
            // The layer's colour and size, once.
            let style = archetypes::Points2D::update_fields()
                .with_colors([colour])
                .with_radii([rerun::Radius::new_ui_points(3.0)]);
            self.row(&format!("world/packets/{layer}"), None, &style);
        }
        // On `sim_time` only: packets move with frames, between events.
        let rows = self.packets.entry(layer.to_string()).or_default();
        rows.push(
            Stamp { t: at.t, seq: None },
            packets.iter().map(|p| p32(*p)).collect(),
        );
        if rows.len() >= FLUSH_ROWS {
            self.flush_packets();
        }
    }

    fn note(&mut self, markdown: &str) {
        self.row(
            "verdict",
            None,
            &archetypes::TextDocument::new(markdown).with_media_type(rerun::MediaType::markdown()),
        );
    }

    fn metrics(&mut self, at: Stamp, m: &Metrics) {
        self.metrics.push(at, *m);
        if self.metrics.len() >= FLUSH_ROWS {
            self.flush_metrics();
        }
    }
}

impl RerunCanvas {
    /// With a viewer connected, everything buffered is sent at each whole simulated second.
    fn live_flush(&mut self, t: f64) {
        if self.live.is_some() && t >= self.next_live_flush {
            self.flush_all();
            self.next_live_flush = t.floor() + 1.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_layout_plots_what_can_move_and_labels_small_runs() {
        let world = Some((Point::new(0.0, 0.0), Point::new(800.0, 400.0)));
        let quiet = Layout::run(world, 100, (false, false), None, 10.0);
        assert_eq!(
            quiet.metrics,
            ["metrics/collisions", "metrics/events_per_second"]
        );
        assert!(!quiet.labels);
        assert!(Layout::run(world, 100, (false, false), Some(true), 10.0).labels);
        assert!(Layout::run(world, 20, (true, true), None, 10.0).labels);
        assert!(!Layout::run(world, 21, (true, true), None, 10.0).labels);
        assert!(!Layout::run(world, 5, (true, true), Some(false), 10.0).labels);
        assert_eq!(
            Layout::run(world, 5, (true, true), None, 10.0).metrics,
            METRICS
        );
        // A 3 % margin of the larger side (800) on every side.
        assert_eq!(quiet.view_bounds(), Some([-24.0, 824.0, -24.0, 424.0]));
        assert_eq!(
            Layout::run(None, 5, (true, true), None, 10.0).view_bounds(),
            None
        );
        assert_eq!(quiet.spacetime, None);
        // Messages over a network without a stack: nothing is ever delivered.
        assert_eq!(
            Layout::run(world, 5, (true, false), None, 10.0).metrics,
            [
                "metrics/collisions",
                "metrics/messages_in_flight",
                "metrics/events_per_second"
            ]
        );
        let check = Layout::check(
            (Point::new(-10.0, -10.0), Point::new(30.0, 10.0)),
            3,
            8,
            1.0,
        );
        assert_eq!(
            check.metrics,
            ["metrics/messages_in_flight", "metrics/deliveries"]
        );
        // Three lanes 10 apart over 8 steps, 45 high (1.5 times the width of three lanes).
        let st = check.spacetime.unwrap();
        assert!(st.full);
        assert_eq!(st.at(2, 8.0), [20.0, 45.0]);
        assert_eq!(st.at(1, 4.0), [10.0, 22.5]);
    }
}
