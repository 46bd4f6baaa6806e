//! A network model and an algorithm defined only in this test file are registered with one
//! line each, named in a scenario's RON, and run: arrival times follow the model's closed form.

use nekosim::registry::{Configured, Setting};
use nekosim::runner::{self, RunOptions};
use nekosim::scenario::{Overrides, Registry, Source};
use nekosim::world::network::{ConfiguredNetwork, NetworkModel, Networks, Send};
use nekosim::world::RobotId;
use nekosim::{Algorithm, AlgorithmFuture, Robot};
use nekosim_protocols::FieldError;
use rand_chacha::ChaCha8Rng;
use serde::Deserialize;
use serde_json::Value;

/// A message travels at `speed` units/s after a fixed `latency`: arrival = send + latency +
/// distance / speed, from the robots' exact positions at the send.
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

/// Robot 0 greets every other robot at `at` seconds; everybody else listens.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Hello {
    at: f64,
}

#[derive(Debug, serde::Serialize, Deserialize, PartialEq)]
struct Hi(u32);

impl Algorithm for Hello {
    fn name(&self) -> &str {
        "Hello"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let at = self.at;
        Box::pin(async move {
            let info = robot.info();
            if info.id == 0 {
                robot.sleep(at).await;
                robot.send((1..info.count as u32).collect(), &Hi(7));
            } else {
                let (_, Hi(n)) = robot.receive_msg::<Hi>().await;
                robot.log(format!("hi {n}"));
            }
        })
    }
}

impl Configured for Hello {
    type Config = Hello;
    fn configure(c: Hello, _: &Setting) -> Result<Self, FieldError> {
        Ok(c)
    }
}

fn registry() -> Registry {
    let mut r = Registry::with_builtins();
    r.network::<DistanceDelay>("DistanceDelay")
        .algorithm::<Hello>("Hello");
    r
}

const SCENARIO: &str = r#"Scenario(
    seed: 1,
    until: 100.0,
    world: (size: Infinite),
    network: DistanceDelay(latency: 0.5, speed: 20.0),
    robots: [
        Group(count: 4, radius: 1.0, born: Points([(0.0, 0.0), (30.0, 40.0), (-60.0, 80.0), (0.0, -10.0)]),
              algorithm: Hello(at: 2.0)),
    ],
)"#;

fn build(text: &str, registry: &Registry) -> Result<nekosim::scenario::Built, String> {
    Source::parse("net.ron", text)
        .and_then(|s| s.build(Overrides::default(), registry))
        .map_err(|e| e.to_string())
}

#[test]
fn a_user_network_model_delivers_at_its_closed_form_times() {
    let built = build(SCENARIO, &registry()).expect("valid");
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.jsonl");
    runner::run(
        built,
        RunOptions {
            trace: Some(trace.clone()),
            ..RunOptions::default()
        },
    )
    .unwrap();
    let records: Vec<Value> = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    // Distances from robot 0: 50, 100, 10; arrival = 2 + 0.5 + d / 20.
    let want = [(1u64, 5.0), (2, 7.5), (3, 3.0)];
    for (robot, t) in want {
        let r = records
            .iter()
            .find(|r| r["kind"] == "receive" && r["robot"] == robot)
            .unwrap_or_else(|| panic!("robot {robot} received nothing"));
        assert!((r["t"].as_f64().unwrap() - t).abs() < 1e-12, "{r}");
        assert_eq!(r["msg"], "Hi(7)");
        let log = records
            .iter()
            .find(|r| r["kind"] == "log" && r["robot"] == robot)
            .unwrap();
        assert_eq!(
            (log["t"].as_f64().unwrap(), log["text"].as_str()),
            (t, Some("hi 7"))
        );
    }
}

#[test]
fn its_configuration_errors_point_into_the_scenario_file() {
    let line = SCENARIO
        .lines()
        .position(|l| l.contains("network:"))
        .unwrap()
        + 1;
    let col = |text: &str, word: &str| {
        let l = text.lines().nth(line - 1).unwrap();
        l.find(word).unwrap() + 1
    };
    let text = SCENARIO.replace("speed: 20.0", "speed: 0.0");
    assert_eq!(
        build(&text, &registry()).unwrap_err(),
        format!(
            "net.ron:{line}:{}: DistanceDelay: speed is 0; expected a number > 0",
            col(&text, "0.0)")
        )
    );
    let text = SCENARIO.replace("latency: 0.5", "latncy: 0.5");
    assert_eq!(
        build(&text, &registry()).unwrap_err(),
        format!(
            "net.ron:{line}:{}: DistanceDelay: unknown field `latncy`; expected one of `latency`, `speed`",
            col(&text, "latncy")
        )
    );
    let e = build(SCENARIO, &Registry::with_builtins()).unwrap_err();
    assert!(
        e.starts_with(&format!(
            "net.ron:{line}:{}: unknown network \"DistanceDelay\"",
            col(SCENARIO, "DistanceDelay")
        )),
        "{e}"
    );
}
