//! The kernel-alone reference: a run's handling code driven without actors.
//!
//! A product run hosts every robot, sensor, manager and protocol layer in an actor, and the
//! scheduler actor hands each event to its actor and waits for the reply (the ordering contract
//! in [`crate::scheduler`]). This module drives the very same handling code ([`HandleEvent`]
//! of each actor type, the scheduler's [`Core`]) from a plain loop: one thread, no mailboxes,
//! no futures. It takes the same events in the same order and produces the same observations,
//! so the gap between the two is the cost of the actor hosting. It exists for the engine bench and the test that compares the two traces; runs
//! of the product are always actor-hosted.

use std::collections::HashMap;

use crate::handler::{handle_one, HandleEvent};
use crate::layer::LayerActor;
use crate::motion_manager::MotionManager;
use crate::network::NetworkActor;
use crate::robot::RobotActor;
use crate::scheduler::{Core, Next, RunOutput, STARTUP_EVERY};
use crate::sensor::Sensor;
use crate::sensor_manager::SensorManager;
use crate::simulation::{Prepared, SimConfig, SimError};
use crate::world::event::Target;
use crate::world::RobotId;

/// Runs `cfg` with its handlers called directly instead of through actors (the reference run;
/// `cfg.arbiters` is ignored). Same outputs as [`crate::run`].
pub fn run(cfg: SimConfig) -> Result<RunOutput, SimError> {
    let mut p = Prepared::new(cfg)?;
    let count = p.robots.len();
    let mut startup = p.observers.startup.take();
    let infos = p.infos();
    let mut motion = MotionManager::new(p.world.clone());
    let mut network = NetworkActor::new(p.network, p.world.clone(), p.wiring.clone());
    let mut sensing = SensorManager::new(p.world.clone(), p.sensing);
    let mut robots: Vec<RobotActor> = Vec::with_capacity(count);
    for (i, ((_, algorithm), info)) in p.robots.into_iter().zip(infos).enumerate() {
        if let Some(f) = startup.as_mut() {
            if i % STARTUP_EVERY == 0 && i > 0 {
                f(i, count);
            }
        }
        robots.push(RobotActor::new(
            info,
            algorithm,
            p.seed,
            p.layer_ids.clone(),
        ));
    }
    if let Some(f) = startup.as_mut() {
        f(count, count);
    }
    let mut layers: Vec<Vec<LayerActor>> = p
        .instances
        .into_iter()
        .enumerate()
        .map(|(r, stack)| {
            stack
                .into_iter()
                .enumerate()
                .map(|(l, layer)| {
                    let ix = l as nekosim_protocols::LayerIx;
                    LayerActor::new(r as RobotId, ix, layer, p.wiring.clone(), count as u32)
                })
                .collect()
        })
        .collect();
    let mut sensors = HashMap::new();
    let mut core = Core::new(p.until, p.setup, p.observers);
    core.set_instant_limit(p.instant_limit);
    while let Next::Deliver(target, msg) = core.next() {
        // The same look ahead as the scheduler actor's ([`crate::scheduler::Routes::prefetch`]).
        if let Some(ahead) = core.ahead_in_world() {
            if let Ok(w) = p.world.try_lock() {
                ahead.prefetch(&w);
            }
        }
        let handler: &mut dyn HandleEvent = match target {
            Target::EventManager => unreachable!("the event manager's events are handled inline"),
            Target::MotionManager => &mut motion,
            Target::SensorManager => &mut sensing,
            Target::Network => &mut network,
            Target::Robot(r) => &mut robots[r as usize],
            Target::Layer(r, l) => &mut layers[r as usize][l as usize],
            Target::Sensor(r, k) => sensors
                .entry((r, k))
                .or_insert_with(|| Sensor::new(r, k, p.seed, p.sensors.clone())),
        };
        core.apply(handle_one(
            handler,
            msg.now,
            msg.seq,
            msg.event,
            msg.effects,
            msg.steps,
        ));
    }
    let out = core.finish();
    match out.failure {
        Some(f) => Err(SimError::Stopped(f)),
        None => Ok(out),
    }
}
