//! Obstacles (issue 16, seed 7.2): exact contact times against closed forms, and whole runs
//! among obstacles replayed against every primitive by brute force.

use nekosim::scenario::{Overrides, Registry, Source};
use nekosim::world::geometry::{Point, Vector};
use nekosim::world::observation::Observation;
use nekosim::world::obstacle::{first_contact, Shape};
use nekosim::world::Obstacle;

use crate::common::{pos_at, radii, trajectories};

/// Runs the scenario `text` in process, keeping its records.
fn records(text: &str) -> (Vec<nekosim::world::observation::Record>, Vec<Shape>) {
    let source = Source::parse("obstacles.ron", text).expect("parses");
    let built = source
        .build(Overrides::default(), &Registry::with_builtins())
        .expect("builds");
    let shapes = built.world.obstacles.to_vec();
    let out = nekosim::run(nekosim::SimConfig {
        seed: built.seed,
        until: built.until,
        world: built.world,
        robots: built.robots,
        arbiters: 1,
        record: true,
        observers: Default::default(),
        comms: built.comms,
        sensors: built.sensors,
    })
    .expect("runs");
    (out.records, shapes)
}

#[test]
fn robots_stop_where_they_touch_a_face_a_corner_and_a_circle() {
    // Robot 0 drives east into the box's face x = 50 (radius 2: contact at x = 48, t = 48/4);
    // robot 1 drives along y = x into the triangle's corner (100, 100) (radius 1: the centre
    // stops 1 short of it, t = (100 - 1/sqrt 2) / 1 per axis); robot 2 drives north into the
    // pillar of radius 5 at (0, 200) (radius 3: at y = 192, t = (192 - 100) / 2).
    let (records, _) = records(
        "Scenario(seed: 1, until: 200.0, world: (size: Infinite),
           obstacles: [
             Rect(min: (50.0, -10.0), max: (60.0, 10.0)),
             Polygon([(100.0, 100.0), (120.0, 100.0), (100.0, 130.0)]),
             Circle(center: (0.0, 200.0), radius: 5.0),
           ],
           robots: [
             Robot(id: 0, radius: 2.0, at: (0.0, 0.0), angle: 0.0, algorithm: Script([Forward(distance: 100.0, move_speed: 4.0)])),
             Robot(id: 1, radius: 1.0, at: (20.0, 20.0), angle: 45.0, algorithm: Script([Forward(distance: 200.0, move_speed: 1.4142135623730951)])),
             Robot(id: 2, radius: 3.0, at: (0.0, 100.0), angle: 90.0, algorithm: Script([Forward(distance: 200.0, move_speed: 2.0)])),
           ])",
    );
    let hits: Vec<(u32, f64, Obstacle, Point, Point)> = records
        .iter()
        .filter_map(|r| match r.obs {
            Observation::Collision {
                robot,
                other,
                pos,
                other_pos,
                ..
            } => Some((robot, r.t, other, pos, other_pos)),
            _ => None,
        })
        .collect();
    assert_eq!(hits.len(), 3, "{hits:?}");
    let corner = 100.0 - std::f64::consts::FRAC_1_SQRT_2;
    let want = [
        (
            0,
            12.0,
            Obstacle::Object(0),
            Point::new(48.0, 0.0),
            Point::new(50.0, 0.0),
        ),
        (
            1,
            corner - 20.0,
            Obstacle::Object(1),
            Point::new(corner, corner),
            Point::new(100.0, 100.0),
        ),
        (
            2,
            46.0,
            Obstacle::Object(2),
            Point::new(0.0, 192.0),
            Point::new(0.0, 195.0),
        ),
    ];
    for w in want {
        let h = hits.iter().find(|h| h.0 == w.0).expect("a collision");
        assert!(
            (h.1 - w.1).abs() < 1e-9,
            "robot {}: t {} want {}",
            w.0,
            h.1,
            w.1
        );
        assert_eq!(h.2, w.2);
        assert!((h.3 - w.3).norm() < 1e-9, "{h:?}");
        assert!((h.4 - w.4).norm() < 1e-9, "{h:?}");
    }
    // Each motion ends collided with the obstacle, and the trace names it `obstacle:K`.
    let mut finishes: Vec<String> = records
        .iter()
        .filter(|r| matches!(r.obs, Observation::MotionFinish { .. }))
        .map(|r| nekosim::trace::to_json(r)["other"].to_string())
        .collect();
    finishes.sort();
    assert_eq!(
        finishes,
        ["\"obstacle:0\"", "\"obstacle:1\"", "\"obstacle:2\""]
    );
}

/// Every straight piece of every robot's path, rebuilt from the trace alone, is replayed
/// against every primitive of every obstacle (no index): where the piece would touch one
/// before its end, the trace has that collision at that instant and the piece ends there; no
/// robot ever overlaps an obstacle.
#[test]
fn random_movement_among_obstacles_agrees_with_a_brute_force_replay() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenarios/obstacles.ron"),
    )
    .unwrap();
    let (records, shapes) = records(&text);
    let prims: Vec<(u32, nekosim::world::obstacle::Primitive)> = shapes
        .iter()
        .enumerate()
        .flat_map(|(k, s)| s.primitives().into_iter().map(move |p| (k as u32, p)))
        .collect();
    let paths = trajectories(&records);
    let radius = radii(&records);
    let end = records.last().unwrap().t;
    let reported: Vec<(u32, f64, u32)> = records
        .iter()
        .filter_map(|r| match r.obs {
            Observation::Collision {
                robot,
                other: Obstacle::Object(k),
                ..
            } => Some((robot, r.t, k)),
            _ => None,
        })
        .collect();
    let mut predicted = std::collections::BTreeSet::new();
    for (robot, path) in paths.iter().enumerate() {
        let r = radius[robot];
        for (i, seg) in path.iter().enumerate() {
            let until = path.get(i + 1).map_or(end, |n| n.t);
            // A piece may last no time: a robot resting against an obstacle that starts
            // into it touches it at once.
            if seg.v == Vector::zeros() || until < seg.t {
                continue;
            }
            let first = prims
                .iter()
                .filter_map(|(k, p)| {
                    first_contact(seg.p, seg.v, r, p, until - seg.t + 1e-9)
                        .map(|(tau, _)| (tau, *k))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((tau, k)) = first {
                // A contact inside the piece: the trace reports it and the piece ends there
                // (or a robot collision ends it at the same instant).
                let t = seg.t + tau;
                if t < until - 1e-9 {
                    panic!(
                        "robot {robot} crosses obstacle {k} at {t}, its piece goes on to {until}"
                    );
                }
                if let Some(n) = reported.iter().position(|&(x, rt, rk)| {
                    x as usize == robot && rk == k && (rt - t).abs() < 1e-7
                }) {
                    predicted.insert(n);
                }
            }
        }
        // Sampled: never inside an obstacle.
        for s in 0..=2000 {
            let t = end * f64::from(s) / 2000.0;
            let p = pos_at(path, t);
            for (k, shape) in shapes.iter().enumerate() {
                assert!(
                    shape.distance(p) >= r - 1e-6,
                    "robot {robot} inside obstacle {k} at {t}: {p}"
                );
            }
        }
    }
    assert_eq!(
        predicted.len(),
        reported.len(),
        "every reported obstacle collision is the brute force's first contact"
    );
    assert!(
        reported.len() >= 5,
        "only {} obstacle collisions: the oracle is barely exercised",
        reported.len()
    );
}

/// Random born points keep clear of obstacles.
#[test]
fn random_born_points_avoid_obstacles() {
    let (records, shapes) = records(
        "Scenario(seed: 3, until: 0.0, world: (size: Bounded(width: 200.0, height: 200.0), origin: (0.0, 0.0)),
           obstacles: [Rect(min: (0.0, 0.0), max: (150.0, 150.0))],
           robots: [Group(count: 50, radius: 3.0, born: Random, algorithm: Idle)])",
    );
    let spawns: Vec<(Point, f64)> = records
        .iter()
        .filter_map(|r| match r.obs {
            Observation::Spawn { pos, radius, .. } => Some((pos, radius)),
            _ => None,
        })
        .collect();
    assert_eq!(spawns.len(), 50);
    for (p, r) in spawns {
        assert!(shapes[0].distance(p) >= r, "{p} in the box");
    }
}
