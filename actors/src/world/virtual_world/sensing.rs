//! The sensor manager's logic (seed 4.2.2-4.2.4, fig. 4.5): sensor requests become sensor
//! events; at trigger time the manager gathers the world's exact data for the robot's sensor
//! (built-in sensors, and registered ones through [`WorldView`]) and keeps push sensors armed:
//! exact entry prediction for push proximity, periodic re-sensing for registered push sensors.

use super::*;

impl VirtualWorld {
    pub(super) fn push_interrupt(
        &self,
        robot: RobotId,
        sensor: SensorKind,
        value: SensorValue,
        out: &mut Outbox,
    ) {
        self.push_interrupt_of(robot, sensor, SensorQuery::DeactivateContact, value, out)
    }

    /// An interrupt of `sensor`, whose reply the sensor computes for `query`.
    fn push_interrupt_of(
        &self,
        robot: RobotId,
        sensor: SensorKind,
        query: SensorQuery,
        value: SensorValue,
        out: &mut Outbox,
    ) {
        out.schedule(
            out.now(),
            Target::Sensor(robot, sensor),
            EventClass::Eventual,
            [Some(robot), None],
            Payload::SensorCompute {
                robot,
                ticket: None,
                query,
                snapshot: value,
            },
        );
    }

    /// Uses the registered sensors `sensors` (beside the built-in ones).
    pub fn with_sensors(mut self, sensors: std::sync::Arc<Sensors>) -> Self {
        self.sensors = sensors;
        self
    }

    fn free_distances(&self, robot: RobotId, range: f64, t: f64) -> Vec<(RobotId, f64)> {
        let me = self.state_at(robot, t).pos;
        let r = self.radius(robot);
        self.within(robot, me, range + r + self.max_radius, t)
            .into_iter()
            .map(|(id, _, d)| (id, d - r - self.radius(id)))
            .filter(|&(_, gap)| gap <= range)
            .collect()
    }

    /// Handles an event addressed to the sensor manager (seed fig. 4.5 and 4.7).
    pub fn handle_sensor(&mut self, payload: Payload, out: &mut Outbox) {
        let now = out.now();
        match payload {
            Payload::SensorRequest { robot, .. } if self.robots[robot as usize].crashed => {}
            Payload::SensorRequest {
                robot,
                ticket,
                query,
            } => {
                out.record(Observation::SensorRequest {
                    robot,
                    query: query.clone(),
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
                let snapshot = match query.validate() {
                    Err(e) => SensorValue::Rejected(e),
                    Ok(()) => self.sense(robot, &query, out),
                };
                out.schedule(
                    now,
                    Target::Sensor(robot, query.kind()),
                    EventClass::Eventual,
                    [Some(robot), None],
                    Payload::SensorCompute {
                        robot,
                        ticket: Some(ticket),
                        query,
                        snapshot,
                    },
                );
            }
            Payload::ProximityEntry { robot, other } => {
                let Some(push) = self.robots[robot as usize].push else {
                    return;
                };
                // Look for this pair's next entry, after the robots have left each other's range.
                let reach = push.range + self.radius(robot) + self.radius(other);
                if let Some(t) = predict_entry(&self.track(robot), &self.track(other), reach, now) {
                    let e = out.schedule(
                        t,
                        Target::SensorManager,
                        EventClass::Conditional,
                        [Some(robot), Some(other)],
                        Payload::ProximityEntry { robot, other },
                    );
                    for (x, y) in [(robot, other), (other, robot)] {
                        self.robots[x as usize].pairs.entry(y).or_default().push(e);
                    }
                }
                if now < push.quiet_until {
                    if let Some(p) = self.robots[robot as usize].push.as_mut() {
                        p.pending = true;
                    }
                } else {
                    self.fire_proximity(robot, out);
                }
            }
            Payload::UserSense {
                robot,
                sensor,
                interval,
                generation,
            } => {
                let SensorKind::User(name) = sensor else {
                    return;
                };
                let r = &self.robots[robot as usize];
                let Some((q, g)) = r.user_push.get(name).cloned() else {
                    return;
                };
                if g != generation || r.crashed {
                    return;
                }
                match self.sensors.sense(name, &q, &View::new(self, robot, now)) {
                    Ok(reading) => {
                        if self.sensors.fires(name, &q, &reading) {
                            self.push_interrupt_of(
                                robot,
                                sensor,
                                SensorQuery::User {
                                    sensor: name.to_string(),
                                    query: q,
                                },
                                SensorValue::User(reading),
                                out,
                            );
                        }
                    }
                    Err(e) => tracing::warn!(robot, sensor = name, "push sensor: {e}"),
                }
                out.schedule(
                    now + interval.0,
                    Target::SensorManager,
                    EventClass::Eventual,
                    [Some(robot), None],
                    Payload::UserSense {
                        robot,
                        sensor,
                        interval,
                        generation,
                    },
                );
            }
            Payload::ProximityRearm { robot, generation } => {
                let Some(push) = self.robots[robot as usize].push else {
                    return;
                };
                if push.generation == generation && push.pending {
                    self.fire_proximity(robot, out);
                }
            }
            other => tracing::warn!(?other, "sensor manager ignores an event it does not serve"),
        }
    }

    /// Reports the robots in range now, then starts the quiet interval.
    fn fire_proximity(&mut self, robot: RobotId, out: &mut Outbox) {
        let now = out.now();
        let Some(mut push) = self.robots[robot as usize].push else {
            return;
        };
        let near = self.free_distances(robot, push.range, now);
        push.pending = false;
        if !near.is_empty() {
            self.push_interrupt(
                robot,
                SensorKind::PushProximity,
                SensorValue::Distances(near),
                out,
            );
            if push.interval > 0.0 {
                push.quiet_until = now + push.interval;
                push.generation += 1;
                out.schedule(
                    push.quiet_until,
                    Target::SensorManager,
                    EventClass::Eventual,
                    [Some(robot), None],
                    Payload::ProximityRearm {
                        robot,
                        generation: push.generation,
                    },
                );
            }
        }
        self.robots[robot as usize].push = Some(push);
    }

    /// The exact data for a request at its trigger time (and (de)activation of push sensors).
    fn sense(&mut self, robot: RobotId, query: &SensorQuery, out: &mut Outbox) -> SensorValue {
        let now = out.now();
        let me = self.state_at(robot, now).pos;
        match *query {
            SensorQuery::User {
                ref sensor,
                query: ref q,
            } => match self.sensors.push_interval(sensor, q) {
                Err(e) => SensorValue::Rejected(e),
                Ok(None) => match self.sensors.sense(sensor, q, &View::new(self, robot, now)) {
                    Ok(reading) => SensorValue::User(reading),
                    Err(e) => SensorValue::Rejected(e),
                },
                Ok(Some(interval)) => {
                    let SensorKind::User(name) = query.kind() else {
                        unreachable!("a user query names a user sensor")
                    };
                    self.user_generation += 1;
                    let generation = self.user_generation;
                    self.robots[robot as usize]
                        .user_push
                        .insert(name, (q.clone(), generation));
                    out.schedule(
                        now,
                        Target::SensorManager,
                        EventClass::Eventual,
                        [Some(robot), None],
                        Payload::UserSense {
                            robot,
                            sensor: query.kind(),
                            interval: crate::world::sensor::Interval(interval),
                            generation,
                        },
                    );
                    SensorValue::Done
                }
            },
            SensorQuery::UserOff { .. } => {
                if let SensorKind::User(name) = query.kind() {
                    self.robots[robot as usize].user_push.remove(name);
                }
                SensorValue::Done
            }
            SensorQuery::SelfPosition { .. } => SensorValue::Position(me),
            SensorQuery::AllPositions { .. } => SensorValue::Positions(self.positions_at(now)),
            SensorQuery::View { range } => SensorValue::Positions(
                self.within(robot, me, range, now)
                    .into_iter()
                    .map(|(id, p, _)| (id, p))
                    .collect(),
            ),
            SensorQuery::Proximity { range } => {
                SensorValue::Distances(self.free_distances(robot, range, now))
            }
            SensorQuery::ActivateProximity { range, interval } => {
                self.robots[robot as usize].push = Some(PushProximity {
                    range,
                    interval,
                    quiet_until: now,
                    generation: 0,
                    pending: false,
                });
                self.ensure_cell_size(range + 2.0 * self.max_radius, out);
                self.cancel_pairs(robot, out);
                self.predict_neighbours(robot, out);
                self.fire_proximity(robot, out);
                SensorValue::Done
            }
            SensorQuery::DeactivateProximity => {
                if self.robots[robot as usize].push.take().is_some() {
                    self.cancel_pairs(robot, out);
                    self.predict_neighbours(robot, out);
                }
                SensorValue::Done
            }
            SensorQuery::ActivateContact => {
                self.robots[robot as usize].contact = true;
                SensorValue::Done
            }
            SensorQuery::DeactivateContact => {
                self.robots[robot as usize].contact = false;
                SensorValue::Done
            }
        }
    }
}

/// A robot's view of the world at an instant, for registered sensors.
struct View<'a> {
    world: &'a VirtualWorld,
    robot: RobotId,
    now: f64,
}

impl<'a> View<'a> {
    fn new(world: &'a VirtualWorld, robot: RobotId, now: f64) -> Self {
        Self { world, robot, now }
    }
}

impl WorldView for View<'_> {
    fn now(&self) -> f64 {
        self.now
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
}
