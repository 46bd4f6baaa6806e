//! Sensor actors (seed 3.1.2 and 4.2.2): one per sensor of a robot. At trigger time the sensor
//! manager hands a sensor the world's exact data; the sensor computes the reply (the seed's
//! `calReply`, e.g. GPS noise from its own seeded random stream) and answers its robot.

use actix::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::scheduler::Deliver;
use crate::world::event::{Notice, Outbox, Payload};
use crate::world::observation::Observation;
use std::sync::Arc;

use crate::world::sensor::{cal_reply, SensorKind, SensorQuery, SensorValue, Sensors};
use crate::world::RobotId;

/// A robot's sensor.
#[derive(Debug)]
pub struct Sensor {
    robot: RobotId,
    kind: SensorKind,
    rng: ChaCha8Rng,
    /// Registered sensors, for the replies of user sensors.
    sensors: Arc<Sensors>,
}

impl Sensor {
    /// The `kind` sensor of `robot`; its noise stream is derived from the run's seed.
    pub fn new(robot: RobotId, kind: SensorKind, seed: u64, sensors: Arc<Sensors>) -> Self {
        let stream = (robot as u64) << 8 | kind.stream();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(stream.wrapping_add(1 << 40));
        Self {
            robot,
            kind,
            rng,
            sensors,
        }
    }
}

impl Actor for Sensor {
    type Context = Context<Self>;
}

impl Handler<Deliver> for Sensor {
    type Result = MessageResult<Deliver>;

    fn handle(&mut self, msg: Deliver, _: &mut Context<Self>) -> Self::Result {
        let mut out = Outbox::new(msg.now, msg.seq);
        if let Payload::SensorCompute {
            robot,
            ticket,
            query,
            snapshot,
        } = msg.event.payload
        {
            debug_assert_eq!(robot, self.robot);
            let value = match (&query, snapshot) {
                // A registered sensor's reply, from its reading (pull or push).
                (SensorQuery::User { sensor, query }, SensorValue::User(reading)) => {
                    match self.sensors.reply(sensor, query, &reading, &mut self.rng) {
                        Ok(reply) => SensorValue::User(reply),
                        Err(e) => SensorValue::Rejected(e),
                    }
                }
                (_, snapshot) => match ticket {
                    Some(_) => cal_reply(&query, snapshot, &mut self.rng),
                    None => snapshot,
                },
            };
            out.record(Observation::SensorReply {
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
        MessageResult(out.into_effects())
    }
}
