//! Protocol stacks of several processes over an adversarial in-memory network: messages in
//! flight are delivered in an order drawn from a seeded generator, processes may crash, timers
//! fire at random points. Checks the guarantees each protocol's doc states, over many seeds.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use nekosim_protocols::lamport::LamportAbcast;
use nekosim_protocols::{
    AppMsg, Content, Ctx, Indication, Input, Layer, LayerIx, LayerSpec, MsgId, Payload, Pid,
    Protocols, Request, Routed, Stack, Wiring, APP, NET,
};

/// xorshift64*: a tiny deterministic generator (no dependency needed for a test schedule).
struct Gen(u64);
impl Gen {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545F4914F6CDD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

struct Cluster {
    n: u32,
    wiring: Wiring,
    stacks: Vec<Stack>,
    crashed: BTreeSet<Pid>,
    /// (from, to, layer, message)
    flight: Vec<(Pid, Pid, LayerIx, Payload)>,
    /// (process, layer, the layer's timer)
    timers: BTreeSet<(Pid, LayerIx, Payload)>,
    /// Broadcast deliveries to the application: (id, message).
    delivered: Vec<Vec<(MsgId, Payload)>>,
    decided: Vec<BTreeMap<u64, Payload>>,
    /// Point-to-point deliveries to the application: (from, message).
    received: Vec<Vec<(Pid, Payload)>>,
    gen: Gen,
}

impl Cluster {
    fn new(n: u32, specs: &[LayerSpec], seed: u64) -> Self {
        let (wiring, stack) =
            Wiring::check(specs, &Protocols::with_builtins()).expect("valid stack");
        let mut c = Cluster {
            n,
            stacks: vec![stack; n as usize],
            wiring,
            crashed: BTreeSet::new(),
            flight: Vec::new(),
            timers: BTreeSet::new(),
            delivered: vec![Vec::new(); n as usize],
            decided: vec![BTreeMap::new(); n as usize],
            received: vec![Vec::new(); n as usize],
            gen: Gen(seed.wrapping_mul(0x9E3779B97F4A7C15) | 1),
        };
        for p in 0..n {
            // Every layer starts, bottom-up in stack order.
            for l in 0..specs.len() as LayerIx {
                c.local(p, l, Input::Start);
            }
        }
        c
    }

    /// Runs `input` at `layer` of process `p` and every hop it causes inside the process, in
    /// FIFO order (as `Stack::step_local` does, but a payload that does not decode fails the
    /// test instead of being dropped); routes what leaves the process.
    fn local(&mut self, p: Pid, layer: LayerIx, input: Input) {
        let ctx = Ctx { me: p, n: self.n };
        let mut queue = VecDeque::from([(layer, input)]);
        let mut out = Vec::new();
        while let Some((l, i)) = queue.pop_front() {
            let routed = self.stacks[p as usize]
                .step(&self.wiring, &ctx, l, i.clone())
                .unwrap_or_else(|e| panic!("p{p} layer {l}: {i:?}: {e}"));
            for r in routed {
                match r {
                    Routed::Layer { to, input } if to != NET => queue.push_back((to, input)),
                    other => out.push(other),
                }
            }
        }
        self.route(p, out);
    }

    fn route(&mut self, p: Pid, routed: Vec<Routed>) {
        for r in routed {
            match r {
                Routed::Net { layer, to, msg } => {
                    for d in to {
                        self.flight.push((p, d, layer, msg.clone()));
                    }
                }
                Routed::App {
                    ind: Indication::BDeliver { id, msg },
                    ..
                } => self.delivered[p as usize].push((id, msg)),
                Routed::App {
                    ind: Indication::Decide { k, value },
                    ..
                } => {
                    assert!(
                        self.decided[p as usize].insert(k, value).is_none(),
                        "integrity: decided twice"
                    );
                }
                Routed::App {
                    ind: Indication::Deliver { from, msg },
                    ..
                } => self.received[p as usize].push((from, msg)),
                Routed::App { .. } => {}
                Routed::SetTimer { layer, timer, .. } => {
                    self.timers.insert((p, layer, timer));
                }
                Routed::CancelTimer { layer, timer } => {
                    self.timers.remove(&(p, layer, timer));
                }
                Routed::Layer { to, input } => {
                    panic!("p{p}: a request to the network that is not a send: {to} {input:?}")
                }
            }
        }
    }

    fn request(&mut self, p: Pid, layer: &str, req: Request) {
        let l = self.wiring.index(layer).unwrap();
        self.local(p, l, Input::Request { from: APP, req });
    }

    /// Delivers one message or fires one timer; false when nothing is left to do.
    fn step(&mut self, timer_weight: usize) -> bool {
        let live: Vec<usize> = (0..self.flight.len())
            .filter(|&i| !self.crashed.contains(&self.flight[i].1))
            .collect();
        let timers: Vec<_> = self
            .timers
            .iter()
            .filter(|t| !self.crashed.contains(&t.0))
            .cloned()
            .collect();
        if live.is_empty() && (timers.is_empty() || timer_weight == 0) {
            return false;
        }
        let pick_timer = !timers.is_empty()
            && timer_weight > 0
            && (live.is_empty() || self.gen.below(100) < timer_weight);
        if pick_timer {
            let (p, layer, timer) = timers[self.gen.below(timers.len())].clone();
            self.timers.remove(&(p, layer, timer.clone()));
            self.local(p, layer, Input::Timer(timer));
        } else {
            let i = live[self.gen.below(live.len())];
            let (from, to, layer, msg) = self.flight.swap_remove(i);
            let input = Input::Indication {
                from: NET,
                ind: Indication::Deliver { from, msg },
            };
            self.local(to, layer, input);
        }
        true
    }

    fn crash(&mut self, p: Pid) {
        self.crashed.insert(p);
        // Messages it had not sent yet are lost; messages already in flight may arrive.
    }

    fn run(&mut self, max_steps: usize, timer_weight: usize) {
        self.run_until(max_steps, timer_weight, |_| false);
    }

    /// Steps until `done`, nothing is left, or `max_steps`.
    fn run_until(
        &mut self,
        max_steps: usize,
        timer_weight: usize,
        done: impl Fn(&Cluster) -> bool,
    ) {
        for _ in 0..max_steps {
            if done(self) || !self.step(timer_weight) {
                break;
            }
        }
    }
}

fn layer(id: &str, protocol: &str, below: &str, uses: &[&str]) -> LayerSpec {
    LayerSpec::new(id, protocol, below, uses)
}

fn msg(p: Pid, i: u64) -> Payload {
    AppMsg::new("M", Content::Int(p as i64 * 1000 + i as i64)).payload()
}

/// The ids of the messages `p` delivered, in order.
fn ids(delivered: &[Vec<(MsgId, Payload)>], p: Pid) -> Vec<MsgId> {
    delivered[p as usize].iter().map(|(id, _)| *id).collect()
}

/// Total order: any two processes' delivery sequences are prefixes of one another; integrity:
/// no duplicates, and each message is the one its origin broadcast (the origin's `n`-th
/// broadcast is `msg(origin, n)` in every test here).
fn assert_total_order(delivered: &[Vec<(MsgId, Payload)>], who: &[Pid]) {
    for &p in who {
        let s: BTreeSet<_> = ids(delivered, p).into_iter().collect();
        assert_eq!(
            s.len(),
            delivered[p as usize].len(),
            "integrity: p{p} delivered a message twice"
        );
        for (id, m) in &delivered[p as usize] {
            assert_eq!(m, &msg(id.origin, id.n), "integrity: p{p} delivered {id}");
        }
        for &q in who {
            let (a, b) = (&delivered[p as usize], &delivered[q as usize]);
            let m = a.len().min(b.len());
            assert_eq!(a[..m], b[..m], "total order: p{p} and p{q} disagree");
        }
    }
}

fn lamport_stack() -> Vec<LayerSpec> {
    vec![
        layer("fifo", "Fifo", "net", &[]),
        layer("abcast", "LamportAbcast", "fifo", &[]),
    ]
}

fn ct_stack() -> Vec<LayerSpec> {
    vec![
        layer("fd", "Heartbeat(period: 1.0, timeout: 3.0)", "net", &[]),
        layer("rb", "ReliableBroadcast", "net", &[]),
        layer("consensus", "ChandraToueg", "net", &["fd"]),
        layer("abcast", "ConsensusAbcast", "rb", &["consensus"]),
    ]
}

#[test]
fn lamport_abcast_delivers_everything_in_one_order() {
    for seed in 0..200 {
        let mut c = Cluster::new(4, &lamport_stack(), seed);
        for p in 0..4 {
            for i in 0..3 {
                c.request(p, "abcast", Request::Broadcast { msg: msg(p, i) });
            }
        }
        c.run(100_000, 0);
        assert_total_order(&c.delivered, &[0, 1, 2, 3]);
        for p in 0..4 {
            assert_eq!(
                c.delivered[p].len(),
                12,
                "validity: seed {seed} p{p} delivered {:?}",
                c.delivered[p]
            );
        }
    }
}

#[test]
fn lamport_without_waiting_breaks_total_order_somewhere() {
    let mut broken = false;
    for seed in 0..200 {
        let mut c = Cluster::new(3, &lamport_stack(), seed);
        for s in c.stacks.iter_mut() {
            s.layers[1] = Layer::new(LamportAbcast::eager());
        }
        for p in 0..3 {
            c.request(p, "abcast", Request::Broadcast { msg: msg(p, 0) });
        }
        c.run(100_000, 0);
        broken |=
            std::panic::catch_unwind(|| assert_total_order(&c.delivered, &[0, 1, 2])).is_err();
    }
    assert!(
        broken,
        "the harness is not vacuous: the eager variant must be caught"
    );
}

#[test]
fn fixed_sequencer_delivers_everything_in_one_order() {
    let stack = vec![layer("abcast", "FixedSequencer", "net", &[])];
    for seed in 0..200 {
        let mut c = Cluster::new(3, &stack, seed);
        for p in 0..3 {
            for i in 0..4 {
                c.request(p, "abcast", Request::Broadcast { msg: msg(p, i) });
            }
        }
        c.run(100_000, 0);
        assert_total_order(&c.delivered, &[0, 1, 2]);
        assert!(c.delivered.iter().all(|d| d.len() == 12));
    }
}

#[test]
fn reliable_broadcast_agreement_survives_a_crashed_broadcaster() {
    let stack = vec![layer("rb", "ReliableBroadcast", "net", &[])];
    for seed in 0..200 {
        let mut c = Cluster::new(4, &stack, seed);
        c.request(0, "rb", Request::Broadcast { msg: msg(0, 0) });
        // Process 0 crashes after at most one of its messages got out.
        let keep = (seed % 4) as usize;
        c.flight.truncate(keep.min(c.flight.len()));
        c.crash(0);
        c.run(100_000, 0);
        let got: Vec<usize> = (1..4).map(|p| c.delivered[p].len()).collect();
        assert!(
            got.iter().all(|&g| g == got[0]),
            "agreement: seed {seed}: {got:?}"
        );
        assert_eq!(got[0], usize::from(keep > 0));
    }
}

#[test]
fn fifo_and_retransmit_give_reliable_fifo_over_a_lossy_network() {
    // The network drops every third message (deterministically); Retransmit resends, Fifo
    // orders.
    let stack = vec![
        layer("rt", "Retransmit(period: 1.0)", "net", &[]),
        layer("fifo", "Fifo", "rt", &[]),
    ];
    for seed in 0..50 {
        let mut c = Cluster::new(2, &stack, seed);
        for i in 0..10 {
            c.request(
                0,
                "fifo",
                Request::Send {
                    to: vec![1],
                    msg: msg(0, i),
                },
            );
        }
        let mut k = 0u64;
        let mut dropped = 0;
        for _ in 0..10_000 {
            // The lossy network: every third step loses a message in flight.
            k += 1;
            if k % 3 == 0 && !c.flight.is_empty() {
                let i = c.gen.below(c.flight.len());
                c.flight.swap_remove(i);
                dropped += 1;
            }
            if c.received[1].len() == 10 && c.flight.is_empty() {
                break;
            }
            if !c.step(30) {
                break;
            }
        }
        assert!(dropped > 0);
        let want: Vec<(Pid, Payload)> = (0..10).map(|i| (0, msg(0, i))).collect();
        assert_eq!(c.received[1], want, "seed {seed}: reliable FIFO delivery");
    }
}

#[test]
fn consensus_abcast_orders_everything_with_a_crash() {
    for seed in 0..60 {
        let mut c = Cluster::new(3, &ct_stack(), seed);
        for p in 0..3 {
            for i in 0..2 {
                c.request(p, "abcast", Request::Broadcast { msg: msg(p, i) });
            }
        }
        if seed % 2 == 1 {
            c.crash(2);
        }
        let correct: Vec<Pid> = (0..3).filter(|p| !c.crashed.contains(p)).collect();
        let who = correct.clone();
        let wanted: Vec<MsgId> = correct
            .iter()
            .flat_map(|&q| (0..2).map(move |n| MsgId { origin: q, n }))
            .collect();
        c.run_until(200_000, 5, |c| {
            who.iter().all(|&p| {
                let got = ids(&c.delivered, p);
                wanted.iter().all(|id| got.contains(id))
            })
        });
        assert_total_order(&c.delivered, &correct);
        for &p in &correct {
            // Validity: every message of a correct process is delivered by every correct one.
            for &q in &correct {
                for i in 0..2 {
                    let id = MsgId { origin: q, n: i };
                    assert!(
                        ids(&c.delivered, p).contains(&id),
                        "seed {seed}: p{p} misses {id}"
                    );
                }
            }
        }
    }
}

#[test]
fn chandra_toueg_decides_one_proposed_value() {
    let stack = vec![
        layer("fd", "Heartbeat(period: 1.0, timeout: 2.0)", "net", &[]),
        layer("consensus", "ChandraToueg", "net", &["fd"]),
    ];
    for seed in 0..200 {
        let mut c = Cluster::new(3, &stack, seed);
        for p in 0..3 {
            c.request(
                p,
                "consensus",
                Request::Propose {
                    k: 0,
                    value: msg(p, 0),
                },
            );
        }
        if seed % 3 == 0 {
            c.crash((seed / 3 % 3) as Pid);
        }
        let correct: Vec<Pid> = (0..3).filter(|p| !c.crashed.contains(p)).collect();
        let who = correct.clone();
        c.run_until(100_000, 10, |c| {
            who.iter().all(|p| c.decided[*p as usize].contains_key(&0))
        });
        let values: BTreeSet<&Payload> = correct
            .iter()
            .filter_map(|p| c.decided[*p as usize].get(&0))
            .collect();
        assert!(values.len() <= 1, "agreement: seed {seed}: {values:?}");
        let proposed: Vec<Payload> = (0..3).map(|p| msg(p, 0)).collect();
        assert!(values.iter().all(|v| proposed.contains(v)), "validity");
        for p in &correct {
            assert!(
                c.decided[*p as usize].contains_key(&0),
                "termination: seed {seed} p{p}"
            );
        }
    }
}
