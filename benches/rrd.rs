//! Cost of a Rerun recording (`cargo bench --bench rrd`): the same 1k-robot random-movement
//! run (seed 5.1 at the seed's density, as `benches/engine.rs`) through the runner without a
//! recording, and with `--rrd` at event instants only (`framerate: 0`), at 5 and 10 animation
//! frames per simulated second, and at the default 25. Figures in docs/performance.md.

use std::path::Path;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use nekosim::recording::Target;
use nekosim::runner::{self, RunOptions};
use nekosim::scenario::{Built, Overrides, Registry, Source};

// The allocator of the `nekosim` command (src/main.rs), so the bench measures what it runs.
#[global_allocator]
static GLOBAL: nekosim::allocator::MiMalloc = nekosim::allocator::MiMalloc;

const ROBOTS: usize = 1_000;
const UNTIL: f64 = 100.0;
/// Animation rates compared: event instants only, a few lower rates, and the default.
const FRAMERATES: [f64; 4] = [0.0, 5.0, 10.0, 25.0];

fn scenario(dir: &Path, framerate: f64) -> Built {
    // The seed's density: 100 robots of radius 5 per 800×800.
    let side = 800.0 * (ROBOTS as f64 / 100.0).sqrt();
    let text = format!(
        "Scenario(name: \"rrd_bench\", seed: 3, until: {UNTIL:?},
          world: (size: Bounded(width: {side:?}, height: {side:?}), origin: (0.0, 0.0)),
          robots: [Group(count: {ROBOTS}, radius: 5.0, born: Random, algorithm: RandomMovement())],
          animation: (framerate: {framerate:?}))"
    );
    let file = dir.join(format!("bench-{framerate}.ron"));
    std::fs::write(&file, text).unwrap();
    Source::load(&file)
        .unwrap()
        .build(Overrides::default(), &Registry::new())
        .unwrap()
}

fn options(rrd: Option<&Path>) -> RunOptions {
    RunOptions {
        recording: Target {
            rrd: rrd.map(Path::to_path_buf),
            connect: None,
        },
        ..RunOptions::default()
    }
}

fn rrd(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bench.rrd");
    let s = runner::run(scenario(dir.path(), 0.0), options(None)).unwrap();
    eprintln!(
        "rrd: {ROBOTS} robots, {UNTIL} simulated s, {} events, {} collisions",
        s.events, s.collisions
    );
    for fr in FRAMERATES {
        runner::run(scenario(dir.path(), fr), options(Some(&file))).unwrap();
        let size = std::fs::metadata(&file).unwrap().len();
        eprintln!("rrd: framerate {fr}: {:.1} MB", size as f64 / 1e6);
    }
    let mut g = c.benchmark_group("rrd");
    g.sample_size(10);
    g.bench_function("1000_robots_100s/no_recording", |b| {
        b.iter_batched(
            || scenario(dir.path(), 0.0),
            |built| runner::run(built, options(None)).unwrap(),
            BatchSize::PerIteration,
        )
    });
    for fr in FRAMERATES {
        g.bench_function(format!("1000_robots_100s/rrd_framerate_{fr}"), |b| {
            b.iter_batched(
                || scenario(dir.path(), fr),
                |built| runner::run(built, options(Some(&file))).unwrap(),
                BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

criterion_group!(benches, rrd);
criterion_main!(benches);
