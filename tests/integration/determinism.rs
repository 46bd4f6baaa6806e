//! Same scenario + seed = the same events in the same order; different seeds differ; the
//! number of arbiters does not matter.

use nekosim::algorithm::{Gathering, RandomMovement};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use nekosim::scheduler::{Observers, RunOutput};
use nekosim::world::observation::Record;
use nekosim::world::virtual_world::RobotSpec;
use nekosim::{Algorithm, SimConfig};

use crate::common::*;

fn run_with(seed: u64, arbiters: usize) -> RunOutput {
    run_observed(seed, arbiters, Observers::default())
}

fn run_observed(seed: u64, arbiters: usize, observers: Observers) -> RunOutput {
    run_hosted(nekosim::run, seed, arbiters, observers)
}

/// The run hosted by `host` ([`nekosim::run`] or [`nekosim::run_then_exit`]).
fn run_hosted(
    host: fn(SimConfig) -> Result<RunOutput, nekosim::SimError>,
    seed: u64,
    arbiters: usize,
    observers: Observers,
) -> RunOutput {
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
    host(SimConfig {
        sensors: Default::default(),
        seed,
        until: 80.0,
        world: bounded(200.0, 200.0),
        robots,
        arbiters,
        record: true,
        observers,
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

/// `nekosim run` leaves its run to the process's exit instead of dropping a million actors
/// one by one ([`nekosim::run_then_exit`]): the same output as a run that is dropped, on one
/// arbiter and on three, and the observers, on which the command's outputs hang, are let go
/// when the run ends.
#[test]
fn a_run_left_to_the_exit_gives_the_same_output_and_lets_its_observers_go() {
    for arbiters in [1, 3] {
        let dropped = run_with(7, arbiters);
        let seen = std::rc::Rc::new(std::cell::Cell::new(0usize));
        let count = seen.clone();
        let observers = Observers {
            sink: Some(Box::new(move |_: &Record| count.set(count.get() + 1))),
            ..Default::default()
        };
        let left = run_hosted(nekosim::run_then_exit, 7, arbiters, observers);
        assert!(left.records.len() > 500);
        assert_eq!(text(&dropped.records), text(&left.records));
        assert_eq!(dropped.stats, left.stats);
        assert_eq!(seen.get(), left.records.len());
        assert_eq!(
            std::rc::Rc::strong_count(&seen),
            1,
            "the sink is dropped when the run ends"
        );
    }
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

/// A run stopped from outside (the user's Ctrl-C) is the beginning of the full run: the same
/// records up to the stop, flagged as interrupted, ending at the virtual time reached.
#[test]
fn a_stopped_run_is_a_prefix_of_the_full_run() {
    let full = run_with(7, 1);
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    let cut = run_observed(
        7,
        1,
        Observers {
            // Raised while the 300th record's event is processed.
            sink: Some(Box::new(move |r: &Record| {
                if r.seq == 300 {
                    flag.store(true, Ordering::Relaxed);
                }
            })),
            stop: Some(stop),
            ..Observers::default()
        },
    );
    assert!(cut.stats.interrupted && !full.stats.interrupted);
    assert!(cut.records.len() > 300 && cut.records.len() < full.records.len());
    assert_eq!(text(&cut.records), text(&full.records[..cut.records.len()]));
    let last = cut.records.last().unwrap();
    assert_eq!(cut.stats.end_time, last.t);
    assert!(cut.stats.end_time < full.stats.end_time);
}

/// A run's summary (its counts of messages, decisions, suspicions and crashes, its events and
/// collisions, its predicates' verdicts) is the same whether the run writes a trace, which
/// reads every record, or nothing, when the robots' step records are not even made.
#[test]
fn a_summary_does_not_depend_on_the_step_records_being_made() {
    use nekosim::runner::{self, RunOptions};
    use nekosim::scenario::{Overrides, Registry, Source};
    let dir = std::env::temp_dir().join(format!("nekosim-steps-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut files: Vec<std::path::PathBuf> = ["examples/scenarios", "examples/lcm"]
        .iter()
        .flat_map(|d| std::fs::read_dir(d).unwrap().map(|e| e.unwrap().path()))
        .filter(|p| p.extension().is_some_and(|x| x == "ron"))
        .collect();
    files.sort();
    assert!(files.len() > 30, "{files:?}");
    let until = Overrides {
        seed: None,
        until: Some(20.0),
    };
    for path in &files {
        let summary = |trace: Option<std::path::PathBuf>| {
            let built = Source::load(path)
                .unwrap()
                .build(until, &Registry::with_builtins())
                .unwrap();
            let opts = RunOptions {
                trace,
                ..RunOptions::default()
            };
            let mut s = runner::run(built, opts).unwrap();
            s.wall_seconds = 0.0;
            s
        };
        let quiet = summary(None);
        let traced = summary(Some(dir.join("trace.jsonl")));
        assert_eq!(quiet, traced, "{}", path.display());
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A sink that reads only what the summary counts gets no step record at all; the same run
/// observed in full gets them, and the same records otherwise, in the same order.
#[test]
fn a_summary_only_sink_gets_every_record_but_the_steps() {
    let seen = |summary_only: bool| {
        let got = Arc::new(std::sync::Mutex::new(Vec::new()));
        let into = got.clone();
        let robots: Vec<(RobotSpec, Box<dyn Algorithm>)> = (0..24)
            .map(|i| {
                let (x, y) = (20.0 + 25.0 * (i % 6) as f64, 20.0 + 30.0 * (i / 6) as f64);
                let alg: Box<dyn Algorithm> = Box::new(RandomMovement::default());
                (spec(x, y, 15.0 * i as f64, 4.0), alg)
            })
            .collect();
        nekosim::run(SimConfig {
            sensors: Default::default(),
            seed: 4,
            until: 80.0,
            world: bounded(200.0, 200.0),
            robots,
            arbiters: 1,
            // Only the sink reads the records.
            record: false,
            observers: Observers {
                sink: Some(Box::new(move |r: &Record| {
                    into.lock().unwrap().push(r.obs.clone())
                })),
                summary_only,
                ..Default::default()
            },
            comms: Default::default(),
        })
        .expect("run");
        let got = got.lock().unwrap().clone();
        got
    };
    let (all, summary) = (seen(false), seen(true));
    let steps = all.iter().filter(|o| o.is_step()).count();
    assert!(steps > 500, "{steps} step records");
    assert!(summary.iter().all(|o| !o.is_step()));
    let others: Vec<_> = all.into_iter().filter(|o| !o.is_step()).collect();
    assert!(others.len() > 20, "{} other records", others.len());
    assert_eq!(summary, others);
}
