//! The cost of a sweep around its runs (issue 14): 1,000 short runs of random movement
//! (the seed's 100 robots in 800 x 800, 10 simulated seconds, seeds 1..=1000) as one sweep with `--jobs 1` and
//! `--jobs 2`, against the sum of the same runs' engine time (each run's own wall time inside
//! `runner::run`, measured by running them one by one).
//!
//! `cargo bench --no-default-features --bench sweep` prints the three times and the two
//! ratios; docs/performance.md records them.

use std::time::Instant;

use nekosim::runner::{self, RunOptions};
use nekosim::scenario::{Overrides, Registry, Source};
use nekosim::sweep::{self, Sweep, SweepOptions};

const RUNS: u64 = 1000;

// The allocator of the `nekosim` binary, so the figures are the command's.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().expect("temp dir");
    let scenario = root.join("examples/scenarios/random_movement.ron");
    let file = dir.path().join("bench.ron");
    std::fs::write(
        &file,
        format!(
            "Sweep(scenario: {:?}, seeds: Range(start: 1, count: {RUNS}), axes: {{\"robots[0].count\": [100], \"until\": [10.0]}})",
            scenario.display().to_string()
        ),
    )
    .expect("sweep file");
    let registry = Registry::with_builtins();

    // The engine time of the same runs, one by one.
    let text = std::fs::read_to_string(&scenario).expect("scenario");
    let text = nekosim::scenario::edit::set(&text, "robots[0].count", "100").expect("count");
    let text = nekosim::scenario::edit::set(&text, "until", "10.0").expect("until");
    let source = Source::parse("bench", &text).expect("parses");
    let mut engine = 0.0;
    let mut building = 0.0;
    let mut events = 0;
    for seed in 1..=RUNS {
        let t0 = Instant::now();
        let built = source
            .build(
                Overrides {
                    seed: Some(seed),
                    until: None,
                },
                &registry,
            )
            .expect("builds");
        building += t0.elapsed().as_secs_f64();
        let s = runner::run(built, RunOptions::default()).expect("runs");
        engine += s.wall_seconds;
        events += s.events;
    }
    println!(
        "{RUNS} runs one by one: {events} events, engine time {engine:.3} s (building the scenarios: {building:.3} s)"
    );

    let mut walls = Vec::new();
    for jobs in [1, 2] {
        let out = dir.path().join(format!("out{jobs}"));
        let started = Instant::now();
        let loaded = Sweep::load(&file, &registry).expect("loads");
        let loaded_at = started.elapsed().as_secs_f64();
        let outcome = sweep::run(
            &loaded,
            &registry,
            &SweepOptions {
                jobs,
                ..SweepOptions::default()
            },
        );
        let ran_at = started.elapsed().as_secs_f64();
        sweep::finish(&loaded.plan, &outcome.rows, &out).expect("writes");
        let wall = started.elapsed().as_secs_f64();
        println!(
            "  load {:.3} s, runs {:.3} s, files {:.3} s",
            loaded_at,
            ran_at - loaded_at,
            wall - ran_at
        );
        assert_eq!(outcome.rows.len(), RUNS as usize);
        println!(
            "sweep --jobs {jobs}: {wall:.3} s wall, {:.3}x the runs' engine time",
            wall / engine
        );
        walls.push(wall);
    }
    println!(
        "--jobs 2 speed-up over --jobs 1: {:.2}x",
        walls[0] / walls[1]
    );
}
