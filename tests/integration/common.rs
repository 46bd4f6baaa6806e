//! Helpers shared by the integration tests.

use nekosim::algorithm::{Idle, Script, ScriptStep};
use nekosim::scheduler::RunOutput;
use nekosim::world::geometry::Point;
use nekosim::world::motion::Pose;
use nekosim::world::virtual_world::{RobotSpec, WorldConfig, WorldSize};
use nekosim::{Algorithm, SimConfig};

pub fn spec(x: f64, y: f64, angle: f64, radius: f64) -> RobotSpec {
    RobotSpec {
        radius,
        pose: Pose {
            pos: Point::new(x, y),
            angle,
        },
    }
}

pub fn infinite() -> WorldConfig {
    WorldConfig {
        size: WorldSize::Infinite,
        ghost_mode: false,
        walls: true,
        turn: Default::default(),
        cell_size: None,
        obstacles: Default::default(),
    }
}

pub fn bounded(w: f64, h: f64) -> WorldConfig {
    WorldConfig {
        size: WorldSize::from_origin(w, h),
        ghost_mode: false,
        walls: true,
        turn: Default::default(),
        cell_size: None,
        obstacles: Default::default(),
    }
}

pub fn script(steps: Vec<ScriptStep>) -> Box<dyn Algorithm> {
    Box::new(Script(steps))
}

pub fn idle() -> Box<dyn Algorithm> {
    Box::new(Idle)
}

pub fn run(
    world: WorldConfig,
    until: f64,
    robots: Vec<(RobotSpec, Box<dyn Algorithm>)>,
) -> RunOutput {
    nekosim::run(SimConfig {
        sensors: Default::default(),
        seed: 1,
        until,
        world,
        robots,
        arbiters: 1,
        record: true,
        observers: Default::default(),
        comms: Default::default(),
    })
    .expect("run")
}

use nekosim::world::geometry::Vector;
use nekosim::world::observation::{Observation, Record};

/// A straight piece of a robot's path rebuilt from the trace: from `t` on the centre is at
/// `p + v (time - t)` until the next piece.
#[derive(Clone, Copy, Debug)]
pub struct Seg {
    pub t: f64,
    pub p: Point,
    pub v: Vector,
}

/// Rebuilds every robot's piecewise-linear path from the recorded kinematic states only
/// (spawn, motion steps, motion finishes), without any engine code.
pub fn trajectories(records: &[Record]) -> Vec<Vec<Seg>> {
    let mut out: Vec<Vec<Seg>> = Vec::new();
    for r in records {
        match &r.obs {
            Observation::Spawn { robot, pos, .. } => {
                assert_eq!(*robot as usize, out.len());
                out.push(vec![Seg {
                    t: r.t,
                    p: *pos,
                    v: Vector::zeros(),
                }]);
            }
            Observation::MotionStep { robot, state, .. }
            | Observation::MotionFinish { robot, state, .. } => {
                out[*robot as usize].push(Seg {
                    t: r.t,
                    p: state.pos,
                    v: state.vel,
                });
            }
            _ => {}
        }
    }
    out
}

/// Position of a rebuilt path at `t`.
pub fn pos_at(path: &[Seg], t: f64) -> Point {
    let i = path.partition_point(|s| s.t <= t).saturating_sub(1);
    let s = path[i];
    s.p + s.v * (t - s.t)
}

/// Radii by robot id, from the spawn records.
pub fn radii(records: &[Record]) -> Vec<f64> {
    records
        .iter()
        .filter_map(|r| match r.obs {
            Observation::Spawn { radius, .. } => Some(radius),
            _ => None,
        })
        .collect()
}

/// The trace records (JSON objects) the Neko log has no line for: an arrival right after the
/// step that finished its motion (docs/log.md), counted from the trace alone.
pub fn silent_arrivals(trace: &[serde_json::Value]) -> usize {
    let mut last: std::collections::HashMap<u64, (String, f64)> = Default::default();
    let mut silent = 0;
    for r in trace {
        let (robot, t) = (r["robot"].as_u64().unwrap(), r["t"].as_f64().unwrap());
        let kind = r["kind"].as_str().unwrap().to_string();
        let after_finish = last
            .get(&robot)
            .is_some_and(|(k, lt)| (k == "finish_turn" || k == "finish_forward") && *lt == t);
        if kind == "motion_finish" && r["outcome"] == "arrived" && after_finish {
            silent += 1;
        }
        last.insert(robot, (kind, t));
    }
    silent
}

/// The texts the algorithms logged, in order.
pub fn log_texts(out: &RunOutput) -> Vec<&str> {
    out.records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::Log { text, .. } => Some(text.as_str()),
            _ => None,
        })
        .collect()
}

/// Runs `cmd`, which must succeed: its standard output and error, together.
pub fn run_command(cmd: &mut std::process::Command) -> String {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot start {cmd:?}: {e}"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{cmd:?} failed:\n{text}");
    text
}
