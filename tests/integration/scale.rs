//! Scale is designed in: ten thousand robots moving at random, with collisions, run.

use nekosim::algorithm::RandomMovement;
use nekosim::world::born::random_born_points;
use nekosim::world::motion::Pose;
use nekosim::world::virtual_world::RobotSpec;
use nekosim::{Algorithm, SimConfig};
use rand::SeedableRng;

use crate::common::*;

#[test]
fn ten_thousand_robots_run() {
    // The seed's density (100 robots of radius 5 in 800×800), a hundred times over.
    let side = 8000.0;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
    let points = random_born_points(10_000, 5.0, side, side, &[], &mut rng).expect("born points");
    let robots = points
        .into_iter()
        .map(|p| {
            let spec = RobotSpec {
                radius: 5.0,
                pose: Pose { pos: p, angle: 0.0 },
            };
            (
                spec,
                Box::new(RandomMovement::default()) as Box<dyn Algorithm>,
            )
        })
        .collect();
    let out = nekosim::run(SimConfig {
        sensors: Default::default(),
        seed: 42,
        until: 20.0,
        world: bounded(side, side),
        robots,
        arbiters: 1,
        record: false,
        observers: Default::default(),
        comms: Default::default(),
    })
    .expect("run");
    println!("{:?}", out.stats);
    assert!(out.stats.events > 50_000, "{:?}", out.stats);
    assert!(out.stats.collisions > 0, "{:?}", out.stats);
    assert_eq!(out.stats.end_time, 20.0);
}
