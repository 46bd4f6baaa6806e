//! Per protocol: scripted inputs give exactly the expected effects; stack wiring and the
//! protocols' configurations are checked.

use nekosim_protocols::consensus::{ChandraToueg, CtMsg};
use nekosim_protocols::consensus_abcast::{Batch, ConsensusAbcast};
use nekosim_protocols::fifo::{Fifo, FifoMsg};
use nekosim_protocols::heartbeat::{Beat, Heartbeat, HeartbeatTimer};
use nekosim_protocols::lamport::{LamportAbcast, LamportMsg};
use nekosim_protocols::omega::Omega;
use nekosim_protocols::protocol::dispatch;
use nekosim_protocols::rbroadcast::{RbMsg, ReliableBroadcast};
use nekosim_protocols::retransmit::{Retransmit, RtMsg};
use nekosim_protocols::sequencer::{FixedSequencer, SeqMsg};
use nekosim_protocols::{
    AppMsg, Content, Ctx, Effect, Indication, Input, LayerIx, LayerSpec, Microprotocol, MsgId, Out,
    Payload, Pid, Protocols, Real, Request, Routed, StackError, Wiring, APP, NET,
};
use serde::Serialize;

/// The index of the layer under test in its (imaginary) stack: not 0, so a payload tagged
/// with the wrong layer shows.
const IX: LayerIx = 3;

const C3: Ctx = Ctx { me: 1, n: 3 };

/// The application's message `M i`.
fn m(i: i64) -> Payload {
    AppMsg::new("M", Content::Int(i)).payload()
}

/// The layer under test sends `msg` (one of its own messages) to `to`.
fn send<M: Serialize>(to: Vec<Pid>, msg: &M) -> Effect {
    Effect::Down(Request::Send {
        to,
        msg: Payload::encode(IX, msg),
    })
}

/// The layer under test sets its timer `timer` to fire after `after` seconds.
fn set_timer<T: Serialize>(timer: &T, after: f64) -> Effect {
    Effect::SetTimer {
        timer: Payload::encode(IX, timer),
        after: Real::new(after),
    }
}

/// An indication to every layer above.
fn up(ind: Indication) -> Effect {
    Effect::Up { to: None, ind }
}

fn deliver(from: Pid, msg: Payload) -> Indication {
    Indication::Deliver { from, msg }
}

/// A protocol instance at index [`IX`] of process `ctx.me`, driven through [`dispatch`]
/// exactly as a stack drives it.
struct Script<P> {
    p: P,
    ctx: Ctx,
}

impl<P: Microprotocol> Script<P> {
    fn new(p: P, ctx: Ctx) -> Self {
        Self { p, ctx }
    }

    fn input(&mut self, input: Input) -> Vec<Effect> {
        dispatch(&mut self.p, &self.ctx, IX, input).expect("the test's payloads decode")
    }

    fn start(&mut self) -> Vec<Effect> {
        self.input(Input::Start)
    }

    fn request(&mut self, from: LayerIx, req: Request) -> Vec<Effect> {
        self.input(Input::Request { from, req })
    }

    /// One of the layer's own messages arrives from process `from` through the network.
    fn receive(&mut self, from: Pid, msg: &P::Msg) -> Vec<Effect> {
        self.input(Input::Indication {
            from: NET,
            ind: deliver(from, Payload::encode(IX, msg)),
        })
    }

    fn indication(&mut self, from: LayerIx, ind: Indication) -> Vec<Effect> {
        self.input(Input::Indication { from, ind })
    }

    fn timer(&mut self, timer: &P::Timer) -> Vec<Effect> {
        self.input(Input::Timer(Payload::encode(IX, timer)))
    }
}

/// Runs a typed handler directly, with an [`Out`] for the layer at `ix`.
fn effects<P: Microprotocol>(
    p: &mut P,
    ctx: Ctx,
    ix: LayerIx,
    f: impl FnOnce(&mut P, &Ctx, &mut Out<P>),
) -> Vec<Effect> {
    let mut out = Out::<P>::new(ix);
    f(p, &ctx, &mut out);
    out.into_effects()
}

#[test]
fn fifo_numbers_each_link_and_holds_early_messages() {
    let mut f = Script::new(Fifo::default(), C3);
    let e = f.request(
        7,
        Request::Send {
            to: vec![0, 2],
            msg: m(1),
        },
    );
    let fifo = |seq, payload| FifoMsg {
        seq,
        up: 7,
        payload,
    };
    assert_eq!(
        e,
        vec![send(vec![0], &fifo(0, m(1))), send(vec![2], &fifo(0, m(1)))]
    );
    // Sequence 1 arrives before 0: held, then both delivered in order.
    assert!(f.receive(0, &fifo(1, m(11))).is_empty());
    let e = f.receive(0, &fifo(0, m(10)));
    assert_eq!(
        e,
        vec![
            Effect::Up {
                to: Some(7),
                ind: deliver(0, m(10))
            },
            Effect::Up {
                to: Some(7),
                ind: deliver(0, m(11))
            }
        ]
    );
}

#[test]
fn dispatch_decodes_own_messages_and_passes_other_payloads_on() {
    // The typed handler called directly and the untyped input through `dispatch` agree.
    let msg = FifoMsg {
        seq: 0,
        up: 7,
        payload: m(1),
    };
    let mut a = Fifo::default();
    let direct = effects(&mut a, C3, IX, |p, c, o| p.on_message(c, 0, msg.clone(), o));
    let mut b = Script::new(Fifo::default(), C3);
    assert_eq!(direct, b.receive(0, &msg));
    assert_eq!(a, b.p);
    // A delivery of another layer's payload is an ordinary indication (Fifo ignores it).
    assert!(b
        .indication(NET, deliver(0, Payload::encode(IX + 1, &msg)))
        .is_empty());
    assert_eq!(a, b.p);
    // Bytes tagged with the layer's index that are not one of its messages are refused and
    // change nothing.
    let garbage = Input::Indication {
        from: NET,
        ind: deliver(0, Payload::from_parts(IX, &[0xff, 0xff, 0xff])),
    };
    assert!(dispatch(&mut b.p, &C3, IX, garbage).is_err());
    assert_eq!(a, b.p);
}

#[test]
fn reliable_broadcast_sends_delivers_and_relays_once() {
    let mut rb = Script::new(ReliableBroadcast::default(), C3);
    let e = rb.request(9, Request::Broadcast { msg: m(5) });
    let id = MsgId { origin: 1, n: 0 };
    assert_eq!(
        e,
        vec![
            send(vec![0, 2], &RbMsg { id, payload: m(5) }),
            up(Indication::BDeliver { id, msg: m(5) })
        ]
    );
    let other = MsgId { origin: 0, n: 3 };
    let rbm = RbMsg {
        id: other,
        payload: m(6),
    };
    let e = rb.receive(0, &rbm);
    assert_eq!(
        e,
        vec![
            send(vec![2], &rbm),
            up(Indication::BDeliver {
                id: other,
                msg: m(6)
            })
        ]
    );
    // A second copy (relayed by process 2) is ignored.
    assert!(rb.receive(2, &rbm).is_empty());
}

#[test]
fn lamport_waits_for_every_process_then_delivers_in_timestamp_order() {
    let c = Ctx { me: 0, n: 3 };
    let mut l = Script::new(LamportAbcast::default(), c);
    let id0 = MsgId { origin: 0, n: 0 };
    let e = l.request(9, Request::Broadcast { msg: m(1) });
    assert_eq!(
        e,
        vec![send(
            vec![1, 2],
            &LamportMsg::Msg {
                ts: 1,
                id: id0,
                payload: m(1)
            }
        )]
    );
    // Process 1 broadcast concurrently with the same timestamp: (1, p0) < (1, p1). Nothing
    // can be delivered before process 2 is heard from.
    let id1 = MsgId { origin: 1, n: 0 };
    let e = l.receive(
        1,
        &LamportMsg::Msg {
            ts: 1,
            id: id1,
            payload: m(2),
        },
    );
    assert_eq!(e, vec![send(vec![1, 2], &LamportMsg::Ack { ts: 2 })]);
    // Process 2's ack at time 2 releases both, in (timestamp, origin) order.
    let e = l.receive(2, &LamportMsg::Ack { ts: 2 });
    assert_eq!(
        e,
        vec![
            up(Indication::BDeliver { id: id0, msg: m(1) }),
            up(Indication::BDeliver { id: id1, msg: m(2) })
        ]
    );
}

#[test]
fn sequencer_forwards_then_numbers_in_order() {
    let mut s1 = Script::new(FixedSequencer::with_sequencer(0), C3);
    let id = MsgId { origin: 1, n: 0 };
    let e = s1.request(9, Request::Broadcast { msg: m(3) });
    assert_eq!(
        e,
        vec![send(vec![0], &SeqMsg::Request { id, payload: m(3) })]
    );
    let mut s0 = Script::new(FixedSequencer::with_sequencer(0), Ctx { me: 0, n: 3 });
    let e = s0.receive(1, &SeqMsg::Request { id, payload: m(3) });
    assert_eq!(
        e,
        vec![
            send(
                vec![1, 2],
                &SeqMsg::Order {
                    gseq: 0,
                    id,
                    payload: m(3)
                }
            ),
            up(Indication::BDeliver { id, msg: m(3) })
        ]
    );
    // Order 1 before order 0 at a receiver: held until 0 arrives.
    let other = MsgId { origin: 2, n: 0 };
    assert!(s1
        .receive(
            0,
            &SeqMsg::Order {
                gseq: 1,
                id: other,
                payload: m(4)
            }
        )
        .is_empty());
    let e = s1.receive(
        0,
        &SeqMsg::Order {
            gseq: 0,
            id,
            payload: m(3),
        },
    );
    assert_eq!(
        e,
        vec![
            up(Indication::BDeliver { id, msg: m(3) }),
            up(Indication::BDeliver {
                id: other,
                msg: m(4)
            })
        ]
    );
}

#[test]
fn heartbeat_suspects_the_silent_and_trusts_them_again() {
    let mut h = Script::new(Heartbeat::with_timing(1.0, 3.0), C3);
    let e = h.start();
    assert_eq!(
        e,
        vec![
            send(vec![0, 2], &Beat),
            set_timer(&HeartbeatTimer::Beat, 1.0),
            set_timer(&HeartbeatTimer::Check, 3.0)
        ]
    );
    assert!(h.receive(0, &Beat).is_empty());
    let e = h.timer(&HeartbeatTimer::Check);
    assert_eq!(
        e,
        vec![
            up(Indication::Suspect(2)),
            set_timer(&HeartbeatTimer::Check, 3.0)
        ]
    );
    assert_eq!(h.p.suspected().iter().copied().collect::<Vec<_>>(), [2]);
    assert!(h.receive(2, &Beat).is_empty());
    let e = h.timer(&HeartbeatTimer::Check);
    assert_eq!(
        e,
        vec![
            up(Indication::Suspect(0)),
            up(Indication::Trust(2)),
            set_timer(&HeartbeatTimer::Check, 3.0)
        ]
    );
    // The beat timer sends the next heartbeat and re-arms.
    assert_eq!(
        h.timer(&HeartbeatTimer::Beat),
        vec![
            send(vec![0, 2], &Beat),
            set_timer(&HeartbeatTimer::Beat, 1.0)
        ]
    );
}

#[test]
fn omega_elects_the_lowest_unsuspected_process() {
    let mut w = Script::new(Omega::default(), C3);
    assert_eq!(w.start(), vec![up(Indication::Leader(0))]);
    assert_eq!(
        w.indication(0, Indication::Suspect(0)),
        vec![up(Indication::Leader(1))]
    );
    assert!(w.indication(0, Indication::Suspect(2)).is_empty());
}

#[test]
fn chandra_toueg_round_zero_goes_to_coordinator_zero() {
    let mut ct = Script::new(ChandraToueg::default(), C3);
    let e = ct.request(9, Request::Propose { k: 4, value: m(8) });
    assert_eq!(
        e,
        vec![send(
            vec![0],
            &CtMsg::Estimate {
                k: 4,
                r: 0,
                est: m(8),
                ts: 0
            }
        )]
    );
    // Suspecting the coordinator: nack, then estimate to round 1's coordinator (itself): it
    // has one estimate of the two it needs, so nothing more.
    let e = ct.indication(0, Indication::Suspect(0));
    assert_eq!(e, vec![send(vec![0], &CtMsg::Nack { k: 4, r: 0 })]);
}

#[test]
fn chandra_toueg_indicates_a_decision_once_even_when_proposing_afterwards() {
    let mut ct = Script::new(ChandraToueg::default(), C3);
    // The decision of instance 2 arrives from p0 before p1 proposes: relay to p2, decide.
    let decision = CtMsg::Decide { k: 2, value: m(5) };
    let e = ct.receive(0, &decision);
    assert_eq!(
        e,
        vec![
            send(vec![2], &decision),
            up(Indication::Decide { k: 2, value: m(5) })
        ]
    );
    // Proposing afterwards, or hearing the decision again, does nothing more.
    let e = ct.request(9, Request::Propose { k: 2, value: m(7) });
    assert_eq!(e, vec![]);
    let e = ct.receive(2, &decision);
    assert_eq!(e, vec![]);
}

#[test]
fn retransmit_numbers_per_destination_acks_and_resends_until_acked() {
    let mut rt = Script::new(Retransmit::with_period(2.0), C3);
    let data = |seq, i| RtMsg::Data {
        seq,
        up: 5,
        payload: m(i),
    };
    let e = rt.request(
        5,
        Request::Send {
            to: vec![0, 2],
            msg: m(1),
        },
    );
    assert_eq!(
        e,
        vec![
            send(vec![0], &data(0, 1)),
            send(vec![2], &data(0, 1)),
            set_timer(&(), 2.0)
        ]
    );
    // p0 acknowledges; the timer resends only to p2 and re-arms.
    let e = rt.receive(0, &RtMsg::Ack { seq: 0 });
    assert_eq!(e, vec![]);
    let e = rt.timer(&());
    assert_eq!(e, vec![send(vec![2], &data(0, 1)), set_timer(&(), 2.0)]);
    // Once everything is acknowledged, the timer stops.
    rt.receive(2, &RtMsg::Ack { seq: 0 });
    assert_eq!(rt.timer(&()), vec![]);
    // Receiving: ack every copy, deliver once, to the layer that sent it.
    for round in 0..2 {
        let e = rt.receive(2, &data(0, 9));
        let mut want = vec![send(vec![2], &RtMsg::Ack { seq: 0 })];
        if round == 0 {
            want.push(Effect::Up {
                to: Some(5),
                ind: deliver(2, m(9)),
            });
        }
        assert_eq!(e, want, "copy {round}");
    }
}

#[test]
fn consensus_abcast_proposes_pending_batches_and_delivers_decisions_in_order() {
    let mut ab = Script::new(ConsensusAbcast::default(), C3);
    let id = |origin, n| MsgId { origin, n };
    let batch = |b: Vec<(MsgId, Payload)>| Payload::encode(IX, &Batch(b));
    // A broadcast goes down to the reliable broadcast layer.
    let e = ab.request(9, Request::Broadcast { msg: m(1) });
    assert_eq!(e, vec![Effect::Down(Request::Broadcast { msg: m(1) })]);
    // R-delivered messages are proposed to instance 0; a second waits for the decision.
    let e = ab.indication(
        0,
        Indication::BDeliver {
            id: id(2, 0),
            msg: m(20),
        },
    );
    let propose = |k, b: Vec<(MsgId, Payload)>| Effect::Use {
        slot: 0,
        req: Request::Propose { k, value: batch(b) },
    };
    assert_eq!(e, vec![propose(0, vec![(id(2, 0), m(20))])]);
    let e = ab.indication(
        0,
        Indication::BDeliver {
            id: id(1, 0),
            msg: m(10),
        },
    );
    assert_eq!(e, vec![]);
    // Instance 1's decision arrives early: kept until instance 0 decides.
    let e = ab.indication(
        1,
        Indication::Decide {
            k: 1,
            value: batch(vec![(id(1, 0), m(10))]),
        },
    );
    assert_eq!(e, vec![]);
    // Instance 0 decides another process's batch: deliver it in id order, then instance 1's.
    let e = ab.indication(
        1,
        Indication::Decide {
            k: 0,
            value: batch(vec![(id(2, 0), m(20)), (id(0, 0), m(0))]),
        },
    );
    let bd = |i: MsgId, msg| up(Indication::BDeliver { id: i, msg });
    assert_eq!(
        e,
        vec![bd(id(0, 0), m(0)), bd(id(2, 0), m(20)), bd(id(1, 0), m(10)),]
    );
    // A late R-delivery of something already ordered is ignored.
    let e = ab.indication(
        0,
        Indication::BDeliver {
            id: id(0, 0),
            msg: m(0),
        },
    );
    assert_eq!(e, vec![]);
}

fn layer(id: &str, protocol: &str, below: &str, uses: &[&str]) -> LayerSpec {
    LayerSpec::new(id, protocol, below, uses)
}

fn check(specs: &[LayerSpec]) -> Result<Wiring, StackError> {
    Wiring::check(specs, &Protocols::with_builtins()).map(|(w, _)| w)
}

#[test]
fn wiring_mistakes_are_named() {
    let e = check(&[layer("abcast", "LamportAbcast", "fifo", &[])]).unwrap_err();
    assert_eq!((e.layer, e.field.as_str()), (0, "below"));
    assert!(e.message.contains("unknown layer \"fifo\""), "{e}");
    let e = check(&[layer("abcast", "LamportAbcast", "net", &[])]).unwrap_err();
    assert_eq!((e.layer, e.field.as_str()), (0, "below"));
    assert!(
        e.message
            .contains("needs FIFO point-to-point messages below it"),
        "{e}"
    );
    let e = check(&[layer("a", "Fifo", "b", &[]), layer("b", "Fifo", "a", &[])]).unwrap_err();
    assert!(e.message.contains("cycle"), "{e}");
    let e = check(&[layer("c", "ChandraToueg", "net", &[])]).unwrap_err();
    assert_eq!(e.field, "uses");
    let e = check(&[layer(
        "fd",
        "Heartbeat(period: 2.0, timeout: 1.0)",
        "net",
        &[],
    )])
    .unwrap_err();
    assert_eq!((e.layer, e.field.as_str()), (0, "protocol.timeout"));
    assert!(e.message.contains("timeout"), "{e}");
    let e = check(&[
        layer("x", "Fifo", "net", &[]),
        layer("x", "Fifo", "net", &[]),
    ])
    .unwrap_err();
    assert_eq!((e.layer, e.field.as_str()), (1, "id"));
    let ok = check(&[
        layer("fd", "Heartbeat(period: 1.0, timeout: 3.0)", "net", &[]),
        layer("rb", "ReliableBroadcast", "net", &[]),
        layer("consensus", "ChandraToueg", "net", &["fd"]),
        layer("abcast", "ConsensusAbcast", "rb", &["consensus"]),
    ])
    .unwrap();
    assert_eq!(ok.app_hears, vec![false, false, false, true]);
}

#[test]
fn the_checked_stack_holds_fresh_instances_of_the_named_protocols() {
    let (wiring, stack) = Wiring::check(
        &[
            layer("rt", "Retransmit(period: 0.5)", "net", &[]),
            layer("fifo", "Fifo()", "rt", &[]),
            layer("abcast", "FixedSequencer(sequencer: 2)", "fifo", &[]),
        ],
        &Protocols::with_builtins(),
    )
    .unwrap();
    assert_eq!(wiring.index("abcast"), Some(2));
    assert_eq!(stack.layers.len(), 3);
    assert_eq!(
        stack.layers[0].downcast_ref::<Retransmit>(),
        Some(&Retransmit::with_period(0.5))
    );
    assert_eq!(
        stack.layers[1].downcast_ref::<Fifo>(),
        Some(&Fifo::default())
    );
    assert_eq!(
        stack.layers[2].downcast_ref::<FixedSequencer>(),
        Some(&FixedSequencer::with_sequencer(2))
    );
    assert!(stack.layers[2].downcast_ref::<Fifo>().is_none());
}

/// 1-based line and column of the first occurrence of `word` in `text`.
fn position(text: &str, word: &str) -> (usize, usize) {
    let at = text.find(word).expect("word in text");
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let col = at - before.rfind('\n').map_or(0, |nl| nl + 1) + 1;
    (line, col)
}

/// Two ways to misspell `period`: on the spec's one line, and on a later line.
const MISSPELLED: [&str; 2] = [
    "Retransmit(period: 1.0, perod: 2.0)",
    "Retransmit(\n    period: 1.0,\n    perod: 2.0,\n)",
];

#[test]
fn a_built_in_unknown_parameter_is_refused_naming_it_and_its_line() {
    for text in MISSPELLED {
        let e = check(&[layer("rt", text, "net", &[])]).unwrap_err();
        assert_eq!((e.layer, e.field.as_str()), (0, "protocol"), "{text}");
        assert!(e.message.contains("`perod`"), "{e}");
        assert!(e.message.contains("`period`"), "{e}");
        let (line, col) = e.at.expect("a position");
        let (want_line, want_col) = position(text, "perod");
        assert_eq!(line, want_line, "{text}: {e}");
        // On the misspelt word (its first column, or the one just after it, where ron
        // stops reading it; see `a_built_in_unknown_parameter_is_pointed_at`).
        assert!(
            (want_col..=want_col + "perod".len()).contains(&col),
            "{text}: column {col}, the word starts at {want_col}"
        );
    }
}

/// The column names the unknown field's first character, as an editor would highlight it.
#[test]
fn a_built_in_unknown_parameter_is_pointed_at() {
    for text in MISSPELLED {
        let e = check(&[layer("rt", text, "net", &[])]).unwrap_err();
        assert_eq!(e.at, Some(position(text, "perod")), "{text}: {e}");
    }
    let text = MISSPELLED[0];
    let e = check(&[layer("rt", text, "net", &[])]).unwrap_err();
    assert_eq!(e.at, Some((1, text.find("perod").unwrap() + 1)));
    let text = "Fifo(x: 1)";
    let e = check(&[layer("fifo", text, "net", &[])]).unwrap_err();
    assert_eq!(e.at, Some((1, text.find('x').unwrap() + 1)), "{e}");
}

#[test]
fn built_in_configurations_are_checked() {
    // A value the protocol refuses names the field.
    let e = check(&[layer(
        "fd",
        "Heartbeat(period: 2.0, timeout: 1.0)",
        "net",
        &[],
    )])
    .unwrap_err();
    assert_eq!(e.field, "protocol.timeout");
    assert_eq!(e.at, None);
    assert!(e.message.starts_with("Heartbeat: "), "{e}");
    let e = check(&[layer("rt", "Retransmit(period: -1.0)", "net", &[])]).unwrap_err();
    assert_eq!(e.field, "protocol.period");
    assert!(e.message.contains("period"), "{e}");
    // A missing field.
    let e = check(&[layer("rt", "Retransmit", "net", &[])]).unwrap_err();
    assert_eq!(e.field, "protocol");
    assert!(e.message.contains("period"), "{e}");
    // A protocol without configuration refuses any field.
    let e = check(&[layer("fifo", "Fifo(x: 1)", "net", &[])]).unwrap_err();
    assert_eq!((e.layer, e.field.as_str()), (0, "protocol"));
    assert!(e.message.contains("`x`"), "{e}");
    assert!(e.message.contains("no configuration"), "{e}");
    assert_eq!(e.at.map(|(line, _)| line), Some(1));
    // But takes none, written either way.
    for ok in ["Fifo", "Fifo()"] {
        assert!(check(&[layer("fifo", ok, "net", &[])]).is_ok(), "{ok}");
    }
}

#[test]
fn an_unknown_protocol_is_refused_with_the_registered_names() {
    let e = check(&[
        layer("fifo", "Fifo", "net", &[]),
        layer("x", "Nope(a: 1)", "fifo", &[]),
    ])
    .unwrap_err();
    assert_eq!((e.layer, e.field.as_str()), (1, "protocol"));
    assert!(e.message.contains("unknown protocol \"Nope\""), "{e}");
    for name in [
        "ChandraToueg",
        "ConsensusAbcast",
        "Fifo",
        "FixedSequencer",
        "Heartbeat",
        "LamportAbcast",
        "Omega",
        "ReliableBroadcast",
        "Retransmit",
    ] {
        assert!(e.message.contains(name), "{name} missing in: {e}");
    }
}

#[test]
fn step_local_with_tells_every_hop_between_layers_and_refuses_a_foreign_payload_unchanged() {
    let specs = [
        layer("fifo", "Fifo", "net", &[]),
        layer("abcast", "LamportAbcast", "fifo", &[]),
    ];
    let (wiring, mut stack) = Wiring::check(&specs, &Protocols::with_builtins()).unwrap();
    let ctx = Ctx { me: 0, n: 2 };
    let mut plain = stack.clone();
    let broadcast = Input::Request {
        from: APP,
        req: Request::Broadcast { msg: m(1) },
    };
    let mut hops = Vec::new();
    let out = stack
        .step_local_with(&wiring, &ctx, 1, broadcast.clone(), |to, input| {
            hops.push((to, input.clone()))
        })
        .unwrap();
    // The same run as `step_local`'s, to the same state.
    assert_eq!(out, plain.step_local(&wiring, &ctx, 1, broadcast));
    assert_eq!(stack, plain);
    // Lamport hands its message to fifo, and fifo sends it over the network.
    assert!(!hops.is_empty());
    for (to, input) in &hops {
        assert_eq!(*to, 0, "{input:?}");
        assert!(
            matches!(
                input,
                Input::Request {
                    from: 1,
                    req: Request::Send { .. }
                }
            ),
            "{input:?}"
        );
    }
    assert!(out
        .iter()
        .any(|r| matches!(r, Routed::Net { layer: 0, .. })));

    // Bytes from elsewhere that are not a fifo message: refused, nothing run, nothing changed.
    let before = stack.clone();
    let junk = Input::Indication {
        from: NET,
        ind: deliver(1, Payload::from_parts(0, &[0xff; 3])),
    };
    let mut told = 0;
    let refused = stack.step_local_with(&wiring, &ctx, 0, junk, |_, _| told += 1);
    assert!(refused.is_err(), "{refused:?}");
    assert_eq!(told, 0);
    assert_eq!(stack, before);
}
