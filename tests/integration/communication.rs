//! Robots communicating through simulated networks and protocol stacks: the abcast guarantees
//! checked from the trace, over several seeds and every network model; crashes and lossy links.

use std::collections::{BTreeMap, BTreeSet};

use nekosim::algorithm::BroadcastLoad;
use nekosim::world::observation::{Observation, Record};
use nekosim::world::virtual_world::RobotSpec;
use nekosim::{Algorithm, Comms, Fault, SimConfig};
use nekosim_protocols::app_decode;
use nekosim_protocols::LayerSpec;
use nekosim_protocols::MsgId;
use nekosim_protocols::Spec as NetworkSpec;

use crate::common::*;

fn layer(id: &str, protocol: &str, below: &str, uses: &[&str]) -> LayerSpec {
    LayerSpec::new(id, protocol, below, uses)
}

fn lamport() -> Vec<LayerSpec> {
    vec![
        layer("fifo", "Fifo", "net", &[]),
        layer("abcast", "LamportAbcast", "fifo", &[]),
    ]
}

fn sequencer() -> Vec<LayerSpec> {
    vec![layer("abcast", "FixedSequencer", "net", &[])]
}

fn ct() -> Vec<LayerSpec> {
    vec![
        layer(
            "fd",
            // Slow heartbeats: on the Metric network every send costs its sender 1 s of CPU.
            "Heartbeat(period: 5.0, timeout: 60.0)",
            "net",
            &[],
        ),
        layer("rb", "ReliableBroadcast", "net", &[]),
        layer("consensus", "ChandraToueg", "net", &["fd"]),
        layer("abcast", "ConsensusAbcast", "rb", &["consensus"]),
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
    let load = || -> Box<dyn Algorithm> {
        Box::new(BroadcastLoad {
            layer: "abcast".into(),
            count: 5,
            mean_interval: 1.0,
        })
    };
    run_line(seed, n, load, network, stack, faults, until)
}

/// `n` robots 20 apart on a line, each running `algorithm()`; the trace.
fn run_line(
    seed: u64,
    n: u32,
    algorithm: impl Fn() -> Box<dyn Algorithm>,
    network: NetworkSpec,
    stack: Vec<LayerSpec>,
    faults: Vec<Fault>,
    until: f64,
) -> Vec<Record> {
    let robots = (0..n)
        .map(|i| (spec(20.0 * i as f64, 0.0, 0.0, 1.0), algorithm()))
        .collect::<Vec<(RobotSpec, Box<dyn Algorithm>)>>();
    nekosim::run(SimConfig {
        sensors: Default::default(),
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
            ..Default::default()
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
        NetworkSpec::new("Reliable(delay: 0.5)"),
        NetworkSpec::new("RandomDelay(lambda: 2.0)"),
        NetworkSpec::new("Metric(lambda: 0.2)"),
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
        layer("rt", "Retransmit(period: 1.0)", "net", &[]),
        layer("fifo", "Fifo", "rt", &[]),
        layer("abcast", "LamportAbcast", "fifo", &[]),
    ];
    let net = NetworkSpec::new("Lossy(p: 0.3, over: RandomDelay(lambda: 1.0))");
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
    let net = NetworkSpec::new("RandomDelay(lambda: 2.0)");
    let a = run_load(9, 3, net.clone(), ct(), vec![], 100.0);
    let b = run_load(9, 3, net.clone(), ct(), vec![], 100.0);
    assert_eq!(text(&a), text(&b));
    assert_ne!(text(&a), text(&run_load(10, 3, net, ct(), vec![], 100.0)));
}

#[test]
fn radio_networks_only_reach_robots_in_range() {
    // Robots 20 apart; range 30 reaches the neighbours only.
    let net = NetworkSpec::new("Radio(range: 30.0, over: Reliable(delay: 0.1))");
    let r = run_load(
        1,
        4,
        net,
        vec![layer("abcast", "ReliableBroadcast", "net", &[])],
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

/// Proposes `id * 10 + k` to consensus instances `0..instances` at random moments, then
/// listens (decisions are recorded as they reach the algorithm).
#[derive(Clone, Debug)]
struct Proposer {
    instances: u64,
}

/// A proposed value: the proposer's id × 10 + the instance.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
struct V(i64);

impl Algorithm for Proposer {
    fn name(&self) -> &str {
        "Proposer"
    }

    fn run(&self, robot: nekosim::Robot) -> nekosim::AlgorithmFuture {
        let instances = self.instances;
        Box::pin(async move {
            use rand::Rng;
            for k in 0..instances {
                let pause = robot.rng().gen_range(0.0..3.0);
                robot.sleep(pause).await;
                let c = robot.layer("consensus").expect("consensus layer");
                c.propose(k, &V(robot.id() as i64 * 10 + k as i64));
            }
            loop {
                robot.receive().await;
            }
        })
    }
}

fn consensus_stack(links: &str) -> Vec<LayerSpec> {
    let mut s = Vec::new();
    if links != "net" {
        s.push(layer(links, "Retransmit(period: 1.0)", "net", &[]));
    }
    s.push(layer(
        "fd",
        "Heartbeat(period: 5.0, timeout: 40.0)",
        "net",
        &[],
    ));
    s.push(layer("consensus", "ChandraToueg", links, &["fd"]));
    s
}

/// Chandra-Toueg with up to f = 2 of 5 robots crashing at random moments, over many seeds and
/// every network model: uniform agreement, validity, integrity and termination of every
/// instance, checked from the trace.
#[test]
fn consensus_properties_with_f_crashes_over_every_network() {
    use rand::{Rng, SeedableRng};
    let n = 5u32;
    let instances = 3u64;
    let mut nets: Vec<(NetworkSpec, &str)> = networks().into_iter().map(|x| (x, "net")).collect();
    // Lossy links made reliable by Retransmit under the consensus layer.
    nets.push((
        NetworkSpec::new("Lossy(p: 0.2, over: RandomDelay(lambda: 1.0))"),
        "rt",
    ));
    let mut runs = 0;
    for (net, links) in &nets {
        for f in 0..=2u32 {
            for seed in 0..6u64 {
                let what = format!("{net:?} f={f} seed={seed}");
                // Victims and crash times drawn from the test's own seeded stream.
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed * 31 + f as u64);
                let mut victims: Vec<u32> = Vec::new();
                while victims.len() < f as usize {
                    let v = rng.gen_range(0..n);
                    if !victims.contains(&v) {
                        victims.push(v);
                    }
                }
                let faults = victims
                    .iter()
                    .map(|&robot| Fault::Crash {
                        robot,
                        at: rng.gen_range(0.0..15.0),
                    })
                    .collect();
                let records = run_line(
                    seed,
                    n,
                    || Box::new(Proposer { instances }),
                    net.clone(),
                    consensus_stack(links),
                    faults,
                    3000.0,
                );
                runs += 1;
                let mut proposed: BTreeMap<u64, BTreeSet<String>> = BTreeMap::new();
                let mut decided: BTreeMap<(u32, u64), Vec<String>> = BTreeMap::new();
                let mut crashed = BTreeSet::new();
                for r in &records {
                    match &r.obs {
                        Observation::Request { op, msg, layer, .. }
                            if op == "propose" && layer == "consensus" =>
                        {
                            let v = format!("{:?}", app_decode::<V>(msg));
                            // The instance is encoded in the value: id * 10 + k.
                            let kk = match app_decode::<V>(msg) {
                                Some(V(x)) => (x % 10) as u64,
                                other => panic!("{what}: unexpected proposal {other:?}"),
                            };
                            proposed.entry(kk).or_default().insert(v);
                        }
                        Observation::Decide {
                            robot, k, value, ..
                        } => decided
                            .entry((*robot, *k))
                            .or_default()
                            .push(format!("{:?}", app_decode::<V>(value))),
                        Observation::Crash { robot, .. } => {
                            crashed.insert(*robot);
                        }
                        _ => {}
                    }
                }
                assert_eq!(crashed.len(), f as usize, "{what}: crashes happened");
                for k in 0..instances {
                    let values: BTreeSet<&String> = decided
                        .iter()
                        .filter(|((_, kk), _)| *kk == k)
                        .flat_map(|(_, v)| v)
                        .collect();
                    assert!(values.len() <= 1, "{what}: agreement on {k}: {values:?}");
                    for v in values {
                        assert!(
                            proposed.get(&k).is_some_and(|p| p.contains(v)),
                            "{what}: validity on {k}: {v} was never proposed"
                        );
                    }
                    for p in 0..n {
                        let d = decided.get(&(p, k)).map_or(0, Vec::len);
                        assert!(d <= 1, "{what}: integrity: p{p} decided {k} {d} times");
                        if !crashed.contains(&p) {
                            assert_eq!(d, 1, "{what}: termination: p{p} never decided {k}");
                        }
                    }
                }
            }
        }
    }
    assert_eq!(runs, 4 * 3 * 6);
}
