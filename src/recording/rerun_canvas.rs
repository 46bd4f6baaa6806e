//! The [`Canvas`] that writes Rerun entities (docs/visualization.md), to an .rrd file
//! ([`super::rrd_file`]), a running viewer ([`connection`]), or both.
//!
//! Robots produce most of the rows (a row per event and per animation frame). They are drawn
//! in groups of [`ROBOT_GROUP`] per entity, one entity per group and family (markers,
//! headings, destinations, sensors): a Rerun row replaces a whole batch, so a row
//! carries the group's robots, and a chunk costs a fixed overhead in time and bytes, so a
//! 1k-robot run must not make thousands of entities. Rows are buffered as columns
//! ([`columns`]) and sent in chunks of up to [`FLUSH_INSTANCES`] robot instances (other
//! entities: [`FLUSH_ROWS`] rows). Path legs, collision markers and lost copies are kept on
//! screen by visible time ranges or rows of their own; rare drawings (messages, queries) are
//! single rows. When a viewer is connected, every buffer is also flushed each simulated second
//! so the live view keeps up. What the viewer shows first is the default blueprint
//! ([`blueprint`]) of the run's [`Layout`].

use std::collections::BTreeMap;
use std::path::PathBuf;

use nekosim_actors::world::geometry::{Point, Vector};
use nekosim_actors::world::RobotId;
use rerun::external::arrow::array::Array as _;
use rerun::external::re_log_types::{LogMsg, StoreId};
use rerun::log::Chunk;
use rerun::{archetypes, RecordingStream, TimeColumn};

use super::rrd_file::{temp_path, Ids, RrdFile};
use super::{
    Canvas, Flight, Level, Mark, Metrics, RecordingError, Rgb, Sight, Stamp, Target, ROBOT_GROUP,
};

mod blueprint;
mod columns;
mod connection;
pub mod layout;

pub use columns::{group_entity, pose_descriptor, pose_robot_descriptor};
use columns::{p32, time_columns, Group, Rows};
pub use connection::VIEWER_TIMEOUT;
pub use layout::{Layout, SpaceTime, LABELLED_ROBOTS, LANE_GAP, METRICS, WORLD_MARGIN};

/// Rows buffered per entity (log, metrics, collisions) before they are sent as one chunk.
pub const FLUSH_ROWS: usize = 4096;

/// Robot instances (rows × robots of the group) buffered per group entity before they are
/// sent as one chunk: fewer, larger chunks save Rerun's per-chunk cost, and beyond this size
/// the saving is too small to pay for the memory (docs/performance.md has the measurements).
/// A group's frames are also sent whenever its event rows are (see
/// [`EVENT_FLUSH_INSTANCES`]), so they are encoded during the run.
pub const FLUSH_INSTANCES: usize = 1 << 15;

/// Robot instances of event rows buffered per group before they are sent: groups fill with
/// event rows much more slowly than with frames, and sending them during the run leaves less
/// to encode at its end. Smaller sizes make more chunks, larger ones leave more for the end
/// (docs/performance.md).
pub const EVENT_FLUSH_INSTANCES: usize = 1536;

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

/// A lost copy's stub runs from the sender towards the receiver for a third of the way, and
/// at most this many radii of the largest robot: it reads as "sent this way" without
/// reaching anyone.
pub const LOST_STUB_RADII: f64 = 3.0;

/// The half size of the cross that ends a lost copy's stub, in radii of the largest robot.
pub const LOST_CROSS_RADII: f64 = 0.6;

/// A static `show_labels: false` for a Points2D entity.
fn hidden_labels() -> archetypes::Points2D {
    archetypes::Points2D::update_fields().with_show_labels(false)
}

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

/// Where the stub of a copy lost on its way from `from` to `to` ends, for robots up to
/// `radius`: a third of the way, at most [`LOST_STUB_RADII`] radii.
fn lost_stub_end(from: Point, to: Point, radius: f64) -> Point {
    let d: Vector = to - from;
    let len = d.norm();
    if len == 0.0 {
        return from;
    }
    from + d * ((len / 3.0).min(LOST_STUB_RADII * radius) / len)
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
        // The viewer first: a bad URL or an absent viewer must not leave a file behind.
        let viewer = connection::open(target.connect.as_ref())?;
        let (blueprint, activation) =
            blueprint::default_blueprint(&recording_id, &mut ids, layout)?;
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
            canvas.live = Some(connection::stream(
                recording_id,
                sink,
                blueprint,
                activation,
            )?);
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
    fn send(&mut self, entity: &str, times: Vec<TimeColumn>, columns: columns::Columns) {
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
        if !data.is_empty() {
            self.send("world/collisions", times, columns::collisions(data));
        }
    }

    fn flush_exact(&mut self) {
        let (times, poses) = self.exact.take();
        if !poses.is_empty() {
            self.send("world/poses", times, columns::exact_poses(poses));
        }
    }

    fn flush_legs(&mut self) {
        let (times, legs) = self.legs.take();
        if !legs.is_empty() {
            self.send("world/paths", times, columns::legs(legs));
        }
    }

    fn flush_log(&mut self) {
        let (times, lines) = self.log.take();
        if !lines.is_empty() {
            self.send("log", times, columns::log_lines(lines));
        }
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
            self.send(entity, times.clone(), columns::scalars(values));
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
            self.send("spacetime/messages", times, columns::arrows(arrows));
        }
        let (times, marks) = self.st_marks.take();
        if !marks.is_empty() {
            self.send("spacetime/marks", times, columns::marks(marks));
        }
    }

    fn flush_packets(&mut self) {
        let layers: Vec<String> = self.packets.keys().cloned().collect();
        for layer in layers {
            let (times, rows) = self.packets.get_mut(&layer).expect("listed").take();
            if !rows.is_empty() {
                let entity = format!("world/packets/{layer}");
                self.send(&entity, times, columns::packets(rows));
            }
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
            let url = self.url.clone().unwrap_or_default();
            if let Err(e) = connection::close(rec, &url) {
                self.error.get_or_insert(e);
            }
        }
        if let Some((mut rrd, temp, target)) = self.file.take() {
            match blueprint::flat_axes(&self.blueprint, &mut self.ids, &self.extent) {
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
impl Drop for RerunCanvas {
    fn drop(&mut self) {
        let _ = self.finish();
    }
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

    fn look(&mut self, at: Stamp, robot: RobotId, sight: Option<Sight<'_>>) {
        let entity = format!("world/looks/{robot}");
        let e = match sight {
            Some(s) => {
                let strips: Vec<[[f32; 2]; 2]> =
                    s.seen.iter().map(|&q| [p32(s.from), p32(q)]).collect();
                let labels = (0..strips.len()).map(|i| if i == 0 { s.phase } else { "" });
                archetypes::LineStrips2D::new(strips)
                    .with_colors([[170, 170, 220]])
                    .with_labels(labels)
            }
            None => archetypes::LineStrips2D::clear_fields(),
        };
        self.row(&entity, Some(at), &e);
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

    fn lost(&mut self, at: Stamp, layer: &str, colour: Rgb, lost: &[Flight]) {
        // A stub from the sender towards the receiver, ending in a cross: sent, never flown.
        let radius = f64::from(self.marker);
        let h = (LOST_CROSS_RADII * radius) as f32;
        let strips = lost.iter().flat_map(|f| {
            let [x, y] = p32(lost_stub_end(f.origin, f.target, radius));
            [
                vec![p32(f.origin), [x, y]],
                vec![[x - h, y - h], [x + h, y + h]],
                vec![[x - h, y + h], [x + h, y - h]],
            ]
        });
        let marks = archetypes::LineStrips2D::new(strips)
            .with_colors([colour])
            .with_radii([rerun::Radius::new_ui_points(0.75)]);
        self.row(&format!("world/lost/{layer}"), Some(at), &marks);
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

    fn milestone(&mut self, at: Stamp, text: &str) {
        self.row(
            "log/milestones",
            Some(at),
            &archetypes::TextLog::new(text).with_level(rerun::TextLogLevel::INFO),
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
