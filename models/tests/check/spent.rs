//! Spent messages, against brute force. Stateright's own breadth-first checker lists every
//! reachable state of the whole model. In each state, every message in flight that the model
//! calls spent (`nekosim_models::model::spent`) must change nothing if delivered there
//! (stateright then takes no step, or one that only consumes it) and must still be spent after every step of the model
//! that leaves it in flight. By induction it changes nothing in any later state, so forgetting
//! it loses no behaviour. The search that forgets spent messages must then explore exactly
//! one state per class of reachable states that are equal once their spent messages are
//! forgotten.

use std::collections::HashSet;
use std::hash::{DefaultHasher, Hash, Hasher};

use nekosim_models::adapter::NetMsg;
use nekosim_models::compact::{CompactBfs, Reductions};
use nekosim_models::model::spent;
use nekosim_models::{
    build, find, run, CheckModel, Exploration, NetworkKind, Options, Outcome, State,
};
use nekosim_protocols::consensus::ChandraToueg;
use nekosim_protocols::rbroadcast::ReliableBroadcast;
use nekosim_protocols::{Layer, Pid, Stack};
use stateright::actor::{ActorModelAction, Envelope, Network};
use stateright::{Checker, Expectation, Model, StateRecorder};

use super::opts;

/// The state with its spent messages forgotten.
fn forgotten(model: &CheckModel, s: &State) -> State {
    let is_spent = spent(model);
    let mut s = s.clone();
    let (states, crashed) = (s.actor_states.clone(), s.crashed.clone());
    match &mut s.network {
        Network::UnorderedNonDuplicating(multiset) => {
            multiset.retain(|env, _| !is_spent(&states, &crashed, by_ref(env)))
        }
        Network::Ordered(channels) => {
            for (&(src, dst), queue) in channels.iter_mut() {
                queue.retain(|msg| !is_spent(&states, &crashed, Envelope { src, dst, msg }));
            }
        }
        Network::UnorderedDuplicating(..) => unreachable!("no model duplicates"),
    }
    s
}

fn by_ref(e: &Envelope<NetMsg>) -> Envelope<&NetMsg> {
    Envelope {
        src: e.src,
        dst: e.dst,
        msg: &e.msg,
    }
}

fn hash(s: &State) -> u64 {
    let mut h = DefaultHasher::new();
    s.hash(&mut h);
    h.finish()
}

/// Checks the model `name` as the module doc says; returns the (state, message) pairs found
/// spent and the unique states of the search that forgets them.
fn spent_messages_are_inert(
    name: &str,
    o: &Options,
    tweak: impl Fn(Pid, &mut Stack) + Copy,
) -> (usize, usize) {
    let model = build(&find(name).unwrap().target(), o, tweak).unwrap();
    let is_spent = spent(&model);
    let (recorder, states) = StateRecorder::new_with_accessor();
    model.clone().checker().visitor(recorder).spawn_bfs().join();
    let states: Vec<State> = states();
    let mut pairs = 0;
    let mut actions = Vec::new();
    for s in &states {
        let in_flight: Vec<_> = s
            .network
            .iter_deliverable()
            .map(|e| e.to_cloned_msg())
            .collect();
        for env in in_flight
            .iter()
            .filter(|e| is_spent(&s.actor_states, &s.crashed, by_ref(e)))
        {
            pairs += 1;
            let deliver = ActorModelAction::Deliver {
                src: env.src,
                dst: env.dst,
                msg: env.msg.clone(),
            };
            // Nothing changes but the message itself being gone (with crashes a delivery may
            // re-arm a process's send timer, which is already armed).
            assert!(
                model
                    .next_state(s, deliver)
                    .is_none_or(|next| forgotten(&model, &next) == forgotten(&model, s)),
                "{name}: delivering a spent {env:?} changes the state"
            );
            actions.clear();
            model.actions(s, &mut actions);
            for action in actions.drain(..) {
                let Some(next) = model.next_state(s, action) else {
                    continue;
                };
                let still = next
                    .network
                    .iter_deliverable()
                    .any(|e| e.to_cloned_msg() == *env);
                assert!(
                    !still || is_spent(&next.actor_states, &next.crashed, by_ref(env)),
                    "{name}: {env:?} is spent, and no longer after a step"
                );
            }
        }
    }
    let classes: HashSet<u64> = states.iter().map(|s| hash(&forgotten(&model, s))).collect();
    let reduced = CompactBfs::spawn(
        model.clone(),
        1,
        None,
        false,
        Reductions {
            spent: Some(spent(&model)),
            ..Default::default()
        },
        None,
    )
    .join();
    for s in &states {
        assert!(reduced.reached(s), "{name}: a class is missed");
    }
    assert_eq!(reduced.unique_state_count(), classes.len(), "{name}");
    // The checker's own search forgets them too, with the same verdicts as without.
    let on = run(model, Exploration::default());
    let off = run(
        build(
            &find(name).unwrap().target(),
            &Options {
                reduction: false,
                ..o.clone()
            },
            tweak,
        )
        .unwrap(),
        Exploration::default(),
    );
    assert_eq!(on.unique_states, classes.len(), "{name}");
    let verdicts = |o: &Outcome| -> Vec<(&str, bool)> {
        o.verdicts.iter().map(|v| (v.name, v.holds)).collect()
    };
    assert_eq!(verdicts(&on), verdicts(&off), "{name}");
    (pairs, on.unique_states)
}

fn with(o: Options, f: impl FnOnce(&mut Options)) -> Options {
    let mut o = o;
    f(&mut o);
    o
}

#[test]
fn spent_consensus_and_broadcast_messages_change_nothing_for_ever() {
    // (model, options, (pairs of a state and a spent message, unique states when forgotten))
    let cases: [(&str, Options, (usize, usize)); 4] = [
        (
            "consensus-abcast",
            with(opts(3, 1), |o| o.timer_budget = 0),
            (3037, 94),
        ),
        ("ct-consensus", opts(3, 2), (156_288, 100_867)),
        (
            "reliable-broadcast",
            with(opts(3, 2), |o| o.crashes = 1),
            (5044, 1556),
        ),
        (
            "reliable-broadcast",
            with(opts(3, 2), |o| o.network = NetworkKind::Lossy),
            (844, 361),
        ),
    ];
    let mut found = Vec::new();
    for (name, o, _) in &cases {
        found.push(spent_messages_are_inert(name, o, |_, _| {}));
    }
    let pinned: Vec<(usize, usize)> = cases.iter().map(|c| c.2).collect();
    assert_eq!(found, pinned);
}

#[test]
fn a_broken_consensus_spends_by_its_own_quorums() {
    // Quorums of one: a coordinator's round settles with the first reply.
    let o = with(opts(3, 2), |o| o.timer_budget = 0);
    let found = spent_messages_are_inert("ct-consensus", &o, |_, s| {
        s.layers[1] = Layer::new(ChandraToueg::minority())
    });
    assert_eq!(found, (818, 48));
}

#[test]
fn broken_variants_fail_the_same_properties_with_spent_messages_forgotten() {
    // Without relays, agreement fails when a broadcaster crashes; on a lossy network it fails
    // anyway. Deciding on a minority breaks agreement once a false suspicion moves a process
    // on to the next coordinator; that space is large, so both searches stop at their first
    // counterexample. Every counterexample found while forgetting is a real path of the model
    // whose last state breaks its property.
    let no_relay: fn(Pid, &mut Stack) =
        |_, s| s.layers[0] = Layer::new(ReliableBroadcast::without_relay());
    let minority: fn(Pid, &mut Stack) = |_, s| s.layers[1] = Layer::new(ChandraToueg::minority());
    let none: fn(Pid, &mut Stack) = |_, _| {};
    let crash = with(opts(3, 1), |o| o.crashes = 1);
    let lossy = with(opts(3, 1), |o| o.network = NetworkKind::Lossy);
    let cases = [
        ("reliable-broadcast", crash, no_relay, false),
        ("reliable-broadcast", lossy, none, false),
        ("ct-consensus", opts(3, 2), minority, true),
    ];
    let mut counts = Vec::new();
    for (name, o, tweak, first) in cases {
        let search = |reduction: bool| {
            let o = Options {
                reduction,
                ..o.clone()
            };
            let model = build(&find(name).unwrap().target(), &o, tweak).unwrap();
            let how = Exploration {
                first_counterexample: first,
                ..Exploration::default()
            };
            (model.clone(), run(model, how))
        };
        let ((model, on), (_, off)) = (search(true), search(false));
        counts.push((on.unique_states, off.unique_states));
        assert!(!on.verdict("agreement").unwrap().holds, "{name}");
        assert!(!off.verdict("agreement").unwrap().holds, "{name}");
        if !first {
            for (a, b) in on.verdicts.iter().zip(&off.verdicts) {
                let (a, b) = (
                    (a.name, a.holds, a.path.is_some()),
                    (b.name, b.holds, b.path.is_some()),
                );
                assert_eq!(a, b, "{name}");
            }
        }
        for (i, v) in on.verdicts.iter().enumerate() {
            let Some(path) = &v.path else { continue };
            let mut state = model.init_states().remove(0);
            for action in path.clone().into_actions() {
                state = model
                    .next_state(&state, action)
                    .expect("a step of the model");
                assert!(
                    Model::within_boundary(&model, &state),
                    "{name}: outside the model"
                );
            }
            let (expectation, condition) = &model.cfg.conditions[i];
            let discovery = condition(&model, &state) == (*expectation == Expectation::Sometimes);
            assert!(discovery, "{name}: {}", v.name);
        }
    }
    assert_eq!(counts, [(32, 32), (14, 19), (2136, 2219)]);
}
