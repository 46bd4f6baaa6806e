//! The search for Look-Compute-Move counterexamples beyond exhaustive checking: it finds a
//! seeded bug in an n-robot algorithm (one robot of three overshoots the centre of gravity,
//! leaving the others' hull), finds nothing for the correct algorithm within what it reports
//! as covered, and every schedule it finds replays exactly in the simulator through the
//! scripted adversary.

use std::sync::Arc;

use nekosim::config::Setting;
use nekosim::lcm::algorithms::{CentreOfGravity, NoConfig};
use nekosim::lcm::predicate::diameter;
use nekosim::lcm::record::LcmRecord;
use nekosim::lcm::search::{self, Goal, Limits, Problem};
use nekosim::lcm::settings::Movement;
use nekosim::lcm::{Decision, Lcm, LcmConfigured, LcmSettings, LookComputeMove, Synchrony, View};
use nekosim::protocols::FieldError;
use nekosim::scenario::{Overrides, Registry, Source};
use nekosim::world::geometry::Point;
use nekosim::world::observation::Observation;

/// The seeded bug: goes four times as far as the centre of gravity, past it.
#[derive(Clone, Copy, Debug)]
struct Overshoot;

impl LookComputeMove for Overshoot {
    fn compute(&self, view: &View) -> Decision {
        Decision::to(Point::from(view.centre_of_gravity().coords * 4.0))
    }
}

impl LcmConfigured for Overshoot {
    type Config = NoConfig;
    fn configure(_: NoConfig, _: &Setting) -> Result<Self, FieldError> {
        Ok(Self)
    }
}

const BORN: [(f64, f64); 3] = [(0.0, 0.0), (40.0, 10.0), (12.0, -31.0)];

fn settings() -> LcmSettings {
    LcmSettings {
        synchrony: Synchrony::Ssync,
        movement: Movement::NonRigid { delta: 1.0 },
        ..LcmSettings::default()
    }
}

fn problem(buggy: bool) -> Problem {
    let cog: Arc<dyn LookComputeMove> = Arc::new(CentreOfGravity);
    let first: Arc<dyn LookComputeMove> = if buggy {
        Arc::new(Overshoot)
    } else {
        cog.clone()
    };
    Problem {
        algorithms: vec![first, cog.clone(), cog],
        settings: Arc::new(settings()),
        seed: 11,
        start: BORN.iter().map(|&(x, y)| Point::new(x, y)).collect(),
    }
}

const MENU: [f64; 2] = [0.5, 1.0];

/// A search's limits of `max_rounds` rounds, never halted otherwise.
fn rounds(max_rounds: u64) -> Limits<'static> {
    Limits {
        max_rounds,
        halt: &|| false,
    }
}

/// The correct centre of gravity keeps every robot inside the others' hull: no schedule of
/// the menu to depth 3 makes the diameter grow, and the search says it covered them all.
#[test]
fn the_correct_centre_of_gravity_never_grows_its_diameter() {
    let out = search::bounded(
        &problem(false),
        &MENU,
        3,
        &[Goal::DiameterNeverGrows],
        rounds(1_000_000),
    );
    assert_eq!(out.violation, None);
    assert!(out.coverage.complete);
    // Seven subsets of three robots, each moving robot with two stops: 26 rounds a level.
    assert_eq!(out.coverage.stops, MENU.to_vec());
    assert!(out.coverage.rounds >= 26, "{:?}", out.coverage);
}

/// Both searches find the overshooting robot, and the bounded one finds it in one round.
#[test]
fn the_search_finds_the_overshooting_robot_and_the_simulator_replays_it() {
    let p = problem(true);
    let found = search::bounded(&p, &MENU, 3, &[Goal::DiameterNeverGrows], rounds(1_000_000))
        .violation
        .expect("a violation");
    assert_eq!(found.goal, Goal::DiameterNeverGrows);
    assert_eq!(found.schedule.0.len(), 1, "{found:?}");
    assert!(found.schedule.0[0].active.contains(&0), "{found:?}");
    let random = search::random(&p, &MENU, 4, 50, 2, 7, &[Goal::DiameterNeverGrows], &|| {
        false
    });
    assert!(random.violation.is_some(), "{:?}", random.coverage);

    // The replay: the same robots, the schedule as a scripted adversary.
    let born: Vec<String> = BORN
        .iter()
        .enumerate()
        .map(|(i, (x, y))| {
            let alg = if i == 0 {
                "Overshoot()"
            } else {
                "CentreOfGravity()"
            };
            format!("Robot(id: {i}, radius: 0.5, at: ({x:?}, {y:?}), algorithm: {alg})")
        })
        .collect();
    let text = format!(
        "Scenario(seed: 11, until: 10.0, world: (size: Infinite, ghost_mode: true),
           lcm: (synchrony: Ssync, movement: NonRigid(delta: 1.0), adversary: {}),
           robots: [{}])",
        found.schedule.scripted(1.0),
        born.join(", ")
    );
    let mut registry = Registry::with_builtins();
    registry.algorithm::<Lcm<Overshoot>>("Overshoot");
    let built = Source::parse("replay.ron", &text)
        .expect("parses")
        .build(Overrides::default(), &registry)
        .expect("builds");
    let records = nekosim::run(built.into_config(true)).expect("runs").records;
    let mut end: Vec<Point> = BORN.iter().map(|&(x, y)| Point::new(x, y)).collect();
    for r in &records {
        if let Observation::Lcm(LcmRecord::Wait { robot, at, .. }) = &r.obs {
            end[*robot as usize] = *at;
        }
    }
    // Exactly where the search says, and the violation shows: the diameter grew.
    assert_eq!(end, found.positions);
    let start: Vec<Point> = BORN.iter().map(|&(x, y)| Point::new(x, y)).collect();
    assert!(diameter(&end) > diameter(&start));
}

/// Every round the search plays is the simulator's round: a longer schedule of the correct
/// algorithm, with non-rigid stops, replays position for position.
#[test]
fn a_searched_schedule_replays_exactly() {
    let p = problem(false);
    let out = search::random(&p, &MENU, 5, 1, 1, 3, &[], &|| false);
    assert_eq!(out.violation, None);
    assert_eq!(out.coverage.rounds, 5);
    // Rebuild the run's schedule the way the search drew it: a random run with no goals
    // reports none, so search again with a goal that breaks at the end.
    let last = search::random(
        &p,
        &MENU,
        5,
        1,
        1,
        3,
        &[Goal::GatheredWithin { cycles: 0 }],
        &|| false,
    )
    .violation
    .expect("not gathered at once");
    let schedule = last.schedule;
    let expected = search::positions(&p, &schedule);
    let born: Vec<String> = BORN
        .iter()
        .map(|(x, y)| format!("({x:?}, {y:?})"))
        .collect();
    let text = format!(
        "Scenario(seed: 11, until: 10.0, world: (size: Infinite, ghost_mode: true),
           lcm: (synchrony: Ssync, movement: NonRigid(delta: 1.0), adversary: {}),
           robots: [Group(count: 3, radius: 0.5, born: Points([{}]), algorithm: CentreOfGravity())])",
        schedule.scripted(1.0),
        born.join(", ")
    );
    let built = Source::parse("replay.ron", &text)
        .expect("parses")
        .build(Overrides::default(), &Registry::with_builtins())
        .expect("builds");
    let records = nekosim::run(built.into_config(true)).expect("runs").records;
    let mut at: Vec<Point> = BORN.iter().map(|&(x, y)| Point::new(x, y)).collect();
    let mut rounds: Vec<Vec<Point>> = Vec::new();
    let mut round = 0;
    for r in &records {
        // A round ends at its three quarters; positions are read at the next round's start.
        while r.t >= round as f64 + 1.0 && rounds.len() < expected.len() {
            rounds.push(at.clone());
            round += 1;
        }
        if let Observation::Lcm(LcmRecord::Wait { robot, at: p, .. }) = &r.obs {
            at[*robot as usize] = *p;
        }
    }
    while rounds.len() < expected.len() {
        rounds.push(at.clone());
    }
    assert_eq!(rounds, expected);
}

/// `nekosim check` on a scenario of three robots that compute the centre of gravity: the
/// search finds two robots merging before the three gather (both activated alone, both go to
/// the same centre), prints the schedule, exits 1, and `--trace` holds the replayed run in
/// which the two stand on one point and the third elsewhere. The diameter never grows on
/// any schedule of the menu (exit 0, stating the depth covered), and the random search finds
/// the merge too.
#[test]
fn the_check_command_searches_and_replays() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("three.ron");
    std::fs::write(
        &scenario,
        "Scenario(seed: 11, until: 10.0, world: (size: Infinite, ghost_mode: true),
           lcm: (synchrony: Ssync, movement: NonRigid(delta: 1.0)),
           robots: [Group(count: 3, radius: 0.5,
                          born: Points([(0.0, 0.0), (40.0, 10.0), (12.0, -31.0)]),
                          algorithm: CentreOfGravity())])",
    )
    .unwrap();
    let trace = dir.path().join("cex.jsonl");
    let check = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_nekosim"))
            .arg("check")
            .arg(&scenario)
            .args(args)
            .output()
            .expect("runs")
    };
    let out = check(&["--depth", "2", "--trace", trace.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(text.contains("collision-free: fails"), "{text}");
    assert!(text.contains("while the robots are not gathered"), "{text}");
    // The replay: after its round, exactly two robots share a point.
    let mut end = std::collections::BTreeMap::new();
    for line in std::fs::read_to_string(&trace).unwrap().lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        if v["kind"] == "wait" {
            end.insert(
                v["robot"].as_u64().unwrap(),
                (v["at"][0].as_f64().unwrap(), v["at"][1].as_f64().unwrap()),
            );
        }
    }
    assert_eq!(end.len(), 2, "{end:?}");
    let points: Vec<_> = end.values().collect();
    assert_eq!(points[0], points[1]);

    let out = check(&["--depth", "2", "--goal", "diameter-never-grows"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(
        text.contains("holds on every schedule searched (depth 2)"),
        "{text}"
    );

    let out = check(&[
        "--depth",
        "3",
        "--strategy",
        "simulation",
        "--max-states",
        "20",
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(text.contains("random runs"), "{text}");

    let out = check(&["--goal", "gathered-within:x"]);
    assert_eq!(out.status.code(), Some(2));
}

/// A search asks its halt before its first round and every `POLL_EVERY` rounds after, and
/// stops when told: a halt that says stop at its second question ends the bounded search
/// after exactly `POLL_EVERY` rounds, incomplete, and the random one before its next run.
#[test]
fn a_search_stops_when_its_halt_says_so() {
    let p = problem(false);
    let asked = std::cell::Cell::new(0);
    let halt = || {
        asked.set(asked.get() + 1);
        asked.get() >= 2
    };
    let limits = Limits {
        max_rounds: u64::MAX,
        halt: &halt,
    };
    let out = search::bounded(&p, &MENU, 8, &[Goal::DiameterNeverGrows], limits);
    assert_eq!(out.violation, None);
    assert!(
        out.coverage.halted && !out.coverage.complete,
        "{:?}",
        out.coverage
    );
    assert_eq!(out.coverage.rounds, search::POLL_EVERY);
    assert_eq!(asked.get(), 2);
    asked.set(0);
    let out = search::random(
        &p,
        &MENU,
        5,
        10_000,
        2,
        1,
        &[Goal::DiameterNeverGrows],
        &halt,
    );
    assert_eq!(out.violation, None);
    assert!(out.coverage.halted, "{:?}", out.coverage);
    // Runs of 5 rounds: the second question comes at the first run that starts at or after
    // round POLL_EVERY.
    assert_eq!(out.coverage.rounds, search::POLL_EVERY.next_multiple_of(5));
    assert_eq!(out.coverage.runs, out.coverage.rounds / 5);
}

/// `nekosim check` on a search honours its budgets: a memory budget the process is already
/// above stops the bounded and the random search before their first round (exit 3, saying
/// what stopped them and what they covered), and Ctrl-C stops a deep bounded search
/// (exit 130) with what it covered. A budget of 1 GiB keeps a lost signal from running the
/// test out of memory: it would end in exit 3, not 130.
#[test]
fn the_search_stops_at_its_memory_budget_and_at_ctrl_c() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("three.ron");
    std::fs::write(
        &scenario,
        "Scenario(seed: 11, until: 10.0, world: (size: Infinite, ghost_mode: true),
           lcm: (synchrony: Ssync, movement: NonRigid(delta: 1.0)),
           robots: [Group(count: 3, radius: 0.5,
                          born: Points([(0.0, 0.0), (40.0, 10.0), (12.0, -31.0)]),
                          algorithm: CentreOfGravity())])",
    )
    .unwrap();
    let path = scenario.to_str().unwrap();
    for strategy in [&[][..], &["--strategy", "simulation"][..]] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_nekosim"))
            .args(["check", path, "--max-memory", "1KiB"])
            .args(strategy)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert_eq!(out.status.code(), Some(3), "{strategy:?}: {text}");
        assert!(text.contains(" 0 rounds played"), "{strategy:?}: {text}");
        assert!(
            text.contains("stopped by the memory budget (resident ")
                && text.contains(" of 1.0 KiB) before the search was done"),
            "{strategy:?}: {text}"
        );
    }
    let (code, text) = crate::lcm_check::interrupted(
        &[
            path,
            "--goal",
            "diameter-never-grows",
            "--depth",
            "12",
            "--max-memory",
            "1GiB",
        ],
        "searching 3 robots",
        std::time::Duration::from_millis(500),
    );
    assert_eq!(code, Some(130), "{text}");
    assert!(
        text.contains("stopped by Ctrl-C before the search was done"),
        "{text}"
    );
    assert!(text.contains("(stopped within the next depth)"), "{text}");
}
