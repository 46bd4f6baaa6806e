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

/// Start-up is reported: every 10,000 robots spawned, and once when all are, before the
/// first event.
#[test]
fn start_up_reports_the_robots_spawned() {
    let side = 4000.0;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let points = random_born_points(25_000, 5.0, side, side, &[], &mut rng).expect("born points");
    let robots = points
        .into_iter()
        .map(|p| {
            let spec = RobotSpec {
                radius: 5.0,
                pose: Pose { pos: p, angle: 0.0 },
            };
            (
                spec,
                Box::new(nekosim::algorithm::Idle) as Box<dyn Algorithm>,
            )
        })
        .collect();
    let calls = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
    let seen = calls.clone();
    let first_event = std::rc::Rc::new(std::cell::Cell::new(None::<usize>));
    let at_first = first_event.clone();
    let calls_at_event = calls.clone();
    nekosim::run(SimConfig {
        sensors: Default::default(),
        seed: 7,
        until: 1.0,
        world: bounded(side, side),
        robots,
        arbiters: 1,
        record: false,
        observers: nekosim::scheduler::Observers {
            startup: Some(Box::new(move |done, all| {
                seen.borrow_mut().push((done, all))
            })),
            sink: Some(Box::new(move |_| {
                if at_first.get().is_none() {
                    at_first.set(Some(calls_at_event.borrow().len()));
                }
            })),
            ..Default::default()
        },
        comms: Default::default(),
    })
    .expect("run");
    assert_eq!(
        *calls.borrow(),
        [(10_000, 25_000), (20_000, 25_000), (25_000, 25_000)]
    );
    assert_eq!(
        first_event.get(),
        Some(3),
        "all reported before the first record"
    );
}

/// Progress counts events, so an instant with many events (every robot starting at t = 0)
/// shows progress although virtual time stands still: 10,000 idle robots are 10,000 start
/// events at t = 0, reported at every `PROGRESS_EVERY` events.
#[test]
fn progress_counts_the_events_of_a_long_instant() {
    let robots = (0..10_000)
        .map(|i| {
            let spec = RobotSpec {
                radius: 1.0,
                pose: Pose {
                    pos: nekosim::world::geometry::Point::new(
                        (i % 100) as f64 * 10.0 + 5.0,
                        (i / 100) as f64 * 10.0 + 5.0,
                    ),
                    angle: 0.0,
                },
            };
            (
                spec,
                Box::new(nekosim::algorithm::Idle) as Box<dyn Algorithm>,
            )
        })
        .collect();
    let calls = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
    let seen = calls.clone();
    let out = nekosim::run(SimConfig {
        sensors: Default::default(),
        seed: 1,
        until: 5.0,
        world: bounded(1000.0, 1000.0),
        robots,
        arbiters: 1,
        record: false,
        observers: nekosim::scheduler::Observers {
            progress: Some(Box::new(move |t, events| {
                seen.borrow_mut().push((t, events))
            })),
            ..Default::default()
        },
        comms: Default::default(),
    })
    .expect("run");
    assert_eq!(out.stats.events, 10_000);
    let every = nekosim::scheduler::PROGRESS_EVERY;
    assert_eq!(*calls.borrow(), [(0.0, every), (0.0, 2 * every)]);
}
