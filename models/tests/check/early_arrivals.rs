//! Early arrivals against brute force (`nekosim_models::reduction`, "Early arrivals"). On a
//! network that reorders, a stack whose layers on the network hold early arrivals back
//! (Fifo) is explored with each link in send order. Stateright's own breadth-first search
//! lists every reachable state of both: the model that reorders (every order of arrival) and
//! the one in send order. Then:
//!
//! - every state in send order is a state of the reordering model, once its channels are read
//!   as the multiset of messages they hold;
//! - the two have the same states once the holding layers and the messages in flight are left
//!   out, which is all any property reads;
//! - the two have the same states at rest, exactly;
//! - every property has the same verdict, and each counterexample or witness found in send
//!   order, with partial-order reduction on top, replays on the reordering model.
//!
//! A layer that claims to hold early arrivals but passes them up at once fails the second
//! point, so the comparison can tell.

use std::collections::HashSet;
use std::fmt;

use nekosim_models::adapter::NetMsg;
use nekosim_models::{build, find, run, CheckModel, Exploration, Options, Outcome, State};
use nekosim_protocols::fifo::{Fifo, FifoMsg};
use nekosim_protocols::lamport::LamportAbcast;
use nekosim_protocols::{
    Ctx, Indication, Layer, LayerIx, Microprotocol, NoConfig, Out, Pid, Request, Service, Shape,
    Stack,
};
use nekosim_protocols::{FieldError, Round, Rounds};
use stateright::actor::{Envelope, Network};
use stateright::{Checker, Expectation, Model, StateRecorder};

use super::opts;

/// A broken Fifo: it numbers what it sends but passes up what arrives at once, in whatever
/// order, while claiming to hold early arrivals back.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct Hasty {
    next: std::collections::BTreeMap<Pid, u64>,
}

impl Microprotocol for Hasty {
    type Msg = FifoMsg;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "Fifo";
    const ROUNDS: Rounds = Rounds::Carried;
    const HOLDS_EARLY: bool = true;

    fn round(m: &FifoMsg) -> Round {
        Round::Carries(m.payload.clone())
    }

    fn shape(_: &NoConfig) -> Shape {
        Shape::on_links(Service::FIFO_P2P)
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_request(&mut self, _ctx: &Ctx, from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Send { to, msg } = req {
            for d in to {
                let seq = self.next.entry(d).or_insert(0);
                let m = FifoMsg {
                    seq: *seq,
                    up: from,
                    payload: msg.clone(),
                };
                out.send(vec![d], m);
                *seq += 1;
            }
        }
    }

    fn on_message(&mut self, _ctx: &Ctx, from: Pid, m: FifoMsg, out: &mut Out<Self>) {
        out.up_to(
            m.up,
            Indication::Deliver {
                from,
                msg: m.payload,
            },
        );
    }

    fn render(m: &FifoMsg, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "FIFO#{}({})", m.seq, m.payload)
    }
}

/// Every reachable state of `model`, by stateright's own breadth-first search.
fn every_state(model: &CheckModel) -> Vec<State> {
    let (recorder, states) = StateRecorder::new_with_accessor();
    model.clone().checker().visitor(recorder).spawn_bfs().join();
    states()
}

/// `s` with its channels read as the multiset of messages they hold.
fn reordering(s: &State) -> State {
    let mut s = s.clone();
    // (Stateright's `iter_all` does not end on a non-empty ordered network.)
    let Network::Ordered(channels) = &s.network else {
        return s;
    };
    let all: Vec<Envelope<NetMsg>> = channels
        .iter()
        .flat_map(|(&(src, dst), queue)| {
            queue.iter().map(move |msg| Envelope {
                src,
                dst,
                msg: msg.clone(),
            })
        })
        .collect();
    s.network = Network::new_unordered_nonduplicating(all);
    s
}

/// What a property can read of `s`: everything but the layers that hold early arrivals and
/// the messages in flight.
fn visible(s: &State) -> State {
    let mut s = s.clone();
    s.network = Network::new_unordered_nonduplicating([]);
    for p in s.actor_states.iter_mut() {
        let p = std::sync::Arc::make_mut(p);
        for layer in p.stack.layers.iter_mut().filter(|l| l.holds_early()) {
            *layer = Layer::new(Fifo::default());
        }
    }
    s
}

/// Searches `model` to the end, settling every property.
fn search(model: &CheckModel) -> Outcome {
    let how = Exploration {
        first_counterexample: false,
        ..Exploration::default()
    };
    run(model.clone(), how)
}

/// The two models of lamport-abcast with `o` after `tweak`: every order of arrival, and each
/// link in send order.
fn models(o: &Options, tweak: impl Fn(Pid, &mut Stack) + Copy) -> (CheckModel, CheckModel) {
    let target = find("lamport-abcast").unwrap().target();
    let every_order = Options {
        defer_early: false,
        ..o.clone()
    };
    let every = build(&target, &every_order, tweak).unwrap();
    let in_order = build(&target, o, tweak).unwrap();
    assert!(!every.cfg.in_send_order && in_order.cfg.in_send_order);
    (every, in_order)
}

/// Whether the visible states of the two models are the same, after checking what holds
/// whatever the layer does: every state in send order is a state of the reordering model.
fn same_visible_states(every: &CheckModel, in_order: &CheckModel) -> (bool, usize, usize) {
    let all: Vec<State> = every_state(every);
    let ordered: Vec<State> = every_state(in_order);
    let all_set: HashSet<&State> = all.iter().collect();
    for s in &ordered {
        assert!(
            all_set.contains(&reordering(s)),
            "a state in send order the reordering model does not reach"
        );
    }
    let a: HashSet<State> = all.iter().map(visible).collect();
    let b: HashSet<State> = ordered.iter().map(visible).collect();
    (a == b, all.len(), ordered.len())
}

/// The same states at rest; the same verdicts; every path found in send order replays on
/// the reordering model and ends in a discovery.
fn same_verdicts_and_rest(every: &CheckModel, in_order: &CheckModel) -> bool {
    let rest = |m: &CheckModel| -> HashSet<State> {
        every_state(m)
            .iter()
            .filter(|s| s.network.len() == 0)
            .map(reordering)
            .collect()
    };
    assert_eq!(rest(every), rest(in_order), "the states at rest");
    let (full, reduced) = (search(every), search(in_order));
    assert!(full.stopped.is_none() && reduced.stopped.is_none());
    for (a, b) in reduced.verdicts.iter().zip(&full.verdicts) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.holds, b.holds, "{}", a.name);
        assert_eq!(a.path.is_some(), b.path.is_some(), "{}", a.name);
    }
    for (i, v) in reduced.verdicts.iter().enumerate() {
        let Some(path) = &v.path else { continue };
        let mut state = every.init_states().remove(0);
        for action in path.clone().into_actions() {
            state = every
                .next_state(&state, action)
                .unwrap_or_else(|| panic!("{}: not a step of the reordering model", v.name));
        }
        let (expectation, condition) = &every.cfg.conditions[i];
        assert_eq!(
            condition(every, &state),
            *expectation == Expectation::Sometimes,
            "{}: the path ends in a discovery",
            v.name
        );
    }
    full.any_fails()
}

#[test]
fn links_in_send_order_reach_what_every_order_reaches() {
    // (processes, requests, states of the reordering model, states in send order)
    let cases = [(3, 2, 4439, 2754), (2, 3, 131, 88)];
    for (n, k, all, ordered) in cases {
        let (every, in_order) = models(&opts(n, k), |_, _| {});
        let (same, a, b) = same_visible_states(&every, &in_order);
        assert!(same, "{n} processes, {k} requests");
        assert_eq!((a, b), (all, ordered), "{n} processes, {k} requests");
        assert!(!same_verdicts_and_rest(&every, &in_order));
    }
}

#[test]
fn a_broken_abcast_fails_the_same_way_in_send_order() {
    let (every, in_order) = models(&opts(3, 2), |_, s| {
        s.layers[1] = Layer::new(LamportAbcast::eager())
    });
    let (same, ..) = same_visible_states(&every, &in_order);
    assert!(same);
    assert!(
        same_verdicts_and_rest(&every, &in_order),
        "total order fails"
    );
}

#[test]
fn a_layer_that_claims_to_hold_but_does_not_is_told_apart() {
    let (every, in_order) = models(&opts(3, 2), |_, s| {
        s.layers[0] = Layer::new(Hasty::default())
    });
    let (same, ..) = same_visible_states(&every, &in_order);
    assert!(!same, "passing early arrivals up at once reaches more");
}
