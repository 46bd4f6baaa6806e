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
        cell_size: None,
    }
}

pub fn bounded(w: f64, h: f64) -> WorldConfig {
    WorldConfig {
        size: WorldSize::Bounded {
            width: w,
            height: h,
        },
        ghost_mode: false,
        cell_size: None,
    }
}

pub fn script(steps: Vec<ScriptStep>) -> Box<dyn Algorithm> {
    Box::new(Script(steps))
}

pub fn idle() -> Box<dyn Algorithm> {
    Box::new(Idle)
}

pub fn run(world: WorldConfig, until: f64, robots: Vec<(RobotSpec, Box<dyn Algorithm>)>) -> RunOutput {
    nekosim::run(SimConfig {
        seed: 1,
        until,
        world,
        robots,
        arbiters: 1,
        record: true,
    })
    .expect("run")
}
