//! A custom robot algorithm written in Rust and used from a scenario file.
//!
//! `Patrol` drives its robot around a square, corner after corner, for a number of laps, and
//! looks around with the view sensor at every corner. It is registered under the name
//! "patrol", so a scenario can say `algorithm: Custom(name: "patrol", params: {"side": 40.0})`.
//!
//! Run: `cargo run --example custom_algorithm` (prints the Neko log).
//! Test: `cargo test --example custom_algorithm`.

use std::collections::BTreeMap;

use nekosim::runner::{self, RunOptions};
use nekosim::scenario::{Overrides, Registry, Source};
use nekosim::world::geometry::Point;
use nekosim::{Algorithm, AlgorithmFuture, Robot};

/// Drives around a square of `side` units, `laps` times, anticlockwise from the born point.
#[derive(Debug, Clone)]
struct Patrol {
    side: f64,
    laps: u32,
    speed: f64,
}

impl Patrol {
    fn from_params(p: &BTreeMap<String, f64>) -> Result<Box<dyn Algorithm>, String> {
        let side = p.get("side").copied().unwrap_or(40.0);
        if !(side.is_finite() && side > 0.0) {
            return Err(format!("patrol side is {side}; expected a number > 0"));
        }
        let laps = p.get("laps").copied().unwrap_or(1.0);
        Ok(Box::new(Patrol {
            side,
            laps: laps as u32,
            speed: p.get("speed").copied().unwrap_or(5.0),
        }))
    }
}

impl Algorithm for Patrol {
    fn name(&self) -> &str {
        "patrol"
    }

    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let me = self.clone();
        Box::pin(async move {
            let start = robot.gps().self_position(0.0).await;
            let corners = [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)];
            for _ in 0..me.laps {
                for (cx, cy) in corners {
                    let corner = Point::new(start.x + cx * me.side, start.y + cy * me.side);
                    robot.move_to(corner, me.speed, 90.0).await;
                    // Look around: who is within one side of me?
                    let seen = robot.robots_in_view(me.side).await;
                    tracing::info!(robot = robot.id(), seen = seen.len(), "corner");
                }
            }
        })
    }
}

const SCENARIO: &str = r#"
Scenario(
    name: "patrol",
    seed: 3,
    until: 200.0,
    world: (size: Infinite),
    robots: [
        Robot(id: 0, radius: 2.0, at: (0.0, 0.0), algorithm: Custom(name: "patrol", params: {"side": 40.0, "laps": 2.0})),
        Robot(id: 1, radius: 2.0, at: (100.0, 100.0), algorithm: Custom(name: "patrol", params: {"side": 10.0})),
    ],
)
"#;

fn registry() -> Registry {
    let mut r = Registry::new();
    r.register("patrol", Patrol::from_params);
    r
}

/// Runs the scenario and returns the log and trace text.
fn run_patrol() -> (String, String) {
    let source = Source::parse("patrol.ron", SCENARIO).expect("scenario parses");
    let built = source
        .build(Overrides::default(), &registry())
        .expect("scenario builds");
    let dir = std::env::temp_dir().join(format!("nekosim-patrol-{}", std::process::id()));
    let (log, trace) = (dir.join("patrol.log"), dir.join("patrol.jsonl"));
    runner::run(
        built,
        RunOptions {
            log: Some(log.clone()),
            trace: Some(trace.clone()),
            ..RunOptions::default()
        },
    )
    .expect("run");
    let out = (
        std::fs::read_to_string(&log).unwrap(),
        std::fs::read_to_string(&trace).unwrap(),
    );
    let _ = std::fs::remove_dir_all(dir);
    out
}

#[cfg_attr(test, allow(dead_code))]
fn main() {
    let (log, _) = run_patrol();
    print!("{log}");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patrol_visits_every_corner_of_every_lap_in_order() {
        let (_, trace) = run_patrol();
        let arrivals: Vec<(u64, f64, f64)> = trace
            .lines()
            .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
            .filter(|v| v["kind"] == "motion_finish" && v["outcome"] == "arrived")
            .map(|v| {
                (
                    v["robot"].as_u64().unwrap(),
                    v["pos"][0].as_f64().unwrap(),
                    v["pos"][1].as_f64().unwrap(),
                )
            })
            .collect();
        let robot0: Vec<(f64, f64)> = arrivals
            .iter()
            .filter(|a| a.0 == 0)
            .map(|a| (a.1, a.2))
            .collect();
        let corners = [(40.0, 0.0), (40.0, 40.0), (0.0, 40.0), (0.0, 0.0)];
        let expected: Vec<(f64, f64)> = corners.iter().chain(corners.iter()).copied().collect();
        assert_eq!(robot0.len(), expected.len());
        for (got, want) in robot0.iter().zip(&expected) {
            assert!(
                (got.0 - want.0).abs() < 1e-9 && (got.1 - want.1).abs() < 1e-9,
                "{got:?} vs {want:?}"
            );
        }
        assert_eq!(arrivals.iter().filter(|a| a.0 == 1).count(), 4);
    }

    #[test]
    fn bad_parameters_are_reported_at_the_params() {
        let text = SCENARIO.replace("\"side\": 40.0", "\"side\": -1.0");
        let source = Source::parse("patrol.ron", &text).unwrap();
        let e = source.build(Overrides::default(), &registry()).unwrap_err();
        assert!(e.to_string().starts_with("patrol.ron:8:"), "{e}");
        assert!(e.to_string().contains("patrol side is -1"), "{e}");
    }
}
