//! The host of a Look-Compute-Move algorithm on a robot: the cycle (wait for the adversary,
//! Look, Compute, Move) around the user's pure `compute`. It is an [`Algorithm`] like every
//! other, so a Look-Compute-Move robot is a robot actor in the same world, and a scenario may
//! mix such robots with message-passing ones.
//!
//! One cycle (Flocchini, Prencipe and Santoro 2019, section 1.1): at the adversary's Look
//! instant the robot reads the Look sensor; maps the snapshot into the local frame the
//! adversary chose; computes; while its Compute lasts its light shows the old colour with the
//! new one being written (what a Look then reads is the register's business); at the end of
//! the Compute the new colour shows; then it glides towards its destination, mapped back to the
//! world and put onto the point it names ([`super::view::snap`]), until the adversary's stop.

use std::sync::Arc;

use rand::Rng;
use serde::de::DeserializeOwned;

use super::adversary::{Adversary, Plan};
use super::circle::smallest_enclosing;
use super::frame::Frame;
use super::glide::Glide;
use super::look::{Look, LookQuery, Snapshot, LOOK};
use super::record::LcmRecord;
use super::settings::{Detection, LcmSettings, Register, Roster};
use super::view::{snap, Light, LightState, LookComputeMove, Multiplicity, Seen, View};
use crate::config::{Configured, Setting};
use crate::robot::{Algorithm, AlgorithmFuture, Robot};
use crate::world::geometry::{Point, Vector};
use crate::world::motion::Motion;
use crate::world::observation::Observation;
use nekosim_protocols::FieldError;

/// A Look-Compute-Move algorithm a scenario can name: its configuration type and how it is
/// built from it (the counterpart of [`Configured`] for a pure `compute`). Register it as
/// `registry.algorithm::<Lcm<MyAlgorithm>>("MyAlgorithm")`.
pub trait LcmConfigured: LookComputeMove + Sized {
    /// What `algorithm: Name(field: value, ...)` is read into.
    type Config: DeserializeOwned;

    /// The algorithm, or why its configuration is refused.
    fn configure(config: Self::Config, setting: &Setting) -> Result<Self, FieldError>;
}

/// A Look-Compute-Move algorithm hosted on a robot, under the scenario's settings.
#[derive(Debug)]
pub struct Lcm<A> {
    algorithm: Arc<A>,
    settings: Arc<LcmSettings>,
}

impl<A> Clone for Lcm<A> {
    fn clone(&self) -> Self {
        Self {
            algorithm: self.algorithm.clone(),
            settings: self.settings.clone(),
        }
    }
}

impl<A: LookComputeMove> Lcm<A> {
    /// `algorithm` under `settings`.
    pub fn new(algorithm: A, settings: Arc<LcmSettings>) -> Self {
        Self {
            algorithm: Arc::new(algorithm),
            settings,
        }
    }
}

impl<A: LcmConfigured> Configured for Lcm<A> {
    type Config = A::Config;

    fn configure(config: A::Config, setting: &Setting) -> Result<Self, FieldError> {
        let algorithm = A::configure(config, setting)?;
        Ok(Self {
            algorithm: Arc::new(algorithm),
            settings: setting.lcm.clone(),
        })
    }
}

impl<A: LookComputeMove> Algorithm for Lcm<A> {
    fn name(&self) -> &str {
        "look-compute-move"
    }

    fn roster(&self) -> Option<&Roster> {
        Some(&self.settings.roster)
    }

    fn look_compute_move(&self) -> Option<Arc<dyn LookComputeMove>> {
        Some(self.algorithm.clone())
    }

    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let (algorithm, settings) = (self.algorithm.clone(), self.settings.clone());
        Box::pin(async move { cycles(&*algorithm, settings, robot).await })
    }
}

/// The robot's cycles, as long as the adversary activates it.
async fn cycles<A: LookComputeMove + ?Sized>(
    algorithm: &A,
    settings: Arc<LcmSettings>,
    robot: Robot,
) {
    let id = robot.id();
    let mut adversary = Adversary::new(settings.clone(), robot.run_seed(), id);
    let colours = algorithm.colours().max(1);
    // Self-stabilising algorithms start from any light: the adversary's choice.
    let mut light: Light = if colours > 1 {
        let drawn = robot.rng().gen_range(0..colours);
        let l = match settings.initial_lights.get(id as usize) {
            Some(&l) if l < colours => l,
            _ => drawn,
        };
        robot.set_light(LightState::steady(l));
        l
    } else {
        0
    };
    let query = LookQuery {
        range: settings.visibility,
        register: settings.register,
        colours,
        read: None,
    };
    let mut cycle = 0u64;
    while let Some(plan) = adversary.next(robot.now()) {
        note(&robot, || LcmRecord::Activate {
            robot: id,
            cycle,
            look: plan.look,
            compute_end: plan.compute_end,
            move_end: plan.move_end,
            round: plan.round,
        });
        let query = LookQuery {
            read: plan.read,
            ..query
        };
        let mut snapshot = match robot.read_at::<Look>(plan.look, LOOK, &query).await {
            Ok(s) => s,
            Err(e) => {
                robot.log(format!("Look refused: {e}"));
                return;
            }
        };
        let frame = adversary.frame();
        let view = view_of(&snapshot, frame, &settings, colours > 1);
        let decision = algorithm.compute(&view);
        let to = decision
            .to
            .map(|local| destination(&snapshot, frame, local))
            .filter(|&p| p != snapshot.me);
        let new = decision.light.filter(|&l| l != light && colours > 1);
        if let Some(l) = decision.light.filter(|&l| l >= colours) {
            robot.log(format!(
                "light {l} is outside the palette of {colours} colours"
            ));
        }
        let new = new.filter(|&l| l < colours);
        note(&robot, || LcmRecord::Look {
            robot: id,
            cycle,
            frame,
            me: snapshot.me,
            light: snapshot.light,
            // The snapshot's last use: its sightings go into the record.
            seen: std::mem::take(&mut snapshot.others),
        });
        note(&robot, || LcmRecord::Compute {
            robot: id,
            cycle,
            local_to: decision.to,
            to,
            light: new,
        });
        // A Compute writes the light even when it keeps its colour (spin-light's Robots.pml);
        // only a safe register, whose reads during a write may return any colour, tells such
        // a write from none, so only there is it made.
        let writes = new.or((settings.register == Register::Safe && colours > 1).then_some(light));
        compute(&robot, &plan, &mut light, writes).await;
        let at = go(&robot, &mut adversary, &plan, snapshot.me, to, cycle).await;
        note(&robot, || LcmRecord::Wait {
            robot: id,
            cycle,
            at,
        });
        cycle += 1;
    }
}

/// Writes the record `make` makes, when anything reads the run's step records.
fn note(robot: &Robot, make: impl FnOnce() -> LcmRecord) {
    if robot.records_steps() {
        robot.record(Observation::Lcm(make()));
    }
}

/// Sleeps until `t` (at once if it has come).
async fn wait_until(robot: &Robot, t: f64) {
    let now = robot.now();
    if t > now {
        robot.sleep(t - now).await;
    }
}

/// The Compute phase: the new light is being written until the phase ends, then shows.
async fn compute(robot: &Robot, plan: &Plan, light: &mut Light, new: Option<Light>) {
    // Without a light to write, the end of the Compute changes nothing the robot must be
    // woken for: the Move phase waits for its own start.
    let Some(n) = new else {
        return;
    };
    if plan.compute_end > robot.now() {
        robot.set_light(LightState {
            shown: *light,
            pending: Some(n),
        });
    }
    wait_until(robot, plan.compute_end).await;
    robot.set_light(LightState::steady(n));
    *light = n;
}

/// The Move phase: glides from `from` towards `to` until the adversary's stop, ending at the
/// plan's instant; returns where the robot ends.
async fn go(
    robot: &Robot,
    adversary: &mut Adversary,
    plan: &Plan,
    from: Point,
    to: Option<Point>,
    cycle: u64,
) -> Point {
    // A robot that stays sleeps through its Move phase at once.
    let start = plan.move_start.max(robot.now());
    let Some(to) = to.filter(|_| plan.move_end > start) else {
        wait_until(robot, plan.move_end).await;
        return from;
    };
    let duration = plan.move_end - start;
    let length = (to - from).norm();
    let reach = adversary.stop(plan, length);
    let stop = if reach >= length {
        to
    } else {
        from + (to - from) * (reach / length)
    };
    // Asked for now and started at the Move's start, the record written then: the robot has
    // nothing to do at that instant but ask.
    let note = robot.records_steps().then(|| {
        Observation::Lcm(LcmRecord::Move {
            robot: robot.id(),
            cycle,
            from,
            to,
            stop,
            end: plan.move_end,
        })
    });
    let glide = Motion::Custom(Arc::new(Glide { to: stop, duration }));
    let ticket = robot.start_motion_at(start, glide, note);
    robot.wait_motion(ticket).await.state.pos
}

/// The snapshot in the local frame `frame`: the robot at the origin, the others by point (and
/// light, where the others' lights are visible), with the multiplicity detection allows.
pub fn view_of(snapshot: &Snapshot, frame: Frame, settings: &LcmSettings, lit: bool) -> View {
    let lights = settings.lights;
    let mut points: Vec<(Point, Option<Light>, u32)> = Vec::with_capacity(snapshot.others.len());
    for s in &snapshot.others {
        let at = Point::from(frame.to_local(s.at - snapshot.me));
        let light = s.light.filter(|_| lit && lights.others_visible());
        match points.iter_mut().find(|(p, l, _)| *p == at && *l == light) {
            Some(entry) => entry.2 += 1,
            None => points.push((at, light, 1)),
        }
    }
    let mut others: Vec<Seen> = points
        .into_iter()
        .map(|(at, light, k)| Seen {
            at,
            light,
            multiplicity: match settings.multiplicity {
                Detection::None => Multiplicity::Unknown,
                Detection::Weak if k == 1 => Multiplicity::One,
                Detection::Weak => Multiplicity::Many,
                Detection::Strong => Multiplicity::Exactly(k),
            },
        })
        .collect();
    others.sort_by(|a, b| {
        (a.at
            .coords
            .norm_squared()
            .total_cmp(&b.at.coords.norm_squared()))
        .then(a.at.x.total_cmp(&b.at.x))
        .then(a.at.y.total_cmp(&b.at.y))
        .then(a.light.cmp(&b.light))
    });
    View {
        light: snapshot.light.filter(|_| lit && lights.own_visible()),
        others,
        visibility: settings.visibility.map(|v| v / frame.unit),
    }
}

/// Most robots a snapshot may hold for its pairs' midpoints to be snapping candidates.
const MIDPOINTS_UP_TO: usize = 16;

/// A local destination in the world: mapped back through the frame, then put onto the
/// snapshot's point it names when it is within rounding of one. The points a destination can
/// name are those the shipped algorithms steer by: a robot's position, the midpoint of two,
/// the centre of gravity of all, the centre of their smallest enclosing circle. Each is
/// computed in world coordinates from the robots' positions sorted by coordinates, so robots
/// that see the same robots compute the very same point, whatever their frames.
pub fn destination(snapshot: &Snapshot, frame: Frame, local: Point) -> Point {
    let p = snapshot.me + frame.to_world(local.coords);
    let n = 1 + snapshot.others.len();
    let mut points: Vec<Point> = Vec::with_capacity(n);
    points.push(snapshot.me);
    points.extend(snapshot.others.iter().map(|s| s.at));
    let scale = points
        .iter()
        .map(|q| (q - snapshot.me).norm())
        .fold(1.0, f64::max);
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    let sum = points.iter().fold(Vector::zeros(), |s, q| s + q.coords);
    let pairs = if n <= MIDPOINTS_UP_TO {
        n * (n - 1) / 2
    } else {
        0
    };
    let mut candidates = Vec::with_capacity(n + 2 + pairs);
    candidates.extend_from_slice(&points);
    candidates.push(Point::from(sum / points.len() as f64));
    points.dedup();
    if let Some(c) = smallest_enclosing(&points) {
        candidates.push(c.centre);
    }
    if points.len() <= MIDPOINTS_UP_TO {
        for (i, a) in points.iter().enumerate() {
            for b in &points[i + 1..] {
                candidates.push(Point::from((a.coords + b.coords) / 2.0));
            }
        }
    }
    snap(p, candidates, scale)
}
