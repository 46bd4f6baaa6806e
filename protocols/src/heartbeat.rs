//! Heartbeat failure detector (Neko's failureDetectors.Heartbeat).
//!
//! Assumes: links that eventually deliver within `timeout` (partial synchrony).
//! Guarantees: ◇P in partially synchronous runs: a crashed process is eventually suspected
//! forever (strong completeness), and a correct one is eventually trusted forever once delays
//! stay below the timeout. Every `period` each process sends a heartbeat to all; every
//! `timeout` it suspects the processes it has not heard from since the last check and trusts
//! again the suspected ones it has heard from. The checks count heartbeats, not clock values,
//! so the protocol stays time-free and a model checker can run it.

use std::collections::BTreeSet;

use crate::protocol::Microprotocol;
use crate::service::{Ctx, Indication, LayerIx, Out, Request, TimerId};
use crate::wire::{Pid, Real, Wire};

const BEAT: TimerId = 1;
const CHECK: TimerId = 2;

/// The heartbeat failure detector layer.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Heartbeat {
    period: Real,
    timeout: Real,
    heard: BTreeSet<Pid>,
    suspected: BTreeSet<Pid>,
}

impl Heartbeat {
    /// Heartbeats every `period` seconds, checks every `timeout` seconds.
    pub fn new(period: f64, timeout: f64) -> Self {
        Self {
            period: Real::new(period),
            timeout: Real::new(timeout),
            heard: BTreeSet::new(),
            suspected: BTreeSet::new(),
        }
    }

    /// The processes suspected now.
    pub fn suspected(&self) -> &BTreeSet<Pid> {
        &self.suspected
    }
}

impl Microprotocol for Heartbeat {
    fn name(&self) -> &'static str {
        "failureDetectors.Heartbeat"
    }

    fn on_start(&mut self, ctx: &Ctx, out: &mut Out) {
        out.send(ctx.others(), Wire::Heartbeat);
        out.set_timer(BEAT, self.period.get());
        out.set_timer(CHECK, self.timeout.get());
    }

    fn on_request(&mut self, _ctx: &Ctx, _from: LayerIx, _req: Request, _out: &mut Out) {}

    fn on_indication(&mut self, _ctx: &Ctx, _from: LayerIx, ind: Indication, _out: &mut Out) {
        if let Indication::Deliver {
            from,
            msg: Wire::Heartbeat,
        } = ind
        {
            self.heard.insert(from);
        }
    }

    fn on_timer(&mut self, ctx: &Ctx, timer: TimerId, out: &mut Out) {
        match timer {
            BEAT => {
                out.send(ctx.others(), Wire::Heartbeat);
                out.set_timer(BEAT, self.period.get());
            }
            CHECK => {
                for p in ctx.others() {
                    let heard = self.heard.contains(&p);
                    if !heard && self.suspected.insert(p) {
                        out.up(Indication::Suspect(p));
                    } else if heard && self.suspected.remove(&p) {
                        out.up(Indication::Trust(p));
                    }
                }
                self.heard.clear();
                out.set_timer(CHECK, self.timeout.get());
            }
            _ => {}
        }
    }
}
