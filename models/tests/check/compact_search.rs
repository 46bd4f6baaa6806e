//! The compact breadth-first search against stateright's own breadth-first checker on the
//! same models: the same generated, unique and depth figures, the same verdicts and
//! counterexamples of the same length, on every network kind, with crashes, and on two
//! threads (without partial-order reduction, which stateright does not have).

use nekosim_models::{build, find, run, Exploration, NetworkKind, Options};
use stateright::{Checker, Expectation, Model};

fn compare(name: &str, opts: &Options, threads: usize) {
    let def = find(name).expect("registered");
    let opts = &Options {
        reduction: false,
        ..opts.clone()
    };
    let model = || build(&def.target(), opts, |_, _| {}).expect("valid");
    let ours = run(
        model(),
        Exploration {
            threads,
            ..Exploration::default()
        },
    );
    let theirs = model().checker().spawn_bfs().join();
    let what = format!("{name} {opts:?} on {threads} threads");
    assert_eq!(ours.unique_states, theirs.unique_state_count(), "{what}");
    assert_eq!(ours.states, theirs.state_count(), "{what}");
    assert_eq!(ours.max_depth, theirs.max_depth(), "{what}");
    let mut found = theirs.discoveries();
    for (v, p) in ours.verdicts.iter().zip(model().properties()) {
        assert_eq!(v.name, p.name);
        let path = found.remove(p.name);
        assert_eq!(v.path.is_some(), path.is_some(), "{what}: {}", v.name);
        // On one thread both are breadth-first in the same order, so the first discovery
        // is the same state; on two, both are shortest for an `always` property.
        if threads == 1 || v.expectation == Expectation::Always {
            assert_eq!(
                v.path.as_ref().map(|p| p.clone().into_actions().len()),
                path.map(|p| p.into_actions().len()),
                "{what}: {}",
                v.name
            );
        }
    }
}

#[test]
fn lamport_on_an_unordered_network() {
    compare("lamport-abcast", &Options::default(), 1);
}

#[test]
fn ct_consensus_on_an_ordered_network_and_two_threads() {
    let opts = Options {
        network: NetworkKind::Ordered,
        timer_budget: 0,
        ..Options::default()
    };
    compare("ct-consensus", &opts, 1);
    compare("ct-consensus", &opts, 2);
}

#[test]
fn reliable_broadcast_on_a_lossy_network_with_a_counterexample() {
    let opts = Options {
        requests: 1,
        network: NetworkKind::Lossy,
        ..Options::default()
    };
    compare("reliable-broadcast", &opts, 1);
}

#[test]
fn sequencer_with_a_crash() {
    let opts = Options {
        crashes: 1,
        ..Options::default()
    };
    compare("sequencer-abcast", &opts, 1);
    compare("sequencer-abcast", &opts, 2);
}
