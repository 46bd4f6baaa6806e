//! The cost of a sweep around its runs: 1,000 short runs of random movement
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
const REPEATS: usize = 5;

// The allocator of the `nekosim` binary, so the figures are the command's.
#[global_allocator]
static GLOBAL: nekosim::allocator::MiMalloc = nekosim::allocator::MiMalloc;

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

    // The engine time of the same runs, one by one; then the sweep with --jobs 1 and 2. Each
    // measured REPEATS times, interleaved, keeping the least (the machine's noise only adds).
    let text = std::fs::read_to_string(&scenario).expect("scenario");
    let text = nekosim::scenario::edit::set(&text, "robots[0].count", "100").expect("count");
    let text = nekosim::scenario::edit::set(&text, "until", "10.0").expect("until");
    let source = Source::parse("bench", &text).expect("parses");
    let (mut engine, mut building, mut walls) = (f64::MAX, f64::MAX, [f64::MAX; 2]);
    let mut events = 0;
    for _ in 0..REPEATS {
        let (mut e, mut b) = (0.0, 0.0);
        events = 0;
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
            b += t0.elapsed().as_secs_f64();
            let s = runner::run(built, RunOptions::default()).expect("runs");
            e += s.wall_seconds;
            events += s.events;
        }
        engine = engine.min(e);
        building = building.min(b);
        for (k, jobs) in [1, 2].into_iter().enumerate() {
            let out = dir.path().join(format!("out{jobs}"));
            let started = Instant::now();
            let loaded = Sweep::load(&file, &registry).expect("loads");
            let outcome = sweep::run(
                &loaded,
                &registry,
                &SweepOptions {
                    jobs,
                    ..SweepOptions::default()
                },
            );
            sweep::finish(&loaded.plan, &outcome.rows, &out).expect("writes");
            assert_eq!(outcome.rows.len(), RUNS as usize);
            walls[k] = walls[k].min(started.elapsed().as_secs_f64());
        }
    }
    println!(
        "{RUNS} runs one by one: {events} events, engine time {engine:.3} s (building the scenarios: {building:.3} s); least of {REPEATS}"
    );
    for (k, jobs) in [1, 2].into_iter().enumerate() {
        println!(
            "sweep --jobs {jobs}: {:.3} s wall, {:.3}x the runs' engine time",
            walls[k],
            walls[k] / engine
        );
    }
    println!(
        "--jobs 2 speed-up over --jobs 1: {:.2}x",
        walls[0] / walls[1]
    );
}
