//! Every property holds for the correct protocols at n = 3 with 2 and 3 requests, explored
//! exhaustively, on each network the protocol assumes, and with the crashes it tolerates.

use nekosim_models::{NetworkKind, Options};

use super::{assert_all_hold, check, opts};

#[test]
fn reliable_broadcast_holds_with_3_broadcasts_and_a_crash() {
    for o in [
        opts(3, 3),
        Options {
            crashes: 1,
            ..opts(3, 2)
        },
        Options {
            network: NetworkKind::Ordered,
            ..opts(3, 3)
        },
    ] {
        let out = check("reliable-broadcast", &o);
        assert_all_hold("reliable-broadcast", &out);
    }
}

#[test]
fn sequencer_abcast_holds_with_3_broadcasts() {
    for network in [NetworkKind::Unordered, NetworkKind::Ordered] {
        let out = check(
            "sequencer-abcast",
            &Options {
                network,
                ..opts(3, 3)
            },
        );
        assert_all_hold("sequencer-abcast", &out);
    }
}

#[test]
fn lamport_abcast_holds_with_3_broadcasts() {
    let out = check("lamport-abcast", &opts(3, 3));
    assert_all_hold("lamport-abcast", &out);
    assert_eq!(out.unique_states, 584_565);
}

#[test]
fn ct_consensus_holds_with_3_proposals_and_with_false_suspicions() {
    let out = check(
        "ct-consensus",
        &Options {
            timer_budget: 0,
            ..opts(3, 3)
        },
    );
    assert_all_hold("ct-consensus", &out);
    // One timer per process: any pattern of (false) suspicions.
    let out = check("ct-consensus", &opts(3, 2));
    assert_all_hold("ct-consensus", &out);
}
