//! The checker is not vacuous: each deliberately broken variant of a protocol (the very
//! protocol code with one flag flipped) yields a counterexample of the property it breaks,
//! and the counterexample's last state does violate that property.

use nekosim_models::{NetworkKind, Options, Outcome};
use nekosim_protocols::consensus::ChandraToueg;
use nekosim_protocols::lamport::LamportAbcast;
use nekosim_protocols::rbroadcast::ReliableBroadcast;
use nekosim_protocols::sequencer::FixedSequencer;
use nekosim_protocols::{Layer, MsgId};

use super::{check, check_with, opts};

/// The counterexample of `property`, checked against the correct model in the same
/// configuration, which must not have one.
fn counterexample(name: &str, o: &Outcome, property: &str, correct: &Options) {
    let v = o.verdict(property).expect("property exists");
    assert!(!v.holds, "{name}: the broken variant must break {property}");
    assert!(v.path.is_some(), "a counterexample path is given");
    let c = check(name, correct);
    assert!(
        c.verdict(property).expect("property exists").holds,
        "{name}: the correct protocol keeps {property}"
    );
}

fn ids(d: &[(MsgId, nekosim_protocols::Payload)]) -> Vec<MsgId> {
    d.iter().map(|(id, _)| *id).collect()
}

#[test]
fn lamport_delivering_without_hearing_from_everybody_breaks_total_order() {
    let o = opts(3, 2);
    let out = check_with(
        "lamport-abcast",
        &o,
        |_, s| s.layers[1] = Layer::new(LamportAbcast::eager()),
        true,
    );
    counterexample("lamport-abcast", &out, "total order", &o);
    let path = out.verdict("total order").unwrap().path.clone().unwrap();
    let last = path.last_state();
    let a = ids(&last.actor_states[0].delivered);
    let b = ids(&last.actor_states[1].delivered);
    let c = ids(&last.actor_states[2].delivered);
    let prefix = |x: &[MsgId], y: &[MsgId]| {
        let k = x.len().min(y.len());
        x[..k] == y[..k]
    };
    assert!(!(prefix(&a, &b) && prefix(&b, &c) && prefix(&a, &c)));
}

#[test]
fn two_sequencers_break_total_order() {
    let o = opts(3, 2);
    let out = check_with(
        "sequencer-abcast",
        &o,
        |_, s| s.layers[0] = Layer::new(FixedSequencer::rogue(0)),
        true,
    );
    counterexample("sequencer-abcast", &out, "total order", &o);
}

#[test]
fn consensus_deciding_on_a_minority_breaks_agreement() {
    // A false suspicion (one timer firing) lets a second coordinator decide on its own.
    let o = Options {
        timer_budget: 1,
        ..opts(3, 2)
    };
    let out = check_with(
        "ct-consensus",
        &o,
        |_, s| s.layers[1] = Layer::new(ChandraToueg::minority()),
        true,
    );
    let v = out.verdict("agreement").unwrap();
    assert!(!v.holds);
    let last = v.path.as_ref().unwrap().last_state();
    let decisions: std::collections::BTreeSet<_> = last
        .actor_states
        .iter()
        .flat_map(|a| a.decided.iter().map(|(_, v)| v.clone()))
        .collect();
    assert!(decisions.len() >= 2, "two values decided: {decisions:?}");
    // The correct protocol with the same budget is checked in correct_models_hold.
}

#[test]
fn reliable_broadcast_without_relay_breaks_agreement_when_the_sender_crashes() {
    let o = Options {
        crashes: 1,
        ..opts(3, 1)
    };
    let out = check_with(
        "reliable-broadcast",
        &o,
        |_, s| s.layers[0] = Layer::new(ReliableBroadcast::without_relay()),
        true,
    );
    counterexample("reliable-broadcast", &out, "agreement", &o);
    let last = out.verdict("agreement").unwrap().path.clone().unwrap();
    let last = last.last_state();
    assert!(last.crashed.iter().any(|c| *c), "the sender crashed");
}

#[test]
fn a_lossy_network_breaks_reliable_broadcast_which_assumes_reliable_links() {
    let o = Options {
        network: NetworkKind::Lossy,
        ..opts(3, 1)
    };
    let out = check("reliable-broadcast", &o);
    assert!(!out.verdict("agreement").unwrap().holds);
    assert!(out.verdict("integrity").unwrap().holds);
}
