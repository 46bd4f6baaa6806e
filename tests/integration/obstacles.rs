//! Obstacles (seed 7.2): exact contact times against closed forms, and whole runs
//! among obstacles replayed against every primitive by brute force.

use nekosim::scenario::{Overrides, Registry, Source};
use nekosim::world::geometry::{Point, Vector};
use nekosim::world::observation::Observation;
use nekosim::world::obstacle::{first_contact, Shape};
use nekosim::world::Obstacle;

use crate::common::{pos_at, radii, trajectories};

/// Builds the scenario `text`; `robot0`, if given, replaces robot 0's algorithm.
fn built(text: &str, robot0: Option<Box<dyn nekosim::Algorithm>>) -> nekosim::scenario::Built {
    let source = Source::parse("obstacles.ron", text).expect("parses");
    let mut built = source
        .build(Overrides::default(), &Registry::with_builtins())
        .expect("builds");
    if let Some(a) = robot0 {
        built.robots[0].1 = a;
    }
    built
}

/// Runs a built scenario in process, keeping its records.
fn run(built: nekosim::scenario::Built) -> nekosim::scheduler::RunOutput {
    nekosim::run(built.into_config(true)).expect("runs")
}

/// Runs the scenario `text` in process: its records and obstacles.
fn records(text: &str) -> (Vec<nekosim::world::observation::Record>, Vec<Shape>) {
    let built = built(text, None);
    let shapes = built.world.obstacles.to_vec();
    (run(built).records, shapes)
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

/// Robot 0 at the origin looks (view and proximity) and sends one message to everyone.
#[derive(Debug)]
struct Looker;

impl nekosim::Algorithm for Looker {
    fn name(&self) -> &str {
        "Looker"
    }
    fn run(&self, robot: nekosim::robot::Robot) -> nekosim::robot::AlgorithmFuture {
        Box::pin(async move {
            let seen: Vec<u32> = robot
                .robots_in_view(500.0)
                .await
                .iter()
                .map(|s| s.0)
                .collect();
            robot.log(format!("view {seen:?}"));
            let near: Vec<u32> = robot.proximity(500.0).await.iter().map(|g| g.0).collect();
            robot.log(format!("proximity {near:?}"));
            let everyone: Vec<u32> = (1..robot.info().count as u32).collect();
            robot.send(everyone, &1u8);
        })
    }
}

/// Whether the segment from `a` to `b` meets the box `[lo, hi]` (Liang-Barsky clipping) or the
/// disc of radius `r` around `c` (closest point of the segment): the oracle, written apart
/// from the simulator's geometry.
fn crosses(
    a: (f64, f64),
    b: (f64, f64),
    lo: (f64, f64),
    hi: (f64, f64),
    c: (f64, f64),
    r: f64,
) -> bool {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let mut inside = true;
    for (p, q) in [
        (-dx, a.0 - lo.0),
        (dx, hi.0 - a.0),
        (-dy, a.1 - lo.1),
        (dy, hi.1 - a.1),
    ] {
        if p == 0.0 {
            inside &= q >= 0.0;
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    let in_box = inside && t0 <= t1;
    let u = (((c.0 - a.0) * dx + (c.1 - a.1) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
    let in_disc = (a.0 + u * dx - c.0).hypot(a.1 + u * dy - c.1) < r;
    in_box || in_disc
}

/// View and proximity leave out the robots hidden behind a box or a pillar, and a Radio with
/// `line_of_sight: true` drops exactly the copies whose straight line crosses one: checked
/// robot by robot against the clipping oracle.
#[test]
fn sensors_and_radio_do_not_see_through_obstacles() {
    let mut robots = String::from("Robot(id: 0, radius: 1.0, at: (0.0, 0.0), algorithm: Idle),");
    let mut at = Vec::new();
    for k in 0..36 {
        let a = f64::from(k) * 10.0_f64.to_radians() + 0.05;
        let d = 40.0 + 30.0 * f64::from(k % 5);
        let p = (d * a.cos(), d * a.sin());
        // Born points clear of the box and the pillar.
        let to_box = (30.0 - p.0)
            .max(p.0 - 45.0)
            .max(0.0)
            .hypot((-25.0 - p.1).max(p.1 - 35.0).max(0.0));
        if to_box < 2.0 || (p.0 + 20.0).hypot(p.1 - 40.0) < 14.0 {
            continue;
        }
        at.push(p);
        robots.push_str(&format!(
            "Robot(id: {}, radius: 1.0, at: ({}, {}), algorithm: Idle),",
            at.len(),
            p.0,
            p.1
        ));
    }
    let text = format!(
        "Scenario(seed: 1, until: 10.0, world: (size: Infinite),
           network: Radio(range: 1000.0, over: Reliable(delay: 1.0), line_of_sight: true),
           obstacles: [Rect(min: (30.0, -25.0), max: (45.0, 35.0)), Circle(center: (-20.0, 40.0), radius: 12.0)],
           robots: [{robots}])"
    );
    let out = run(built(&text, Some(Box::new(Looker))));
    let visible: Vec<u32> = at
        .iter()
        .enumerate()
        .filter(|(_, p)| {
            !crosses(
                (0.0, 0.0),
                **p,
                (30.0, -25.0),
                (45.0, 35.0),
                (-20.0, 40.0),
                12.0,
            )
        })
        .map(|(k, _)| k as u32 + 1)
        .collect();
    assert!(
        visible.len() >= 10 && visible.len() <= 30,
        "{} visible: a weak setting",
        visible.len()
    );
    assert_eq!(
        crate::common::log_texts(&out),
        [
            format!("view {visible:?}"),
            format!("proximity {visible:?}")
        ]
    );
    let mut received: Vec<u32> = out
        .records
        .iter()
        .filter_map(|r| match r.obs {
            Observation::Receive { robot, .. } => Some(robot),
            _ => None,
        })
        .collect();
    received.sort_unstable();
    assert_eq!(received, visible);
}

/// Drives east into a wall with its contact sensor on, and logs the interrupt.
#[derive(Debug)]
struct Bumper;

impl nekosim::Algorithm for Bumper {
    fn name(&self) -> &str {
        "Bumper"
    }
    fn run(&self, robot: nekosim::robot::Robot) -> nekosim::robot::AlgorithmFuture {
        Box::pin(async move {
            robot.activate_contact().await;
            robot.forward(100.0, 2.0).await;
            let notice = robot.next_notice().await;
            robot.log(format!("{:.6} {notice:?}", robot.now()));
        })
    }
}

/// The contact sensor fires when its robot touches an obstacle, at the contact instant.
#[test]
fn the_contact_sensor_fires_on_an_obstacle() {
    let out = run(built(
        "Scenario(seed: 1, until: 100.0, world: (size: Infinite),
           obstacles: [Segment(from: (30.0, -10.0), to: (30.0, 10.0))],
           robots: [Robot(id: 0, radius: 2.0, at: (0.0, 0.0), angle: 0.0, algorithm: Idle)])",
        Some(Box::new(Bumper)),
    ));
    let replies: Vec<(f64, String)> = out
        .records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::SensorReply {
                value,
                interrupt: true,
                ..
            } => Some((r.t, value.text())),
            _ => None,
        })
        .collect();
    // Contact when the centre reaches x = 28 at 2 units/s.
    assert_eq!(replies.len(), 1, "{replies:?}");
    assert!((replies[0].0 - 14.0).abs() < 1e-9, "{replies:?}");
    assert_eq!(replies[0].1, "contact obstacle:0");
}

/// The Neko log lists the obstacles first and names the obstacle a robot collided with, as the
/// trace does.
#[test]
fn the_log_lists_obstacles_and_names_them_in_collisions() {
    let dir = tempfile::tempdir().unwrap();
    let (log, trace) = (dir.path().join("o.log"), dir.path().join("o.jsonl"));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .args([
            "run",
            "examples/scenarios/obstacles.ron",
            "--quiet",
            "--log",
        ])
        .arg(&log)
        .arg("--trace")
        .arg(&trace)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0));
    let log = std::fs::read_to_string(log).unwrap();
    let head: Vec<&str> = log.lines().take(5).collect();
    assert_eq!(
        head[..4],
        [
            "0.000 Obstacle: 0 | Segment | [100.000,600.000] [500.000,700.000]",
            "0.000 Obstacle: 1 | Rect | [300.000,300.000] [450.000,380.000]",
            "0.000 Obstacle: 2 | Polygon | [550.000,100.000] [700.000,150.000] [600.000,260.000]",
            "0.000 Obstacle: 3 | Circle | [180.000,250.000] radius 60.000",
        ]
    );
    assert!(head[4].contains(" Born: "));
    let trace = std::fs::read_to_string(trace).unwrap();
    for k in 0..4 {
        let name = format!("obstacle:{k}");
        let in_trace = trace
            .lines()
            .filter(|l| {
                l.contains("\"kind\":\"motion_finish\"")
                    && l.contains(&format!("\"other\":\"{name}\""))
            })
            .count();
        let in_log = log.matches(&format!("Collided_MoveTo({name})")).count();
        assert_eq!(in_log, in_trace, "{name}");
        assert!(in_trace > 0, "nobody touched {name}");
    }
}
