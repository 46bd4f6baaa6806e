//! Building a run from a scenario, in named steps: the end time, the world, the robots'
//! sizes and counts (bounded before anything is allocated for them), their ids, the
//! communication settings, the placement and algorithms, and the recording's settings.

use std::path::Path;

use nekosim_actors::registry::{Setting, MIN_RADIUS};
use nekosim_actors::world::born::random_born_points_clear;
use nekosim_actors::world::geometry::Point;
use nekosim_actors::world::motion::Pose;
#[cfg(debug_assertions)]
use nekosim_actors::world::virtual_world::VirtualWorld;
use nekosim_actors::world::virtual_world::{RobotSpec, WorldConfig, WorldSize};
use nekosim_actors::Algorithm;
use nekosim_protocols::{FieldError, Spec};
use rand::Rng;

use super::{
    Born, Built, Overrides, Registry, RobotEntry, ScenarioError, Size, Source, MAX_COORDINATE,
    PACKING_DENSITY,
};

/// The most robots a scenario may have: ids are 32-bit.
pub const MAX_ROBOTS: u64 = 1 << 32;

/// The fewest bytes a robot takes in a run (the measured figure at a million robots is about
/// 2.4 KB): a scenario whose robots cannot fit in the machine's memory at this rate is refused
/// before anything is allocated for them.
pub const MIN_BYTES_PER_ROBOT: u64 = 1024;

/// The most grid cells the obstacles' index may visit when it is built (16 Mi): each is a
/// distance test, so this bounds the set-up to about a second.
pub const MAX_OBSTACLE_CELLS: f64 = (1u64 << 24) as f64;

/// A robot as a run takes it: where it is born and what it runs.
type Robot = (RobotSpec, Box<dyn Algorithm>);

/// The robots' count and radii, checked before any table of robots is allocated.
struct Sizes {
    /// Every robot entry's radius, in the scenario's order.
    radii: Vec<f64>,
    total: usize,
}

impl Source {
    /// Checks the scenario and builds the robots, ids, born points and algorithms.
    pub fn build(&self, overrides: Overrides, registry: &Registry) -> Result<Built, ScenarioError> {
        let s = &self.scenario;
        let until = self.until(overrides.until)?;
        if s.arbiters == 0 {
            return Err(self.err(FieldError::new("arbiters", "arbiters is 0", "at least 1")));
        }
        let seed = overrides.seed.unwrap_or(s.seed);
        let world = self.world()?;
        let sizes = self.sizes(world.size)?;
        self.obstacle_cells(&sizes)?;
        let taken = self.ids(sizes.total)?;
        // The stack first: algorithms are checked against it.
        let (comms, codecs, setting) = self.comms(sizes.total, registry)?;
        let robots = self.place_robots(&world, &sizes, &taken, seed, &setting, registry)?;
        // The checks above are the kernel's (`VirtualWorld::new`, which the run applies again
        // as it builds its world): debug builds, the tests', make sure they agree; release
        // builds do not pay twice for every run of a sweep.
        #[cfg(debug_assertions)]
        {
            let specs: Vec<RobotSpec> = robots.iter().map(|r| r.0).collect();
            VirtualWorld::new(world.clone(), &specs)
                .map_err(|e| self.place("robots", e.to_string()))?;
        }
        let framerate = self.framerate()?;
        let view = self.view(world.size)?;
        let name = s.name.clone().unwrap_or_else(|| {
            Path::new(&self.file)
                .file_stem()
                .map_or("scenario".into(), |s| s.to_string_lossy().into_owned())
        });
        Ok(Built {
            comms,
            codecs,
            sensors: registry.sensors.clone(),
            framerate,
            labels: s.animation.as_ref().and_then(|a| a.labels),
            view,
            outputs: s.outputs.clone(),
            messages: s.network.is_some() || !s.stack.is_empty(),
            deliveries: !s.stack.is_empty(),
            predicates: s.lcm.as_ref().map_or(Vec::new(), |l| l.predicates.clone()),
            name,
            seed,
            until,
            arbiters: s.arbiters,
            world,
            robots,
        })
    }

    /// The end time: the command line's, else the file's.
    fn until(&self, over: Option<f64>) -> Result<f64, ScenarioError> {
        let until = over.unwrap_or(self.scenario.until);
        if until.is_nan() || until < 0.0 {
            return Err(self.err(FieldError::new(
                "until",
                format!("until is {until}"),
                "a time >= 0 in seconds",
            )));
        }
        Ok(until)
    }

    /// The world: its extent, walls, turn rule, cell size and obstacles.
    fn world(&self) -> Result<WorldConfig, ScenarioError> {
        let w = &self.scenario.world;
        let size = match w.size {
            Size::Infinite => WorldSize::Infinite,
            Size::Bounded { width, height } => {
                self.positive("world.size.width", "world width", width)?;
                self.positive("world.size.height", "world height", height)?;
                self.within("world.size.width", "world width", width)?;
                self.within("world.size.height", "world height", height)?;
                match w.origin {
                    Some((x, y)) => {
                        self.point("world.origin", ("origin x", "origin y"), (x, y))?;
                        WorldSize::Bounded {
                            min: Point::new(x, y),
                            max: Point::new(x + width, y + height),
                        }
                    }
                    None => WorldSize::centred(width, height),
                }
            }
        };
        if let Some(c) = w.cell_size {
            self.positive("world.cell_size", "cell size", c)?;
        }
        if w.walls == Some(true) && size == WorldSize::Infinite {
            return Err(self.err(FieldError::new(
                "world.walls",
                "walls: true in an infinite world",
                "no `walls` (an infinite world has none)",
            )));
        }
        for (k, o) in self.scenario.obstacles.iter().enumerate() {
            if let Err(e) = o.check() {
                let path = match e.field.as_str() {
                    "" => format!("obstacles[{k}]"),
                    f if f.starts_with('[') => format!("obstacles[{k}][0]{f}"),
                    f => format!("obstacles[{k}].{f}"),
                };
                return Err(self.err(FieldError::new(
                    &path,
                    format!("obstacle {k}: {}", e.message),
                    e.expected,
                )));
            }
        }
        Ok(WorldConfig {
            size,
            ghost_mode: w.ghost_mode,
            walls: w.walls.unwrap_or(true),
            turn: w.turn,
            cell_size: w.cell_size,
            obstacles: self.scenario.obstacles.clone().into(),
        })
    }

    /// Every entry's radius and the robots' number, bounded before anything is allocated for
    /// them: at most [`MAX_ROBOTS`], within the machine's memory, and each group's randomly
    /// born robots, with the robots before them, no more than discs can cover of the area where
    /// they are born (refused at once rather than after a long random search).
    fn sizes(&self, size: WorldSize) -> Result<Sizes, ScenarioError> {
        let s = &self.scenario;
        let (lo, hi) = nekosim_actors::algorithm::destination_area(size);
        let area = (hi.x - lo.x) * (hi.y - lo.y);
        let disc = |r: f64| std::f64::consts::PI * r * r;
        let mut radii = Vec::with_capacity(s.robots.len());
        let mut total: u64 = 0;
        let mut covered = 0.0;
        for (i, r) in s.robots.iter().enumerate() {
            let path = format!("robots[{i}]");
            let radius = match r {
                RobotEntry::Robot { radius, .. } | RobotEntry::Group { radius, .. } => {
                    self.radius(&path, *radius)?
                }
            };
            radii.push(radius);
            if let RobotEntry::Robot { .. } = r {
                total += 1;
                covered += disc(radius);
            }
        }
        for (i, r) in s.robots.iter().enumerate() {
            let RobotEntry::Group { count, born, .. } = r else {
                continue;
            };
            let path = format!("robots[{i}].count");
            total = total.saturating_add(*count as u64);
            if total > MAX_ROBOTS {
                return Err(self.err(FieldError::new(
                    &path,
                    format!("{total} robots in all"),
                    format!("at most {MAX_ROBOTS} (robot ids are 32-bit)"),
                )));
            }
            covered += *count as f64 * disc(radii[i]);
            let listed = match born {
                Born::Random => 0,
                Born::Points(ps) => ps.len(),
            };
            if *count > listed && covered > PACKING_DENSITY * area {
                return Err(self.place(
                    &path,
                    format!(
                        "{count} robots of radius {} cannot fit: with the robots before them they would cover {covered:.0} square units, more than the {:.0} that discs can fill of the {}x{} area where they are born; use a larger world or fewer/smaller robots",
                        radii[i],
                        PACKING_DENSITY * area,
                        hi.x - lo.x,
                        hi.y - lo.y
                    ),
                ));
            }
        }
        if let Some(memory) = nekosim_models::available_memory() {
            if total.saturating_mul(MIN_BYTES_PER_ROBOT) > memory {
                let at = s
                    .robots
                    .iter()
                    .rposition(|r| matches!(r, RobotEntry::Group { .. }))
                    .map_or("robots".to_string(), |i| format!("robots[{i}].count"));
                return Err(self.err(FieldError::new(
                    &at,
                    format!(
                        "{total} robots need at least {:.1} GB, more than the {:.1} GB this machine gives",
                        (total * MIN_BYTES_PER_ROBOT) as f64 / 1e9,
                        memory as f64 / 1e9
                    ),
                    "fewer robots",
                )));
            }
        }
        Ok(Sizes {
            radii,
            total: total as usize,
        })
    }

    /// A robot entry's radius, or the scenario's `robot_size` (seed 6.1 `robot.size`): from
    /// [`MIN_RADIUS`] to [`MAX_COORDINATE`].
    fn radius(&self, path: &str, radius: Option<f64>) -> Result<f64, ScenarioError> {
        let (field, r) = match radius {
            Some(r) => (format!("{path}.radius"), r),
            None => match self.scenario.robot_size {
                Some(r) => ("robot_size".to_string(), r),
                None => {
                    return Err(self.err(FieldError::new(
                        path,
                        "no radius",
                        "`radius: R` in the entry, or `robot_size: R` for every robot",
                    )))
                }
            },
        };
        self.positive(&field, "radius", r)?;
        self.within(&field, "radius", r)?;
        if r < MIN_RADIUS {
            return Err(self.err(FieldError::new(
                &field,
                format!("radius is {r:e}"),
                format!("at least {MIN_RADIUS:e} (smaller, contacts are below the precision of positions)"),
            )));
        }
        Ok(r)
    }

    /// The obstacles' index must stay small: the cells it visits (the bounding boxes of the
    /// obstacles' edges, in cells of the spatial index) at most [`MAX_OBSTACLE_CELLS`].
    fn obstacle_cells(&self, sizes: &Sizes) -> Result<(), ScenarioError> {
        let s = &self.scenario;
        let max_r = sizes.radii.iter().copied().fold(0.0, f64::max);
        // The kernel's cell size (`VirtualWorld::new`).
        let size = s
            .world
            .cell_size
            .unwrap_or(4.0 * max_r)
            .max(2.0 * max_r * (1.0 + 1e-9))
            .max(1e-9);
        let mut cells = 0.0;
        for (k, o) in s.obstacles.iter().enumerate() {
            cells += o.index_cells(size);
            if cells > MAX_OBSTACLE_CELLS {
                return Err(self.err(FieldError::new(
                    &format!("obstacles[{k}]"),
                    format!("the obstacles up to {k} span {cells:.0} cells of the spatial index (cells {size} wide)"),
                    format!("at most {MAX_OBSTACLE_CELLS:.0} cells: smaller obstacles, or a larger `world.cell_size`"),
                )));
            }
        }
        Ok(())
    }

    /// Ids: explicit ones first (each id's entry), groups take the next free ids in order.
    fn ids(&self, total: usize) -> Result<Vec<Option<usize>>, ScenarioError> {
        let mut taken = vec![None::<usize>; total];
        for (i, r) in self.scenario.robots.iter().enumerate() {
            if let RobotEntry::Robot { id, .. } = r {
                let path = format!("robots[{i}].id");
                let slot = taken.get_mut(*id as usize).ok_or_else(|| {
                    self.err(FieldError::new(
                        &path,
                        format!("robot id {id} is out of range"),
                        format!(
                            "an id in 0..={} (there are {total} robots)",
                            total.saturating_sub(1)
                        ),
                    ))
                })?;
                if let Some(first) = *slot {
                    return Err(self.err(FieldError::new(
                        &path,
                        format!("duplicate robot id {id} (also used by robots[{first}])"),
                        "unique ids",
                    )));
                }
                *slot = Some(i);
            }
        }
        Ok(taken)
    }

    /// Placement: explicit robots, then each group's listed points, then random points; and
    /// every robot's algorithm.
    fn place_robots(
        &self,
        world: &WorldConfig,
        sizes: &Sizes,
        taken: &[Option<usize>],
        seed: u64,
        setting: &Setting,
        registry: &Registry,
    ) -> Result<Vec<Robot>, ScenarioError> {
        let total = sizes.total;
        let mut rng = nekosim_actors::random::rng(seed, nekosim_actors::random::Stream::Placement);
        let mut p = Placement {
            source: self,
            size: world.size,
            placed: vec![None; total],
            algorithms: (0..total).map(|_| None).collect(),
        };
        for (i, r) in self.scenario.robots.iter().enumerate() {
            if let RobotEntry::Robot {
                id,
                at,
                angle,
                algorithm,
                ..
            } = r
            {
                let path = format!("robots[{i}]");
                self.point(&format!("{path}.at"), ("x", "y"), *at)?;
                self.finite(&format!("{path}.angle"), "angle", *angle)?;
                let spec = RobotSpec {
                    radius: sizes.radii[i],
                    pose: Pose {
                        pos: Point::new(at.0, at.1),
                        angle: *angle,
                    },
                };
                p.check_spot(*id as usize, &spec, &format!("{path}.at"))?;
                p.placed[*id as usize] = Some(spec);
                p.algorithms[*id as usize] = Some(
                    registry
                        .algorithms
                        .build(algorithm, setting)
                        .map_err(|e| self.spec_err(&format!("{path}.algorithm"), &e))?,
                );
            }
        }
        let mut free = (0..total).filter(|&k| taken[k].is_none());
        for (i, r) in self.scenario.robots.iter().enumerate() {
            if let RobotEntry::Group {
                count,
                born,
                angle,
                algorithm,
                ..
            } = r
            {
                let group = Group {
                    path: format!("robots[{i}]"),
                    count: *count,
                    radius: sizes.radii[i],
                    born,
                    angle: *angle,
                    algorithm,
                };
                if let Some(a) = group.angle {
                    self.finite(&format!("{}.angle", group.path), "angle", a)?;
                }
                let ids: Vec<usize> = free.by_ref().take(*count).collect();
                p.group(&group, &ids, &mut rng, setting, registry)?;
            }
        }
        Ok(p.placed
            .into_iter()
            .zip(p.algorithms)
            .map(|(p, a)| {
                (
                    p.expect("every id placed"),
                    a.expect("every id has an algorithm"),
                )
            })
            .collect())
    }

    /// Animation frames per simulated second of recordings.
    fn framerate(&self) -> Result<f64, ScenarioError> {
        let Some(a) = &self.scenario.animation else {
            return Ok(crate::recording::DEFAULT_FRAMERATE);
        };
        if !(0.0..=crate::recording::MAX_FRAMERATE).contains(&a.framerate) {
            return Err(self.err(FieldError::value(
                "animation.framerate",
                "animation framerate",
                a.framerate,
                format!(
                    "frames per simulated second from 0 to {}",
                    crate::recording::MAX_FRAMERATE
                ),
            )));
        }
        Ok(if a.enabled { a.framerate } else { 0.0 })
    }

    /// The 2D view: the panel from the world's lower-left corner (centred on the origin in an
    /// infinite world), or the world itself.
    fn view(&self, size: WorldSize) -> Result<Option<(Point, Point)>, ScenarioError> {
        Ok(
            match self.scenario.animation.as_ref().and_then(|a| a.panel) {
                Some((w, h)) => {
                    self.positive("animation.panel[0]", "panel width", w)?;
                    self.positive("animation.panel[1]", "panel height", h)?;
                    self.within("animation.panel[0]", "panel width", w)?;
                    self.within("animation.panel[1]", "panel height", h)?;
                    let lo = match size {
                        WorldSize::Bounded { min, .. } => min,
                        WorldSize::Infinite => Point::new(-w / 2.0, -h / 2.0),
                    };
                    Some((lo, Point::new(lo.x + w, lo.y + h)))
                }
                None => match size {
                    WorldSize::Bounded { min, max } => Some((min, max)),
                    WorldSize::Infinite => None,
                },
            },
        )
    }

    pub(super) fn finite(&self, path: &str, what: &str, v: f64) -> Result<f64, ScenarioError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(FieldError::new(
                path,
                format!("{what} is {v}"),
                "a finite number",
            )))
        }
    }

    /// `v` must be at most [`MAX_COORDINATE`] in size: beyond, f64 motion is no longer exact
    /// to a small fraction of a unit.
    fn within(&self, path: &str, what: &str, v: f64) -> Result<f64, ScenarioError> {
        if v.abs() <= MAX_COORDINATE {
            Ok(v)
        } else {
            Err(self.err(FieldError::new(
                path,
                format!("{what} is {v:e}"),
                format!("at most {MAX_COORDINATE:e} in size (beyond, positions lose the precision exact motion needs)"),
            )))
        }
    }

    /// A point `(x, y)` at `path`: finite coordinates within [`MAX_COORDINATE`].
    fn point(
        &self,
        path: &str,
        what: (&str, &str),
        (x, y): (f64, f64),
    ) -> Result<(), ScenarioError> {
        let (px, py) = (format!("{path}[0]"), format!("{path}[1]"));
        self.finite(&px, what.0, x)?;
        self.finite(&py, what.1, y)?;
        self.within(&px, what.0, x)?;
        self.within(&py, what.1, y)?;
        Ok(())
    }

    fn positive(&self, path: &str, what: &str, v: f64) -> Result<f64, ScenarioError> {
        self.finite(path, what, v)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(FieldError::new(
                path,
                format!("{what} is {v}"),
                "a number > 0",
            )))
        }
    }
}

/// A group entry, its radius resolved.
struct Group<'a> {
    path: String,
    count: usize,
    radius: f64,
    born: &'a Born,
    angle: Option<f64>,
    algorithm: &'a Spec,
}

/// The robots placed so far, by id, and their algorithms.
struct Placement<'a> {
    source: &'a Source,
    size: WorldSize,
    placed: Vec<Option<RobotSpec>>,
    algorithms: Vec<Option<Box<dyn Algorithm>>>,
}

impl Placement<'_> {
    /// A born point must be inside a bounded world, clear of the obstacles and of the robots
    /// placed before.
    fn check_spot(&self, id: usize, spec: &RobotSpec, path: &str) -> Result<(), ScenarioError> {
        let src = self.source;
        let (p, r) = (spec.pose.pos, spec.radius);
        if let WorldSize::Bounded { min, max } = self.size {
            if p.x < min.x + r || p.y < min.y + r || p.x > max.x - r || p.y > max.y - r {
                return Err(src.err(FieldError::new(path, format!("robot {id} at ({}, {}) with radius {r} is not inside the world [{}, {}] x [{}, {}]", p.x, p.y, min.x, max.x, min.y, max.y), "a born point at least one radius inside")));
            }
        }
        let obstacles = &src.scenario.obstacles;
        if let Some(k) = obstacles.iter().position(|o| o.distance(p) < r) {
            return Err(src.err(FieldError::new(
                path,
                format!(
                    "robot {id} at ({}, {}) with radius {r} overlaps obstacle {k}",
                    p.x, p.y
                ),
                "a born point at least one radius away from every obstacle",
            )));
        }
        // In ghost mode robots never collide, so they may be born on one point.
        let ghosts = src.scenario.world.ghost_mode;
        for (other, o) in self.placed.iter().enumerate().filter(|_| !ghosts) {
            if let Some(o) = o {
                if (o.pose.pos - p).norm() < o.radius + r {
                    return Err(src.err(FieldError::new(
                        path,
                        format!(
                            "robot {id} at ({}, {}) overlaps robot {other} at ({}, {})",
                            p.x, p.y, o.pose.pos.x, o.pose.pos.y
                        ),
                        "born points at least the sum of the radii apart",
                    )));
                }
            }
        }
        Ok(())
    }

    /// A group's robots `ids`: at its listed points, the rest at random, each with the group's
    /// algorithm and heading.
    fn group(
        &mut self,
        g: &Group,
        ids: &[usize],
        rng: &mut rand_chacha::ChaCha8Rng,
        setting: &Setting,
        registry: &Registry,
    ) -> Result<(), ScenarioError> {
        let (src, path, count, radius) = (self.source, &g.path, g.count, g.radius);
        let listed: &[(f64, f64)] = match g.born {
            Born::Random => &[],
            Born::Points(ps) => ps,
        };
        if listed.len() > count {
            return Err(src.err(FieldError::new(
                &format!("{path}.born"),
                format!("{} born points for a group of {count}", listed.len()),
                format!("at most {count}"),
            )));
        }
        for (k, &(x, y)) in listed.iter().enumerate() {
            let pp = format!("{path}.born[0][{k}]");
            src.point(&pp, ("x", "y"), (x, y))?;
            let spec = RobotSpec {
                radius,
                pose: Pose {
                    pos: Point::new(x, y),
                    angle: 0.0,
                },
            };
            self.check_spot(ids[k], &spec, &pp)?;
            self.placed[ids[k]] = Some(spec);
        }
        let rest = count - listed.len();
        if rest > 0 {
            let (lo, hi) = nekosim_actors::algorithm::destination_area(self.size);
            let occupied: Vec<(Point, f64)> = (self.placed.iter().flatten())
                .map(|s| (s.pose.pos - lo.coords, s.radius))
                .collect();
            let clear = |q: Point| {
                let q = q + lo.coords;
                src.scenario
                    .obstacles
                    .iter()
                    .all(|o| o.distance(q) >= radius)
            };
            let drawn = random_born_points_clear(
                rest,
                radius,
                hi.x - lo.x,
                hi.y - lo.y,
                &occupied,
                &clear,
                rng,
            )
            .map_err(|e| src.place(&format!("{path}.count"), e.to_string()))?;
            for (k, q) in drawn.into_iter().enumerate() {
                self.placed[ids[listed.len() + k]] = Some(RobotSpec {
                    radius,
                    pose: Pose {
                        pos: q + lo.coords,
                        angle: 0.0,
                    },
                });
            }
        }
        if ids.is_empty() {
            return Ok(());
        }
        let built = registry
            .algorithms
            .build_many(g.algorithm, setting, ids.len())
            .map_err(|e| src.spec_err(&format!("{path}.algorithm"), &e))?;
        for (id, algorithm) in ids.iter().zip(built) {
            let heading = match g.angle {
                Some(a) => a,
                None => rng.gen_range(0.0..360.0),
            };
            if let Some(spec) = self.placed[*id].as_mut() {
                spec.pose.angle = heading;
            }
            self.algorithms[*id] = Some(algorithm);
        }
        Ok(())
    }
}
