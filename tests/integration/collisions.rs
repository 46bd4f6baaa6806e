//! Whole-run collision oracle: an O(n²) brute force over every pair of rebuilt path segments
//! finds exactly the collisions the engine reported, and no two robots ever overlap.

use crate::common::*;
use nekosim::algorithm::RandomMovement;
use nekosim::world::observation::{Observation, Record};
use nekosim::world::virtual_world::{RobotSpec, WorldConfig};
use nekosim::world::Obstacle;
use nekosim::{Algorithm, SimConfig};
use rand::{Rng, SeedableRng};

const TOL: f64 = 1e-9;

/// Random non-overlapping born points in a `w`×`h` world.
fn born(n: usize, w: f64, h: f64, radius: f64, seed: u64) -> Vec<RobotSpec> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut out: Vec<RobotSpec> = Vec::new();
    while out.len() < n {
        let s = spec(
            rng.gen_range(radius..w - radius),
            rng.gen_range(radius..h - radius),
            rng.gen_range(0.0..360.0),
            radius,
        );
        if out
            .iter()
            .all(|o| (o.pose.pos - s.pose.pos).norm() >= 2.0 * radius)
        {
            out.push(s);
        }
    }
    out
}

fn random_run(seed: u64, n: usize, world: WorldConfig, until: f64) -> Vec<Record> {
    sized_run(seed, n, 200.0, 4.0, world, until)
}

/// `n` robots of `radius` born at random in a `side` x `side` world, moving at random.
fn sized_run(
    seed: u64,
    n: usize,
    side: f64,
    radius: f64,
    world: WorldConfig,
    until: f64,
) -> Vec<Record> {
    let robots = born(n, side, side, radius, seed)
        .into_iter()
        .map(|s| (s, Box::new(RandomMovement::default()) as Box<dyn Algorithm>))
        .collect();
    nekosim::run(SimConfig {
        sensors: Default::default(),
        seed,
        until,
        world,
        robots,
        arbiters: 1,
        record: true,
        observers: Default::default(),
        comms: Default::default(),
    })
    .expect("run")
    .records
}

/// Reported robot-robot collisions as (time, lower id, higher id).
fn reported(records: &[Record]) -> Vec<(f64, u32, u32)> {
    records
        .iter()
        .filter_map(|r| match r.obs {
            Observation::Collision {
                robot,
                other: Obstacle::Robot(o),
                ..
            } => Some((r.t, robot.min(o), robot.max(o))),
            _ => None,
        })
        .collect()
}

/// Brute force over all pairs and all pairs of their rebuilt segments (including segments of
/// zero length, such as a forward move stopped at its very start). Returns the contacts it
/// finds (centres exactly r1 + r2 apart at the end of a common window while approaching, with
/// the velocities recorded for that window) and panics on any overlap.
fn brute_force(records: &[Record], end: f64) -> Vec<(f64, u32, u32)> {
    let paths = trajectories(records);
    let radii = radii(records);
    // Each segment with its closed validity interval.
    let spans: Vec<Vec<(Seg, f64)>> = paths
        .iter()
        .map(|p| {
            p.iter()
                .enumerate()
                .map(|(k, s)| (*s, p.get(k + 1).map_or(end, |n| n.t)))
                .collect()
        })
        .collect();
    let mut contacts: Vec<(f64, u32, u32)> = Vec::new();
    for i in 0..paths.len() {
        for j in i + 1..paths.len() {
            let reach = radii[i] + radii[j];
            for &(a, a_end) in &spans[i] {
                let first = spans[j].partition_point(|(_, b_end)| *b_end < a.t);
                for &(b, b_end) in spans[j][first..].iter().take_while(|(b, _)| b.t <= a_end) {
                    let (s, e) = (a.t.max(b.t), a_end.min(b_end));
                    if e < s {
                        continue;
                    }
                    let d0 = (a.p + a.v * (s - a.t)) - (b.p + b.v * (s - b.t));
                    let dv = a.v - b.v;
                    // Closest approach over [s, e] by minimising |d0 + dv τ|² directly.
                    let q = dv.norm_squared();
                    let tau = if q > 0.0 {
                        (-d0.dot(&dv) / q).clamp(0.0, e - s)
                    } else {
                        0.0
                    };
                    let dmin = (d0 + dv * tau).norm();
                    assert!(
                        dmin >= reach - TOL,
                        "robots {i} and {j} overlap by {} at t={}",
                        reach - dmin,
                        s + tau
                    );
                    let d1 = d0 + dv * (e - s);
                    if (d1.norm() - reach).abs() <= TOL && d1.dot(&dv) < 0.0 {
                        let dup = contacts
                            .iter()
                            .any(|c| c.1 == i as u32 && c.2 == j as u32 && (c.0 - e).abs() < TOL);
                        if !dup {
                            contacts.push((e, i as u32, j as u32));
                        }
                    }
                }
            }
        }
    }
    contacts.sort_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    contacts
}

fn check_run(records: &[Record], end: f64) -> usize {
    check_sized_run(records, end, 200.0)
}

/// [`check_run`] in a `side` x `side` world.
fn check_sized_run(records: &[Record], end: f64, side: f64) -> usize {
    let mut engine = reported(records);
    engine.sort_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    let brute = brute_force(records, end);
    assert_eq!(
        engine.len(),
        brute.len(),
        "engine {engine:?}\nbrute force {brute:?}"
    );
    for (e, b) in engine.iter().zip(&brute) {
        assert!(
            (e.0 - b.0).abs() < 1e-9 && e.1 == b.1 && e.2 == b.2,
            "engine {e:?} brute {b:?}"
        );
    }
    // Boundary contacts: reported ones touch a wall; nobody ever leaves the world.
    let paths = trajectories(records);
    let radii = radii(records);
    for (id, path) in paths.iter().enumerate() {
        let r = radii[id];
        for s in path {
            let p = s.p;
            assert!(
                p.x >= r - TOL && p.y >= r - TOL && p.x <= side - r + TOL && p.y <= side - r + TOL,
                "robot {id} outside the world at {p:?}"
            );
        }
    }
    for rec in records {
        if let Observation::Collision {
            robot,
            other: Obstacle::Boundary,
            pos,
            ..
        } = rec.obs
        {
            let r = radii[robot as usize];
            let gap = (pos.x - r)
                .abs()
                .min((side - r - pos.x).abs())
                .min((pos.y - r).abs())
                .min((side - r - pos.y).abs());
            assert!(gap < TOL, "boundary collision away from the wall: {pos:?}");
        }
    }
    engine.len()
}

#[test]
fn brute_force_finds_exactly_the_reported_collisions() {
    let mut total = 0;
    for seed in 0..12 {
        let records = random_run(seed, 30, bounded(200.0, 200.0), 120.0);
        let end = records.last().map_or(0.0, |r| r.t);
        total += check_run(&records, end);
    }
    // The setting is dense enough that the oracle is exercised, not vacuous.
    assert!(total > 50, "only {total} collisions in all runs");
}

/// The whole-run oracle at scale: 2,000 robots at the seed's density (100 of radius 5 per
/// 800 x 800), every pair of rebuilt path pieces checked (O(n^2) pairs).
#[test]
fn brute_force_agrees_at_two_thousand_robots() {
    let side = 800.0 * 20f64.sqrt();
    let records = sized_run(11, 2000, side, 5.0, bounded(side, side), 20.0);
    let end = records.last().map_or(0.0, |r| r.t);
    let collisions = check_sized_run(&records, end, side);
    assert!(
        collisions > 20,
        "only {collisions} collisions: the oracle is barely exercised"
    );
}

#[test]
fn ghost_mode_has_no_collisions_and_robots_pass_through() {
    let mut world = bounded(200.0, 200.0);
    world.ghost_mode = true;
    let records = random_run(3, 30, world, 100.0);
    assert!(reported(&records).is_empty());
    let end = records.last().unwrap().t;
    let paths = trajectories(&records);
    // Somebody does pass through somebody: the oracle would have seen an overlap.
    let mut overlapped = false;
    for t in (0..1000).map(|k| k as f64 * end / 1000.0) {
        for i in 0..paths.len() {
            for j in i + 1..paths.len() {
                overlapped |= (pos_at(&paths[i], t) - pos_at(&paths[j], t)).norm() < 8.0 - 1e-6;
            }
        }
    }
    assert!(overlapped);
}

#[test]
fn a_robot_stopped_by_a_collision_is_told_with_whom() {
    use nekosim::algorithm::ScriptStep;
    let out = run(
        infinite(),
        100.0,
        vec![
            (
                spec(0.0, 0.0, 0.0, 2.0),
                script(vec![ScriptStep::MoveTo {
                    x: 100.0,
                    y: 0.0,
                    move_speed: 4.0,
                    turn_speed: 90.0,
                }]),
            ),
            (spec(50.0, 1.0, 0.0, 3.0), idle()),
        ],
    );
    let finish: Vec<_> = out
        .records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::MotionFinish {
                robot,
                outcome,
                state,
            } => Some((r.t, *robot, outcome.clone(), state.pos)),
            _ => None,
        })
        .collect();
    assert_eq!(finish.len(), 1, "{finish:?}");
    let (t, robot, outcome, pos) = &finish[0];
    assert_eq!(*robot, 0);
    assert_eq!(
        *outcome,
        nekosim::world::MotionOutcome::Collided {
            with: Obstacle::Robot(1)
        }
    );
    // Contact when the centres are 5 apart: x = 50 - sqrt(25 - 1).
    let x = 50.0 - 24f64.sqrt();
    assert!(
        (pos.x - x).abs() < 1e-9 && (t - x / 4.0).abs() < 1e-9,
        "{t} {pos:?}"
    );
}

/// A robot that a collision stops and that stays at rest is predicted for at rest (at the end
/// of the instant it stopped, docs/architecture.md "Events"): a third robot, whose path missed
/// the stopped robot's original one, runs into it where it stands.
#[test]
fn a_robot_left_at_rest_by_a_collision_is_run_into_later() {
    use nekosim::algorithm::ScriptStep;
    let step = |x: f64, y: f64, move_speed: f64| ScriptStep::MoveTo {
        x,
        y,
        move_speed,
        turn_speed: 90.0,
    };
    let out = run(
        infinite(),
        100.0,
        vec![
            // Stops against robot 1 with its centre at x = 46 at t = 11.5; its script then ends.
            (
                spec(0.0, 0.0, 0.0, 2.0),
                script(vec![step(100.0, 0.0, 4.0)]),
            ),
            (spec(50.0, 0.0, 0.0, 2.0), idle()),
            // Facing down, it passes y = 18.5 when robot 0 passes x = 46, and would have
            // missed it; robot 0 at rest at (46, 0) it touches at y = 4, t = 26.
            (
                spec(46.0, 30.0, -90.0, 2.0),
                script(vec![step(46.0, -100.0, 1.0)]),
            ),
        ],
    );
    let collisions: Vec<(f64, u32, Obstacle)> = out
        .records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::Collision { robot, other, .. } => Some((r.t, *robot, *other)),
            _ => None,
        })
        .collect();
    assert_eq!(collisions.len(), 2, "{collisions:?}");
    assert_eq!((collisions[0].1, collisions[0].2), (0, Obstacle::Robot(1)));
    assert!((collisions[0].0 - 11.5).abs() < 1e-9, "{collisions:?}");
    // Either robot may be the one recorded first.
    assert!(
        matches!(
            (collisions[1].1, collisions[1].2),
            (2, Obstacle::Robot(0)) | (0, Obstacle::Robot(2))
        ),
        "{collisions:?}"
    );
    assert!((collisions[1].0 - 26.0).abs() < 1e-9, "{collisions:?}");
}
