//! The seed's first example (section 5.1): 100 robots of radius 5 born at random in an 800×800
//! world move to random destinations at random speeds, with collisions, for 120 simulated
//! seconds. Prints the first events and a summary.
//!
//! Run: `cargo run --release --example seed_random_movement [SEED]`

use nekosim::algorithm::RandomMovement;
use nekosim::world::born::random_born_points;
use nekosim::world::motion::Pose;
use nekosim::world::observation::Observation;
use nekosim::world::virtual_world::{RobotSpec, WorldConfig, WorldSize};
use nekosim::{Algorithm, SimConfig};
use rand::SeedableRng;

fn main() {
    let seed = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1u64);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let born = random_born_points(100, 5.0, 800.0, 800.0, &[], &mut rng).expect("born points");
    let robots = born
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
        seed,
        until: 120.0,
        world: WorldConfig {
            size: WorldSize::from_origin(800.0, 800.0),
            ghost_mode: false,
            cell_size: None,
        },
        robots,
        arbiters: 1,
        record: true,
        observers: Default::default(),
    })
    .expect("run");
    for r in out
        .records
        .iter()
        .filter(|r| !matches!(r.obs, Observation::Spawn { .. }))
        .take(12)
    {
        println!("{:>9.3} {:?}", r.t, r.obs);
    }
    println!(
        "robots: 100, events: {}, collisions: {}, simulated time: {:.3} s, observations: {}",
        out.stats.events,
        out.stats.collisions,
        out.stats.end_time,
        out.records.len()
    );
}
