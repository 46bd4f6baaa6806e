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

/// `nekosim run` of 600,000 robots moving at random (the seed's density), writing a trace and
/// a log into `dir`, with its output piped.
#[cfg(unix)]
fn large_run(dir: &std::path::Path) -> std::process::Child {
    std::process::Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .arg("run")
        .arg(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("examples/scenarios/random_movement.ron"),
        )
        .args(["--set", "robots[0].count=600000"])
        .args(["--set", "world.size.width=61968"])
        .args(["--set", "world.size.height=61968"])
        .args(["--until", "10"])
        .arg("--trace")
        .arg(dir.join("run.jsonl"))
        .arg("--log")
        .arg(dir.join("run.log"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

/// What a terminal's Ctrl-C sends.
#[cfg(unix)]
fn ctrl_c(child: &std::process::Child) {
    let kill = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
}

/// The names of the files in `dir`, sorted.
#[cfg(unix)]
fn names_in(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Ctrl-C while a large run sets up (its world, its robots' actors, the setup's records), after
/// the scenario is built and the outputs are opened, ends it within seconds, as documented
/// (docs/scenario.md): exit 130 before any event, the trace and the log complete for the run
/// up to there (a prefix of its setup records), and no temporary file left. Left alone, the
/// setup takes several times as long.
#[cfg(unix)]
#[test]
fn ctrl_c_while_a_large_run_sets_up_ends_it_within_seconds() {
    let dir = tempfile::tempdir().unwrap();
    let mut child = large_run(dir.path());
    // The outputs' temporary files appear once the scenario is built: the run sets up.
    let started = std::time::Instant::now();
    while !names_in(dir.path()).iter().any(|n| n.contains(".partial-")) {
        assert!(child.try_wait().unwrap().is_none(), "the run ended early");
        assert!(started.elapsed().as_secs() < 300, "the run never set up");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    ctrl_c(&child);
    let interrupted = std::time::Instant::now();
    let out = child.wait_with_output().unwrap();
    let took = interrupted.elapsed();
    let err = String::from_utf8_lossy(&out.stderr);
    let summary = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(took.as_secs_f64() < 5.0, "exited {took:?} after Ctrl-C");
    assert!(
        err.contains("interrupted at simulated time 0.000 s"),
        "{err}"
    );
    assert!(
        summary.contains(", events: 0,"),
        "an event was taken: {summary}"
    );
    assert_eq!(names_in(dir.path()), ["run.jsonl", "run.log"]);
    // Whole records, all of the setup at t = 0, and the log a line for each.
    let records: Vec<serde_json::Value> = std::fs::read_to_string(dir.path().join("run.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(
        records.iter().all(|r| r["t"] == 0.0),
        "{:?}",
        records.last()
    );
    assert!(records.len() < 600_000, "the setup was not cut");
    let log = std::fs::read_to_string(dir.path().join("run.log")).unwrap();
    assert!(log.is_empty() || log.ends_with('\n'));
    assert_eq!(
        log.lines().count(),
        records.len() - silent_arrivals(&records)
    );
}

/// Ctrl-C while the scenario is still built (the robots placed) ends the command at once with
/// exit 130 and writes nothing (docs/scenario.md).
#[cfg(unix)]
#[test]
fn ctrl_c_while_a_large_scenario_is_built_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let child = large_run(dir.path());
    // Placing 600,000 robots takes seconds: the interrupt comes while they are placed.
    std::thread::sleep(std::time::Duration::from_millis(1000));
    ctrl_c(&child);
    let interrupted = std::time::Instant::now();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(interrupted.elapsed().as_secs_f64() < 5.0);
    assert!(
        err.contains("interrupted while building the scenario: nothing was written"),
        "{err}"
    );
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(
        names_in(dir.path()).is_empty(),
        "{:?}",
        names_in(dir.path())
    );
}
