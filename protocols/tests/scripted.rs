//! Per protocol: scripted inputs give exactly the expected effects; stack wiring is checked.

use nekosim_protocols::consensus::ChandraToueg;
use nekosim_protocols::fifo::Fifo;
use nekosim_protocols::heartbeat::Heartbeat;
use nekosim_protocols::lamport::LamportAbcast;
use nekosim_protocols::omega::Omega;
use nekosim_protocols::rbroadcast::ReliableBroadcast;
use nekosim_protocols::sequencer::FixedSequencer;
use nekosim_protocols::stack::{LayerSpec, ProtocolSpec, Wiring};
use nekosim_protocols::{
    Content, Ctx, Effect, Indication, Microprotocol, MsgId, Out, Real, Request, Wire, NET,
};

fn m(i: i64) -> Wire {
    Wire::app("M", Content::Int(i))
}

fn send(to: Vec<u32>, msg: Wire) -> Effect {
    Effect::Down(Request::Send { to, msg })
}

fn deliver(from: u32, msg: Wire) -> Indication {
    Indication::Deliver { from, msg }
}

fn effects<P: Microprotocol>(
    p: &mut P,
    ctx: Ctx,
    f: impl FnOnce(&mut P, &Ctx, &mut Out),
) -> Vec<Effect> {
    let mut out = Out::new();
    f(p, &ctx, &mut out);
    out.effects
}

const C3: Ctx = Ctx { me: 1, n: 3 };

#[test]
fn fifo_numbers_each_link_and_holds_early_messages() {
    let mut f = Fifo::default();
    let e = effects(&mut f, C3, |f, c, o| {
        f.on_request(
            c,
            7,
            Request::Send {
                to: vec![0, 2],
                msg: m(1),
            },
            o,
        )
    });
    assert_eq!(
        e,
        vec![
            send(
                vec![0],
                Wire::Fifo {
                    seq: 0,
                    up: 7,
                    inner: Box::new(m(1))
                }
            ),
            send(
                vec![2],
                Wire::Fifo {
                    seq: 0,
                    up: 7,
                    inner: Box::new(m(1))
                }
            )
        ]
    );
    // Sequence 1 arrives before 0: held, then both delivered in order.
    let e = effects(&mut f, C3, |f, c, o| {
        f.on_indication(
            c,
            NET,
            deliver(
                0,
                Wire::Fifo {
                    seq: 1,
                    up: 7,
                    inner: Box::new(m(11)),
                },
            ),
            o,
        )
    });
    assert!(e.is_empty());
    let e = effects(&mut f, C3, |f, c, o| {
        f.on_indication(
            c,
            NET,
            deliver(
                0,
                Wire::Fifo {
                    seq: 0,
                    up: 7,
                    inner: Box::new(m(10)),
                },
            ),
            o,
        )
    });
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
fn reliable_broadcast_sends_delivers_and_relays_once() {
    let mut rb = ReliableBroadcast::default();
    let e = effects(&mut rb, C3, |p, c, o| {
        p.on_request(c, 9, Request::Broadcast { msg: m(5) }, o)
    });
    let id = MsgId { origin: 1, n: 0 };
    assert_eq!(
        e,
        vec![
            send(
                vec![0, 2],
                Wire::Rb {
                    id,
                    inner: Box::new(m(5))
                }
            ),
            Effect::Up {
                to: None,
                ind: Indication::BDeliver { id, msg: m(5) }
            }
        ]
    );
    let other = MsgId { origin: 0, n: 3 };
    let rbm = Wire::Rb {
        id: other,
        inner: Box::new(m(6)),
    };
    let e = effects(&mut rb, C3, |p, c, o| {
        p.on_indication(c, NET, deliver(0, rbm.clone()), o)
    });
    assert_eq!(
        e,
        vec![
            send(vec![2], rbm.clone()),
            Effect::Up {
                to: None,
                ind: Indication::BDeliver {
                    id: other,
                    msg: m(6)
                }
            }
        ]
    );
    // A second copy (relayed by process 2) is ignored.
    assert!(effects(&mut rb, C3, |p, c, o| p.on_indication(
        c,
        NET,
        deliver(2, rbm),
        o
    ))
    .is_empty());
}

#[test]
fn lamport_waits_for_every_process_then_delivers_in_timestamp_order() {
    let c = Ctx { me: 0, n: 3 };
    let mut l = LamportAbcast::default();
    let id0 = MsgId { origin: 0, n: 0 };
    let e = effects(&mut l, c, |p, c, o| {
        p.on_request(c, 9, Request::Broadcast { msg: m(1) }, o)
    });
    assert_eq!(
        e,
        vec![send(
            vec![1, 2],
            Wire::LamportMsg {
                ts: 1,
                id: id0,
                inner: Box::new(m(1))
            }
        )]
    );
    // Process 1 broadcast concurrently with the same timestamp: (1, p0) < (1, p1). Nothing
    // can be delivered before process 2 is heard from.
    let id1 = MsgId { origin: 1, n: 0 };
    let e = effects(&mut l, c, |p, c, o| {
        p.on_indication(
            c,
            NET,
            deliver(
                1,
                Wire::LamportMsg {
                    ts: 1,
                    id: id1,
                    inner: Box::new(m(2)),
                },
            ),
            o,
        )
    });
    assert_eq!(e, vec![send(vec![1, 2], Wire::LamportAck { ts: 2 })]);
    // Process 2's ack at time 2 releases both, in (timestamp, origin) order.
    let e = effects(&mut l, c, |p, c, o| {
        p.on_indication(c, NET, deliver(2, Wire::LamportAck { ts: 2 }), o)
    });
    assert_eq!(
        e,
        vec![
            Effect::Up {
                to: None,
                ind: Indication::BDeliver { id: id0, msg: m(1) }
            },
            Effect::Up {
                to: None,
                ind: Indication::BDeliver { id: id1, msg: m(2) }
            }
        ]
    );
}

#[test]
fn sequencer_forwards_then_numbers_in_order() {
    let mut s1 = FixedSequencer::new(0);
    let id = MsgId { origin: 1, n: 0 };
    let e = effects(&mut s1, C3, |p, c, o| {
        p.on_request(c, 9, Request::Broadcast { msg: m(3) }, o)
    });
    assert_eq!(
        e,
        vec![send(
            vec![0],
            Wire::SeqRequest {
                id,
                inner: Box::new(m(3))
            }
        )]
    );
    let mut s0 = FixedSequencer::new(0);
    let c0 = Ctx { me: 0, n: 3 };
    let e = effects(&mut s0, c0, |p, c, o| {
        p.on_indication(
            c,
            NET,
            deliver(
                1,
                Wire::SeqRequest {
                    id,
                    inner: Box::new(m(3)),
                },
            ),
            o,
        )
    });
    assert_eq!(
        e,
        vec![
            send(
                vec![1, 2],
                Wire::SeqOrder {
                    gseq: 0,
                    id,
                    inner: Box::new(m(3))
                }
            ),
            Effect::Up {
                to: None,
                ind: Indication::BDeliver { id, msg: m(3) }
            }
        ]
    );
    // Order 1 before order 0 at a receiver: held until 0 arrives.
    let other = MsgId { origin: 2, n: 0 };
    assert!(effects(&mut s1, C3, |p, c, o| p.on_indication(
        c,
        NET,
        deliver(
            0,
            Wire::SeqOrder {
                gseq: 1,
                id: other,
                inner: Box::new(m(4))
            }
        ),
        o
    ))
    .is_empty());
    let e = effects(&mut s1, C3, |p, c, o| {
        p.on_indication(
            c,
            NET,
            deliver(
                0,
                Wire::SeqOrder {
                    gseq: 0,
                    id,
                    inner: Box::new(m(3)),
                },
            ),
            o,
        )
    });
    assert_eq!(e.len(), 2);
}

#[test]
fn heartbeat_suspects_the_silent_and_trusts_them_again() {
    let mut h = Heartbeat::new(1.0, 3.0);
    let e = effects(&mut h, C3, |p, c, o| p.on_start(c, o));
    assert_eq!(
        e,
        vec![
            send(vec![0, 2], Wire::Heartbeat),
            Effect::SetTimer {
                timer: 1,
                after: Real::new(1.0)
            },
            Effect::SetTimer {
                timer: 2,
                after: Real::new(3.0)
            }
        ]
    );
    effects(&mut h, C3, |p, c, o| {
        p.on_indication(c, NET, deliver(0, Wire::Heartbeat), o)
    });
    let e = effects(&mut h, C3, |p, c, o| p.on_timer(c, 2, o));
    assert_eq!(
        e,
        vec![
            Effect::Up {
                to: None,
                ind: Indication::Suspect(2)
            },
            Effect::SetTimer {
                timer: 2,
                after: Real::new(3.0)
            }
        ]
    );
    effects(&mut h, C3, |p, c, o| {
        p.on_indication(c, NET, deliver(2, Wire::Heartbeat), o)
    });
    let e = effects(&mut h, C3, |p, c, o| p.on_timer(c, 2, o));
    assert_eq!(
        e,
        vec![
            Effect::Up {
                to: None,
                ind: Indication::Suspect(0)
            },
            Effect::Up {
                to: None,
                ind: Indication::Trust(2)
            },
            Effect::SetTimer {
                timer: 2,
                after: Real::new(3.0)
            }
        ]
    );
}

#[test]
fn omega_elects_the_lowest_unsuspected_process() {
    let mut w = Omega::default();
    assert_eq!(
        effects(&mut w, C3, |p, c, o| p.on_start(c, o)),
        vec![Effect::Up {
            to: None,
            ind: Indication::Leader(0)
        }]
    );
    assert_eq!(
        effects(&mut w, C3, |p, c, o| p.on_indication(
            c,
            0,
            Indication::Suspect(0),
            o
        )),
        vec![Effect::Up {
            to: None,
            ind: Indication::Leader(1)
        }]
    );
    assert!(effects(&mut w, C3, |p, c, o| p.on_indication(
        c,
        0,
        Indication::Suspect(2),
        o
    ))
    .is_empty());
}

#[test]
fn chandra_toueg_round_zero_goes_to_coordinator_zero() {
    let mut ct = ChandraToueg::default();
    let e = effects(&mut ct, C3, |p, c, o| {
        p.on_request(c, 9, Request::Propose { k: 4, value: m(8) }, o)
    });
    assert_eq!(
        e,
        vec![send(
            vec![0],
            Wire::CtEstimate {
                k: 4,
                r: 0,
                est: Box::new(m(8)),
                ts: 0
            }
        )]
    );
    // Suspecting the coordinator: nack, then estimate to round 1's coordinator (itself): it
    // has one estimate of the two it needs, so nothing more.
    let e = effects(&mut ct, C3, |p, c, o| {
        p.on_indication(c, 0, Indication::Suspect(0), o)
    });
    assert_eq!(e, vec![send(vec![0], Wire::CtNack { k: 4, r: 0 })]);
}

#[test]
fn chandra_toueg_indicates_a_decision_once_even_when_proposing_afterwards() {
    let mut ct = ChandraToueg::default();
    // The decision of instance 2 arrives from p0 before p1 proposes: relay to p2, decide.
    let e = effects(&mut ct, C3, |p, c, o| {
        p.on_indication(
            c,
            0,
            deliver(
                0,
                Wire::CtDecide {
                    k: 2,
                    value: Box::new(m(5)),
                },
            ),
            o,
        )
    });
    assert_eq!(
        e,
        vec![
            send(
                vec![2],
                Wire::CtDecide {
                    k: 2,
                    value: Box::new(m(5))
                }
            ),
            Effect::Up {
                to: None,
                ind: Indication::Decide { k: 2, value: m(5) }
            }
        ]
    );
    // Proposing afterwards, or hearing the decision again, does nothing more.
    let e = effects(&mut ct, C3, |p, c, o| {
        p.on_request(c, 9, Request::Propose { k: 2, value: m(7) }, o)
    });
    assert_eq!(e, vec![]);
    let e = effects(&mut ct, C3, |p, c, o| {
        p.on_indication(
            c,
            0,
            deliver(
                2,
                Wire::CtDecide {
                    k: 2,
                    value: Box::new(m(5)),
                },
            ),
            o,
        )
    });
    assert_eq!(e, vec![]);
}

fn layer(id: &str, protocol: ProtocolSpec, below: &str, uses: &[&str]) -> LayerSpec {
    LayerSpec::new(id, protocol, below, uses)
}

#[test]
fn wiring_mistakes_are_named() {
    let e =
        Wiring::check(&[layer("abcast", ProtocolSpec::LamportAbcast, "fifo", &[])]).unwrap_err();
    assert_eq!((e.layer, e.field), (0, "below"));
    assert!(e.message.contains("unknown layer \"fifo\""), "{e}");
    let e = Wiring::check(&[layer("abcast", ProtocolSpec::LamportAbcast, "net", &[])]).unwrap_err();
    assert!(
        e.message
            .contains("needs FIFO point-to-point messages below it"),
        "{e}"
    );
    let e = Wiring::check(&[
        layer("a", ProtocolSpec::Fifo, "b", &[]),
        layer("b", ProtocolSpec::Fifo, "a", &[]),
    ])
    .unwrap_err();
    assert!(e.message.contains("cycle"), "{e}");
    let e = Wiring::check(&[layer("c", ProtocolSpec::ChandraToueg, "net", &[])]).unwrap_err();
    assert_eq!(e.field, "uses");
    let e = Wiring::check(&[layer(
        "fd",
        ProtocolSpec::Heartbeat {
            period: 2.0,
            timeout: 1.0,
        },
        "net",
        &[],
    )])
    .unwrap_err();
    assert_eq!(e.field, "protocol");
    let e = Wiring::check(&[
        layer("x", ProtocolSpec::Fifo, "net", &[]),
        layer("x", ProtocolSpec::Fifo, "net", &[]),
    ])
    .unwrap_err();
    assert_eq!((e.layer, e.field), (1, "id"));
    let ok = Wiring::check(&[
        layer(
            "fd",
            ProtocolSpec::Heartbeat {
                period: 1.0,
                timeout: 3.0,
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
    ])
    .unwrap();
    assert_eq!(ok.app_hears, vec![false, false, false, true]);
}

#[test]
fn retransmit_numbers_per_destination_acks_and_resends_until_acked() {
    use nekosim_protocols::retransmit::Retransmit;
    let mut rt = Retransmit::new(2.0);
    let data = |seq, i| Wire::RtData {
        seq,
        up: 5,
        inner: Box::new(m(i)),
    };
    let e = effects(&mut rt, C3, |p, c, o| {
        p.on_request(
            c,
            5,
            Request::Send {
                to: vec![0, 2],
                msg: m(1),
            },
            o,
        )
    });
    assert_eq!(
        e,
        vec![
            send(vec![0], data(0, 1)),
            send(vec![2], data(0, 1)),
            Effect::SetTimer {
                timer: 1,
                after: Real::new(2.0)
            }
        ]
    );
    // p0 acknowledges; the timer resends only to p2 and re-arms.
    let e = effects(&mut rt, C3, |p, c, o| {
        p.on_indication(c, NET, deliver(0, Wire::RtAck { seq: 0 }), o)
    });
    assert_eq!(e, vec![]);
    let e = effects(&mut rt, C3, |p, c, o| p.on_timer(c, 1, o));
    assert_eq!(
        e,
        vec![
            send(vec![2], data(0, 1)),
            Effect::SetTimer {
                timer: 1,
                after: Real::new(2.0)
            }
        ]
    );
    // Once everything is acknowledged, the timer stops.
    effects(&mut rt, C3, |p, c, o| {
        p.on_indication(c, NET, deliver(2, Wire::RtAck { seq: 0 }), o)
    });
    assert_eq!(effects(&mut rt, C3, |p, c, o| p.on_timer(c, 1, o)), vec![]);
    // Receiving: ack every copy, deliver once, to the layer that sent it.
    for round in 0..2 {
        let e = effects(&mut rt, C3, |p, c, o| {
            p.on_indication(c, NET, deliver(2, data(0, 9)), o)
        });
        let mut want = vec![send(vec![2], Wire::RtAck { seq: 0 })];
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
    use nekosim_protocols::consensus_abcast::ConsensusAbcast;
    let mut ab = ConsensusAbcast::default();
    let id = |origin, n| MsgId { origin, n };
    // A broadcast goes down to the reliable broadcast layer.
    let e = effects(&mut ab, C3, |p, c, o| {
        p.on_request(c, 9, Request::Broadcast { msg: m(1) }, o)
    });
    assert_eq!(e, vec![Effect::Down(Request::Broadcast { msg: m(1) })]);
    // R-delivered messages are proposed to instance 0; a second waits for the decision.
    let e = effects(&mut ab, C3, |p, c, o| {
        p.on_indication(
            c,
            0,
            Indication::BDeliver {
                id: id(2, 0),
                msg: m(20),
            },
            o,
        )
    });
    let propose = |k, batch: Vec<(MsgId, Wire)>| Effect::Use {
        slot: 0,
        req: Request::Propose {
            k,
            value: Wire::Batch(batch),
        },
    };
    assert_eq!(e, vec![propose(0, vec![(id(2, 0), m(20))])]);
    let e = effects(&mut ab, C3, |p, c, o| {
        p.on_indication(
            c,
            0,
            Indication::BDeliver {
                id: id(1, 0),
                msg: m(10),
            },
            o,
        )
    });
    assert_eq!(e, vec![]);
    // Instance 1's decision arrives early: kept until instance 0 decides.
    let e = effects(&mut ab, C3, |p, c, o| {
        p.on_indication(
            c,
            1,
            Indication::Decide {
                k: 1,
                value: Wire::Batch(vec![(id(1, 0), m(10))]),
            },
            o,
        )
    });
    assert_eq!(e, vec![]);
    // Instance 0 decides another process's batch: deliver it in id order, then instance 1's.
    let e = effects(&mut ab, C3, |p, c, o| {
        p.on_indication(
            c,
            1,
            Indication::Decide {
                k: 0,
                value: Wire::Batch(vec![(id(2, 0), m(20)), (id(0, 0), m(0))]),
            },
            o,
        )
    });
    let bd = |i: MsgId, msg| Effect::Up {
        to: None,
        ind: Indication::BDeliver { id: i, msg },
    };
    assert_eq!(
        e,
        vec![bd(id(0, 0), m(0)), bd(id(2, 0), m(20)), bd(id(1, 0), m(10)),]
    );
    // A late R-delivery of something already ordered is ignored.
    let e = effects(&mut ab, C3, |p, c, o| {
        p.on_indication(
            c,
            0,
            Indication::BDeliver {
                id: id(0, 0),
                msg: m(0),
            },
            o,
        )
    });
    assert_eq!(e, vec![]);
}
