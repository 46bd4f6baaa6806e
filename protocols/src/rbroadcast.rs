//! Reliable broadcast by eager relay (Neko's RBroadcast).
//!
//! Assumes: reliable point-to-point links; any number of crashes.
//! Guarantees: validity (a correct broadcaster delivers its message), integrity (each message
//! at most once, only if broadcast) and agreement (if a correct process delivers m, every
//! correct process does): every process relays a message to all others the first time it
//! receives it, before delivering it.

use std::collections::BTreeSet;
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::payload::Payload;
use crate::protocol::{FieldError, Microprotocol, NoConfig, Out};
use crate::service::{Ctx, Indication, LayerIx, Request, Service, Shape};
use crate::symmetry::Rename;
use crate::wire::{MsgId, Pid};

/// A broadcast message and its id, relayed by every receiver.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct RbMsg {
    pub id: MsgId,
    pub payload: Payload,
}

/// The reliable broadcast layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct ReliableBroadcast {
    count: u64,
    delivered: BTreeSet<MsgId>,
    /// Relay received messages (turned off only by the deliberately broken variant used to
    /// show the model checker is not vacuous).
    no_relay: bool,
}

impl ReliableBroadcast {
    /// A broken variant that does not relay: agreement fails when the broadcaster crashes.
    pub fn without_relay() -> Self {
        Self {
            no_relay: true,
            ..Self::default()
        }
    }
}

impl Microprotocol for ReliableBroadcast {
    type Msg = RbMsg;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "RBroadcast";

    fn shape(_: &NoConfig) -> Shape {
        Shape::on_links(Service::BROADCAST)
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Broadcast { msg } = req {
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            self.delivered.insert(id);
            out.send(
                ctx.others(),
                RbMsg {
                    id,
                    payload: msg.clone(),
                },
            );
            out.up(Indication::BDeliver { id, msg });
        }
    }

    fn on_message(&mut self, ctx: &Ctx, from: Pid, m: RbMsg, out: &mut Out<Self>) {
        let id = m.id;
        if !self.delivered.insert(id) {
            return;
        }
        if !self.no_relay {
            let relay: Vec<_> = ctx
                .others()
                .into_iter()
                .filter(|&p| p != id.origin && p != from)
                .collect();
            out.send(relay, m.clone());
        }
        out.up(Indication::BDeliver { id, msg: m.payload });
    }

    // A message is relayed and delivered once; its later copies change nothing.
    fn spent(&self, _ctx: &Ctx, _from: Pid, m: &RbMsg) -> bool {
        self.delivered.contains(&m.id)
    }

    fn renamed(&self, r: &Rename) -> Option<Self> {
        Some(Self {
            delivered: self.delivered.iter().map(|id| r.msg_id(*id)).collect(),
            ..self.clone()
        })
    }

    fn renamed_msg(m: &RbMsg, r: &Rename) -> Option<RbMsg> {
        Some(RbMsg {
            id: r.msg_id(m.id),
            payload: r.payload(&m.payload)?,
        })
    }

    fn render(m: &RbMsg, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "RB({}, {})", m.id, m.payload)
    }
}
