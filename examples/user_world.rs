//! A user's own program: a protocol, a sensor, a network model and an algorithm, each written
//! against the same public API as nekosim's built-ins, registered with one line each and
//! stacked in `examples/user/beacons.ron`; `main` is the whole `nekosim` command with them.
//!
//! - `Flood` (protocol): best-effort broadcast, one copy to every other process.
//! - `Nearest` (sensor): the nearest other robot and its centre distance, exact.
//! - `DistanceDelay` (network): arrival = send + latency + distance / speed.
//! - `Beacon` (algorithm): every `period` seconds, read `Nearest` and broadcast the reading;
//!   log every reading delivered.
//!
//! Run: `cargo run --example user_world -- run examples/user/beacons.ron --log out/beacons.log`.
//! Test: `cargo test --example user_world`.

use std::process::ExitCode;

use nekosim::registry::{Configured, Setting};
use nekosim::scenario::Registry;
use nekosim::world::network::{ConfiguredNetwork, NetworkModel, Networks, Send};
use nekosim::world::sensor::{SensorModel, WorldView};
use nekosim::world::RobotId;
use nekosim::{Algorithm, AlgorithmFuture, Robot};
use nekosim_protocols::{
    Ctx, FieldError, Indication, LayerIx, Microprotocol, MsgId, NoConfig, Out, Payload, Pid,
    Request, Service, Shape,
};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Best-effort broadcast: one copy to every other process, delivered on receipt.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct Flood {
    count: u64,
}

#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
struct Copy {
    id: MsgId,
    payload: Payload,
}

impl Microprotocol for Flood {
    type Msg = Copy;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "Flood";

    fn shape(_: &NoConfig) -> Shape {
        Shape::on_links(Service::BROADCAST)
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_request(&mut self, ctx: &Ctx, _: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Broadcast { msg } = req {
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            out.send(
                ctx.others(),
                Copy {
                    id,
                    payload: msg.clone(),
                },
            );
            out.up(Indication::BDeliver { id, msg });
        }
    }

    fn on_message(&mut self, _: &Ctx, _: Pid, m: Copy, out: &mut Out<Self>) {
        out.up(Indication::BDeliver {
            id: m.id,
            msg: m.payload,
        });
    }
}

/// The nearest other robot within `range`, and its centre distance.
#[derive(Debug)]
struct Nearest;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct NearestQuery {
    range: f64,
}

impl SensorModel for Nearest {
    type Query = NearestQuery;
    type Reading = Option<(RobotId, f64)>;
    type Reply = Option<(RobotId, f64)>;

    fn sense(q: &NearestQuery, world: &dyn WorldView) -> Self::Reading {
        world
            .within(q.range)
            .into_iter()
            .map(|(id, _, d)| (id, d))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    fn reply(_: &NearestQuery, r: Self::Reading, _: &mut ChaCha8Rng) -> Self::Reply {
        r
    }
}

/// Arrival = send + `latency` + distance / `speed`, from the exact positions at the send.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DistanceDelay {
    latency: f64,
    speed: f64,
}

impl NetworkModel for DistanceDelay {
    fn transmit(&mut self, s: &Send<'_>, _: &mut ChaCha8Rng) -> Vec<(RobotId, Option<f64>)> {
        let me = (s.pos)(s.from);
        s.to.iter()
            .map(|&d| {
                let dist = ((s.pos)(d) - me).norm();
                (d, Some(s.now + self.latency + dist / self.speed))
            })
            .collect()
    }
}

impl ConfiguredNetwork for DistanceDelay {
    type Config = DistanceDelay;
    fn configure(c: DistanceDelay, _: &Networks) -> Result<Self, FieldError> {
        if !(c.speed.is_finite() && c.speed > 0.0) {
            return Err(FieldError::value("speed", "speed", c.speed, "a number > 0"));
        }
        Ok(c)
    }
}

/// What a beacon broadcasts: who saw whom at which distance.
#[derive(Debug, Serialize, Deserialize)]
#[serde(rename = "SEEN")]
struct Seen {
    by: RobotId,
    nearest: Option<(RobotId, f64)>,
}

/// Every `period` seconds, `count` times: read `Nearest`, broadcast it through `layer`; log
/// every reading delivered (its own included).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Beacon {
    layer: String,
    period: f64,
    count: u32,
}

impl Algorithm for Beacon {
    fn name(&self) -> &str {
        "Beacon"
    }

    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let me = self.clone();
        Box::pin(async move {
            let layer = robot.layer(&me.layer).expect("checked by configure");
            for _ in 0..me.count {
                robot.sleep(me.period).await;
                let nearest = robot
                    .read::<Nearest>("Nearest", &NearestQuery { range: 1000.0 })
                    .await
                    .expect("a valid query");
                layer.broadcast(&Seen {
                    by: robot.id(),
                    nearest,
                });
            }
            loop {
                let (_, seen) = robot.receive_msg::<Seen>().await;
                robot.log(format!("{seen:?}"));
            }
        })
    }
}

impl Configured for Beacon {
    type Config = Beacon;
    fn configure(c: Beacon, setting: &Setting) -> Result<Self, FieldError> {
        if !setting
            .layer(&c.layer)
            .is_some_and(|s| s.serves(Service::BROADCAST))
        {
            return Err(FieldError::new(
                "layer",
                format!("{:?} is not a broadcast layer of the stack", c.layer),
                "the id of one",
            ));
        }
        if !(c.period.is_finite() && c.period > 0.0) {
            return Err(FieldError::value(
                "period",
                "period",
                c.period,
                "a number > 0",
            ));
        }
        Ok(c)
    }
}

/// The built-ins plus this program's own protocol, sensor, network and algorithm.
fn registry() -> Registry {
    let mut r = Registry::with_builtins();
    r.protocol::<Flood>("Flood")
        .sensor::<Nearest>("Nearest")
        .network::<DistanceDelay>("DistanceDelay")
        .algorithm::<Beacon>("Beacon");
    r
}

#[cfg_attr(test, allow(dead_code))]
fn main() -> ExitCode {
    nekosim::cli::main_with(registry())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    #[test]
    fn beacons_read_their_sensor_and_deliver_over_the_distance_network() {
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
        let dir = tempfile::tempdir().unwrap();
        let trace = dir.path().join("t.jsonl");
        let code = nekosim::cli::run_cli(
            &registry(),
            [
                "user_world",
                "run",
                root.join("examples/user/beacons.ron").to_str().unwrap(),
                "--quiet",
                "--trace",
                trace.to_str().unwrap(),
            ],
        );
        assert_eq!(code, 0);
        let records: Vec<serde_json::Value> = std::fs::read_to_string(&trace)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        let pos = [(0.0, 0.0), (30.0, 40.0), (-60.0, 80.0), (0.0, -10.0)];
        let dist = |a: usize, b: usize| {
            let (p, q): ((f64, f64), (f64, f64)) = (pos[a], pos[b]);
            ((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)).sqrt()
        };
        // Oracle: each robot's nearest neighbour, brute force.
        let nearest = |a: usize| {
            (0..4)
                .filter(|&b| b != a)
                .min_by(|&x, &y| dist(a, x).total_cmp(&dist(a, y)))
                .unwrap()
        };
        let mut delivered = 0;
        for r in records.iter().filter(|r| r["kind"] == "deliver") {
            let at = r["robot"].as_u64().unwrap() as usize;
            let by = r["origin"].as_u64().unwrap() as usize;
            // `SEEN(by: B, nearest: Some((N, D)))`, as the trace shows the message.
            let text = r["content"].as_str().unwrap();
            assert_eq!(
                text,
                format!(
                    "SEEN(by: {by}, nearest: Some(({}, {:?})))",
                    nearest(by),
                    dist(by, nearest(by))
                )
            );
            // Broadcasts at 5, 10 and 15 s; a copy travels latency + distance / speed.
            let delay = if at == by {
                0.0
            } else {
                0.25 + dist(by, at) / 40.0
            };
            let t = r["t"].as_f64().unwrap();
            let k = ((t - delay) / 5.0).round();
            assert!(
                (1.0..=3.0).contains(&k) && (t - (5.0 * k + delay)).abs() < 1e-9,
                "{text} at robot {at} at {t}"
            );
            delivered += 1;
        }
        assert_eq!(delivered, 4 * 4 * 3, "every robot delivers every reading");
        let logs = records.iter().filter(|r| r["kind"] == "log").count();
        assert_eq!(logs, 4 * 4 * 3, "every robot logs every reading");
    }
}
