//! Omega leader election (Neko's OmegaFailureDetector): the leader is the lowest-numbered
//! process the failure detector it uses does not suspect.
//!
//! Assumes: a ◇P or ◇S detector underneath (used layer 0).
//! Guarantees: eventually all correct processes trust the same correct leader forever (when
//! the detector eventually stops suspecting correct processes).

use std::collections::BTreeSet;

use crate::protocol::Microprotocol;
use crate::service::{Ctx, Indication, LayerIx, Out, Request};
use crate::wire::Pid;

/// The Omega layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Omega {
    suspected: BTreeSet<Pid>,
    leader: Option<Pid>,
}

impl Omega {
    fn elect(&mut self, ctx: &Ctx, out: &mut Out) {
        let leader = (0..ctx.n).find(|p| *p == ctx.me || !self.suspected.contains(p));
        if leader != self.leader {
            self.leader = leader;
            if let Some(l) = leader {
                out.up(Indication::Leader(l));
            }
        }
    }
}

impl Microprotocol for Omega {
    fn name(&self) -> &'static str {
        "OmegaFailureDetector"
    }

    fn on_start(&mut self, ctx: &Ctx, out: &mut Out) {
        self.elect(ctx, out);
    }

    fn on_request(&mut self, _ctx: &Ctx, _from: LayerIx, _req: Request, _out: &mut Out) {}

    fn on_indication(&mut self, ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out) {
        match ind {
            Indication::Suspect(p) => {
                self.suspected.insert(p);
            }
            Indication::Trust(p) => {
                self.suspected.remove(&p);
            }
            _ => return,
        }
        self.elect(ctx, out);
    }
}
