//! Partial-order reduction against the full search. On every shipped model and on the
//! deliberately broken variants, on both reliable networks: the same verdict for every
//! property, a counterexample (or witness) exactly when the full search has one, and each of
//! them a real path of the model whose last state is a discovery of its property (its length
//! may differ: the reduced search finds a shortest path of the reduced space). Against brute
//! force: every state at rest of the full space is reached. The reduction factor of each
//! model is pinned.

use nekosim_models::compact::{CompactBfs, Reductions};
use nekosim_models::model::invisible;
use nekosim_models::rest::at_rest;
use nekosim_models::{
    build, find, run, CheckModel, Exploration, NetworkKind, Options, Outcome, State,
};
use nekosim_protocols::consensus::ChandraToueg;
use nekosim_protocols::lamport::LamportAbcast;
use nekosim_protocols::rbroadcast::ReliableBroadcast;
use nekosim_protocols::sequencer::FixedSequencer;
use nekosim_protocols::{Layer, Pid, Stack};
use stateright::{Checker, Expectation, Model, StateRecorder};

use super::opts;

/// A model of `name` with `o` after `tweak`, and the searches of it with and without the
/// reduction, each exploring on after a counterexample to settle every property.
fn both(
    name: &str,
    o: &Options,
    tweak: impl Fn(Pid, &mut Stack) + Copy,
) -> (CheckModel, Outcome, Outcome) {
    searched(name, o, tweak, false)
}

/// [`both`], stopping at the first counterexample when `first`.
fn searched(
    name: &str,
    o: &Options,
    tweak: impl Fn(Pid, &mut Stack) + Copy,
    first: bool,
) -> (CheckModel, Outcome, Outcome) {
    let def = find(name).expect("registered model");
    let with = |reduction| {
        let o = Options {
            reduction,
            ..o.clone()
        };
        build(&def.target(), &o, tweak).expect("valid model")
    };
    let search = |m: CheckModel| {
        run(
            m,
            Exploration {
                first_counterexample: first,
                ..Exploration::default()
            },
        )
    };
    let model = with(true);
    let on = search(model.clone());
    let off = search(with(false));
    (model, on, off)
}

/// The same verdicts; every path of `on` is a path of `model` ending in a discovery, no
/// shorter than the full search's.
fn same_verdicts(what: &str, model: &CheckModel, on: &Outcome, off: &Outcome) {
    assert!(on.stopped.is_none() && off.stopped.is_none(), "{what}");
    assert_eq!(on.verdicts.len(), off.verdicts.len(), "{what}");
    for (a, b) in on.verdicts.iter().zip(&off.verdicts) {
        let name = format!("{what}: {}", a.name);
        assert_eq!(a.name, b.name);
        assert_eq!(a.holds, b.holds, "{name}");
        assert_eq!(a.path.is_some(), b.path.is_some(), "{name}");
        if let (Some(p), Some(q)) = (&a.path, &b.path) {
            let (p, q) = (p.clone().into_actions(), q.clone().into_actions());
            assert!(p.len() >= q.len(), "{name}: shorter than the shortest");
        }
    }
    real_paths(what, model, on);
}

/// Every counterexample or witness of `o` is a path of `model`, inside it, whose last
/// state is a discovery of its property.
fn real_paths(what: &str, model: &CheckModel, o: &Outcome) {
    for (i, v) in o.verdicts.iter().enumerate() {
        let Some(path) = &v.path else { continue };
        let name = format!("{what}: {}", v.name);
        let mut state = model.init_states().remove(0);
        for action in path.clone().into_actions() {
            state = model
                .next_state(&state, action)
                .unwrap_or_else(|| panic!("{name}: not a step of the model"));
            assert!(model.within_boundary(&state), "{name}: outside the model");
        }
        let (expectation, condition) = &model.cfg.conditions[i];
        let holds = condition(model, &state);
        assert_eq!(holds, *expectation == Expectation::Sometimes, "{name}");
    }
}

fn network(network: NetworkKind, o: Options) -> Options {
    Options { network, ..o }
}

/// Unique states with and without the reduction, after checking the verdicts.
fn counts(name: &str, o: &Options) -> (usize, usize) {
    let (model, on, off) = both(name, o, |_, _| {});
    same_verdicts(&format!("{name} {o:?}"), &model, &on, &off);
    (on.unique_states, off.unique_states)
}

#[test]
fn every_shipped_model_keeps_its_verdicts_and_its_pinned_factor() {
    let no_timers = |o: Options| Options {
        timer_budget: 0,
        ..o
    };
    // (model, options, unique states with and without the reductions on an unordered and on
    // an ordered network): spent messages forgotten on the first, partial-order reduction on
    // the second. Lamport's stack sits on Fifo, which holds early arrivals: on the first its
    // links are explored in send order, with partial-order reduction.
    let cases = [
        ("lamport-abcast", opts(3, 2), [(1597, 4439), (1597, 2754)]),
        ("sequencer-abcast", opts(3, 3), [(580, 580), (196, 222)]),
        (
            "consensus-abcast",
            no_timers(opts(3, 1)),
            [(94, 678), (116, 195)],
        ),
        (
            "ct-consensus",
            no_timers(opts(3, 3)),
            [(156, 447), (302, 397)],
        ),
        (
            "reliable-broadcast",
            opts(3, 3),
            [(1008, 5756), (4577, 6806)],
        ),
        // A crash may come at any step, and afterwards each multicast leaves one message at
        // a time: no set of processes is ever persistent here.
        (
            "reliable-broadcast",
            Options {
                crashes: 1,
                ..opts(3, 2)
            },
            [(1556, 4364), (3036, 3036)],
        ),
    ];
    let mut found = Vec::new();
    for (name, o, _) in &cases {
        let unordered = counts(name, &network(NetworkKind::Unordered, o.clone()));
        let ordered = counts(name, &network(NetworkKind::Ordered, o.clone()));
        found.push([unordered, ordered]);
    }
    let pinned: Vec<[(usize, usize); 2]> = cases.iter().map(|c| c.2).collect();
    assert_eq!(found, pinned);
}

#[test]
fn ct_consensus_with_false_suspicions_keeps_its_verdicts() {
    let (on, off) = counts("ct-consensus", &network(NetworkKind::Ordered, opts(3, 2)));
    assert_eq!((on, off), (85_122, 123_167));
}

/// What makes a variant broken.
type Tweak = fn(Pid, &mut Stack);

#[test]
fn broken_variants_fail_the_same_properties() {
    let o = network(NetworkKind::Ordered, opts(3, 2));
    let cases: [(&str, Options, Tweak); 3] = [
        ("lamport-abcast", o.clone(), |_, s| {
            s.layers[1] = Layer::new(LamportAbcast::eager())
        }),
        ("sequencer-abcast", o.clone(), |_, s| {
            s.layers[0] = Layer::new(FixedSequencer::rogue(0))
        }),
        (
            "reliable-broadcast",
            Options {
                crashes: 1,
                ..network(NetworkKind::Ordered, opts(3, 1))
            },
            |_, s| s.layers[0] = Layer::new(ReliableBroadcast::without_relay()),
        ),
    ];
    let mut factors = Vec::new();
    for (name, o, tweak) in cases {
        let (model, on, off) = both(name, &o, tweak);
        assert!(off.any_fails(), "{name}: the broken variant fails");
        same_verdicts(&format!("broken {name}"), &model, &on, &off);
        factors.push((name, on.unique_states, off.unique_states));
    }
    assert_eq!(
        factors,
        [
            ("lamport-abcast", 1909, 3432),
            ("sequencer-abcast", 42, 49),
            ("reliable-broadcast", 32, 32),
        ]
    );
    // A wrong composition: reliable broadcast on a lossy network, where spent messages are
    // forgotten.
    let lossy = network(NetworkKind::Lossy, opts(3, 1));
    let (model, on, off) = both("reliable-broadcast", &lossy, |_, _| {});
    assert!(!off.verdict("agreement").unwrap().holds);
    same_verdicts("lossy reliable-broadcast", &model, &on, &off);
    assert_eq!((on.unique_states, off.unique_states), (14, 19));
}

/// Chandra-Toueg deciding on a minority, with a false suspicion, fails agreement either way;
/// its whole space is large, so both searches stop at the first counterexample.
#[test]
fn consensus_on_a_minority_fails_agreement_either_way() {
    let o = network(NetworkKind::Ordered, opts(3, 2));
    let (model, on, off) = searched(
        "ct-consensus",
        &o,
        |_, s| s.layers[1] = Layer::new(ChandraToueg::minority()),
        true,
    );
    let failing = |o: &Outcome| -> Vec<&str> {
        o.verdicts
            .iter()
            .filter(|v| v.path.is_some() && v.expectation == Expectation::Always)
            .map(|v| v.name)
            .collect()
    };
    assert_eq!(failing(&on), ["agreement"]);
    assert_eq!(failing(&off), ["agreement"]);
    real_paths("minority", &model, &on);
}

/// Every state of the full space at rest is reached by the reduced search.
fn keeps_every_state_at_rest(name: &str, o: &Options) -> usize {
    let model = build(&find(name).unwrap().target(), o, |_, _| {}).unwrap();
    let (recorder, states) = StateRecorder::new_with_accessor();
    model.clone().checker().visitor(recorder).spawn_bfs().join();
    let states: Vec<State> = states();
    let reduced = CompactBfs::spawn(
        model.clone(),
        1,
        None,
        false,
        Reductions {
            invisible: Some(invisible(&model)),
            ..Default::default()
        },
        None,
    )
    .join();
    let resting: Vec<&State> = states.iter().filter(|s| at_rest(&model, s)).collect();
    for s in &resting {
        assert!(reduced.reached(s), "{name}: a state at rest is missed");
    }
    resting.len()
}

#[test]
fn every_state_at_rest_is_reached() {
    let o = |n, k| network(NetworkKind::Ordered, opts(n, k));
    assert_eq!(keeps_every_state_at_rest("lamport-abcast", &o(3, 2)), 41);
    assert_eq!(
        keeps_every_state_at_rest("reliable-broadcast", &o(3, 3)),
        38
    );
    let no_timers = Options {
        timer_budget: 0,
        ..o(3, 3)
    };
    assert_eq!(keeps_every_state_at_rest("ct-consensus", &no_timers), 2);
}

#[test]
fn the_reduced_space_is_the_same_on_two_threads_and_with_symmetry() {
    let o = network(NetworkKind::Ordered, opts(3, 3));
    let m = || build(&find("reliable-broadcast").unwrap().target(), &o, |_, _| {}).unwrap();
    let one = run(m(), Exploration::default());
    let two = run(
        m(),
        Exploration {
            threads: 2,
            ..Exploration::default()
        },
    );
    assert_eq!(one.unique_states, two.unique_states);
    let sym = |reduction| {
        let o = Options {
            symmetry: true,
            reduction,
            ..o.clone()
        };
        run(
            build(&find("reliable-broadcast").unwrap().target(), &o, |_, _| {}).unwrap(),
            Exploration::default(),
        )
    };
    let (on, off) = (sym(true), sym(false));
    assert!(on.all_hold() && off.all_hold());
    assert_eq!((on.unique_states, off.unique_states), (779, 1147));
}
