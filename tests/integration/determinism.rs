//! Same scenario + seed = the same events in the same order; different seeds differ; the
//! number of arbiters does not matter.

use nekosim::algorithm::{Gathering, RandomMovement};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use nekosim::scheduler::{Observers, RunOutput};
use nekosim::world::observation::Record;
use nekosim::world::virtual_world::RobotSpec;
use nekosim::{Algorithm, SimConfig};

use crate::common::*;

fn run_with(seed: u64, arbiters: usize) -> RunOutput {
    run_observed(seed, arbiters, Observers::default())
}

fn run_observed(seed: u64, arbiters: usize, observers: Observers) -> RunOutput {
    let mut robots: Vec<(RobotSpec, Box<dyn Algorithm>)> = Vec::new();
    for i in 0..24 {
        let (x, y) = (20.0 + 25.0 * (i % 6) as f64, 20.0 + 30.0 * (i / 6) as f64);
        let alg: Box<dyn Algorithm> = if i % 3 == 0 {
            Box::new(Gathering {
                error: 0.5,
                ..Gathering::default()
            })
        } else {
            Box::new(RandomMovement::default())
        };
        robots.push((spec(x, y, 15.0 * i as f64, 4.0), alg));
    }
    nekosim::run(SimConfig {
        sensors: Default::default(),
        seed,
        until: 80.0,
        world: bounded(200.0, 200.0),
        robots,
        arbiters,
        record: true,
        observers,
        comms: Default::default(),
    })
    .expect("run")
}

fn text(records: &[Record]) -> String {
    records
        .iter()
        .map(|r| format!("{} {} {:?}\n", r.t, r.seq, r.obs))
        .collect()
}

#[test]
fn same_seed_same_events() {
    let (a, b) = (run_with(7, 1), run_with(7, 1));
    assert!(a.records.len() > 500);
    assert_eq!(text(&a.records), text(&b.records));
    assert_eq!(a.stats, b.stats);
}

#[test]
fn different_seeds_differ() {
    assert_ne!(text(&run_with(7, 1).records), text(&run_with(8, 1).records));
}

#[test]
fn several_arbiters_give_the_same_order_as_one() {
    let one = run_with(11, 1);
    let three = run_with(11, 3);
    assert_eq!(text(&one.records), text(&three.records));
}

#[test]
fn time_never_goes_backwards_and_seq_strictly_increases() {
    let out = run_with(5, 2);
    for w in out.records.windows(2) {
        assert!(
            w[1].t >= w[0].t,
            "time went back: {:?} then {:?}",
            w[0],
            w[1]
        );
        assert!(w[1].seq > w[0].seq);
    }
}

/// A run stopped from outside (the user's Ctrl-C) is the beginning of the full run: the same
/// records up to the stop, flagged as interrupted, ending at the virtual time reached.
#[test]
fn a_stopped_run_is_a_prefix_of_the_full_run() {
    let full = run_with(7, 1);
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    let cut = run_observed(
        7,
        1,
        Observers {
            // Raised while the 300th record's event is processed.
            sink: Some(Box::new(move |r: &Record| {
                if r.seq == 300 {
                    flag.store(true, Ordering::Relaxed);
                }
            })),
            stop: Some(stop),
            ..Observers::default()
        },
    );
    assert!(cut.stats.interrupted && !full.stats.interrupted);
    assert!(cut.records.len() > 300 && cut.records.len() < full.records.len());
    assert_eq!(text(&cut.records), text(&full.records[..cut.records.len()]));
    let last = cut.records.last().unwrap();
    assert_eq!(cut.stats.end_time, last.t);
    assert!(cut.stats.end_time < full.stats.end_time);
}
