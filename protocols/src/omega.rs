//! Omega leader election (Neko's OmegaFailureDetector): the leader is the lowest-numbered
//! process the failure detector it uses does not suspect.
//!
//! Assumes: a ◇P or ◇S detector underneath (used layer 0).
//! Guarantees: eventually all correct processes trust the same correct leader forever (when
//! the detector eventually stops suspecting correct processes).

use std::collections::BTreeSet;

use crate::protocol::{FieldError, Microprotocol, NoConfig, NoMsg, Out};
use crate::service::{Ctx, Indication, LayerIx, Service, Shape};
use crate::wire::Pid;

/// The Omega layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Omega {
    suspected: BTreeSet<Pid>,
    leader: Option<Pid>,
}

impl Omega {
    fn elect(&mut self, ctx: &Ctx, out: &mut Out<Self>) {
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
    type Msg = NoMsg;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "OmegaFailureDetector";

    fn shape(_: &NoConfig) -> Shape {
        Shape {
            provides: Service::LEADER,
            needs_below: Service::P2P,
            needs_uses: vec![Service::FAILURE_DETECTOR],
        }
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_start(&mut self, ctx: &Ctx, out: &mut Out<Self>) {
        self.elect(ctx, out);
    }

    fn on_indication(&mut self, ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out<Self>) {
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
