//! How the product hosts handlers in actix actors: deliveries, runs of events, replies and
//! the look-ahead (the ordering contract's points 3 and 5 in [`crate::scheduler`]).
//!
//! The scheduler actor sends each event to the actor that hosts its handler as a [`Deliver`]
//! and waits for the reply with the handling's effects before it takes the next event: a call
//! when the actor runs on the scheduler's thread ([`Here`]), else a [`Replied`] message. A
//! delivery may carry a run: the events that come next for the same actor, which the host
//! hands to its handler in turn for as long as the handlings before leave each the next event
//! to take ([`handle_run`]), so a run saves round trips between the scheduler and a manager
//! without changing which events are taken or their order. A delivery with no run may
//! also be passed on ([`PassOn`]): when the event a handling schedules at its instant is the
//! next event there is, the host hands it straight to its actor instead of replying, and the
//! last actor of such a chain replies for all of them; the events, their order and their
//! numbers are again those of one delivery per event. Everything here is about hosting; the
//! handlers ([`HandleEvent`]) know none of it.

use std::cell::RefCell;
use std::rc::Rc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use actix::prelude::*;

use crate::handler::{handle_one, HandleEvent};
use crate::world::event::{Effect, Event, EventId, Target};
use crate::world::radix::time_key;
use crate::world::RobotId;

/// Delivery of one event to the actor that handles it; the reply, the handling's effects,
/// goes back to the scheduler as a message of its own ([`Replied`]).
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
    /// Where the reply goes (none when the handling is called directly).
    pub reply: Option<ReplyTo>,
    /// The events that come next for the same actor, taken from the queue with this one (a
    /// run, at most [`RUN`] events in all). The actor handles each in turn, as numbers
    /// `seq + 1`, `seq + 2`, ..., for as long as the handlings before it leave it the next
    /// event ([`handle_run`]), and hands the others back in its [`Reply`]. Most events of a
    /// random-movement run are the motion manager's and follow another of its own, and each
    /// would otherwise pay a round trip between the scheduler and the manager.
    pub then: Vec<Event>,
    /// How many events the actor may take on at once after this one, at this instant and
    /// with no run: the events its own handlings schedule for itself at this instant, when
    /// each is the next event of the whole run, as nothing else is pending at this instant
    /// ([`handle_run`]). Zero where the scheduler takes every event itself. A sensor request
    /// and its trigger, the seed's two steps at one instant, are one round trip this way.
    pub inline: u32,
    /// Whether the scheduler looks ahead (a large queue): the host then asks the handler,
    /// before each handling of the run, for what the next ones will read
    /// ([`HandleEvent::look_ahead`]).
    pub look_ahead: bool,
    /// Whether anything reads the robots' step records: when not, the handlings leave them
    /// out ([`crate::world::outbox::Outbox::records_steps`]).
    pub steps: bool,
    /// Where the events taken on at once may go when they are for another actor: with it,
    /// [`Deliver::inline`] counts the events taken on for any actor, passed on along a chain
    /// ([`handle_run`]); without it, only the actor's own.
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

/// The most events a delivery carries ([`Deliver::then`] and its own).
pub const RUN: usize = 8;

/// An actor's reply to a delivery: the effects of the events it handled, in order; where each
/// handling's effects end (`ends[0]` the delivered event's, `ends[1]` the first of
/// [`Deliver::then`]'s, and so on); and the events of `then` it did not handle, which go back
/// to the queue as they were.
#[derive(Debug, Default)]
pub struct Reply {
    pub effects: Vec<Effect>,
    pub ends: smallvec::SmallVec<[u32; RUN]>,
    pub then: Vec<Event>,
    /// How many of the handled events, after the delivered one, were scheduled by the
    /// handlings before them and taken on at once ([`Deliver::inline`]); their schedules are
    /// not among the effects.
    pub inline: u32,
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

/// The way back to the scheduler for one delivery's reply: a call when the actor runs on the
/// scheduler's thread ([`Here`]), else one message; no channel either way. Dropped without a
/// reply (the actor stopped, or its handling panicked), it tells the scheduler so, naming the
/// actor that held it, and the run ends with a failure instead of waiting forever.
#[derive(Debug)]
pub struct ReplyTo {
    to: Option<Arc<Recipient<Replied>>>,
    /// The actor the delivery is with (the last of a chain passed on).
    with: Target,
    /// The scheduler's number ([`Here::number`]).
    scheduler: u64,
}

impl ReplyTo {
    /// Replies go to `to`, the scheduler numbered `scheduler`, for a delivery to `with`.
    pub fn new(to: Arc<Recipient<Replied>>, with: Target, scheduler: u64) -> Self {
        Self {
            to: Some(to),
            with,
            scheduler,
        }
    }

    /// Sends the handling's effects back.
    pub fn send(mut self, reply: Reply) {
        if let Some(to) = self.to.take() {
            match Here::find(self.scheduler) {
                Some(scheduler) => scheduler.replied(Ok(reply)),
                None => to.do_send(Replied(Ok(reply))),
            }
        }
    }
}

/// A scheduler that takes the replies made on its own thread by a call ([`Here`]).
pub trait TakesReplies {
    /// The reply to the delivery in flight.
    fn replied(&self, reply: Result<Reply, NoReply>);
}

thread_local! {
    /// The scheduler whose replies are taken by a call on this thread, with its number.
    static HERE: RefCell<Option<(u64, Rc<dyn TakesReplies>)>> = const { RefCell::new(None) };
}

/// While it lives, a reply to the scheduler it names, made on the thread that made it (the
/// scheduler's own), reaches the scheduler by a call instead of a message: one delivery is in
/// flight at a time, so the scheduler is then idle, and a message would only wake it up to
/// take the very same reply.
#[derive(Debug)]
pub struct Here(u64);

impl Here {
    /// A number no other scheduler of the process has.
    pub fn number() -> u64 {
        static NEXT: AtomicU64 = AtomicU64::new(1);
        NEXT.fetch_add(1, Ordering::Relaxed)
    }

    /// Replies to the scheduler numbered `id` made on this thread go to `scheduler`.
    pub fn new(id: u64, scheduler: Rc<dyn TakesReplies>) -> Self {
        let before = HERE.with(|h| h.borrow_mut().replace((id, scheduler)));
        // A scheduler left behind (a run that never finished) is let go here, outside the
        // borrow, since its own `Here` clears this slot.
        drop(before);
        Self(id)
    }

    /// The scheduler numbered `id`, if it takes replies on this thread.
    fn find(id: u64) -> Option<Rc<dyn TakesReplies>> {
        HERE.with(|h| {
            h.borrow()
                .as_ref()
                .filter(|(here, _)| *here == id)
                .map(|(_, s)| s.clone())
        })
    }
}

impl Drop for Here {
    fn drop(&mut self) {
        let id = self.0;
        // At the thread's exit the slot may already be gone.
        let gone = HERE.try_with(|h| {
            let mut h = h.borrow_mut();
            if h.as_ref().is_some_and(|(here, _)| *here == id) {
                h.take()
            } else {
                None
            }
        });
        drop(gone);
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

/// Handles a delivery as its actor does: its event, then each event of its run
/// ([`Deliver::then`]) in turn for as long as the handlings so far leave that event the next
/// one to take (the ordering contract): nothing they scheduled comes before it (their events
/// all come after every pending one at equal times, their cause being newer), they did not
/// cancel it, and they asked for no instant's end event (which could come between). The
/// first event that fails this, and those after it, go back unhandled in the [`Reply`].
///
/// Then, up to [`Deliver::inline`] of them, it takes on the events the handlings schedule for
/// the same actor at the instant of the last, as long as each is the next event there is
/// (see [`take_on`]). Given where deliveries may be passed on ([`Deliver::pass_on`]), it also
/// takes on those for other actors: the first is passed on ([`Handled::PassOn`]), with the
/// reply so far.
pub fn handle_run<H: HandleEvent + ?Sized>(handler: &mut H, msg: Deliver) -> Handled {
    let Deliver {
        now,
        seq,
        event,
        effects,
        reply: reply_to,
        mut then,
        inline,
        look_ahead,
        steps,
        pass_on,
        chain,
    } = msg;
    let own = event.target;
    let onward = Onward {
        room: inline,
        steps,
        reply_to,
        pass_on,
    };
    if then.is_empty() && (inline > 0 || chain.is_some()) {
        let mut reply = chain.map_or_else(Reply::default, |c| *c);
        let effects = handle_one(handler, now, seq, event, effects, steps);
        reply.ends.push(end_of(&effects));
        let at = Instant { now, seq, own };
        return take_on(handler, onward, at, reply, effects);
    }
    // The run's events in reverse: the next one last.
    then.reverse();
    if look_ahead {
        look_ahead_in_run(handler, &then);
    }
    let (mut now, mut seq) = (now, seq);
    let mut effects = handle_one(handler, now, seq, event, effects, steps);
    let mut ends = smallvec::SmallVec::new();
    let mut scanned = 0;
    // The first event scheduled so far, and how many events of `then` may still be handled.
    let mut first: Option<(u64, EventId)> = None;
    let mut free = then.len();
    loop {
        ends.push(end_of(&effects));
        // With no event of the run left, what the handlings scheduled no longer matters here.
        let Some(next) = then.last() else {
            break;
        };
        for e in &effects[scanned..] {
            match e {
                Effect::Schedule(ev) | Effect::ScheduleIn(ev, _) => {
                    let key = (time_key(ev.time), ev.id);
                    first = Some(first.map_or(key, |f| f.min(key)));
                }
                Effect::Cancel(h) => {
                    if let Some(k) = then.iter().position(|ev| ev.id == h.id) {
                        free = free.min(then.len() - 1 - k);
                    }
                }
                Effect::AtInstantEnd(_) | Effect::WithdrawAtInstantEnd(_) => free = 0,
                Effect::Record(_) => {}
            }
        }
        scanned = effects.len();
        if free == 0 || first.is_some_and(|f| f < (time_key(next.time), next.id)) {
            break;
        }
        let event = then.pop().expect("a next event");
        free -= 1;
        seq += 1;
        now = event.time;
        if look_ahead {
            look_ahead_in_run(handler, &then);
        }
        effects = handle_one(handler, now, seq, event, effects, steps);
    }
    then.reverse();
    let mut reply = Reply {
        then,
        ends,
        ..Reply::default()
    };
    // What the last handling schedules at its instant may come next, before the run's events
    // handed back, when the scheduler allowed it ([`Deliver::inline`]): nothing else pending
    // up to the run's last event.
    if inline > 0 && reply.then.first().is_none_or(|n| n.time > now) {
        let at = Instant { now, seq, own };
        return take_on(handler, onward, at, reply, effects);
    }
    reply.effects = effects;
    Handled::Reply(reply)
}

/// What a delivery allows beyond its events: how many more may be taken on, where to, and
/// where the reply goes (see [`Deliver`]).
struct Onward {
    room: u32,
    steps: bool,
    reply_to: Option<ReplyTo>,
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
        reply.inline += 1;
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
                    reply: onward.reply_to.take(),
                    then: Vec::new(),
                    inline: room,
                    look_ahead: false,
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

/// [`HandleEvent::look_ahead`] for the next two events of a run kept in reverse (the next
/// last). The scheduler's own look-ahead sees only the events after the run.
fn look_ahead_in_run<H: HandleEvent + ?Sized>(handler: &H, reversed: &[Event]) {
    let mut rev = reversed.iter().rev();
    if let Some(next) = rev.next() {
        handler.look_ahead(Some(next), rev.next());
    }
}

/// The actor that hosts a handler: it takes [`Deliver`]s and replies with their effects.
#[derive(Debug)]
pub struct Host<H>(pub H);

impl<H: HandleEvent + Unpin + 'static> Actor for Host<H> {
    type Context = Context<Self>;
}

impl<H: HandleEvent + Unpin + 'static> Handler<Deliver> for Host<H> {
    type Result = ();

    fn handle(&mut self, mut msg: Deliver, _: &mut Context<Self>) {
        // Held across the handling: should it panic, dropping it tells the scheduler.
        let reply = msg.reply.take();
        match handle_run(&mut self.0, msg) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;

    /// An actor that counts the replies it is sent as messages.
    struct Mailbox(Arc<AtomicUsize>);

    impl Actor for Mailbox {
        type Context = Context<Self>;
    }

    impl Handler<Replied> for Mailbox {
        type Result = ();
        fn handle(&mut self, _: Replied, _: &mut Context<Self>) {
            self.0.fetch_add(1, Ordering::SeqCst);
        }
    }

    /// How many messages the mailbox has taken, once it has taken those sent before.
    #[derive(Message)]
    #[rtype(result = "usize")]
    struct Count;

    impl Handler<Count> for Mailbox {
        type Result = usize;
        fn handle(&mut self, _: Count, _: &mut Context<Self>) -> usize {
            self.0.load(Ordering::SeqCst)
        }
    }

    /// A scheduler that notes the replies it is handed by a call: `Ok` or `Err`.
    struct Calls(RefCell<Vec<bool>>);

    impl TakesReplies for Calls {
        fn replied(&self, reply: Result<Reply, NoReply>) {
            self.0.borrow_mut().push(reply.is_ok());
        }
    }

    /// A reply made on the thread of the scheduler it is for reaches it by a call while that
    /// scheduler is registered there; other schedulers' replies, replies from other threads,
    /// replies after the registration ends, and every unanswered delivery, go as messages.
    #[test]
    fn replies_on_the_schedulers_thread_are_calls_and_the_others_messages() {
        actix::System::new().block_on(async {
            let messages = Arc::new(AtomicUsize::new(0));
            let addr = Mailbox(messages.clone()).start();
            let to = Arc::new(addr.clone().recipient::<Replied>());
            let calls = Rc::new(Calls(RefCell::new(Vec::new())));
            let (id, other) = (Here::number(), Here::number());
            assert_ne!(id, other);
            let reply_to = |scheduler| ReplyTo::new(to.clone(), Target::Robot(3), scheduler);

            let here = Here::new(id, calls.clone());
            reply_to(id).send(Reply::default());
            reply_to(other).send(Reply::default());
            let from_elsewhere = reply_to(id);
            std::thread::spawn(move || from_elsewhere.send(Reply::default()))
                .join()
                .expect("the other thread");
            drop(reply_to(id));
            assert_eq!(addr.send(Count).await.expect("counted"), 3);
            assert_eq!(*calls.0.borrow(), vec![true]);

            drop(here);
            reply_to(id).send(Reply::default());
            assert_eq!(addr.send(Count).await.expect("counted"), 4);
            assert_eq!(calls.0.borrow().len(), 1);
            assert_eq!(
                Rc::strong_count(&calls),
                1,
                "the thread lets the scheduler go"
            );
        });
    }
}
