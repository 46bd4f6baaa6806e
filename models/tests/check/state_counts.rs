//! Exact unique state counts for small fixed configurations, as stateright's own examples pin
//! theirs: any change in protocol code (or in the adapter) that changes behaviour shows here.
//! The whole space is counted, without the reductions (models/tests/check/reduction.rs and
//! spent.rs pin what they leave). A deliberate change updates the numbers here and in
//! docs/model-checking.md.

use nekosim_models::Options;

use super::{assert_all_hold, check, opts};

fn count(name: &str, o: &Options) -> usize {
    let o = Options {
        reduction: false,
        ..o.clone()
    };
    let out = check(name, &o);
    assert_all_hold(name, &out);
    out.unique_states
}

#[test]
fn lamport_abcast_3_processes_2_broadcasts() {
    assert_eq!(count("lamport-abcast", &opts(3, 2)), 4439);
}

#[test]
fn sequencer_abcast_3_processes_2_broadcasts() {
    assert_eq!(count("sequencer-abcast", &opts(3, 2)), 46);
}

#[test]
fn reliable_broadcast_3_processes_2_broadcasts() {
    assert_eq!(count("reliable-broadcast", &opts(3, 2)), 129);
}

#[test]
fn ct_consensus_3_processes_2_proposals_no_timers() {
    let o = Options {
        timer_budget: 0,
        ..opts(3, 2)
    };
    assert_eq!(count("ct-consensus", &o), 23);
}

#[test]
fn consensus_abcast_3_processes_1_broadcast_no_timers() {
    let o = Options {
        timer_budget: 0,
        ..opts(3, 1)
    };
    assert_eq!(count("consensus-abcast", &o), 678);
}
