//! The round bound is a declaration any protocol can make (`Microprotocol::ROUNDS` and
//! `round`), not a list of built-ins: a protocol written here that plays ping-pong in rounds
//! without end is explored exhaustively once it declares its rounds, directly on the network
//! and through the built-in `Fifo`'s headers, and without the declaration the same search
//! never ends on its own.

use nekosim_models::{
    build_in, run, Budget, Exploration, Family, Options, Outcome, Stopped, Target,
};
use nekosim_protocols::{
    Ctx, FieldError, Indication, LayerIx, LayerSpec, Microprotocol, MsgId, NoConfig, Out, Payload,
    Pid, Protocols, Request, Round, Rounds, Service, Shape,
};
use serde::{Deserialize, Serialize};

/// A best-effort broadcast whose processes 0 and 1 also play ping-pong for ever: each ball
/// carries its round, and each return starts the next round.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct PingPong<const DECLARED: bool> {
    count: u64,
    /// The last round seen, so every round is a new state.
    round: u64,
}

#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
enum PingMsg {
    Data { id: MsgId, msg: Payload },
    Ball { round: u64 },
}

impl<const DECLARED: bool> Microprotocol for PingPong<DECLARED> {
    type Msg = PingMsg;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "PingPong";
    const ROUNDS: Rounds = if DECLARED {
        Rounds::Numbered
    } else {
        Rounds::None
    };

    fn round(msg: &PingMsg) -> Round {
        match msg {
            PingMsg::Ball { round } => Round::At(*round),
            PingMsg::Data { .. } => Round::None,
        }
    }

    fn shape(_: &NoConfig) -> Shape {
        Shape::on_links(Service::BROADCAST)
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_start(&mut self, ctx: &Ctx, out: &mut Out<Self>) {
        if ctx.me == 0 {
            out.send(vec![1], PingMsg::Ball { round: 0 });
        }
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Broadcast { msg } = req {
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            out.send(
                ctx.others(),
                PingMsg::Data {
                    id,
                    msg: msg.clone(),
                },
            );
            out.up(Indication::BDeliver { id, msg });
        }
    }

    fn on_message(&mut self, _ctx: &Ctx, from: Pid, m: PingMsg, out: &mut Out<Self>) {
        match m {
            PingMsg::Data { id, msg } => out.up(Indication::BDeliver { id, msg }),
            PingMsg::Ball { round } => {
                self.round = round;
                out.send(vec![from], PingMsg::Ball { round: round + 1 });
            }
        }
    }
}

fn protocols() -> Protocols {
    let mut p = Protocols::with_builtins();
    p.protocol::<PingPong<true>>("Declared");
    p.protocol::<PingPong<false>>("Undeclared");
    p
}

/// Checks `protocol` on the network, or on `Fifo` when `on_fifo`, with round bound `rounds`.
fn check(protocol: &str, on_fifo: bool, rounds: u64, budget: Budget) -> Outcome {
    let protocols = protocols();
    let stack = if on_fifo {
        vec![
            LayerSpec::new("fifo", "Fifo", "net", &[]),
            LayerSpec::new("ping", protocol, "fifo", &[]),
        ]
    } else {
        vec![LayerSpec::new("ping", protocol, "net", &[])]
    };
    let target = Target::of_stack(stack, None, &protocols).expect("valid stack");
    assert_eq!(target.family, Family::Broadcast);
    let opts = Options {
        processes: 2,
        requests: 1,
        max_round: rounds,
        ..Options::default()
    };
    let model = build_in(&protocols, &target, &opts, |_, _| {}).expect("valid model");
    run(
        model,
        Exploration {
            budget,
            ..Exploration::default()
        },
    )
}

#[test]
fn a_users_protocol_that_declares_its_rounds_is_explored_up_to_the_bound() {
    for on_fifo in [false, true] {
        let counts: Vec<usize> = [1, 2, 3]
            .into_iter()
            .map(|rounds| {
                let o = check("Declared", on_fifo, rounds, Budget::default());
                assert_eq!(o.stopped, None, "exhaustive");
                assert!(o.all_hold(), "{:?}", o.verdicts);
                o.unique_states
            })
            .collect();
        // Each round more lets the ball bounce once more: more states.
        assert!(counts[0] < counts[1] && counts[1] < counts[2], "{counts:?}");
    }
}

#[test]
fn without_the_declaration_the_same_rounds_are_unbounded() {
    let budget = Budget {
        max_states: Some(2_000),
        max_memory: None,
    };
    let o = check("Undeclared", false, 1, budget);
    assert_eq!(o.stopped, Some(Stopped::States { limit: 2_000 }));
    assert!(o.unique_states >= 2_000, "{}", o.unique_states);
    // Declared, the same search ends on its own far below that budget.
    let o = check("Declared", false, 1, budget);
    assert_eq!(o.stopped, None);
    assert!(o.unique_states < 2_000, "{}", o.unique_states);
}
