//! A lasso of the two-robot model replayed in the simulator as a concrete geometric run: the
//! lasso's steps become the scripted adversary's activations (docs/lcm.md), the stem once and
//! the cycle twice, from concrete positions of the lasso's start class and its first lights;
//! the replay is then checked to show the violation (the robots apart at the end of each
//! repetition of the cycle, with the lights they had at its start).
//!
//! Each step of the lasso takes one second of simulated time: a robot's Look at the step's
//! start, the end of its Compute at a quarter in, the start of its Move at half and its end
//! at three quarters, so the other robot acts only in other steps (what the model's atomic
//! steps say). A step of both robots (FSYNC, SSYNC) is the simulator's round. A non-rigid move
//! that the model ends short of the other robot stops halfway.

use nekosim_actors::lcm::settings::Activation;
use nekosim_actors::lcm::Light;
use nekosim_actors::world::geometry::Point;

use super::abstraction::{Pending, Phase, Position, State, Step};
use nekosim_models::liveness::Lasso;

/// The concrete run of a lasso.
#[derive(Clone, Debug, PartialEq)]
pub struct Replay {
    pub born: [Point; 2],
    pub lights: [Light; 2],
    pub activations: Vec<Activation>,
    /// Where each repetition of the cycle starts and ends [s]: the stem's end, the first
    /// repetition's end, the second's.
    pub marks: [f64; 3],
    pub until: f64,
}

/// Distance between the robots at the start: `Near` (every move reaches its destination)
/// and `Far` (a non-rigid move may stop short) [units].
const NEAR: f64 = 10.0;
const FAR: f64 = 100.0;

/// The replay of `lasso` (`None` when its cycle is empty: nothing repeats).
pub fn replay(lasso: &Lasso<State, Step>) -> Option<Replay> {
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
    let steps: Vec<(&Step, &State)> = lasso
        .stem
        .iter()
        .chain(&lasso.cycle)
        .chain(&lasso.cycle)
        .map(|(l, s)| (l, s))
        .collect();
    let mut open: [Option<Activation>; 2] = [None, None];
    let mut activations = Vec::new();
    let mut before = &lasso.start;
    for (i, (step, after)) in steps.iter().enumerate() {
        let t = i as f64;
        for &(r, phase) in &step.phases {
            match phase {
                Phase::Look => {
                    open[r] = Some(Activation {
                        robot: r as u32,
                        look: t,
                        compute: t,
                        start_move: None,
                        move_end: t + 0.75,
                        stop: None,
                    });
                }
                Phase::EndCompute => {
                    if let Some(a) = open[r].as_mut() {
                        a.compute = t + 0.25;
                    }
                }
                Phase::EndMove => {
                    if let Some(mut a) = open[r].take() {
                        a.move_end = t + 0.75;
                        // A move to the other robot that the model ends apart was cut short.
                        let cut = before.robots[r].pending == Pending::ToOther
                            && after.position != Position::Same;
                        a.stop = cut.then_some(0.5);
                        activations.push(a);
                    }
                }
                Phase::BeginMove => {
                    if let Some(a) = open[r].as_mut() {
                        a.start_move = Some(t + 0.5);
                    }
                }
                Phase::BeginCompute => {}
            }
        }
        before = after;
    }
    let stem = lasso.stem.len() as f64;
    let cycle = lasso.cycle.len() as f64;
    Some(Replay {
        born,
        lights: [lasso.start.robots[0].light, lasso.start.robots[1].light],
        activations,
        marks: [stem, stem + cycle, stem + 2.0 * cycle],
        until: stem + 2.0 * cycle,
    })
}
