// The `Redundant` protocol of docs/extending.md, section 1 (kept identical to it by a test).
use nekosim::protocols::{
    FieldError, Ctx, Indication, LayerIx, Microprotocol, MsgId, Out, Payload, Pid, Request,
    Service, Shape,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::fmt;

/// The layer's message: a broadcast message, its id and which copy it is.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Copy {
    id: MsgId,
    copy: u32,
    payload: Payload,
}

/// `Redundant(copies: 2)`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RedundantConfig {
    #[serde(default = "two")]
    copies: u32,
}

fn two() -> u32 {
    2
}

/// Best-effort broadcast that sends each message `copies` times and delivers it once.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Redundant {
    copies: u32,
    count: u64,
    delivered: BTreeSet<MsgId>,
}

impl Microprotocol for Redundant {
    type Msg = Copy;
    type Timer = ();
    type Config = RedundantConfig;
    const NAME: &'static str = "Redundant";

    fn shape(_: &RedundantConfig) -> Shape {
        // Provides a broadcast on top of point-to-point links, uses no other layer.
        Shape::on_links(Service::BROADCAST)
    }

    fn new(c: RedundantConfig) -> Result<Self, FieldError> {
        if !(1..=10).contains(&c.copies) {
            return Err(FieldError::new(
"copies",
format!("copies is {}", c.copies),
"1 to 10",
));
        }
        Ok(Self { copies: c.copies, count: 0, delivered: BTreeSet::new() })
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Broadcast { msg } = req {
            let id = MsgId { origin: ctx.me, n: self.count };
            self.count += 1;
            for copy in 0..self.copies {
                out.send(ctx.others(), Copy { id, copy, payload: msg.clone() });
            }
            self.delivered.insert(id);
            out.up(Indication::BDeliver { id, msg });
        }
    }

    fn on_message(&mut self, _ctx: &Ctx, _from: Pid, m: Copy, out: &mut Out<Self>) {
        if self.delivered.insert(m.id) {
            out.up(Indication::BDeliver { id: m.id, msg: m.payload });
        }
    }

    /// How the log, the trace, recordings and counterexamples show the message; its first
    /// word is the message's type. (Without it, the message's `Debug`.)
    fn render(m: &Copy, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "COPY#{}({}, {})", m.copy, m.id, m.payload)
    }
}
