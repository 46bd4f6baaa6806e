//! Retransmission over lossy links (acknowledgements and resends).
//!
//! Assumes: fair-lossy links (a message sent infinitely often is received infinitely often).
//! Guarantees: every message sent to a correct process is delivered to it exactly once
//! (reliable links, in no particular order; put [`crate::fifo::Fifo`] on top for order).

use std::collections::{BTreeMap, BTreeSet};

use crate::protocol::Microprotocol;
use crate::service::{Ctx, Indication, LayerIx, Out, Request, TimerId};
use crate::wire::{Pid, Real, Wire};

const RESEND: TimerId = 1;

/// The retransmission layer.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Retransmit {
    /// Resend period [s].
    period: Real,
    next: BTreeMap<Pid, u64>,
    unacked: BTreeMap<(Pid, u64), (LayerIx, Wire)>,
    delivered: BTreeSet<(Pid, u64)>,
    timer_on: bool,
}

impl Retransmit {
    /// Resends unacknowledged messages every `period` seconds.
    pub fn new(period: f64) -> Self {
        Self {
            period: Real::new(period),
            next: BTreeMap::new(),
            unacked: BTreeMap::new(),
            delivered: BTreeSet::new(),
            timer_on: false,
        }
    }

    fn arm(&mut self, out: &mut Out) {
        if !self.timer_on && !self.unacked.is_empty() {
            self.timer_on = true;
            out.set_timer(RESEND, self.period.get());
        }
    }
}

impl Microprotocol for Retransmit {
    fn name(&self) -> &'static str {
        "Retransmit"
    }

    fn on_request(&mut self, _ctx: &Ctx, from: LayerIx, req: Request, out: &mut Out) {
        if let Request::Send { to, msg } = req {
            for d in to {
                let seq = self.next.entry(d).or_insert(0);
                let data = Wire::RtData {
                    seq: *seq,
                    up: from,
                    inner: Box::new(msg.clone()),
                };
                self.unacked.insert((d, *seq), (from, msg.clone()));
                *seq += 1;
                out.send(vec![d], data);
            }
            self.arm(out);
        }
    }

    fn on_indication(&mut self, _ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out) {
        match ind {
            Indication::Deliver {
                from,
                msg: Wire::RtData { seq, up, inner },
            } => {
                out.send(vec![from], Wire::RtAck { seq });
                if self.delivered.insert((from, seq)) {
                    out.up_to(up, Indication::Deliver { from, msg: *inner });
                }
            }
            Indication::Deliver {
                from,
                msg: Wire::RtAck { seq },
            } => {
                self.unacked.remove(&(from, seq));
            }
            _ => {}
        }
    }

    fn on_timer(&mut self, _ctx: &Ctx, _timer: TimerId, out: &mut Out) {
        self.timer_on = false;
        for (&(d, seq), (up, msg)) in &self.unacked {
            out.send(
                vec![d],
                Wire::RtData {
                    seq,
                    up: *up,
                    inner: Box::new(msg.clone()),
                },
            );
        }
        self.arm(out);
    }
}
