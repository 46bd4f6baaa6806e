//! Rows as Arrow columns: what the Rerun canvas buffers between chunks, and how each entity
//! family's rows become the component columns of one chunk.
//!
//! A row only carries what changed; the other components are null there ([`sparse`]), so
//! Rerun's latest-at keeps showing their earlier values. Robots are buffered per group of
//! [`ROBOT_GROUP`] ([`Group`], [`GroupRows`]), one row per event or animation frame carrying
//! every robot of the group; the other families are one value per row ([`Rows`]). 2D vectors
//! go straight into Arrow arrays ([`vec2_array`]) rather than through the archetype builders,
//! which convert value by value.

use std::sync::Arc;

use nekosim_actors::world::geometry::{heading_vector, Point};
use nekosim_actors::world::RobotId;
use rerun::external::arrow::array::{
    ArrayRef, FixedSizeListArray, Float32Array, Float64Array, ListArray, UInt32Array,
};
use rerun::external::arrow::buffer::NullBuffer;
use rerun::external::arrow::datatypes::{DataType, Field};
use rerun::{
    archetypes, ComponentDescriptor, SerializationError, SerializedComponentBatch,
    SerializedComponentColumn, TimeColumn,
};

use super::{DESTINATION_ALPHA, DESTINATION_RADII, HEADING_RADII};
use crate::recording::{Level, Rgb, Stamp, GREY, ROBOT_GROUP};

/// Columns of one chunk, or why Rerun could not make them.
pub type Columns = Result<Vec<SerializedComponentColumn>, SerializationError>;

/// Name of the group of robot `robot` under an entity family: `world/robots/0-15`.
pub fn group_entity(family: &str, robot: RobotId) -> String {
    let first = robot - robot % ROBOT_GROUP;
    format!("world/{family}/{first}-{}", first + ROBOT_GROUP - 1)
}

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
pub struct Rows<T> {
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
    pub fn push(&mut self, at: Stamp, v: T) {
        self.sim.push(at.t);
        if let Some(s) = at.seq {
            self.seq.push(s as i64);
        }
        self.data.push(v);
    }

    /// The time columns and the data, leaving the buffer empty.
    pub fn take(&mut self) -> (Vec<TimeColumn>, Vec<T>) {
        let seq = std::mem::take(&mut self.seq);
        (
            time_columns(std::mem::take(&mut self.sim), seq),
            std::mem::take(&mut self.data),
        )
    }

    pub fn len(&self) -> usize {
        self.data.len()
    }
}

/// `sim_time`, and `event` when the rows are at events.
pub fn time_columns(sim: Vec<f64>, seq: Vec<i64>) -> Vec<TimeColumn> {
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
pub struct Col<T> {
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
    pub fn push(&mut self, values: impl IntoIterator<Item = T>) {
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

    pub fn skip(&mut self) {
        if self.present.is_empty() {
            self.leading += 1;
        } else {
            self.lengths.push(0);
            self.present.push(false);
        }
    }

    pub fn any(&self) -> bool {
        // Rows are listed from the first value on.
        !self.present.is_empty()
    }

    /// The columns `build` makes of the values, null on the rows without them.
    pub fn columns<I>(
        self,
        build: impl FnOnce(Vec<T>, Vec<usize>) -> Result<I, SerializationError>,
    ) -> Result<Vec<SerializedComponentColumn>, SerializationError>
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
pub type EntityChunk = (String, Vec<TimeColumn>, Vec<SerializedComponentColumn>);

/// Rows of a robot group's entities on one set of timelines (events, or animation frames).
#[derive(Debug, Default)]
pub struct GroupRows {
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
    /// Robots' names in world units ([`crate::recording::names`]), on every row when names are drawn.
    names: Col<Vec<[f32; 2]>>,
    /// Push sensor circles, on rows where one is active or one was switched off.
    centres: Col<[f32; 2]>,
    half_sizes: Col<[f32; 2]>,
}

impl GroupRows {
    pub fn rows(&self) -> usize {
        self.sim.len()
    }

    /// Values buffered, to decide when to send.
    pub fn size(&self) -> usize {
        self.positions.values.len()
    }

    /// The chunks of the group whose first robot is `first`: `(entity, times, columns)`.
    pub fn take(&mut self, first: RobotId) -> Result<Vec<EntityChunk>, SerializationError> {
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
pub struct Group {
    pub radius: Vec<f64>,
    pub colour: Vec<Rgb>,
    /// Where each robot's current motion ends.
    pub dest: Vec<Option<[f32; 2]>>,
    /// Active push sensors' reach.
    pub reach: Vec<Option<f64>>,
    /// Where each robot was at its latest kinematic record: where its trail starts.
    pub corner: Vec<Option<[f32; 2]>>,
    /// The headings last drawn and their arrows.
    pub angle: Vec<f64>,
    pub vector: Vec<[f32; 2]>,
    /// Each robot's name relative to its centre, when names are drawn (`Some`).
    pub names: Option<Vec<Vec<Vec<[f32; 2]>>>>,
    /// What changed since the group's last row.
    pub style_changed: bool,
    pub dests_changed: bool,
    pub sensors_changed: bool,
    pub events: GroupRows,
    pub frames: GroupRows,
}

impl Group {
    pub fn fit(&mut self, n: usize) {
        if self.radius.len() < n {
            self.radius.resize(n, 0.0);
            self.colour.resize(n, GREY);
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
    pub fn row(&mut self, at: Stamp, first: RobotId, poses: &[(Point, f64)]) {
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
pub fn sparse(
    column: SerializedComponentColumn,
    present: &[bool],
) -> Result<SerializedComponentColumn, SerializationError> {
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
    .map_err(|e| SerializationError::Context {
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
pub fn vec2_array(values: Vec<[f32; 2]>) -> ArrayRef {
    let floats = Float32Array::from(values.into_flattened());
    Arc::new(FixedSizeListArray::new(
        Arc::new(Field::new("item", DataType::Float32, false)),
        2,
        Arc::new(floats),
        None,
    ))
}

/// A component column of 2D vectors, `lengths` of them per row.
pub fn vec2_column(
    values: Vec<[f32; 2]>,
    descriptor: ComponentDescriptor,
    lengths: Vec<usize>,
) -> Result<[SerializedComponentColumn; 1], SerializationError> {
    SerializedComponentBatch::new(vec2_array(values), descriptor)
        .partitioned(lengths)
        .map(|c| [c])
}

pub fn p32(p: Point) -> [f32; 2] {
    [p.x as f32, p.y as f32]
}

/// Collision markers, one per row: a cross of two strokes, the diagonals of a square of side
/// `2 h` on the contact point, for each `(contact point, h)`.
pub fn collisions(data: Vec<([f32; 2], f32)>) -> Columns {
    let n = data.len();
    let strips = data.into_iter().flat_map(|([x, y], h)| {
        [
            [[x - h, y - h], [x + h, y + h]],
            [[x - h, y + h], [x + h, y - h]],
        ]
    });
    archetypes::LineStrips2D::update_fields()
        .with_strips(strips)
        .columns(std::iter::repeat_n(2, n))
        .map(|c| c.collect())
}

/// Exact poses, one per row: the robot ([`pose_robot_descriptor`]) and `[x, y, angle]` in
/// 64-bit floats ([`pose_descriptor`]).
pub fn exact_poses(poses: Vec<(RobotId, [f64; 3])>) -> Columns {
    let (robots, poses): (Vec<RobotId>, Vec<[f64; 3]>) = poses.into_iter().unzip();
    let n = robots.len();
    let robots = SerializedComponentBatch::new(
        Arc::new(UInt32Array::from(robots)) as ArrayRef,
        pose_robot_descriptor(),
    )
    .partitioned(std::iter::repeat_n(1, n))?;
    let poses = SerializedComponentBatch::new(
        Arc::new(Float64Array::from(poses.into_flattened())) as ArrayRef,
        pose_descriptor(),
    )
    .partitioned(std::iter::repeat_n(3, n))?;
    Ok(vec![robots, poses])
}

/// Legs of the robots' paths, one per row: `(from, to, colour)`.
pub fn legs(legs: Vec<([f32; 2], [f32; 2], Rgb)>) -> Columns {
    let (strips, colours): (Vec<[[f32; 2]; 2]>, Vec<Rgb>) =
        legs.into_iter().map(|(a, b, c)| ([a, b], c)).unzip();
    archetypes::LineStrips2D::update_fields()
        .with_strips(strips)
        .with_colors(colours)
        .columns_of_unit_batches()
        .map(|c| c.collect())
}

/// Log lines, one per row, with their levels.
pub fn log_lines(lines: Vec<(Level, String)>) -> Columns {
    let (levels, lines): (Vec<Level>, Vec<String>) = lines.into_iter().unzip();
    archetypes::TextLog::update_fields()
        .with_many_text(lines)
        .with_many_level(
            levels
                .into_iter()
                .map(|l| rerun::TextLogLevel::from(l.name())),
        )
        .columns_of_unit_batches()
        .map(|c| c.collect())
}

/// A metric's samples, one per row.
pub fn scalars(values: Vec<f64>) -> Columns {
    archetypes::Scalars::update_fields()
        .with_scalars(values)
        .columns_of_unit_batches()
        .map(|c| c.collect())
}

/// Arrows of the space-time diagram, one per row: `(origin, vector, colour, label)`.
pub fn arrows(arrows: Vec<([f32; 2], [f32; 2], Rgb, String)>) -> Columns {
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
    archetypes::Arrows2D::update_fields()
        .with_origins(origins)
        .with_vectors(vectors)
        .with_colors(colours)
        .with_labels(labels)
        .columns_of_unit_batches()
        .map(|c| c.collect())
}

/// Marks on the space-time diagram's lanes, one per row: `(position, colour, label)`.
pub fn marks(marks: Vec<([f32; 2], Rgb, String)>) -> Columns {
    let mut positions = Vec::with_capacity(marks.len());
    let mut colours = Vec::with_capacity(marks.len());
    let mut labels = Vec::with_capacity(marks.len());
    for (p, c, l) in marks {
        positions.push(p);
        colours.push(c);
        labels.push(l);
    }
    archetypes::Points2D::update_fields()
        .with_positions(positions)
        .with_colors(colours)
        .with_labels(labels)
        .columns_of_unit_batches()
        .map(|c| c.collect())
}

/// Packets of one layer: on each row, every packet in flight then.
pub fn packets(rows: Vec<Vec<[f32; 2]>>) -> Columns {
    let lengths: Vec<usize> = rows.iter().map(Vec::len).collect();
    archetypes::Points2D::update_fields()
        .with_positions(rows.into_iter().flatten())
        .columns(lengths)
        .map(|c| c.collect())
}
