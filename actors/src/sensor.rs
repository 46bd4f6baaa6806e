//! Sensor actors (seed 3.1.2 and 4.2.2): one per sensor of a robot. At trigger time the sensor
//! manager hands a sensor the world's exact data; the sensor computes the reply (the seed's
//! `calReply`, e.g. GPS noise from its own seeded random stream) and answers its robot.

use rand_chacha::ChaCha8Rng;

use crate::handler::HandleEvent;
use crate::world::event::{Event, Notice, Payload, SensorCompute};
use crate::world::observation::Observation;
use crate::world::outbox::Outbox;
use std::sync::Arc;

use crate::world::sensor::{SensorKind, SensorValue, Sensors};
use crate::world::RobotId;

/// A robot's sensor.
#[derive(Debug)]
pub struct Sensor {
    robot: RobotId,
    kind: SensorKind,
    rng: ChaCha8Rng,
    /// The sensors, for the reply of this one.
    sensors: Arc<Sensors>,
}

impl Sensor {
    /// The `kind` sensor of `robot`; its noise stream is derived from the run's seed.
    pub fn new(robot: RobotId, kind: SensorKind, seed: u64, sensors: Arc<Sensors>) -> Self {
        let kind_number = u8::try_from(kind.stream()).expect("sensor kinds number below 256");
        let rng = crate::random::rng(seed, crate::random::Stream::Sensor(robot, kind_number));
        Self {
            robot,
            kind,
            rng,
            sensors,
        }
    }
}

impl HandleEvent for Sensor {
    fn handle_event(&mut self, event: Event, out: &mut Outbox) {
        if let Payload::SensorCompute(compute) = event.payload {
            let SensorCompute {
                robot,
                ticket,
                query,
                snapshot,
            } = *compute;
            debug_assert_eq!(robot, self.robot);
            // The sensor's reply from its reading (pull or push); (de)activations and
            // rejections pass through.
            let value = match (&query.query, snapshot) {
                (Some(q), SensorValue::Reply(reading)) => {
                    match self.sensors.reply(self.kind, q, reading, &mut self.rng) {
                        Ok(reply) => SensorValue::Reply(reply),
                        Err(e) => SensorValue::Rejected(e),
                    }
                }
                (_, other) => other,
            };
            out.record_step(|| Observation::SensorReply {
                robot,
                sensor: self.kind,
                value: value.clone(),
                interrupt: ticket.is_none(),
            });
            let notice = match ticket {
                Some(ticket) => Notice::SensorReply { ticket, value },
                None => Notice::Interrupt {
                    sensor: self.kind,
                    value,
                },
            };
            out.notify(robot, notice);
        }
    }
}
