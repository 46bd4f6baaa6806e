//! The sensor manager's logic and state (seed 4.2.2-4.2.4, fig. 4.5), owned by the sensor
//! manager actor: sensor requests become sensor events; at trigger time the manager asks the
//! robot's sensor ([`Sensors`]) for the world's exact data through a [`WorldView`] and keeps
//! push sensors armed as their [`Trigger`] says: exact entry prediction (push proximity),
//! periodic re-sensing, or contacts. It knows no sensor by name: the built-in sensors are
//! registered like a user's. Of its armed sensors the world sees only what physics needs (the
//! entry ranges its pair predictions use, and which sensors a contact triggers).

use std::collections::BTreeMap;

use super::*;
use crate::lcm::LightState;
use crate::world::event::SensorCompute;

/// An armed push sensor whose trigger is another robot's entry into its range
/// ([`Trigger::Entry`]).
#[derive(Clone, Debug)]
struct EntryWatch {
    sensor: SensorKind,
    /// The activation query.
    query: Datum,
    /// Free distance that triggers [units].
    range: f64,
    /// Quiet period after an interrupt [s].
    quiet: f64,
    quiet_until: f64,
    generation: u64,
    pending: bool,
}

/// A robot's armed push sensors.
#[derive(Clone, Debug, Default)]
struct Armed {
    /// Triggered by entries into their range.
    entry: Vec<EntryWatch>,
    /// Triggered by contacts, with their activation queries.
    contact: BTreeMap<SensorKind, Datum>,
    /// Re-sensing periodically: activation query and generation.
    periodic: BTreeMap<SensorKind, (Datum, u64)>,
}

/// The sensor manager's state: the sensors robots can use and every robot's armed push
/// sensors.
#[derive(Debug)]
pub struct Sensing {
    sensors: std::sync::Arc<Sensors>,
    /// By robot; `None` until the robot arms a push sensor (most robots never do, and three
    /// empty collections per robot would be 72 MB at a million robots).
    armed: Vec<Option<Box<Armed>>>,
    /// Activations of periodic push sensors so far (tells a stale re-sense apart).
    periodic_generation: u64,
    /// The lights robots show ([`crate::lcm`]), by robot; only robots that set one.
    lights: BTreeMap<RobotId, LightState>,
}

impl Sensing {
    /// The sensor manager of `robots` robots using `sensors` (the built-in ones and any
    /// registered beside them).
    pub fn new(sensors: std::sync::Arc<Sensors>, robots: usize) -> Self {
        Self {
            sensors,
            armed: vec![None; robots],
            periodic_generation: 0,
            lights: BTreeMap::new(),
        }
    }

    /// Hands `reading` to the robot's `sensor`, which computes the reply to `query` and
    /// interrupts the robot with it.
    fn interrupt(
        robot: RobotId,
        sensor: SensorKind,
        query: &Datum,
        reading: Datum,
        out: &mut Outbox,
    ) {
        out.schedule(
            out.now(),
            Target::Sensor(robot, sensor),
            EventClass::Eventual,
            [Some(robot), None],
            Payload::SensorCompute(Box::new(SensorCompute {
                robot,
                ticket: None,
                query: SensorQuery {
                    sensor,
                    query: Some(query.clone()),
                },
                snapshot: SensorValue::Reply(reading),
            })),
        );
    }

    /// Senses `query` of `sensor` for `robot` now and interrupts it when the reading fires.
    fn sense_push(
        &self,
        world: &VirtualWorld,
        robot: RobotId,
        sensor: SensorKind,
        query: &Datum,
        contact: Option<Obstacle>,
        out: &mut Outbox,
    ) -> bool {
        let view = View::new(world, &self.lights, robot, out.now(), contact);
        match self.sensors.sense(sensor, query, &view) {
            Ok(reading) => {
                let fires = self.sensors.fires(sensor, query, &reading);
                if fires {
                    Self::interrupt(robot, sensor, query, reading, out);
                }
                fires
            }
            Err(e) => {
                tracing::warn!(robot, %sensor, "push sensor: {e}");
                false
            }
        }
    }

    /// Handles an event addressed to the sensor manager (seed fig. 4.5 and 4.7).
    pub fn handle(&mut self, world: &mut VirtualWorld, payload: Payload, out: &mut Outbox) {
        let now = out.now();
        match payload {
            Payload::Light { robot, .. } if world.robots[robot as usize].crashed => {}
            Payload::Light { robot, light } => {
                out.record_step(|| Observation::Light {
                    robot,
                    light: light.shown,
                    pending: light.pending,
                });
                self.lights.insert(robot, light);
            }
            Payload::SensorRequest { robot, .. } if world.robots[robot as usize].crashed => {}
            Payload::SensorRequest {
                robot,
                ticket,
                query,
            } => {
                out.record_step(|| Observation::SensorRequest {
                    robot,
                    query: (*query).clone(),
                    plan: query
                        .query
                        .as_ref()
                        .and_then(|q| self.sensors.plan(query.sensor, q).ok()),
                });
                out.schedule(
                    now,
                    Target::SensorManager,
                    EventClass::Eventual,
                    [Some(robot), None],
                    Payload::SensorTrigger {
                        robot,
                        ticket,
                        query,
                    },
                );
            }
            Payload::SensorTrigger {
                robot,
                ticket,
                query,
            } => {
                let snapshot = self.trigger(world, robot, &query, out);
                out.schedule(
                    now,
                    Target::Sensor(robot, query.sensor),
                    EventClass::Eventual,
                    [Some(robot), None],
                    Payload::SensorCompute(Box::new(SensorCompute {
                        robot,
                        ticket: Some(ticket),
                        query: *query,
                        snapshot,
                    })),
                );
            }
            Payload::ProximityEntry {
                robot,
                other,
                sensor,
            } => {
                let Some(w) = self.watch(robot, sensor) else {
                    return;
                };
                let (range, quiet_until) = (w.range, w.quiet_until);
                // Look for this pair's next entry, after the robots have left each other's range.
                let reach = range + world.radius(robot) + world.radius(other);
                if let Some(t) =
                    predict_reentry(&world.track(robot), &world.track(other), reach, now)
                {
                    let e = out.schedule_in(
                        &mut world.claims,
                        t,
                        Target::SensorManager,
                        EventClass::Conditional,
                        [Some(robot), Some(other)],
                        Payload::ProximityEntry {
                            robot,
                            other,
                            sensor,
                        },
                    );
                    for (x, y) in [(robot, other), (other, robot)] {
                        world.robots[x as usize].pairs.events_mut(y).push(e);
                    }
                }
                if now < quiet_until {
                    if let Some(w) = self.watch_mut(robot, sensor) {
                        w.pending = true;
                    }
                } else {
                    self.fire_entry(world, robot, sensor, out);
                }
            }
            Payload::ProximityRearm {
                robot,
                sensor,
                generation,
            } => {
                if self
                    .watch(robot, sensor)
                    .is_some_and(|w| w.generation == generation && w.pending)
                {
                    self.fire_entry(world, robot, sensor, out);
                }
            }
            Payload::Touched {
                robot,
                sensor,
                with,
            } => {
                if let Some(query) = self.armed(robot).and_then(|a| a.contact.get(&sensor)) {
                    self.sense_push(world, robot, sensor, query, Some(with), out);
                }
            }
            Payload::PeriodicSense {
                robot,
                sensor,
                interval,
                generation,
            } => {
                let Some((query, g)) = self.armed(robot).and_then(|a| a.periodic.get(&sensor))
                else {
                    return;
                };
                if *g != generation || world.robots[robot as usize].crashed {
                    return;
                }
                self.sense_push(world, robot, sensor, query, None, out);
                out.schedule(
                    now + interval,
                    Target::SensorManager,
                    EventClass::Eventual,
                    [Some(robot), None],
                    Payload::PeriodicSense {
                        robot,
                        sensor,
                        interval,
                        generation,
                    },
                );
            }
            other => tracing::warn!(?other, "sensor manager ignores an event it does not serve"),
        }
    }

    /// The robot's armed push sensors, if it has armed any.
    fn armed(&self, robot: RobotId) -> Option<&Armed> {
        self.armed[robot as usize].as_deref()
    }

    /// The robot's armed push sensors, made empty if it had none.
    fn armed_mut(&mut self, robot: RobotId) -> &mut Armed {
        self.armed[robot as usize].get_or_insert_with(Box::default)
    }

    fn watch(&self, robot: RobotId, sensor: SensorKind) -> Option<&EntryWatch> {
        self.armed(robot)?.entry.iter().find(|w| w.sensor == sensor)
    }

    fn watch_mut(&mut self, robot: RobotId, sensor: SensorKind) -> Option<&mut EntryWatch> {
        self.armed[robot as usize]
            .as_deref_mut()?
            .entry
            .iter_mut()
            .find(|w| w.sensor == sensor)
    }

    /// An entry sensor senses now; when it fires, its quiet interval starts.
    fn fire_entry(
        &mut self,
        world: &VirtualWorld,
        robot: RobotId,
        sensor: SensorKind,
        out: &mut Outbox,
    ) {
        let now = out.now();
        let Some(w) = self.watch(robot, sensor) else {
            return;
        };
        let fired = self.sense_push(world, robot, sensor, &w.query, None, out);
        let Some(w) = self.watch_mut(robot, sensor) else {
            return;
        };
        w.pending = false;
        if fired && w.quiet > 0.0 {
            w.quiet_until = now + w.quiet;
            w.generation += 1;
            let generation = w.generation;
            out.schedule(
                now + w.quiet,
                Target::SensorManager,
                EventClass::Eventual,
                [Some(robot), None],
                Payload::ProximityRearm {
                    robot,
                    sensor,
                    generation,
                },
            );
        }
    }

    /// Disarms `sensor` of `robot`, whatever its trigger.
    fn disarm(
        &mut self,
        world: &mut VirtualWorld,
        robot: RobotId,
        sensor: SensorKind,
        out: &mut Outbox,
    ) {
        if let Some(a) = self.armed[robot as usize].as_deref_mut() {
            a.periodic.remove(&sensor);
            a.contact.remove(&sensor);
            a.entry.retain(|w| w.sensor != sensor);
        }
        let mut reach_changed = false;
        if let Some(l) = world.robots[robot as usize].listening.as_deref_mut() {
            l.contact.retain(|s| *s != sensor);
            let before = l.entry.len();
            l.entry.retain(|(s, _)| *s != sensor);
            reach_changed = l.entry.len() != before;
        }
        if reach_changed {
            world.cancel_pairs(robot, out);
            world.predict_neighbours(robot, out);
        }
    }

    /// A request at its trigger time: the reading of a pull query, or the (de)activation of a
    /// push sensor.
    fn trigger(
        &mut self,
        world: &mut VirtualWorld,
        robot: RobotId,
        query: &SensorQuery,
        out: &mut Outbox,
    ) -> SensorValue {
        let now = out.now();
        let sensor = query.sensor;
        let Some(q) = &query.query else {
            self.disarm(world, robot, sensor, out);
            return SensorValue::Done;
        };
        let plan = match self.sensors.plan(sensor, q) {
            Ok(plan) => plan,
            Err(e) => return SensorValue::Rejected(e),
        };
        match plan.trigger {
            Trigger::Pull => {
                let view = View::new(world, &self.lights, robot, now, None);
                return match self.sensors.sense(sensor, q, &view) {
                    Ok(reading) => SensorValue::Reply(reading),
                    Err(e) => SensorValue::Rejected(e),
                };
            }
            Trigger::Off => self.disarm(world, robot, sensor, out),
            Trigger::Every(interval) => {
                self.periodic_generation += 1;
                let generation = self.periodic_generation;
                self.armed_mut(robot)
                    .periodic
                    .insert(sensor, (q.clone(), generation));
                out.schedule(
                    now,
                    Target::SensorManager,
                    EventClass::Eventual,
                    [Some(robot), None],
                    Payload::PeriodicSense {
                        robot,
                        sensor,
                        interval,
                        generation,
                    },
                );
            }
            Trigger::Contact => {
                self.armed_mut(robot).contact.insert(sensor, q.clone());
                let listeners = &mut world.robots[robot as usize].listening_mut().contact;
                if !listeners.contains(&sensor) {
                    listeners.push(sensor);
                }
            }
            Trigger::Entry { range, quiet } => {
                let watch = EntryWatch {
                    sensor,
                    query: q.clone(),
                    range,
                    quiet,
                    quiet_until: now,
                    generation: 0,
                    pending: false,
                };
                let entry = &mut self.armed_mut(robot).entry;
                match entry.iter_mut().find(|w| w.sensor == sensor) {
                    Some(w) => *w = watch,
                    None => entry.push(watch),
                }
                world.entries_armed = true;
                let reaches = &mut world.robots[robot as usize].listening_mut().entry;
                match reaches.iter_mut().find(|(s, _)| *s == sensor) {
                    Some(r) => r.1 = range,
                    None => reaches.push((sensor, range)),
                }
                world.ensure_cell_size(range + 2.0 * world.max_radius, out);
                world.cancel_pairs(robot, out);
                world.predict_neighbours(robot, out);
                self.fire_entry(world, robot, sensor, out);
            }
        }
        SensorValue::Done
    }
}

/// A robot's view of the world at an instant, for its sensors.
struct View<'a> {
    world: &'a VirtualWorld,
    lights: &'a BTreeMap<RobotId, LightState>,
    robot: RobotId,
    now: f64,
    contact: Option<Obstacle>,
}

impl<'a> View<'a> {
    fn new(
        world: &'a VirtualWorld,
        lights: &'a BTreeMap<RobotId, LightState>,
        robot: RobotId,
        now: f64,
        contact: Option<Obstacle>,
    ) -> Self {
        Self {
            world,
            lights,
            robot,
            now,
            contact,
        }
    }
}

impl WorldView for View<'_> {
    fn now(&self) -> f64 {
        self.now
    }
    fn light(&self, robot: RobotId) -> Option<LightState> {
        self.lights.get(&robot).copied()
    }
    fn robot(&self) -> RobotId {
        self.robot
    }
    fn count(&self) -> usize {
        self.world.robots.len()
    }
    fn position(&self, robot: RobotId) -> Point {
        self.world.state_at(robot, self.now).pos
    }
    fn radius(&self, robot: RobotId) -> f64 {
        self.world.radius(robot)
    }
    fn within(&self, range: f64) -> Vec<(RobotId, Point, f64)> {
        let me = self.position(self.robot);
        self.world.within(self.robot, me, range, self.now)
    }
    fn near(&self, gap: f64) -> Vec<(RobotId, f64)> {
        let w = self.world;
        let me = self.position(self.robot);
        let r = w.radius(self.robot);
        let reach = gap + r + w.max_radius + CONTACT_TOLERANCE;
        w.within(self.robot, me, reach, self.now)
            .into_iter()
            .map(|(id, _, d)| (id, d - r - w.radius(id)))
            // To within the precision of predicted contacts: at an entry instant the entering
            // robot is on the range's edge, and rounding must not hide it.
            .filter(|&(_, free)| free <= gap + CONTACT_TOLERANCE)
            .collect()
    }
    fn contact(&self) -> Option<Obstacle> {
        self.contact
    }
    fn in_sight(&self, other: RobotId) -> bool {
        let obstacles = self.world.obstacles();
        obstacles.is_empty() || !obstacles.blocks(self.position(self.robot), self.position(other))
    }
}
