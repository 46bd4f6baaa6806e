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
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::protocol::{FieldError, Microprotocol, Out};
use crate::service::{Ctx, Indication, Service, Shape};
use crate::symmetry::Rename;
use crate::wire::{Pid, Real};

/// The heartbeat.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Beat;

/// The detector's two timers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum HeartbeatTimer {
    /// Send the next heartbeat.
    Beat,
    /// Check whom we heard from.
    Check,
}

/// `Heartbeat(period: 1.0, timeout: 3.0)`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeartbeatConfig {
    /// Heartbeat period [s].
    pub period: f64,
    /// Check period [s], at least `period`.
    pub timeout: f64,
}

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
    pub fn with_timing(period: f64, timeout: f64) -> Self {
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
    type Msg = Beat;
    type Timer = HeartbeatTimer;
    type Config = HeartbeatConfig;
    const NAME: &'static str = "failureDetectors.Heartbeat";

    fn shape(_: &HeartbeatConfig) -> Shape {
        Shape::on_links(Service::FAILURE_DETECTOR)
    }

    fn suspicions(&self) -> Option<Vec<Pid>> {
        Some(self.suspected.iter().copied().collect())
    }

    fn new(c: HeartbeatConfig) -> Result<Self, FieldError> {
        FieldError::positive_seconds("period", c.period)?;
        FieldError::positive_seconds("timeout", c.timeout)?;
        if c.timeout < c.period {
            return Err(FieldError::new(
                "timeout",
                format!(
                    "timeout {} is shorter than the period {}",
                    c.timeout, c.period
                ),
                "timeout >= period",
            ));
        }
        Ok(Self::with_timing(c.period, c.timeout))
    }

    fn on_start(&mut self, ctx: &Ctx, out: &mut Out<Self>) {
        out.send(ctx.others(), Beat);
        out.set_timer(HeartbeatTimer::Beat, self.period.get());
        out.set_timer(HeartbeatTimer::Check, self.timeout.get());
    }

    fn on_message(&mut self, _ctx: &Ctx, from: Pid, _beat: Beat, _out: &mut Out<Self>) {
        self.heard.insert(from);
    }

    fn on_timer(&mut self, ctx: &Ctx, timer: HeartbeatTimer, out: &mut Out<Self>) {
        match timer {
            HeartbeatTimer::Beat => {
                out.send(ctx.others(), Beat);
                out.set_timer(HeartbeatTimer::Beat, self.period.get());
            }
            HeartbeatTimer::Check => {
                for p in ctx.others() {
                    let heard = self.heard.contains(&p);
                    if !heard && self.suspected.insert(p) {
                        out.up(Indication::Suspect(p));
                    } else if heard && self.suspected.remove(&p) {
                        out.up(Indication::Trust(p));
                    }
                }
                self.heard.clear();
                out.set_timer(HeartbeatTimer::Check, self.timeout.get());
            }
        }
    }

    fn renamed(&self, r: &Rename) -> Option<Self> {
        Some(Self {
            heard: self.heard.iter().map(|p| r.pid(*p)).collect(),
            suspected: self.suspected.iter().map(|p| r.pid(*p)).collect(),
            ..self.clone()
        })
    }

    fn renamed_msg(beat: &Beat, _: &Rename) -> Option<Beat> {
        Some(*beat)
    }

    fn render(_: &Beat, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "HEARTBEAT")
    }
}
