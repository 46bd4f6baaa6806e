//! The n-robot Look-Compute-Move algorithms against closed forms computed apart from the
//! engine: the centre of gravity under FSYNC (one round to the centroid, rigid; a contraction
//! by the stop fraction each round, non-rigid), and the predicates each shipped example
//! reaches.

use nekosim::lcm::record::LcmRecord;
use nekosim::scenario::{Overrides, Registry, Source};
use nekosim::world::geometry::Point;
use nekosim::world::observation::{Observation, Record};

/// Runs the scenario `text` in process and keeps its records.
fn records(text: &str) -> Vec<Record> {
    let source = Source::parse("lcm.ron", text).expect("parses");
    let built = source
        .build(Overrides::default(), &Registry::with_builtins())
        .expect("builds");
    nekosim::run(built.into_config(true)).expect("runs").records
}

/// Where each robot waits after each of its cycles: `(robot, cycle, position)`.
fn waits(records: &[Record]) -> Vec<(u32, u64, Point)> {
    records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::Lcm(LcmRecord::Wait { robot, cycle, at }) => Some((*robot, *cycle, *at)),
            _ => None,
        })
        .collect()
}

const BORN: [(f64, f64); 5] = [
    (0.0, 0.0),
    (40.0, 10.0),
    (-17.5, 33.25),
    (12.0, -41.0),
    (77.0, 61.0),
];

fn born_points() -> String {
    let pts: Vec<String> = BORN
        .iter()
        .map(|(x, y)| format!("({x:?}, {y:?})"))
        .collect();
    pts.join(", ")
}

fn centroid() -> Point {
    let (sx, sy) = BORN
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    Point::new(sx / BORN.len() as f64, sy / BORN.len() as f64)
}

/// Under FSYNC with rigid moves every robot computes the centroid of all five in its own
/// frame, and all five stand on it, on equal coordinates, after the first round.
#[test]
fn fsync_centre_of_gravity_gathers_in_one_round() {
    let text = format!(
        "Scenario(seed: 7, until: 3.0, world: (size: Infinite, ghost_mode: true),
           lcm: (synchrony: Fsync),
           robots: [Group(count: 5, radius: 0.5, born: Points([{}]),
                          algorithm: CentreOfGravity())])",
        born_points()
    );
    let records = records(&text);
    let first: Vec<Point> = waits(&records)
        .into_iter()
        .filter(|w| w.1 == 0)
        .map(|w| w.2)
        .collect();
    assert_eq!(first.len(), 5);
    let c = centroid();
    for p in &first {
        assert!((p - c).norm() < 1e-9, "{p} against the centroid {c}");
        assert_eq!(*p, first[0], "robots on one point, equal coordinates");
    }
    // The frames differed: the robots computed the centroid in frames the adversary chose.
    let frames: Vec<f64> = records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::Lcm(LcmRecord::Look {
                frame, cycle: 0, ..
            }) => Some(frame.rotation),
            _ => None,
        })
        .collect();
    assert_eq!(frames.len(), 5);
    assert!(frames.windows(2).any(|w| w[0] != w[1]), "{frames:?}");
}

/// A scripted FSYNC adversary that stops every move halfway: the centroid stays put, and
/// every robot's offset from it halves each round, `(p0 - c) / 2^k` after k rounds.
#[test]
fn centre_of_gravity_cut_short_contracts_by_the_stop_fraction() {
    let rounds = 8;
    let mut acts = Vec::new();
    for k in 0..rounds {
        for r in 0..5 {
            acts.push(format!(
                "(robot: {r}, look: {k}.0, compute: {k}.25, move: {k}.75, stop: Some(0.5))"
            ));
        }
    }
    let text = format!(
        "Scenario(seed: 2, until: {rounds}.0, world: (size: Infinite, ghost_mode: true),
           lcm: (synchrony: Fsync, movement: NonRigid(delta: 1e-6),
                 adversary: Scripted([{}])),
           robots: [Group(count: 5, radius: 0.5, born: Points([{}]),
                          algorithm: CentreOfGravity())])",
        acts.join(", "),
        born_points()
    );
    let c = centroid();
    let waits = waits(&records(&text));
    assert_eq!(waits.len(), 5 * rounds);
    for (robot, cycle, at) in waits {
        let (x, y) = BORN[robot as usize];
        let expected = c + (Point::new(x, y) - c) / 2f64.powi(cycle as i32 + 1);
        assert!(
            (at - expected).norm() < 1e-9 * (1.0 + (expected - c).norm()),
            "robot {robot} after round {cycle}: {at} against {expected}"
        );
    }
}

/// Runs a shipped example with the command line and returns its printed summary.
fn summary(example: &str) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .args(["run", &format!("examples/lcm/{example}.ron")])
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Each n-robot example reaches what it is for, and keeps it to the end.
#[test]
fn the_n_robot_examples_reach_their_predicates() {
    for (example, predicate) in [
        ("cog", "converged(epsilon 1)"),
        ("ando", "converged(epsilon 1)"),
        ("gather_multiplicity", "gathered"),
        ("formation_circle", "uniform circle(epsilon 0.01)"),
        ("formation_circle", "collision-free"),
    ] {
        let s = summary(example);
        let line = s
            .lines()
            .find(|l| l.starts_with(&format!("{predicate}:")))
            .unwrap_or_else(|| panic!("{example}: no {predicate} line in\n{s}"));
        assert!(line.contains("to the end"), "{example}: {line}");
    }
}

/// A crashed robot stops where it is, in mid-move if it was moving, and acts no more; the
/// others keep seeing it there, and converge onto it: the centre of gravity of robots around a
/// point that never moves ends on that point.
#[test]
fn a_crashed_robot_stays_visible_where_it_stopped() {
    let text = format!(
        "Scenario(seed: 4, until: 40.0, world: (size: Infinite, ghost_mode: true),
           lcm: (synchrony: Async, predicates: [Converged(epsilon: 0.01)]),
           faults: [Crash(robot: 2, at: 1.3)],
           robots: [Group(count: 5, radius: 0.5, born: Points([{}]),
                          algorithm: CentreOfGravity())])",
        born_points()
    );
    let records = records(&text);
    let crash = records
        .iter()
        .find_map(|r| match &r.obs {
            Observation::Crash { robot: 2, state } => Some((r.t, state.pos)),
            _ => None,
        })
        .expect("robot 2 crashes");
    assert_eq!(crash.0, 1.3);
    // Robot 2 acts no more after its crash.
    assert!(records
        .iter()
        .filter(|r| r.t > crash.0)
        .all(|r| !matches!(&r.obs, Observation::Lcm(l) if l.robot() == 2)));
    // Every later Look sees it where it crashed.
    let mut looks = 0;
    for r in records.iter().filter(|r| r.t > crash.0) {
        if let Observation::Lcm(LcmRecord::Look { seen, .. }) = &r.obs {
            let it = seen.iter().find(|s| s.robot == 2).expect("robot 2 seen");
            assert_eq!(it.at, crash.1, "at {}", r.t);
            looks += 1;
        }
    }
    assert!(looks > 20, "{looks} looks after the crash");
    // The others end next to it.
    let last: std::collections::BTreeMap<u32, Point> = waits(&records)
        .into_iter()
        .map(|(robot, _, at)| (robot, at))
        .collect();
    for (robot, at) in last {
        if robot != 2 {
            assert!(
                (at - crash.1).norm() < 0.05,
                "robot {robot} ends at {at}, robot 2 at {}",
                crash.1
            );
        }
    }
}

/// Under `AsyncMoveAtomic` and `AsyncCmAtomic` no Look sees a robot in mid-move: the random
/// adversary keeps Looks and moves in different slots (and, under `AsyncCmAtomic`, each
/// Compute's end with its Move). The robots still act asynchronously (their Looks are at
/// different instants) and converge.
#[test]
fn atomic_moves_are_never_seen_under_way() {
    for synchrony in ["AsyncMoveAtomic", "AsyncCmAtomic"] {
        let text = format!(
            "Scenario(seed: 6, until: 30.0, world: (size: Infinite, ghost_mode: true),
               lcm: (synchrony: {synchrony}, movement: NonRigid(delta: 2.0),
                     predicates: [Converged(epsilon: 1.0)]),
               robots: [Group(count: 5, radius: 0.5, born: Points([{}]),
                              algorithm: CentreOfGravity())])",
            born_points()
        );
        let records = records(&text);
        let mut moves: Vec<(u32, f64, f64)> = Vec::new();
        let mut looks: Vec<(u32, f64)> = Vec::new();
        for r in &records {
            match &r.obs {
                Observation::Lcm(LcmRecord::Move { robot, end, .. }) => {
                    moves.push((*robot, r.t, *end))
                }
                Observation::Lcm(LcmRecord::Look { robot, .. }) => looks.push((*robot, r.t)),
                _ => {}
            }
        }
        assert!(moves.len() > 20 && looks.len() > 40, "{synchrony}");
        for &(robot, t) in &looks {
            for &(other, start, end) in &moves {
                assert!(
                    other == robot || !(start < t && t < end),
                    "{synchrony}: robot {robot} looked at {t} while robot {other} moved from {start} to {end}"
                );
            }
        }
        let distinct: std::collections::BTreeSet<u64> =
            looks.iter().map(|(_, t)| t.to_bits()).collect();
        assert_eq!(
            distinct.len(),
            looks.len(),
            "{synchrony}: Looks at one instant"
        );
        // Looks in even half-second slots; under AsyncCmAtomic each Compute ends in the odd
        // slot its Move fills.
        let slot = |t: f64| (t / 0.5).floor() as i64;
        for r in &records {
            if let Observation::Lcm(LcmRecord::Activate {
                look,
                compute_end,
                move_end,
                ..
            }) = &r.obs
            {
                assert_eq!(slot(*look) % 2, 0, "{synchrony}: a Look at {look}");
                if synchrony == "AsyncCmAtomic" {
                    assert_eq!(slot(*compute_end) % 2, 1, "{synchrony}: {compute_end}");
                    assert!(*move_end <= (slot(*compute_end) + 1) as f64 * 0.5);
                }
            }
        }
        let last = waits(&records);
        let end: Vec<Point> = (0..5u32)
            .map(|r| last.iter().rev().find(|w| w.0 == r).map(|w| w.2).unwrap())
            .collect();
        assert!(
            nekosim::lcm::predicate::diameter(&end) < 1.0,
            "{synchrony}: diameter {}",
            nekosim::lcm::predicate::diameter(&end)
        );
    }
}
