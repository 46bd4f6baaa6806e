//! How the product hosts handlers in actix actors: deliveries, events taken on at once,
//! replies (the ordering contract's points 3 and 5 in [`crate::scheduler`]).
//!
//! The scheduler actor hands each event to the actor that hosts its handler and waits for the
//! reply with the handling's effects before it takes the next event: by a call into the host
//! when the actor runs on the scheduler's thread ([`Call`]), else as a [`Deliver`] message
//! answered by a [`Replied`] one. When the event a handling schedules at its instant is the
//! next event there is, the host takes it on at once ([`Deliver::inline`]), or passes it on
//! to its actor ([`PassOn`]), instead of replying, and the last actor of such a chain replies
//! for all of them; the events, their order and their numbers are those of one delivery per
//! event. Everything here is about hosting; the handlers ([`HandleEvent`]) know none of it.

use std::cell::RefCell;
use std::panic::AssertUnwindSafe;
use std::rc::Rc;
use std::sync::Arc;

use actix::prelude::*;

use crate::handler::{handle_one, HandleEvent};
use crate::world::event::{Effect, Event, Target};
use crate::world::RobotId;

/// Delivery of one event to the actor that handles it; the reply is the handling's effects
/// ([`Reply`]).
#[derive(Debug, Message)]
#[rtype(result = "()")]
pub struct Deliver {
    /// Virtual time of the event [s].
    pub now: f64,
    /// The event's processing number (the `cause` of whatever it creates).
    pub seq: u64,
    pub event: Event,
    /// An empty buffer for the handling's effects: the scheduler's, handed back in the reply
    /// and reused, so no handling allocates its effects' vector.
    pub effects: Vec<Effect>,
    /// Where the reply goes when the delivery is a message (none when it is a call).
    pub reply: Option<ReplyTo>,
    /// How many events the actor may take on at once after this one, at this instant: the
    /// events its own handlings schedule for itself at this instant, when each is the next
    /// event of the whole run, as nothing else is pending at this instant
    /// ([`handle_delivery`]). Zero where the scheduler takes every event itself. A sensor
    /// request and its trigger, the seed's two steps at one instant, are one round trip this
    /// way.
    pub inline: u32,
    /// Whether anything reads the robots' step records: when not, the handlings leave them
    /// out ([`crate::world::outbox::Outbox::records_steps`]).
    pub steps: bool,
    /// Where the events taken on at once may go when they are for another actor: with it,
    /// [`Deliver::inline`] counts the events taken on for any actor, passed on along a chain
    /// ([`handle_delivery`]); without it, only the actor's own.
    pub pass_on: Option<Arc<dyn PassOn>>,
    /// What the chain's handlings before this one did, when the delivery was passed on: the
    /// reply so far, without its effects (they are in [`Deliver::effects`]).
    pub chain: Option<Box<Reply>>,
}

/// The actors a delivery may be passed on to, straight from the host of the one before
/// ([`Deliver::pass_on`]).
pub trait PassOn: Send + Sync {
    /// Whether `target`'s actor is running and may be sent the delivery at once.
    fn reaches(&self, target: Target) -> bool;

    /// Sends `msg` to `target`'s actor (one that [`PassOn::reaches`]).
    fn pass(&self, target: Target, msg: Deliver);
}

impl std::fmt::Debug for dyn PassOn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("PassOn")
    }
}

/// The most events one delivery handles: its own and those taken on at once
/// ([`Deliver::inline`]).
pub const CHAIN: usize = 8;

/// An actor's reply to a delivery: the effects of the events it handled, in order, and where
/// each handling's effects end (`ends[0]` the delivered event's, `ends[1]` the first event
/// taken on at once's, and so on). The schedules of the events taken on are not among the
/// effects.
#[derive(Debug, Default)]
pub struct Reply {
    pub effects: Vec<Effect>,
    pub ends: smallvec::SmallVec<[u32; CHAIN]>,
    /// The robots whose events were among those taken on, in order (the scheduler counts
    /// each robot's deliveries at an instant).
    pub robots: smallvec::SmallVec<[RobotId; 2]>,
}

/// What a host does with a delivery once its handler is done: reply to the scheduler, or pass
/// the next event on to its actor.
#[derive(Debug)]
pub enum Handled {
    Reply(Reply),
    PassOn(Target, Deliver),
}

/// The way back to the scheduler for one delivery's reply, for a delivery sent as a message
/// (to an actor on another thread, or passed on to one): one message, no channel. Dropped
/// without a reply (the actor stopped, or its handling panicked), it tells the scheduler so,
/// naming the actor that held it, and the run ends with a failure instead of waiting forever.
#[derive(Debug)]
pub struct ReplyTo {
    to: Option<Arc<Recipient<Replied>>>,
    /// The actor the delivery is with (the last of a chain passed on).
    with: Target,
}

impl ReplyTo {
    /// Replies go to `to` for a delivery to `with`.
    pub fn new(to: Arc<Recipient<Replied>>, with: Target) -> Self {
        Self { to: Some(to), with }
    }

    /// Sends the handling's effects back.
    pub fn send(mut self, reply: Reply) {
        if let Some(to) = self.to.take() {
            to.do_send(Replied(Ok(reply)));
        }
    }
}

impl Drop for ReplyTo {
    fn drop(&mut self) {
        if let Some(to) = self.to.take() {
            to.do_send(Replied(Err(NoReply {
                with: self.with,
                error: "the actor dropped the event unanswered".into(),
            })));
        }
    }
}

/// Why a delivery has no reply, and with which actor it was.
#[derive(Debug)]
pub struct NoReply {
    pub with: Target,
    pub error: String,
}

/// The reply to a delivery: the handling's effects, or why there are none.
#[derive(Debug, Message)]
#[rtype(result = "()")]
pub struct Replied(pub Result<Reply, NoReply>);

/// Handles a delivery as its actor does: its event, then, up to [`Deliver::inline`] of them,
/// the events the handlings schedule for the same actor at its instant, as long as each is
/// the next event there is (see [`take_on`]). Given where deliveries may be passed on
/// ([`Deliver::pass_on`]), it also takes on those for other actors: the first is passed on
/// ([`Handled::PassOn`]), with the reply so far. Where the reply goes is the host's business:
/// it takes [`Deliver::reply`] out first.
pub fn handle_delivery<H: HandleEvent + ?Sized>(handler: &mut H, msg: Deliver) -> Handled {
    let Deliver {
        now,
        seq,
        event,
        effects,
        reply,
        inline,
        steps,
        pass_on,
        chain,
    } = msg;
    debug_assert!(reply.is_none(), "the host takes the reply out first");
    let own = event.target;
    let mut reply = chain.map_or_else(Reply::default, |c| *c);
    let effects = handle_one(handler, now, seq, event, effects, steps);
    reply.ends.push(end_of(&effects));
    let onward = Onward {
        room: inline,
        steps,
        pass_on,
    };
    take_on(handler, onward, Instant { now, seq, own }, reply, effects)
}

/// What a delivery allows beyond its events: how many more may be taken on, and where to (see
/// [`Deliver`]).
struct Onward {
    room: u32,
    steps: bool,
    pass_on: Option<Arc<dyn PassOn>>,
}

/// Where a delivery's handlings stand: the instant of the last, its number, and its actor.
struct Instant {
    now: f64,
    seq: u64,
    own: Target,
}

/// After the handling numbered `at.seq`, whose effects end `effects` (and `reply.ends`): up to
/// [`Deliver::inline`] events that the handlings schedule at its instant, each taken out of the
/// effects and handled while it is the next event there is: here when it is for the same
/// actor, passed on with the reply so far when it is for another that [`Deliver::pass_on`]
/// reaches.
fn take_on<H: HandleEvent + ?Sized>(
    handler: &mut H,
    mut onward: Onward,
    at: Instant,
    mut reply: Reply,
    mut effects: Vec<Effect>,
) -> Handled {
    let Instant { now, mut seq, own } = at;
    let steps = onward.steps;
    let mut room = onward.room;
    while room > 0 {
        let Some((k, target)) = next_at(&effects, now) else {
            break;
        };
        let passed = target != own;
        if passed && !onward.pass_on.as_ref().is_some_and(|p| p.reaches(target)) {
            break;
        }
        let Effect::Schedule(event) = effects.remove(k) else {
            unreachable!("next_at names a plain schedule");
        };
        for end in reply.ends.iter_mut().filter(|e| **e as usize > k) {
            *end -= 1;
        }
        seq += 1;
        room -= 1;
        if let Target::Robot(r) = target {
            reply.robots.push(r);
        }
        if passed {
            return Handled::PassOn(
                target,
                Deliver {
                    now,
                    seq,
                    event,
                    effects,
                    reply: None,
                    inline: room,
                    steps,
                    pass_on: onward.pass_on.take(),
                    chain: Some(Box::new(reply)),
                },
            );
        }
        effects = handle_one(handler, now, seq, event, effects, steps);
        reply.ends.push(end_of(&effects));
    }
    reply.effects = effects;
    Handled::Reply(reply)
}

fn end_of(effects: &[Effect]) -> u32 {
    u32::try_from(effects.len()).expect("fewer than 2^32 effects")
}

/// The position among `effects` of the event that comes next when nothing was pending at
/// `now` before them, and its actor, if it is a plain schedule: of the events scheduled at
/// `now` and not cancelled since, the first scheduled (at one instant, events come in the
/// order of their causes, and these are the newest). Nothing when an instant's end event was
/// asked for, or the next is the event manager's, which the scheduler takes in its own turn.
fn next_at(effects: &[Effect], now: f64) -> Option<(usize, Target)> {
    for (k, e) in effects.iter().enumerate() {
        match e {
            Effect::Schedule(ev) if ev.time == now => {
                let cancelled = effects[k + 1..]
                    .iter()
                    .any(|c| matches!(c, Effect::Cancel(h) if h.id == ev.id));
                if cancelled {
                    continue;
                }
                return (ev.target != Target::EventManager).then_some((k, ev.target));
            }
            Effect::ScheduleIn(ev, _) if ev.time == now => return None,
            Effect::AtInstantEnd(_) | Effect::WithdrawAtInstantEnd(_) => return None,
            _ => {}
        }
    }
    None
}

/// The actor that hosts a handler: it takes [`Deliver`]s and replies with their effects. A
/// scheduler on the same thread shares the handler and hands it deliveries by a call instead
/// ([`Host::call`]).
#[derive(Debug)]
pub struct Host<H>(Rc<RefCell<H>>);

impl<H: HandleEvent + 'static> Host<H> {
    /// The host of `handler`.
    pub fn new(handler: H) -> Self {
        Self(Rc::new(RefCell::new(handler)))
    }

    /// The handler, for a scheduler on this thread to call ([`Call`]).
    pub fn call(&self) -> Call {
        Call(self.0.clone())
    }
}

impl<H: HandleEvent + Unpin + 'static> Actor for Host<H> {
    type Context = Context<Self>;
}

impl<H: HandleEvent + Unpin + 'static> Handler<Deliver> for Host<H> {
    type Result = ();

    fn handle(&mut self, mut msg: Deliver, _: &mut Context<Self>) {
        // Held across the handling: should it panic, dropping it tells the scheduler.
        let reply = msg.reply.take();
        match handle_delivery(&mut *self.0.borrow_mut(), msg) {
            Handled::Reply(handled) => {
                if let Some(reply) = reply {
                    reply.send(handled);
                }
            }
            Handled::PassOn(target, mut next) => {
                next.reply = reply.map(|mut r| {
                    r.with = target;
                    r
                });
                let to = next
                    .pass_on
                    .clone()
                    .expect("a delivery passed on knows where");
                to.pass(target, next);
            }
        }
    }
}

/// A hosted handler that the scheduler on the host's thread hands deliveries to by a call: one
/// delivery is in flight at a time, so while the scheduler waits for the reply the actor is
/// idle, and a message would only queue the delivery for the actor to take at once.
#[derive(Clone)]
pub struct Call(Rc<RefCell<dyn HandleEvent>>);

impl Call {
    /// Handles `msg` as the host's actor would ([`handle_delivery`]); the text of the panic when
    /// the handling panics (its actor then gives no answer).
    pub fn deliver(&self, msg: Deliver) -> Result<Handled, String> {
        let mut handler = self.0.borrow_mut();
        std::panic::catch_unwind(AssertUnwindSafe(|| handle_delivery(&mut *handler, msg))).map_err(
            |panic| {
                let text = (panic.downcast_ref::<&str>().copied())
                    .or_else(|| panic.downcast_ref::<String>().map(String::as_str))
                    .unwrap_or("a panic");
                format!("its handling panicked: {text}")
            },
        )
    }
}

impl std::fmt::Debug for Call {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Call")
    }
}

/// An actor's way in for the scheduler: its mailbox, and a call into its host when the actor
/// runs on the scheduler's thread.
#[derive(Debug)]
pub struct Route {
    pub mailbox: Recipient<Deliver>,
    pub call: Option<Call>,
}

impl Route {
    /// Starts `host`'s actor on this thread, the scheduler's.
    pub fn start_here<H: HandleEvent + Unpin + 'static>(host: Host<H>) -> Self {
        let call = Some(host.call());
        Self {
            mailbox: host.start().recipient(),
            call,
        }
    }

    /// An actor on another thread, reached by messages to `mailbox`.
    pub fn elsewhere(mailbox: Recipient<Deliver>) -> Self {
        Self {
            mailbox,
            call: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::event::{EventClass, EventId, Payload, NO_ROBOT};
    use crate::world::outbox::Outbox;

    /// A handler that notes the instant of each event it takes, and panics at its third.
    #[derive(Debug)]
    struct Notes(Rc<RefCell<Vec<f64>>>);

    impl HandleEvent for Notes {
        fn handle_event(&mut self, event: Event, _: &mut Outbox) {
            let mut seen = self.0.borrow_mut();
            seen.push(event.time);
            assert!(seen.len() < 3, "a bug in the handler");
        }
    }

    /// A delivery of a timer event at `now`, with no reply asked for.
    fn delivery(now: f64) -> Deliver {
        Deliver {
            now,
            seq: 1,
            event: Event {
                time: now,
                id: EventId { cause: 0, index: 0 },
                target: Target::Robot(0),
                class: EventClass::Eventual,
                concerns: [NO_ROBOT; 2],
                payload: Payload::Timer {
                    robot: 0,
                    ticket: 0,
                },
            },
            effects: Vec::new(),
            reply: None,
            inline: 0,
            steps: false,
            pass_on: None,
            chain: None,
        }
    }

    /// An actor started on the scheduler's thread is reached by its mailbox and by a call,
    /// both into one handler; a call returns the handling's reply, or the panic's text when
    /// the handling panics; an actor elsewhere has no call.
    #[test]
    fn a_call_and_the_mailbox_reach_one_handler() {
        actix::System::new().block_on(async {
            let seen = Rc::new(RefCell::new(Vec::new()));
            let route = Route::start_here(Host::new(Notes(seen.clone())));
            route.mailbox.send(delivery(1.0)).await.expect("handled");
            let call = route.call.clone().expect("started here");
            match call.deliver(delivery(2.0)) {
                Ok(Handled::Reply(reply)) => assert_eq!(reply.ends.as_slice(), &[0]),
                other => panic!("expected a reply, got {other:?}"),
            }
            assert_eq!(*seen.borrow(), vec![1.0, 2.0]);
            let panicked = call
                .deliver(delivery(3.0))
                .expect_err("the handling panics");
            assert!(panicked.contains("a bug in the handler"), "{panicked}");
            assert!(Route::elsewhere(route.mailbox).call.is_none());
        });
    }
}
