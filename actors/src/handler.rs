//! What every actor's logic is to the engine (seed 3.6, 4.2.3): a handler of events.
//!
//! Each robot, sensor, manager, network and protocol layer is a plain value that takes one
//! event at a time and writes what the handling causes (events to schedule or cancel,
//! observations) into an [`Outbox`]. A handler knows nothing of how it is hosted: the product
//! hosts each in an actix actor ([`crate::host`]), the kernel-alone reference
//! ([`crate::kernel`]) calls it from a plain loop, and both take the same events in the same
//! order, so they produce the same run.

use crate::world::event::{Effect, Event};
use crate::world::outbox::Outbox;

/// One actor's handling of events.
pub trait HandleEvent {
    /// Handles `event`, which happens at `out`'s time; writes its effects into `out`.
    fn handle_event(&mut self, event: Event, out: &mut Outbox);
}

/// Handles `event` at time `now` as processing number `seq`, writing into `effects` (an empty
/// buffer, reused): the handling's effects, in order. `steps` says whether anything reads the
/// robots' step records ([`Outbox::records_steps`]).
pub fn handle_one<H: HandleEvent + ?Sized>(
    handler: &mut H,
    now: f64,
    seq: u64,
    event: Event,
    effects: Vec<Effect>,
    steps: bool,
) -> Vec<Effect> {
    let mut out = Outbox::reusing(now, seq, effects).recording_steps(steps);
    handler.handle_event(event, &mut out);
    out.into_effects()
}
