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
    // Each link in send order, with partial-order reduction, and every order of arrival.
    let out = check("lamport-abcast", &opts(3, 3));
    assert_all_hold("lamport-abcast", &out);
    assert_eq!(out.unique_states, 84_924);
    let every_order = Options {
        defer_early: false,
        ..opts(3, 3)
    };
    let out = check("lamport-abcast", &every_order);
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

#[test]
fn ct_consensus_holds_with_a_crash_and_false_suspicions() {
    // Two proposers: termination is claimed for the crash of the process that did not
    // propose (the others leave a majority of proposers). Whole multicasts: with partial
    // ones the heartbeats make the space too large for a test.
    let out = check(
        "ct-consensus",
        &Options {
            crashes: 1,
            partial_multicasts: false,
            ..opts(3, 2)
        },
    );
    assert_all_hold("ct-consensus", &out);
    assert!(out.verdict("termination with p2 crashed").unwrap().holds);
    // With spent messages forgotten (575,524 states without).
    assert_eq!(out.unique_states, 403_468);
}

#[test]
fn lamport_abcast_blocks_after_a_crash_as_its_assumptions_say() {
    // Lamport assumes no crashes: a crashed process never acknowledges, so the survivors stop
    // delivering. The at-rest checks see it, which shows they are not vacuous.
    let out = check(
        "lamport-abcast",
        &Options {
            crashes: 1,
            ..opts(3, 1)
        },
    );
    assert!(out.verdict("total order").unwrap().holds);
    assert!(
        !out.verdict("uniform agreement").unwrap().holds || !out.verdict("validity").unwrap().holds
    );
}

/// 7,467 unique states with spent messages forgotten; 1,145,914 without (docs/model-checking.md).
#[test]
fn consensus_abcast_holds_with_2_broadcasts() {
    let out = check(
        "consensus-abcast",
        &Options {
            timer_budget: 0,
            ..opts(3, 2)
        },
    );
    assert_all_hold("consensus-abcast", &out);
    assert_eq!(out.unique_states, 7_467);
}
