//! The kernel-alone reference (`nekosim::kernel::run`) drives the same handling code
//! as the actor-hosted run without actors: it must take the same events in the same order, so
//! both traces are the same, observation for observation, on every example scenario (motion
//! and collisions, sensors, networks, protocol stacks, crashes, partitions, obstacles).

use std::path::Path;

use nekosim::scenario::{Overrides, Registry, Source};
use nekosim::scheduler::RunOutput;
use nekosim::SimConfig;

fn config(path: &Path, until: f64) -> SimConfig {
    let built = Source::load(path)
        .expect("scenario")
        .build(
            Overrides {
                seed: None,
                until: Some(until),
            },
            &Registry::with_builtins(),
        )
        .expect("built");
    SimConfig {
        seed: built.seed,
        until: built.until,
        world: built.world,
        robots: built.robots,
        arbiters: built.arbiters,
        record: true,
        observers: Default::default(),
        comms: built.comms,
        sensors: built.sensors,
    }
}

fn text(out: &RunOutput) -> String {
    out.records
        .iter()
        .map(|r| format!("{} {} {:?}\n", r.t, r.seq, r.obs))
        .collect()
}

#[test]
fn the_kernel_alone_takes_the_same_events_as_the_actors_on_every_example() {
    let mut scenarios: Vec<_> = std::fs::read_dir("examples/scenarios")
        .expect("examples")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "ron"))
        .collect();
    scenarios.sort();
    assert!(scenarios.len() >= 10, "{scenarios:?}");
    for path in scenarios {
        let actors = nekosim::run(config(&path, 60.0)).expect("actor run");
        let kernel = nekosim::kernel::run(config(&path, 60.0)).expect("kernel run");
        assert!(
            actors.records.len() > 10,
            "{}: only {} observations",
            path.display(),
            actors.records.len()
        );
        assert_eq!(actors.stats, kernel.stats, "{}", path.display());
        // Compared line by line so that a difference names its first observation.
        for (a, k) in text(&actors).lines().zip(text(&kernel).lines()) {
            assert_eq!(a, k, "{}", path.display());
        }
        assert_eq!(actors.records.len(), kernel.records.len());
    }
}
