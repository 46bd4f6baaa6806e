//! Building and running a simulation: starts the actors (managers, robots, sensors on demand,
//! the scheduler), runs the actix system until the scheduler finishes, and returns what was
//! recorded.

use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

use actix::prelude::*;

use crate::handler::HandleEvent;
use crate::host::{Host, Route};
use crate::layer::LayerActor;
use crate::motion_manager::MotionManager;
use crate::network::NetworkActor;
use crate::robot::{Algorithm, RobotActor, RobotInfo};
use crate::scheduler::{Observers, Routes, RunOutput, Scheduler};
use crate::sensor::Sensor;
use crate::sensor_manager::SensorManager;
use crate::world::event::{EventClass, Payload, Target};
use crate::world::network::{Network, Networks, Partition};
use crate::world::outbox::Outbox;
use crate::world::sensor::Sensors;
use crate::world::virtual_world::{RobotSpec, Sensing, VirtualWorld, WorldConfig, WorldError};
use crate::world::RobotId;
use nekosim_protocols::{Input, LayerSpec, Protocols, Spec, Wiring};

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
    /// Network, protocol stack and faults.
    pub comms: Comms,
    /// Sensors registered beside the built-in ones.
    pub sensors: Sensors,
}

/// Communication settings of a run (seed 3.4-3.5).
#[derive(Clone, Debug, PartialEq)]
pub struct Comms {
    /// The network model (`Reliable(delay: 1.0)` by default), built from `networks`.
    pub network: Spec,
    /// The network models the scenario may name (built-in and registered user models).
    pub networks: Networks,
    /// Every robot gets this stack; the algorithm sits on top.
    pub stack: Vec<LayerSpec>,
    pub faults: Vec<Fault>,
    /// The protocols the stack may name (built-in and registered user protocols).
    pub protocols: Protocols,
}

impl Default for Comms {
    /// `Reliable(delay: 1.0)`, no stack, no faults, the built-in protocols and networks.
    fn default() -> Self {
        Self {
            network: Spec::new("Reliable(delay: 1.0)"),
            networks: Networks::with_builtins(),
            stack: Vec::new(),
            faults: Vec::new(),
            protocols: Protocols::with_builtins(),
        }
    }
}

/// A fault injected into a run.
#[derive(Clone, Debug, PartialEq)]
pub enum Fault {
    /// The robot stops moving, sensing and communicating at `at` [s].
    Crash {
        robot: RobotId,
        at: f64,
    },
    Partition(Partition),
}

/// Events allowed at one instant of virtual time per robot (at least [`MIN_INSTANT_LIMIT`])
/// before a run is declared a livelock: room for every robot to hear every other at one
/// instant in a run of a thousand robots (a broadcast over a network without delay).
pub const INSTANT_EVENTS_PER_ROBOT: u64 = 1000;
/// Floor of the livelock limit: far above the few events per robot that start a run at t = 0,
/// and low enough that a small run spinning at one instant is reported within about a second,
/// even in a debug build.
pub const MIN_INSTANT_LIMIT: u64 = 100_000;

/// How many robots are spawned between two looks at [`Observers::stop`] while a run starts.
const STOP_EVERY: usize = 1024;

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
    /// The network model is unknown or misconfigured (fatal before the run starts).
    #[error("network: {0}")]
    Network(#[from] nekosim_protocols::SpecError),
    /// The protocol stack is wired wrongly (fatal before the run starts).
    #[error("stack: {0}")]
    Stack(#[from] nekosim_protocols::StackError),
    /// The run stopped before its end: virtual time stopped advancing, or an actor failed.
    #[error(transparent)]
    Stopped(#[from] crate::scheduler::RunFailure),
}

/// A run made ready to host: the shared world, the setup events, the network, the protocol
/// stacks, the robots' algorithms. Both hosts start from it: the actors ([`run`]) and the
/// kernel-alone reference ([`crate::kernel::run`]).
pub(crate) struct Prepared {
    pub seed: u64,
    pub until: f64,
    pub world: Arc<Mutex<VirtualWorld>>,
    pub world_size: crate::world::virtual_world::WorldSize,
    pub sensing: Sensing,
    pub sensors: Arc<Sensors>,
    pub network: Network,
    pub wiring: Arc<Wiring>,
    /// Every robot's layer instances, by robot then stack index.
    pub instances: Vec<Vec<nekosim_protocols::Layer>>,
    pub layer_ids: Arc<Vec<String>>,
    /// The effects of the setup at t = 0 (cause 0).
    pub setup: Outbox,
    pub robots: Vec<(RobotSpec, Box<dyn Algorithm>)>,
    pub observers: Observers,
    pub arbiters: usize,
    /// The livelock limit: events at one instant.
    pub instant_limit: u64,
}

/// Tells every Look-Compute-Move algorithm which robots run one (once per roster).
fn fill_rosters(robots: &[(RobotSpec, Box<dyn Algorithm>)]) {
    let ids: Vec<RobotId> = (robots.iter().enumerate())
        .filter(|(_, (_, a))| a.roster().is_some())
        .map(|(i, _)| i as RobotId)
        .collect();
    for (_, a) in robots {
        if let Some(roster) = a.roster() {
            if roster.robots().is_empty() {
                roster.set(ids.clone());
            }
        }
    }
}

impl Prepared {
    /// Checks `cfg` and builds the world, the setup events and the network.
    pub(crate) fn new(cfg: SimConfig) -> Result<Self, SimError> {
        if cfg.until.is_nan() || cfg.until < 0.0 {
            return Err(SimError::BadUntil(cfg.until));
        }
        let specs: Vec<RobotSpec> = cfg.robots.iter().map(|(s, _)| *s).collect();
        fill_rosters(&cfg.robots);
        let sensors = Arc::new(cfg.sensors);
        // A stop from outside (the user's Ctrl-C) while the world is built leaves the setup
        // empty: the run then ends before its first record, without starting a million
        // robots' worth of setup first.
        let stop = cfg.observers.stop.clone();
        let stopped = move || stop.as_ref().is_some_and(|s| s.load(Ordering::Relaxed));
        let world = VirtualWorld::new(cfg.world.clone(), &specs)?;
        let sensing = Sensing::new(sensors.clone(), specs.len());
        let (wiring, template) = Wiring::check(&cfg.comms.stack, &cfg.comms.protocols)?;
        let mut setup = Outbox::new(0.0, 0);
        let starts = if stopped() { 0 } else { specs.len() };
        // Protocol layers start first, bottom-up, then the algorithms; crashes are scheduled.
        for r in 0..starts as RobotId {
            for l in 0..cfg.comms.stack.len() as nekosim_protocols::LayerIx {
                setup.schedule(
                    0.0,
                    Target::Layer(r, l),
                    EventClass::Eventual,
                    [Some(r), None],
                    Payload::LayerInput {
                        robot: r,
                        layer: l,
                        input: Box::new(Input::Start),
                    },
                );
            }
        }
        if !stopped() {
            world.start(&mut setup);
        }
        let mut partitions = Vec::new();
        for f in &cfg.comms.faults {
            match f {
                Fault::Crash { robot, at } if !stopped() => {
                    setup.schedule(
                        *at,
                        Target::EventManager,
                        EventClass::Eventual,
                        [Some(*robot), None],
                        Payload::Crash { robot: *robot },
                    );
                }
                Fault::Crash { .. } => {}
                Fault::Partition(p) => partitions.push(p.clone()),
            }
        }
        let net_rng = crate::random::rng(cfg.seed, crate::random::Stream::Network);
        let model = cfg.comms.networks.build(&cfg.comms.network)?;
        let network = Network::new(model, net_rng, partitions);
        let count = world.len();
        let mut observers = cfg.observers;
        observers.keep = cfg.record;
        Ok(Self {
            seed: cfg.seed,
            until: cfg.until,
            world: Arc::new(Mutex::new(world)),
            world_size: cfg.world.size,
            sensing,
            sensors,
            network,
            layer_ids: Arc::new(wiring.ids.clone()),
            wiring: Arc::new(wiring),
            // Every robot's instances: fresh copies of the checked stack's.
            instances: (0..count).map(|_| template.layers.clone()).collect(),
            setup,
            robots: cfg.robots,
            observers,
            arbiters: cfg.arbiters.max(1),
            instant_limit: (count as u64 * INSTANT_EVENTS_PER_ROBOT).max(MIN_INSTANT_LIMIT),
        })
    }

    /// Every robot's settings, by id.
    pub(crate) fn infos(&self) -> Vec<RobotInfo> {
        let (count, steps) = (self.robots.len(), self.observers.read_steps());
        (self.robots.iter().enumerate())
            .map(|(i, (spec, _))| RobotInfo {
                id: i as RobotId,
                count,
                radius: spec.radius,
                world: self.world_size,
                steps,
            })
            .collect()
    }
}

/// Runs a simulation to its end.
pub fn run(cfg: SimConfig) -> Result<RunOutput, SimError> {
    run_hosted(cfg, Teardown::Drop)
}

/// Runs a simulation to its end, for a process that exits after it: the run's actors, world
/// and queue are left to the process's exit instead of being dropped one by one (a million
/// robots take a noticeable while to drop). The observers are dropped as in
/// [`run`]; the actors' own `Drop`s do not run, as they would not at the process's exit.
/// Only for a last run: its memory stays in use.
pub fn run_then_exit(cfg: SimConfig) -> Result<RunOutput, SimError> {
    run_hosted(cfg, Teardown::Leave)
}

/// What becomes of a run's actors once it is over.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Teardown {
    Drop,
    Leave,
}

/// Starts the actor that `make` hosts on the arbiter of robot `id` among `arbiters` (a
/// robot's own, its sensors' and its layers' share one): in place when it is the first, this
/// thread's, the scheduler's, which then reaches it by a call; else on its own thread.
fn start_for<H: HandleEvent + Unpin + 'static>(
    arbiters: &[ArbiterHandle],
    id: RobotId,
    make: impl FnOnce() -> Host<H> + Send + 'static,
) -> Route {
    match id as usize % arbiters.len() {
        0 => Route::start_here(make()),
        k => Route::elsewhere(Host::start_in_arbiter(&arbiters[k], move |_| make()).recipient()),
    }
}

fn run_hosted(cfg: SimConfig, teardown: Teardown) -> Result<RunOutput, SimError> {
    let mut p = Prepared::new(cfg)?;
    let count = p.robots.len();
    let robot_info = p.infos();
    let system = System::new();
    let (tx, rx) = tokio::sync::oneshot::channel();
    let mut startup = p.observers.startup.take();
    system.block_on(async move {
        let seed = p.seed;
        let mut extra: Vec<Arbiter> = Vec::new();
        let mut handles = vec![Arbiter::current()];
        for _ in 1..p.arbiters {
            let a = Arbiter::new();
            handles.push(a.handle());
            extra.push(a);
        }
        let world = p.world;
        let wiring = p.wiring;
        let motion_manager = Route::start_here(Host::new(MotionManager::new(world.clone())));
        let network = Route::start_here(Host::new(NetworkActor::new(
            p.network,
            world.clone(),
            wiring.clone(),
        )));
        let prefetch = {
            let world = world.clone();
            Box::new(move |ahead: &crate::scheduler::WorldAhead| {
                // One event is in flight at a time, so the world is never held here.
                if let Ok(w) = world.try_lock() {
                    ahead.prefetch(&w);
                }
            })
        };
        let sensor_manager = Route::start_here(Host::new(SensorManager::new(world, p.sensing)));
        let layer_ids = p.layer_ids;
        // A stop while the robots spawn (the user's Ctrl-C) ends the spawning: the scheduler
        // then finishes before the first event.
        let stop = p.observers.stop.clone();
        let stopped = move |i: usize| {
            i % STOP_EVERY == 0 && stop.as_ref().is_some_and(|s| s.load(Ordering::Relaxed))
        };
        let mut robots: Vec<Route> = p
            .robots
            .into_iter()
            .zip(robot_info)
            .enumerate()
            .take_while(|(i, _)| !stopped(*i))
            .map(|(i, ((_, algorithm), info))| {
                if let Some(f) = startup.as_mut() {
                    if i % crate::scheduler::STARTUP_EVERY == 0 && i > 0 {
                        f(i, count);
                    }
                }
                let ids = layer_ids.clone();
                start_for(&handles, info.id, move || {
                    Host::new(RobotActor::new(info, algorithm, seed, ids))
                })
            })
            .collect();
        // Collected in place from the robots' settings (48 bytes each): 32 MB at a million
        // robots that the routes do not need.
        robots.shrink_to_fit();
        if let Some(f) = startup.as_mut() {
            f(count, count);
        }
        let layers: Vec<Vec<Route>> = p
            .instances
            .into_iter()
            .enumerate()
            .take_while(|(r, _)| !stopped(*r))
            .map(|(r, stack)| {
                let r = r as RobotId;
                stack
                    .into_iter()
                    .enumerate()
                    .map(|(l, layer)| {
                        let wiring = wiring.clone();
                        let ix = l as nekosim_protocols::LayerIx;
                        start_for(&handles, r, move || {
                            Host::new(LayerActor::new(r, ix, layer, wiring, count as u32))
                        })
                    })
                    .collect()
            })
            .collect();
        let sensors = p.sensors;
        let routes = Routes {
            motion_manager,
            sensor_manager,
            robots,
            network,
            layers,
            spawn_sensor: Box::new(move |robot, kind| {
                let sensors = sensors.clone();
                start_for(&handles, robot, move || {
                    Host::new(Sensor::new(robot, kind, seed, sensors))
                })
            }),
            prefetch,
        };
        let on_finish = Box::new(move |out: RunOutput| {
            for a in &extra {
                a.stop();
            }
            let _ = tx.send(out);
            System::current().stop();
        });
        Scheduler::new(routes, p.until, p.setup, p.observers, on_finish)
            .with_instant_limit(p.instant_limit)
            .start();
    });
    // The system runs until the scheduler hands over the output (and stops it).
    let out = system
        .block_on(rx)
        .map_err(|_| SimError::System("the scheduler ended without a result".into()))?;
    match teardown {
        Teardown::Drop => drop(system),
        Teardown::Leave => std::mem::forget(system),
    }
    match out.failure {
        Some(f) => Err(SimError::Stopped(f)),
        None => Ok(out),
    }
}
