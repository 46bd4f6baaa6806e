//! A custom robot algorithm written in Rust and used from a scenario file.
//!
//! `Patrol` drives its robot around a square, corner after corner, for a number of laps, and
//! looks around with the view sensor at every corner. Its configuration is its own serde type,
//! and one registry line, `registry.algorithm::<Patrol>("Patrol")`, lets a scenario say
//! `algorithm: Patrol(side: 40.0, laps: 2)`.
//!
//! Run: `cargo run --example custom_algorithm` (prints the Neko log).
//! Test: `cargo test --example custom_algorithm`.

use nekosim::registry::{Configured, Setting};
use nekosim::runner::{self, RunOptions};
use nekosim::scenario::{Overrides, Registry, Source};
use nekosim::world::geometry::Point;
use nekosim::{Algorithm, AlgorithmFuture, Robot};
use nekosim_protocols::FieldError;
use serde::Deserialize;

/// Drives around a square of `side` units, `laps` times, anticlockwise from the born point.
#[derive(Debug, Clone)]
struct Patrol {
    side: f64,
    laps: u32,
    speed: f64,
}

/// `Patrol(side: 40.0, laps: 2, speed: 5.0)`; every field has a default.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PatrolConfig {
    #[serde(default = "forty")]
    side: f64,
    #[serde(default = "one")]
    laps: u32,
    #[serde(default = "five")]
    speed: f64,
}

fn forty() -> f64 {
    40.0
}
fn one() -> u32 {
    1
}
fn five() -> f64 {
    5.0
}

impl Configured for Patrol {
    type Config = PatrolConfig;

    fn configure(c: PatrolConfig, _: &Setting) -> Result<Self, FieldError> {
        if !(c.side.is_finite() && c.side > 0.0) {
            return Err(FieldError::new(
                "side",
                format!("patrol side is {}", c.side),
                "a number > 0",
            ));
        }
        Ok(Patrol {
            side: c.side,
            laps: c.laps,
            speed: c.speed,
        })
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
        Robot(id: 0, radius: 2.0, at: (0.0, 0.0), algorithm: Patrol(side: 40.0, laps: 2)),
        Robot(id: 1, radius: 2.0, at: (100.0, 100.0), algorithm: Patrol(side: 10.0)),
    ],
)
"#;

fn registry() -> Registry {
    let mut r = Registry::with_builtins();
    r.algorithm::<Patrol>("Patrol");
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

    /// The error for the scenario with `from` replaced by `to`, and where `word` starts.
    fn error(from: &str, to: &str, word: &str) -> (String, String) {
        let text = SCENARIO.replace(from, to);
        let source = Source::parse("patrol.ron", &text).unwrap();
        let e = source
            .build(Overrides::default(), &registry())
            .map(|_| ())
            .unwrap_err()
            .to_string();
        let (line, l) = text
            .lines()
            .enumerate()
            .find(|(_, l)| l.contains(to))
            .unwrap();
        let col = l.find(to).unwrap() + to.find(word).unwrap() + 1;
        (e, format!("patrol.ron:{}:{col}: ", line + 1))
    }

    #[test]
    fn bad_configurations_are_reported_where_they_are() {
        let (e, at) = error("side: 40.0", "side: -1.0", "-1.0");
        assert_eq!(
            e,
            format!("{at}Patrol: patrol side is -1; expected a number > 0")
        );
        let (e, at) = error("laps: 2", "laps: 2.5", "2.5");
        assert!(e.starts_with(&format!("{at}Patrol: ")), "{e}");
        let (e, at) = error("laps: 2", "lap: 2", "lap");
        assert_eq!(
            e,
            format!("{at}Patrol: unknown field `lap`; expected one of `side`, `laps`, `speed`")
        );
    }
}
