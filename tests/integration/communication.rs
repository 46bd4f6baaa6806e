//! Robots communicating through simulated networks and protocol stacks: the abcast guarantees
//! checked from the trace, over several seeds and every network model; crashes and lossy links.

use std::collections::{BTreeMap, BTreeSet};

use nekosim::algorithm::BroadcastLoad;
use nekosim::world::network::NetworkSpec;
use nekosim::world::observation::{Observation, Record};
use nekosim::world::virtual_world::RobotSpec;
use nekosim::{Algorithm, Comms, Fault, SimConfig};
use nekosim_protocols::stack::{LayerSpec, ProtocolSpec};
use nekosim_protocols::MsgId;

use crate::common::*;

fn layer(id: &str, protocol: ProtocolSpec, below: &str, uses: &[&str]) -> LayerSpec {
    LayerSpec::new(id, protocol, below, uses)
}

fn lamport() -> Vec<LayerSpec> {
    vec![
        layer("fifo", ProtocolSpec::Fifo, "net", &[]),
        layer("abcast", ProtocolSpec::LamportAbcast, "fifo", &[]),
    ]
}

fn sequencer() -> Vec<LayerSpec> {
    vec![layer("abcast", ProtocolSpec::FixedSequencer, "net", &[])]
}

fn ct() -> Vec<LayerSpec> {
    vec![
        layer(
            "fd",
            // Slow heartbeats: on the Metric network every send costs its sender 1 s of CPU.
            ProtocolSpec::Heartbeat {
                period: 5.0,
                timeout: 60.0,
            },
            "net",
            &[],
        ),
        layer("rb", ProtocolSpec::ReliableBroadcast, "net", &[]),
        layer("consensus", ProtocolSpec::ChandraToueg, "net", &["fd"]),
        layer(
            "abcast",
            ProtocolSpec::ConsensusAbcast,
            "rb",
            &["consensus"],
        ),
    ]
}

fn run_load(
    seed: u64,
    n: u32,
    network: NetworkSpec,
    stack: Vec<LayerSpec>,
    faults: Vec<Fault>,
    until: f64,
) -> Vec<Record> {
    let robots = (0..n)
        .map(|i| {
            let a: Box<dyn Algorithm> = Box::new(BroadcastLoad {
                layer: "abcast".into(),
                count: 5,
                mean_interval: 1.0,
            });
            (spec(20.0 * i as f64, 0.0, 0.0, 1.0), a)
        })
        .collect::<Vec<(RobotSpec, Box<dyn Algorithm>)>>();
    nekosim::run(SimConfig {
        seed,
        until,
        world: infinite(),
        robots,
        arbiters: 1,
        record: true,
        observers: Default::default(),
        comms: Comms {
            network,
            stack,
            faults,
            protocols: Default::default(),
        },
    })
    .expect("run")
    .records
}

/// Each robot's delivery sequence of the abcast layer.
fn deliveries(records: &[Record], n: u32) -> Vec<Vec<MsgId>> {
    let mut d = vec![Vec::new(); n as usize];
    for r in records {
        if let Observation::Deliver {
            robot, layer, id, ..
        } = &r.obs
        {
            if layer == "abcast" {
                d[*robot as usize].push(*id);
            }
        }
    }
    d
}

fn check_abcast(records: &[Record], n: u32, correct: &[u32], what: &str) {
    let d = deliveries(records, n);
    let broadcast: BTreeSet<MsgId> = (0..n)
        .flat_map(|o| (0..5).map(move |k| MsgId { origin: o, n: k }))
        .collect();
    for &p in correct {
        let s: BTreeSet<MsgId> = d[p as usize].iter().copied().collect();
        assert_eq!(
            s.len(),
            d[p as usize].len(),
            "{what}: integrity: p{p} delivered twice"
        );
        assert!(
            s.is_subset(&broadcast),
            "{what}: integrity: p{p} delivered something never broadcast"
        );
        for &q in correct {
            // Validity: everything a correct process broadcast is delivered by every correct one.
            for k in 0..5 {
                assert!(
                    s.contains(&MsgId { origin: q, n: k }),
                    "{what}: validity: p{p} misses {q}:{k}"
                );
            }
            // Total order and agreement: the same sequence at every correct process.
            assert_eq!(d[p as usize], d[q as usize], "{what}: p{p} and p{q} differ");
        }
    }
}

fn networks() -> Vec<NetworkSpec> {
    vec![
        NetworkSpec::Reliable { delay: 0.5 },
        NetworkSpec::RandomDelay { lambda: 2.0 },
        NetworkSpec::Metric { lambda: 0.2 },
    ]
}

#[test]
fn lamport_and_sequencer_abcast_over_every_network() {
    for net in networks() {
        for seed in 0..4 {
            let r = run_load(seed, 4, net.clone(), lamport(), vec![], 200.0);
            check_abcast(
                &r,
                4,
                &[0, 1, 2, 3],
                &format!("lamport {net:?} seed {seed}"),
            );
            let r = run_load(seed, 4, net.clone(), sequencer(), vec![], 200.0);
            check_abcast(
                &r,
                4,
                &[0, 1, 2, 3],
                &format!("sequencer {net:?} seed {seed}"),
            );
        }
    }
}

#[test]
fn consensus_abcast_tolerates_a_crash() {
    for net in networks() {
        for seed in 0..3 {
            // Robot 3 crashes before it broadcasts anything; f = 1 < n/2 with n = 4.
            let r = run_load(
                seed,
                4,
                net.clone(),
                ct(),
                vec![Fault::Crash { robot: 3, at: 0.0 }],
                2000.0,
            );
            let crashed = r
                .iter()
                .any(|x| matches!(x.obs, Observation::Crash { robot: 3, .. }));
            assert!(crashed);
            let d = deliveries(&r, 4);
            assert!(d[3].is_empty(), "a crashed robot delivers nothing");
            // Only the correct robots' messages are expected.
            let correct = [0u32, 1, 2];
            for &p in &correct {
                for &q in &correct {
                    assert_eq!(
                        d[p as usize], d[q as usize],
                        "ct {net:?} seed {seed}: p{p} p{q}"
                    );
                    for k in 0..5 {
                        assert!(
                            d[p as usize].contains(&MsgId { origin: q, n: k }),
                            "ct {net:?} seed {seed}: p{p} misses {q}:{k}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn retransmit_and_fifo_give_reliable_fifo_over_lossy_links() {
    let stack = vec![
        layer("rt", ProtocolSpec::Retransmit { period: 1.0 }, "net", &[]),
        layer("fifo", ProtocolSpec::Fifo, "rt", &[]),
        layer("abcast", ProtocolSpec::LamportAbcast, "fifo", &[]),
    ];
    let net = NetworkSpec::Lossy {
        p: 0.3,
        over: Box::new(NetworkSpec::RandomDelay { lambda: 1.0 }),
    };
    for seed in 0..3 {
        let r = run_load(seed, 3, net.clone(), stack.clone(), vec![], 300.0);
        let sent = r
            .iter()
            .filter(|x| matches!(x.obs, Observation::Send { .. }))
            .count();
        let received = r
            .iter()
            .filter(|x| matches!(x.obs, Observation::Receive { .. }))
            .count();
        let copies: usize = r
            .iter()
            .map(|x| match &x.obs {
                Observation::Send { to, .. } => to.len(),
                _ => 0,
            })
            .sum();
        assert!(
            received < copies,
            "the network did lose messages ({received} of {copies}, {sent} sends)"
        );
        check_abcast(&r, 3, &[0, 1, 2], &format!("lossy seed {seed}"));
    }
}

#[test]
fn communication_runs_are_deterministic() {
    let text = |r: &[Record]| {
        r.iter()
            .map(|x| format!("{} {:?}\n", x.t, x.obs))
            .collect::<String>()
    };
    let net = NetworkSpec::RandomDelay { lambda: 2.0 };
    let a = run_load(9, 3, net.clone(), ct(), vec![], 100.0);
    let b = run_load(9, 3, net.clone(), ct(), vec![], 100.0);
    assert_eq!(text(&a), text(&b));
    assert_ne!(text(&a), text(&run_load(10, 3, net, ct(), vec![], 100.0)));
}

#[test]
fn radio_networks_only_reach_robots_in_range() {
    // Robots 20 apart; range 30 reaches the neighbours only.
    let net = NetworkSpec::Radio {
        range: 30.0,
        over: Box::new(NetworkSpec::Reliable { delay: 0.1 }),
    };
    let r = run_load(
        1,
        4,
        net,
        vec![layer("abcast", ProtocolSpec::ReliableBroadcast, "net", &[])],
        vec![],
        50.0,
    );
    // Relaying carries every message hop by hop to everybody.
    let d = deliveries(&r, 4);
    assert!(d.iter().all(|x| x.len() == 20), "{d:?}");
    let mut heard: BTreeMap<u32, BTreeSet<u32>> = BTreeMap::new();
    for x in &r {
        if let Observation::Receive { robot, from, .. } = &x.obs {
            heard.entry(*robot).or_default().insert(*from);
        }
    }
    for (robot, froms) in heard {
        for f in froms {
            assert!(
                (robot as i64 - f as i64).abs() == 1,
                "p{robot} heard p{f}, 40+ units away"
            );
        }
    }
}
