//! Building and running a simulation: starts the actors (managers, robots, sensors on demand,
//! the scheduler), runs the actix system until the scheduler finishes, and returns what was
//! recorded.

use std::sync::{mpsc, Arc, Mutex};

use actix::prelude::*;

use crate::motion_manager::MotionManager;
use crate::robot::{Algorithm, RobotActor, RobotInfo};
use crate::scheduler::{Deliver, Observers, Routes, RunOutput, Scheduler};
use crate::sensor::Sensor;
use crate::sensor_manager::SensorManager;
use crate::world::event::Outbox;
use crate::world::virtual_world::{RobotSpec, VirtualWorld, WorldConfig, WorldError};
use crate::world::RobotId;

/// Everything a run needs.
pub struct SimConfig {
    /// Seed of every random stream in the run.
    pub seed: u64,
    /// The run ends at this virtual time [s] or when no event is left.
    pub until: f64,
    pub world: WorldConfig,
    /// Robot `i` gets id `i`.
    pub robots: Vec<(RobotSpec, Box<dyn Algorithm>)>,
    /// Number of actix arbiters (threads) hosting robots and sensors; 1 hosts everything on
    /// the current thread. The event order is the same for any number.
    pub arbiters: usize,
    /// Keep the observations (the trace) in the output; false only counts them.
    pub record: bool,
    /// Streaming observers (outputs written while the run goes on, progress).
    pub observers: Observers,
}

/// Events allowed at one instant of virtual time per robot (at least [`MIN_INSTANT_LIMIT`])
/// before a run is declared a livelock.
pub const INSTANT_EVENTS_PER_ROBOT: u64 = 1000;
/// Floor of the livelock limit.
pub const MIN_INSTANT_LIMIT: u64 = 1_000_000;

impl std::fmt::Debug for SimConfig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimConfig")
            .field("seed", &self.seed)
            .field("until", &self.until)
            .field("world", &self.world)
            .field("robots", &self.robots.len())
            .field("arbiters", &self.arbiters)
            .field("record", &self.record)
            .finish()
    }
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// The initial world is invalid (fatal before the run starts).
    #[error(transparent)]
    World(#[from] WorldError),
    /// `until` is not a number >= 0.
    #[error("the end time must be a number >= 0, got {0}")]
    BadUntil(f64),
    /// The actor system failed (an internal error).
    #[error("actor system: {0}")]
    System(String),
    /// The run stopped: virtual time stopped advancing.
    #[error("{0}")]
    Livelock(String),
}

/// Runs a simulation to its end.
pub fn run(cfg: SimConfig) -> Result<RunOutput, SimError> {
    if cfg.until.is_nan() || cfg.until < 0.0 {
        return Err(SimError::BadUntil(cfg.until));
    }
    let specs: Vec<RobotSpec> = cfg.robots.iter().map(|(s, _)| *s).collect();
    let world = VirtualWorld::new(cfg.world, &specs)?;
    let mut setup = Outbox::new(0.0, 0);
    world.start(&mut setup);
    let count = world.len();
    let world = Arc::new(Mutex::new(world));

    let system = System::new();
    let (tx, rx) = mpsc::channel();
    let seed = cfg.seed;
    let until = cfg.until;
    let mut observers = cfg.observers;
    observers.keep = cfg.record;
    let world_cfg = cfg.world;
    let robots = cfg.robots;
    let n_arbiters = cfg.arbiters.max(1);
    system.block_on(async move {
        let mut extra: Vec<Arbiter> = Vec::new();
        let mut handles = vec![Arbiter::current()];
        for _ in 1..n_arbiters {
            let a = Arbiter::new();
            handles.push(a.handle());
            extra.push(a);
        }
        let motion_manager = MotionManager::new(world.clone()).start().recipient();
        let sensor_manager = SensorManager::new(world).start().recipient();
        let arbiter_of = {
            let handles = handles.clone();
            move |id: RobotId| handles[id as usize % handles.len()].clone()
        };
        let robots: Vec<Recipient<Deliver>> = robots
            .into_iter()
            .enumerate()
            .map(|(i, (spec, algorithm))| {
                let info = RobotInfo {
                    id: i as RobotId,
                    count,
                    radius: spec.radius,
                    world: world_cfg.size,
                };
                RobotActor::start_in_arbiter(&arbiter_of(info.id), move |_| {
                    RobotActor::new(info, algorithm, seed)
                })
                .recipient()
            })
            .collect();
        let routes = Routes {
            motion_manager,
            sensor_manager,
            robots,
            spawn_sensor: Box::new(move |robot, kind| {
                Sensor::start_in_arbiter(&arbiter_of(robot), move |_| {
                    Sensor::new(robot, kind, seed)
                })
                .recipient()
            }),
        };
        let on_finish = Box::new(move |out: RunOutput| {
            for a in &extra {
                a.stop();
            }
            let _ = tx.send(out);
            System::current().stop();
        });
        let limit = (count as u64 * INSTANT_EVENTS_PER_ROBOT).max(MIN_INSTANT_LIMIT);
        Scheduler::new(routes, until, setup, observers, on_finish)
            .with_instant_limit(limit)
            .start();
    });
    system.run().map_err(|e| SimError::System(e.to_string()))?;
    let out = rx
        .recv()
        .map_err(|_| SimError::System("the scheduler ended without a result".into()))?;
    match &out.failure {
        Some(f) if f.starts_with("livelock") => Err(SimError::Livelock(f.clone())),
        Some(f) => Err(SimError::System(f.clone())),
        None => Ok(out),
    }
}
