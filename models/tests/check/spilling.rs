//! Spilling to disk against the search in memory. With a tiny spill threshold the visited set
//! and the frontier go to disk many times, within levels and between them; on every shipped
//! model (small configurations, on a network that reorders messages and on one that keeps
//! their order, with and without the reductions) and on broken variants, the spilled search
//! must give the same generated and unique states, the same depth, the same verdicts and, on
//! one thread, the very same counterexamples and witnesses as the search in memory, and the
//! unique states of stateright's own breadth-first search. A disk budget too small stops the
//! search cleanly, and no spill file is ever left.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use nekosim_models::spill::{Spill, Spilled};
use nekosim_models::{
    build, find, run, run_watched, CheckModel, Exploration, NetworkKind, Options, Outcome, Stopped,
    Watch,
};
use nekosim_protocols::consensus::ChandraToueg;
use nekosim_protocols::lamport::LamportAbcast;
use nekosim_protocols::rbroadcast::ReliableBroadcast;
use nekosim_protocols::{Layer, Pid, Stack};
use stateright::{Checker, Model};

use super::opts;

/// Remembers what the search said it spilled.
#[derive(Default)]
struct Told(Option<Spilled>);

impl Watch for Told {
    fn spilled(&mut self, so_far: &Spilled) {
        self.0 = Some(*so_far);
    }
}

/// An empty directory of this test's own.
fn scratch() -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "nekosim-spilling-test-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `model` searched as `how` says, spilling whenever `after` visited states are in memory,
/// with at most `max_disk` bytes of files; what it spilled; the spill directory is gone.
fn spilled(
    model: CheckModel,
    how: &Exploration,
    after: usize,
    max_disk: Option<u64>,
) -> (Outcome, Spilled) {
    let parent = scratch();
    let dir = parent.join("spill");
    let mut told = Told::default();
    let how = Exploration {
        spill: Some(Spill {
            dir: dir.clone(),
            after_states: Some(after),
            max_disk,
        }),
        ..how.clone()
    };
    let o = run_watched(model, how, &mut told);
    assert!(!dir.exists(), "the spill directory is left");
    std::fs::remove_dir(&parent).expect("nothing else is left either");
    (o, told.0.unwrap_or_default())
}

/// The same figures, verdicts and (on one thread) paths.
fn same(what: &str, memory: &Outcome, disk: &Outcome, threads: usize) {
    assert_eq!(disk.stopped, None, "{what}");
    assert_eq!(
        (disk.states, disk.unique_states, disk.max_depth),
        (memory.states, memory.unique_states, memory.max_depth),
        "{what}: states, unique states, depth"
    );
    for (a, b) in memory.verdicts.iter().zip(&disk.verdicts) {
        let name = format!("{what}: {}", a.name);
        assert_eq!(a.name, b.name);
        assert_eq!(a.holds, b.holds, "{name}");
        assert_eq!(a.path.is_some(), b.path.is_some(), "{name}");
        if threads == 1 {
            assert_eq!(
                a.path.clone().map(|p| p.into_actions()),
                b.path.clone().map(|p| p.into_actions()),
                "{name}: another path"
            );
        }
    }
}

/// What `tweak` makes of model `name` with `o`, searched in memory and spilled (every
/// `after` states) on `threads` threads, exploring on after a counterexample unless `first`;
/// the search in memory and what the spilled one spilled.
fn compare(
    name: &str,
    o: &Options,
    tweak: impl Fn(Pid, &mut Stack),
    (threads, first, after): (usize, bool, usize),
) -> (Outcome, Spilled) {
    let model = build(&find(name).unwrap().target(), o, tweak).expect("valid model");
    let how = Exploration {
        threads,
        first_counterexample: first,
        ..Exploration::default()
    };
    let memory = run(model.clone(), how.clone());
    let (disk, told) = spilled(model, &how, after, None);
    let what = format!("{name} {o:?} on {threads} threads, first {first}, every {after}");
    same(&what, &memory, &disk, threads);
    // A search cut short by its first counterexample may end before memory holds `after`.
    if memory.unique_states >= 4 * after {
        assert!(told.spills > 1, "{what}: spilled {told:?}");
        assert!(told.written > 0 && told.peak_bytes > 0, "{what}: {told:?}");
    }
    (memory, told)
}

fn on(network: NetworkKind, reduction: bool, o: Options) -> Options {
    Options {
        network,
        reduction,
        ..o
    }
}

fn no_timers(o: Options) -> Options {
    Options {
        timer_budget: 0,
        ..o
    }
}

#[test]
fn every_shipped_model_spilled_explores_what_it_explores_in_memory() {
    let crash = Options {
        crashes: 1,
        ..opts(3, 2)
    };
    let cases = [
        ("lamport-abcast", opts(3, 2)),
        ("sequencer-abcast", opts(3, 3)),
        ("consensus-abcast", no_timers(opts(3, 1))),
        ("ct-consensus", no_timers(opts(3, 3))),
        ("reliable-broadcast", opts(3, 3)),
        ("reliable-broadcast", crash),
    ];
    for (name, o) in cases {
        for network in [NetworkKind::Unordered, NetworkKind::Ordered] {
            for reduction in [true, false] {
                compare(
                    name,
                    &on(network, reduction, o.clone()),
                    |_, _| {},
                    (1, false, 40),
                );
            }
        }
    }
    // Two broadcasts of consensus-abcast, forgetting spent messages: 7,467 unique states
    // (docs/model-checking.md).
    let (memory, _) = compare(
        "consensus-abcast",
        &on(NetworkKind::Unordered, true, no_timers(opts(3, 2))),
        |_, _| {},
        (1, false, 300),
    );
    assert_eq!(memory.unique_states, 7_467);
}

/// The unique states of stateright's own breadth-first search of `name` with `o` (no
/// reduction).
fn stateright_unique(name: &str, o: &Options, tweak: impl Fn(Pid, &mut Stack)) -> usize {
    let model = build(&find(name).unwrap().target(), o, tweak).unwrap();
    model.checker().spawn_bfs().join().unique_state_count()
}

#[test]
fn spilled_searches_count_stateright_s_unique_states() {
    let cases = [
        (
            "lamport-abcast",
            on(NetworkKind::Unordered, false, opts(3, 2)),
        ),
        (
            "ct-consensus",
            on(NetworkKind::Ordered, false, no_timers(opts(3, 3))),
        ),
        (
            "consensus-abcast",
            on(NetworkKind::Unordered, false, no_timers(opts(3, 1))),
        ),
        (
            "reliable-broadcast",
            on(NetworkKind::Lossy, false, opts(3, 1)),
        ),
    ];
    for (name, o) in cases {
        let (memory, _) = compare(name, &o, |_, _| {}, (1, false, 100));
        assert_eq!(
            memory.unique_states,
            stateright_unique(name, &o, |_, _| {}),
            "{name} {o:?}"
        );
    }
}

#[test]
fn broken_variants_spilled_give_the_very_same_counterexamples() {
    let eager = |_: Pid, s: &mut Stack| s.layers[1] = Layer::new(LamportAbcast::eager());
    for network in [NetworkKind::Unordered, NetworkKind::Ordered] {
        for reduction in [true, false] {
            for first in [true, false] {
                let o = on(network, reduction, opts(3, 2));
                let (memory, _) = compare("lamport-abcast", &o, eager, (1, first, 30));
                assert!(!memory.verdict("total order").unwrap().holds, "{o:?}");
            }
        }
    }
    let without_relay =
        |_: Pid, s: &mut Stack| s.layers[0] = Layer::new(ReliableBroadcast::without_relay());
    let crash = Options {
        crashes: 1,
        ..opts(3, 1)
    };
    for network in [NetworkKind::Unordered, NetworkKind::Ordered] {
        let o = on(network, false, crash.clone());
        let (memory, _) = compare("reliable-broadcast", &o, without_relay, (1, false, 10));
        assert!(!memory.verdict("agreement").unwrap().holds, "{o:?}");
        assert_eq!(
            memory.unique_states,
            stateright_unique("reliable-broadcast", &o, without_relay)
        );
    }
    // Chandra-Toueg deciding on a minority, with false suspicions: a large space, searched to
    // its first counterexample.
    let minority = |_: Pid, s: &mut Stack| s.layers[1] = Layer::new(ChandraToueg::minority());
    let o = on(NetworkKind::Ordered, true, opts(3, 2));
    let (memory, _) = compare("ct-consensus", &o, minority, (1, true, 200));
    assert!(!memory.verdict("agreement").unwrap().holds);
}

#[test]
fn two_threads_spilled_count_what_one_thread_counts_in_memory() {
    for (network, reduction) in [
        (NetworkKind::Ordered, true),
        (NetworkKind::Unordered, true),
        (NetworkKind::Unordered, false),
    ] {
        let o = on(network, reduction, opts(3, 3));
        compare("reliable-broadcast", &o, |_, _| {}, (2, false, 60));
    }
}

#[test]
fn a_disk_budget_too_small_stops_the_search_cleanly() {
    let o = on(NetworkKind::Unordered, false, opts(3, 2));
    let model = build(&find("lamport-abcast").unwrap().target(), &o, |_, _| {}).unwrap();
    let whole = run(model.clone(), Exploration::default());
    let (disk, told) = spilled(model, &Exploration::default(), 200, Some(20_000));
    assert_eq!(disk.stopped, Some(Stopped::Disk { limit: 20_000 }));
    assert!(told.spills >= 1 && told.peak_bytes <= 20_000, "{told:?}");
    assert!(
        disk.unique_states < whole.unique_states,
        "{} of {}",
        disk.unique_states,
        whole.unique_states
    );
    // What was explored is settled: no counterexample, nothing failing.
    assert!(disk.verdicts.iter().all(|v| v.path.is_none() || v.holds));
}

#[test]
fn a_watcher_s_time_budget_stops_the_search_cleanly() {
    struct Late;
    impl Watch for Late {
        fn out_of_time(&self) -> Option<Duration> {
            Some(Duration::from_secs(60))
        }
    }
    let o = opts(3, 3);
    let model = build(&find("lamport-abcast").unwrap().target(), &o, |_, _| {}).unwrap();
    let o = run_watched(model.clone(), Exploration::default(), &mut Late);
    assert_eq!(
        o.stopped,
        Some(Stopped::Time {
            limit: Duration::from_secs(60)
        })
    );
    // 84,924 unique states when exhaustive (links in send order, partial-order reduction).
    assert!(o.unique_states < 84_924, "{}", o.unique_states);
    assert!(model.init_states().len() <= o.unique_states);
}
