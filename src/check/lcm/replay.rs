//! A lasso of the two-robot model replayed in the simulator as a concrete geometric run: the
//! lasso's steps become the scripted adversary's activations (docs/lcm.md), the stem once and
//! the cycle twice, from concrete positions of the lasso's start class and its first lights;
//! the replay is then checked against the lasso step by step, and so shown to exhibit the
//! violation (the cycle repeats, with the robots apart in it).
//!
//! Each step of the lasso takes one second of simulated time. A robot's Look happens at the
//! start of the step that runs it, the end of its Compute a quarter into the step that ends
//! it, its Move starts half-way into the step that begins it and ends three quarters into the
//! step that ends it. So a Look, a Compute and a Move span the steps the model gives them: a
//! robot that Looks while the other's Move has begun and not ended sees it in mid-move, which
//! is what makes the model's pending move stale (`Miss`). A step of both robots (FSYNC, SSYNC,
//! the joint Look of ASYNC_LC_ATOMIC) runs their phases at the same instants.
//!
//! The model's `Far` is a distance at which a non-rigid move may stop short, and every move
//! from `Far` ends `Near` with the other robot's destination stale: the replay stops each such
//! move at [`CUT`] of its way, short of every point either robot's rule names.

use nekosim_actors::lcm::record::LcmRecord;
use nekosim_actors::lcm::settings::{Activation, AdversaryKind, Movement, Synchrony};
use nekosim_actors::lcm::Light;
use nekosim_actors::world::geometry::Point;
use nekosim_actors::world::observation::{Observation, Record};
use nekosim_models::liveness::Lasso;

use super::abstraction::{Abstraction, Phase, Position, State, Step};
use crate::check::CheckError;
use crate::scenario::{Built, Overrides, Registry, Source};

/// The concrete run of a lasso.
#[derive(Clone, Debug, PartialEq)]
pub struct Replay {
    pub born: [Point; 2],
    pub lights: [Light; 2],
    pub activations: Vec<Activation>,
    /// The model's state after each step, the stem's then the cycle's twice: what the run must
    /// show when the step is over.
    pub expected: Vec<Expected>,
    /// Where each repetition of the cycle starts and ends [s]: the stem's end, the first
    /// repetition's end, the second's.
    pub marks: [f64; 3],
    pub until: f64,
}

/// What the model says after a step, in the simulator's terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Expected {
    /// When the step is over [s].
    pub at: f64,
    pub lights: [Light; 2],
    /// Whether the robots stand on one point.
    pub together: bool,
}

/// Distance between the robots at the start: `Near` (every move reaches its destination)
/// and `Far` (a non-rigid move may stop short) [units].
const NEAR: f64 = 10.0;
const FAR: f64 = 100.0;

/// Where a move from `Far` stops, as a fraction of its way: short of its destination, and
/// off the midpoint that the other robot's `ToHalf` names.
const CUT: f64 = 0.3;

/// Where a phase happens within its step [fraction of the step].
fn instant(phase: Phase) -> f64 {
    match phase {
        Phase::Look | Phase::BeginCompute => 0.0,
        Phase::EndCompute => 0.25,
        Phase::BeginMove => 0.5,
        Phase::EndMove => 0.75,
    }
}

/// The replay of `lasso`, a lasso of `model` (`None` when its cycle is empty: nothing
/// repeats).
pub fn replay(model: &Abstraction, lasso: &Lasso<State, Step>) -> Option<Replay> {
    if lasso.cycle.is_empty() {
        return None;
    }
    let distance = match lasso.start.position {
        Position::Same => 0.0,
        Position::Near => NEAR,
        Position::Far => FAR,
    };
    let born = [
        Point::new(0.0, 0.0),
        Point::new(distance * 0.6, distance * 0.8),
    ];
    let steps: Vec<&(Step, State)> = lasso
        .stem
        .iter()
        .chain(&lasso.cycle)
        .chain(&lasso.cycle)
        .collect();
    let mut open: [Option<Activation>; 2] = [None, None];
    // Whether the open activation's Compute has ended.
    let mut computed = [false; 2];
    let mut activations = Vec::new();
    let mut expected = Vec::new();
    let mut before = &lasso.start;
    for (i, (step, after)) in steps.iter().enumerate() {
        let t = i as f64;
        // Phases of one step run in the model's order; a robot's own phases never share an
        // instant except Look and BeginCompute, which the simulator does not tell apart.
        let mut position = before.position;
        for &(r, phase) in &step.phases {
            let at = t + instant(phase);
            match phase {
                Phase::Look => {
                    open[r] = Some(Activation {
                        robot: r as u32,
                        look: at,
                        compute: at,
                        start_move: None,
                        move_end: at,
                        stop: None,
                        read: read(model, before, step, after),
                    });
                    computed[r] = false;
                }
                Phase::BeginCompute => {}
                Phase::EndCompute => {
                    if let Some(a) = open[r].as_mut() {
                        a.compute = at;
                        computed[r] = true;
                    }
                }
                Phase::BeginMove => {
                    if let Some(a) = open[r].as_mut() {
                        a.start_move = Some(at);
                    }
                }
                Phase::EndMove => {
                    if let Some(mut a) = open[r].take() {
                        a.move_end = at;
                        // The model ends every move from `Far` short of where it was going,
                        // and every other move where it was going (a script's stop left
                        // out is the random adversary's).
                        a.stop = Some(if position == Position::Far { CUT } else { 1.0 });
                        if position == Position::Far {
                            position = Position::Near;
                        }
                        activations.push(a);
                    }
                }
            }
        }
        expected.push(Expected {
            at: t + 1.0,
            lights: [after.robots[0].light, after.robots[1].light],
            together: after.position == Position::Same,
        });
        before = after;
    }
    // A cycle left open at the end still runs the phases the lasso gives it, and the rest
    // after the run's end.
    let until = steps.len() as f64;
    for (r, a) in open.into_iter().enumerate() {
        if let Some(a) = a {
            activations.push(Activation {
                compute: if computed[r] { a.compute } else { until + 0.25 },
                start_move: Some(a.start_move.unwrap_or(until + 0.5)),
                move_end: until + 0.75,
                stop: Some(1.0),
                ..a
            });
        }
    }
    activations.sort_by(|a, b| a.look.total_cmp(&b.look).then(a.robot.cmp(&b.robot)));
    let stem = lasso.stem.len() as f64;
    let cycle = lasso.cycle.len() as f64;
    Some(Replay {
        born,
        lights: [lasso.start.robots[0].light, lasso.start.robots[1].light],
        activations,
        expected,
        marks: [stem, stem + cycle, stem + 2.0 * cycle],
        until,
    })
}

/// The colour a step that is one robot's Look read of the other's light, among those the
/// register allows, for the outcome the lasso took (a regular or safe register offers several).
fn read(model: &Abstraction, before: &State, step: &Step, after: &State) -> Option<Light> {
    let [(r, Phase::Look)] = step.phases[..] else {
        return None;
    };
    model
        .readable(before, r)
        .into_iter()
        .find(|&c| model.look(before, r, c).robots[r] == after.robots[r])
}

/// What the simulated run shows at an instant: where each robot stood at the end of its
/// last Move, and the light it showed last, once each record before the instant is in.
pub fn seen_at(replay: &Replay, records: &[Record], t: f64) -> ([Point; 2], [Light; 2]) {
    let (mut pos, mut light) = (replay.born, replay.lights);
    for r in records.iter().take_while(|r| r.t < t) {
        match &r.obs {
            Observation::Lcm(LcmRecord::Wait { robot, at, .. }) => pos[*robot as usize] = *at,
            Observation::Light {
                robot,
                light: l,
                pending: None,
            } => light[*robot as usize] = *l,
            _ => {}
        }
    }
    (pos, light)
}

/// Where the simulated run departs from the lasso: the first step after which its lights, or
/// whether the robots share a point, are not the model's.
#[derive(Clone, Debug, PartialEq)]
pub struct Departure {
    /// The step, counted from 1 over the stem and the cycle's two repetitions.
    pub step: usize,
    pub expected: Expected,
    pub seen: ([Point; 2], [Light; 2]),
}

/// How the simulated run shows the violation: it follows the lasso after each of its steps,
/// and in each repetition of the cycle the robots are apart after some of them.
#[derive(Clone, Debug, PartialEq)]
pub struct Shown {
    /// The steps followed: the stem's and the cycle's twice.
    pub steps: usize,
    /// After how many of the cycle's steps the robots are apart, in each repetition.
    pub apart: [usize; 2],
    /// Where the robots end.
    pub end: [Point; 2],
}

/// Checks the simulated run against the lasso after every step: `Ok` when it follows it and
/// the robots are apart in each repetition of the cycle (so the cycle, repeated forever,
/// never leaves them on one point), else the first step where it departs.
pub fn shows(replay: &Replay, records: &[Record]) -> Result<Shown, Departure> {
    let stem = replay.marks[0] as usize;
    let cycle = replay.marks[1] as usize - stem;
    let mut apart = [0; 2];
    for (i, e) in replay.expected.iter().enumerate() {
        let (pos, lights) = seen_at(replay, records, e.at);
        let together = pos[0] == pos[1];
        if lights != e.lights || together != e.together {
            return Err(Departure {
                step: i + 1,
                expected: *e,
                seen: (pos, lights),
            });
        }
        if i >= stem && !together {
            apart[((i - stem) / cycle).min(1)] += 1;
        }
    }
    Ok(Shown {
        steps: replay.expected.len(),
        apart,
        end: seen_at(replay, records, replay.until).0,
    })
}

/// The scenario that plays `replay` of a lasso of `model`: `source` under the script, from the
/// lasso's first lights, with the model's register and movement, until the replay's end.
pub fn scenario(source: &Source, model: &Abstraction, replay: &Replay) -> Source {
    let mut scenario = source.clone();
    let lcm = scenario.scenario.lcm.get_or_insert_with(Default::default);
    // The script fixes every instant; the synchrony model only names the schedule.
    lcm.synchrony = Synchrony::Async;
    lcm.adversary = AdversaryKind::Scripted(replay.activations.clone());
    lcm.initial_lights = replay.lights.to_vec();
    lcm.register = model.variant.register();
    lcm.predicates.clear();
    if model.rigid {
        lcm.movement = Movement::Rigid;
    } else if lcm.movement == Movement::Rigid {
        lcm.movement = Movement::NonRigid { delta: 1.0 };
    }
    scenario.scenario.until = replay.until;
    scenario
}

/// `scenario` built, its robots born where the replay puts them.
pub fn build(scenario: &Source, replay: &Replay) -> Result<Built, CheckError> {
    let mut built = scenario.build(Overrides::default(), &Registry::with_builtins())?;
    for (i, (spec, _)) in built.robots.iter_mut().enumerate() {
        spec.pose.pos = replay.born[i.min(1)];
    }
    Ok(built)
}

/// Runs the replay of a lasso of `model` in the simulator: the run's records.
pub fn simulate(
    source: &Source,
    model: &Abstraction,
    replay: &Replay,
) -> Result<Vec<Record>, CheckError> {
    let built = build(&scenario(source, model, replay), replay)?;
    Ok(nekosim_actors::run(built.into_config(true))
        .map_err(|e| CheckError::Lcm(format!("the replay did not run: {e}")))?
        .records)
}
