//! Same scenario + seed = the same events in the same order; different seeds differ; the
//! number of arbiters does not matter.

use nekosim::algorithm::{Gathering, RandomMovement};
use nekosim::scheduler::RunOutput;
use nekosim::world::observation::Record;
use nekosim::world::virtual_world::RobotSpec;
use nekosim::{Algorithm, SimConfig};

use crate::common::*;

fn run_with(seed: u64, arbiters: usize) -> RunOutput {
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
        seed,
        until: 80.0,
        world: bounded(200.0, 200.0),
        robots,
        arbiters,
        record: true,
        observers: Default::default(),
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
