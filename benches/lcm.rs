//! Look-Compute-Move robots at scale (`cargo bench --bench lcm`): robots at the seed's density
//! (100 of radius 5 per 800 x 800) computing the centre of gravity of what they see within 60
//! units, under ASYNC with non-rigid moves, each completing about one cycle per simulated
//! second, through the runner as `nekosim run` runs them. Prints, for each robot count, the
//! real-time factor over 10 simulated seconds (one core: run it under `taskset -c 0`), then the
//! same scenario under the kernel-alone reference (`nekosim::kernel::run`: the same handlers and
//! scheduler core with no actors, no records written anywhere): the gap between the two is the
//! actors' hosting. The goal and figures are in docs/performance.md.

use std::time::Instant;

use nekosim::runner::{self, RunOptions};
use nekosim::scenario::{Overrides, Registry, Source};

// The allocator of the `nekosim` command (src/main.rs), so the bench measures what it runs.
#[global_allocator]
static GLOBAL: nekosim::allocator::MiMalloc = nekosim::allocator::MiMalloc;

const UNTIL: f64 = 10.0;

fn main() {
    let sizes: Vec<usize> = std::env::var("NEKOSIM_LCM_SIZES")
        .ok()
        .map(|s| s.split(',').filter_map(|n| n.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![10_000, 100_000]);
    for robots in sizes {
        let side = 800.0 * (robots as f64 / 100.0).sqrt();
        let text = format!(
            "Scenario(name: \"lcm_bench\", seed: 1, until: {UNTIL:?},
              world: (size: Bounded(width: {side:?}, height: {side:?}), ghost_mode: true,
                      cell_size: Some(60.0)),
              lcm: (synchrony: Async, visibility: Some(60.0), movement: NonRigid(delta: 5.0)),
              robots: [Group(count: {robots}, radius: 5.0, born: Random,
                             algorithm: CentreOfGravity())])"
        );
        let built = Source::parse("lcm_bench.ron", &text)
            .expect("parses")
            .build(Overrides::default(), &Registry::with_builtins())
            .expect("builds");
        let started = Instant::now();
        let summary = runner::run(built, RunOptions::default()).expect("runs");
        let wall = started.elapsed().as_secs_f64();
        println!(
            "lcm {robots} robots: {:.2}x real time ({wall:.2} s for {UNTIL} simulated s), {} events, {:.2} us an event",
            UNTIL / wall,
            summary.events,
            wall / summary.events as f64 * 1e6
        );
        let reference = Source::parse("lcm_bench.ron", &text)
            .expect("parses")
            .build(Overrides::default(), &Registry::with_builtins())
            .expect("builds")
            .into_config(false);
        let started = Instant::now();
        let kernel = nekosim::kernel::run(reference).expect("runs");
        let wall = started.elapsed().as_secs_f64();
        println!(
            "lcm {robots} robots, kernel alone: {:.2}x real time ({wall:.2} s), {} events",
            UNTIL / wall,
            kernel.stats.events
        );
    }
}
