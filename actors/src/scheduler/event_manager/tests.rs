//! The event manager's ordering, chains and look-ahead, against brute-force orders.
use super::*;
use crate::handler::HandleEvent;
use crate::host::{handle_delivery, Handled, PassOn};
use crate::world::event::{EventClass, EventId};

fn timer(robot: RobotId) -> Payload {
    Payload::Timer { robot, ticket: 0 }
}

/// Runs a core from timers `(time, robot)` set at the setup, with `handle` as every
/// actor's handling (given the robot of the event, see `robot_of`); returns the events
/// taken as `(time, robot)`, in order.
fn run_timers(
    timers: &[(f64, RobotId)],
    mut handle: impl FnMut(RobotId, &mut Outbox),
) -> Vec<(f64, RobotId)> {
    let mut setup = Outbox::new(0.0, 0);
    for &(t, r) in timers {
        setup.schedule(
            t,
            Target::Robot(r),
            EventClass::Eventual,
            [Some(r), None],
            timer(r),
        );
    }
    let mut core = Core::new(10.0, setup, Observers::default());
    let mut order = Vec::new();
    while let Next::Deliver(_, d) = core.next() {
        let r = robot_of(&d.event.payload);
        order.push((d.now, r));
        let mut out = Outbox::new(d.now, d.seq);
        handle(r, &mut out);
        core.apply(out.into_effects());
    }
    order
}

/// A core with timers for robots `0..n` at 1, 2, ... s.
fn timers_core(n: usize) -> Core {
    let mut setup = Outbox::new(0.0, 0);
    for k in 0..n {
        let r = k as RobotId;
        setup.schedule(
            1.0 + k as f64,
            Target::Robot(r),
            EventClass::Eventual,
            [Some(r), None],
            timer(r),
        );
    }
    Core::new(1e9, setup, Observers::default())
}

/// The core looks ahead only while the queue holds [`LOOK_AHEAD_FROM`] events or more,
/// and then sees the routes of the next two events.
#[test]
fn the_core_looks_ahead_only_in_a_large_queue() {
    // One event taken leaves LOOK_AHEAD_FROM - 1 pending: no look.
    let mut small = timers_core(LOOK_AHEAD_FROM);
    assert!(matches!(small.next(), Next::Deliver(Target::Robot(0), _)));
    assert_eq!(small.ahead(), Ahead::default());
    let mut large = timers_core(LOOK_AHEAD_FROM + 1);
    assert!(matches!(large.next(), Next::Deliver(Target::Robot(0), _)));
    let route = |r: RobotId| Some((Target::Robot(r), [r, crate::world::event::NO_ROBOT]));
    assert_eq!(large.ahead().next, route(1));
    assert_eq!(large.ahead().after, route(2));
}

/// The robot an event stands for here: its timer's, 99 for the end of an instant, 100
/// for a listing's notice.
fn robot_of(p: &Payload) -> RobotId {
    match p {
        Payload::Timer { robot, .. } => *robot,
        Payload::Notice(_) => 100,
        Payload::Settle => 99,
        other => panic!("unexpected {other:?}"),
    }
}

/// Sets robot `r`'s timer now.
fn wake(out: &mut Outbox, r: RobotId) {
    out.schedule(
        out.now(),
        Target::Robot(r),
        EventClass::Eventual,
        [None, None],
        timer(r),
    );
}

/// An instant's end event comes after every other event of its instant, those caused after
/// it was scheduled included, and before the next instant; its own events at the instant
/// follow it. A listing of events taken while one is pending waits for it.
#[test]
fn an_instants_end_event_comes_after_the_instant_and_before_the_next() {
    let order = run_timers(&[(1.0, 1), (1.0, 2), (2.0, 3)], |r, out| match r {
        // Robot 1 asks for the end of the instant, then causes robot 4's timer now and a
        // listing now.
        1 => {
            out.at_instant_end(Target::MotionManager, [None, None], Payload::Settle);
            wake(out, 4);
            out.schedule(
                out.now(),
                Target::EventManager,
                EventClass::Eventual,
                [Some(1), None],
                Payload::ListEvents {
                    robot: 1,
                    of: 1,
                    ticket: 0,
                },
            );
        }
        // Robot 4 causes robot 5's timer now.
        4 => wake(out, 5),
        // The end of the instant causes robot 6's timer now.
        99 => wake(out, 6),
        _ => {}
    });
    // 100: the listing's notice, sent after the end of the instant.
    assert_eq!(
        order,
        [
            (1.0, 1),
            (1.0, 2),
            (1.0, 4),
            (1.0, 5),
            (1.0, 99),
            (1.0, 6),
            (1.0, 100),
            (2.0, 3)
        ]
    );
}

/// An instant's end event withdrawn before it is taken never comes; withdrawing one that
/// was taken changes nothing.
#[test]
fn an_instants_end_event_withdrawn_never_comes() {
    let mut pending = None;
    let order = run_timers(
        &[(1.0, 1), (1.0, 2), (2.0, 3), (2.0, 4)],
        |r, out| match r {
            // Robots 1 and 3 ask for the end of their instant; robot 2 withdraws it at
            // instant 1; at instant 2 the end comes and causes robot 5's timer, which
            // withdraws it after it was taken.
            1 | 3 => {
                pending =
                    Some(out.at_instant_end(Target::MotionManager, [None, None], Payload::Settle));
            }
            2 | 5 => out.withdraw_at_instant_end(pending.expect("asked for")),
            99 => wake(out, 5),
            _ => {}
        },
    );
    assert_eq!(
        order,
        [(1.0, 1), (1.0, 2), (2.0, 3), (2.0, 4), (2.0, 99), (2.0, 5)]
    );
}

/// A handler for every actor of a test run, whose handlings make pseudo-random effects
/// from the run's seed and the event's number: timers for a few robots, now or later,
/// some cancellable and some of those cancelled later, an instant's end event now and
/// then, withdrawn now and then. One state for all targets, as the managers share the
/// world, so that a handling's effects depend on every handling before it.
struct Scrambler {
    seed: u64,
    robots: RobotId,
    claims: crate::world::queue::Claims,
    handles: Vec<crate::world::event::Handle>,
    closing: Option<EventId>,
    /// `(time, number, robot)` of each handling, in order.
    log: Vec<(f64, u64, RobotId)>,
}

impl Scrambler {
    fn new(seed: u64, robots: RobotId) -> Self {
        Self {
            seed,
            robots,
            claims: Default::default(),
            handles: Vec::new(),
            closing: None,
            log: Vec::new(),
        }
    }
}

impl HandleEvent for Scrambler {
    fn handle_event(&mut self, event: Event, out: &mut Outbox) {
        let robot = match event.payload {
            Payload::Timer { robot, .. } => robot,
            _ => 99,
        };
        self.log.push((out.now(), out.cause(), robot));
        // SplitMix64 of the seed, the number and what was handled so far.
        let mut x =
            self.seed ^ out.cause().wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ self.log.len() as u64;
        let mut draw = move |n: u64| {
            x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = x;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            (z ^ (z >> 31)) % n
        };
        let now = out.now();
        for _ in 0..draw(3) {
            // Robots, and as often the motion manager (robot number MANAGER), which may
            // take on at once what it schedules for itself at its instant.
            let r = match draw(2 * u64::from(self.robots)) as RobotId {
                r if r >= self.robots => MANAGER,
                r => r,
            };
            let at = now + [0.0, 0.0, 0.0, 0.25, 0.5, 1.0][draw(6) as usize];
            let robots = [Some(r), None];
            let payload = Payload::Timer {
                robot: r,
                ticket: 0,
            };
            let target = match r {
                MANAGER => Target::MotionManager,
                r => Target::Robot(r),
            };
            if draw(2) == 0 {
                out.schedule(at, target, EventClass::Eventual, robots, payload);
            } else {
                let h = out.schedule_in(
                    &mut self.claims,
                    at,
                    target,
                    EventClass::Eventual,
                    robots,
                    payload,
                );
                self.handles.push(h);
            }
        }
        if !self.handles.is_empty() && draw(3) == 0 {
            let h = self
                .handles
                .swap_remove(draw(self.handles.len() as u64) as usize);
            out.cancel(h);
            self.claims.release(h);
        }
        match draw(12) {
            0 if self.closing.is_none() => {
                let id = out.at_instant_end(Target::Robot(99), [None, None], Payload::Settle);
                self.closing = Some(id);
            }
            1 => {
                if let Some(id) = self.closing.take() {
                    out.withdraw_at_instant_end(id);
                }
            }
            _ => {}
        }
        if robot == 99 {
            self.closing = None;
        }
    }
}

/// The robot number a [`Scrambler`] logs for the motion manager's events.
const MANAGER: RobotId = 50;

/// The reply of a handling that passed nothing on.
fn replied(handled: Handled) -> Reply {
    match handled {
        Handled::Reply(reply) => reply,
        Handled::PassOn(target, _) => panic!("passed on to {target:?} with nowhere to pass"),
    }
}

/// Every actor, for hosts that pass deliveries on: the tests follow each chain themselves.
struct Everyone;

impl PassOn for Everyone {
    fn reaches(&self, _: Target) -> bool {
        true
    }

    fn pass(&self, target: Target, _: Deliver) {
        unreachable!("the test hands the delivery for {target:?} over itself")
    }
}

/// How a core's deliveries are made in [`scrambled`].
#[derive(Clone, Copy, PartialEq)]
enum Hosting {
    /// One event a delivery.
    OneByOne,
    /// A manager's own events taken on at once.
    TakeOn,
    /// Every event taken on at once, passed on to its actor where it is another's.
    PassOn,
}

/// What [`scrambled`] returns.
type Scrambled = (Vec<(f64, u64, RobotId)>, u64, u64, u64, u64);

/// Runs a core over a [`Scrambler`] as `hosting` says; returns the handlings, the events
/// taken, those cancelled, how many deliveries there were and how many were passed on.
fn scrambled(seed: u64, robots: RobotId, hosting: Hosting) -> Scrambled {
    let mut setup = Outbox::new(0.0, 0);
    for r in 0..robots {
        setup.schedule(
            0.1 * f64::from(r),
            Target::Robot(r),
            EventClass::Eventual,
            [Some(r), None],
            timer(r),
        );
    }
    let mut core = Core::new(6.0, setup, Observers::default());
    core.set_instant_limit(10_000);
    core.chains = hosting != Hosting::OneByOne;
    if hosting == Hosting::PassOn {
        core.pass_on = Some(std::sync::Arc::new(Everyone));
    }
    let mut actor = Scrambler::new(seed, robots);
    let (mut deliveries, mut passed) = (0, 0);
    while let Next::Deliver(_, d) = core.next() {
        deliveries += 1;
        // One handler stands for every actor; the target of each event passed on is checked
        // in its handling, as it is the target's own.
        let mut handled = handle_delivery(&mut actor, d);
        while let Handled::PassOn(target, d) = handled {
            assert_eq!(d.event.target, target);
            passed += 1;
            handled = handle_delivery(&mut actor, d);
        }
        core.apply_reply(replied(handled));
    }
    let out = core.finish();
    (
        actor.log,
        out.stats.events,
        out.stats.cancelled,
        deliveries,
        passed,
    )
}

proptest::proptest! {
    /// Deliveries that take on what a manager schedules for itself at its instant, or pass
    /// on what the handlings schedule for others, take the same events in the same order,
    /// with the same numbers, as deliveries of one event each, whatever the handlings
    /// schedule, cancel or leave to the end of an instant; and they need fewer deliveries.
    #[test]
    fn chains_take_the_events_of_one_by_one_delivery(seed in proptest::prelude::any::<u64>(), robots in 1u32..4) {
        let (one, events, cancelled, singles, _) = scrambled(seed, robots, Hosting::OneByOne);
        let (own, own_events, own_cancelled, deliveries, _) = scrambled(seed, robots, Hosting::TakeOn);
        proptest::prop_assert_eq!(&own, &one);
        proptest::prop_assert_eq!((own_events, own_cancelled), (events, cancelled));
        proptest::prop_assert_eq!(singles, events);
        proptest::prop_assert!(deliveries <= singles);
        let (chain, chain_events, chain_cancelled, trips, _) = scrambled(seed, robots, Hosting::PassOn);
        proptest::prop_assert_eq!(&chain, &one);
        proptest::prop_assert_eq!((chain_events, chain_cancelled), (events, cancelled));
        proptest::prop_assert!(trips <= deliveries);
    }
}

/// In a queue large enough for the look-ahead, where a reply's cancellations are asked
/// for before they are applied, cancelled events still never fire and are counted.
#[test]
fn cancellations_asked_for_ahead_still_cancel() {
    let n = LOOK_AHEAD_FROM + 10;
    let mut setup = Outbox::new(0.0, 0);
    let mut claims = crate::world::queue::Claims::default();
    let handles: Vec<_> = (0..n)
        .map(|k| {
            let r = k as RobotId;
            setup.schedule_in(
                &mut claims,
                1.0 + k as f64,
                Target::Robot(r),
                EventClass::Eventual,
                [Some(r), None],
                timer(r),
            )
        })
        .collect();
    // The first handling cancels the events of robots 5, 7, ..., 13.
    let cancelled: Vec<RobotId> = (5..15).step_by(2).collect();
    let mut core = Core::new(1e9, setup, Observers::default());
    let mut fired = Vec::new();
    while let Next::Deliver(_, d) = core.next() {
        let r = robot_of(&d.event.payload);
        fired.push(r);
        let mut out = Outbox::reusing(d.now, d.seq, d.effects);
        if r == 0 {
            for &c in &cancelled {
                out.cancel(handles[c as usize]);
            }
        }
        core.apply(out.into_effects());
    }
    assert_eq!(fired.len(), n - cancelled.len());
    assert!(fired.iter().all(|r| !cancelled.contains(r)));
    assert_eq!(core.finish().stats.cancelled, cancelled.len() as u64);
}

/// Runs `n` robots from timers at 1 s: each robot acts again at the same instant for as long
/// as `again(robot, times it acted)` says. Returns the events handled and the failure.
fn run_instant(
    n: RobotId,
    lead_limit: u64,
    again: impl Fn(RobotId, u64) -> bool,
) -> (u64, Option<RunFailure>) {
    let mut setup = Outbox::new(0.0, 0);
    for r in 0..n {
        setup.schedule(
            1.0,
            Target::Robot(r),
            EventClass::Eventual,
            [Some(r), None],
            timer(r),
        );
    }
    let mut core = Core::new(10.0, setup, Observers::default());
    core.set_lead_limit(lead_limit);
    let mut acted = vec![0u64; n as usize];
    while let Next::Deliver(_, d) = core.next() {
        let r = robot_of(&d.event.payload);
        acted[r as usize] += 1;
        let mut out = Outbox::reusing(d.now, d.seq, d.effects);
        if again(r, acted[r as usize]) {
            out.schedule(
                d.now,
                Target::Robot(r),
                EventClass::Eventual,
                [Some(r), None],
                timer(r),
            );
        }
        core.apply(out.into_effects());
    }
    let out = core.finish();
    (out.stats.events, out.failure)
}

/// A robot that acts again and again at one instant ends the run as a livelock once it has
/// acted `lead` times more than all other robots, however many robots there are: the run
/// stops after about the others' events plus the lead, far below any limit on all events.
#[test]
fn a_robot_acting_again_at_one_instant_is_a_livelock_however_many_robots() {
    for n in [1, 10, 5_000] {
        let (events, failure) = run_instant(n, 300, |r, _| r == n / 2);
        assert_eq!(
            failure,
            Some(RunFailure::RobotLivelock {
                t: 1.0,
                robot: n / 2,
                lead: 300
            }),
            "{n} robots"
        );
        // Each other robot's one event cancels at most one of the spinning robot's.
        assert!(
            events <= 2 * u64::from(n) + 300,
            "{n} robots: {events} events"
        );
    }
}

/// Robots that each act many times at one instant, taking turns, are no livelock: no robot
/// leads the others, whatever the number of events at the instant.
#[test]
fn robots_taking_turns_at_one_instant_are_no_livelock() {
    let (events, failure) = run_instant(10, 50, |_, acted| acted < 200);
    assert_eq!(failure, None);
    assert_eq!(events, 10 * 200);
}

#[test]
fn a_manager_takes_on_what_it_schedules_for_itself_at_a_quiet_instant() {
    // The motion manager's event at t = 1 schedules two more of its own at t = 1 and one for
    // a robot in between; at t = 2 it schedules one of its own while a robot's event waits
    // at t = 2, which must come first.
    #[derive(Default)]
    struct Chain {
        log: Vec<(f64, u64, RobotId)>,
    }
    impl HandleEvent for Chain {
        fn handle_event(&mut self, event: Event, out: &mut Outbox) {
            self.log
                .push((out.now(), out.cause(), robot_of(&event.payload)));
            let at = |r: RobotId| {
                let target = if r == MANAGER {
                    Target::MotionManager
                } else {
                    Target::Robot(r)
                };
                (target, [Some(r), None], timer(r))
            };
            let now = out.now();
            let n = self.log.len();
            let mut put = |r: RobotId| {
                let (target, robots, payload) = at(r);
                out.schedule(now, target, EventClass::Eventual, robots, payload);
            };
            if n == 1 {
                put(MANAGER);
                put(0);
                put(MANAGER);
            } else if n == 6 {
                put(MANAGER);
            }
        }
    }
    let run = |chains: bool| {
        let mut setup = Outbox::new(0.0, 0);
        for (t, r) in [(1.0, MANAGER), (2.0, 1), (2.0, MANAGER)] {
            let target = if r == MANAGER {
                Target::MotionManager
            } else {
                Target::Robot(r)
            };
            setup.schedule(t, target, EventClass::Eventual, [Some(r), None], timer(r));
        }
        let mut core = Core::new(5.0, setup, Observers::default());
        core.chains = chains;
        let mut chain = Chain::default();
        let mut deliveries = Vec::new();
        while let Next::Deliver(_, d) = core.next() {
            deliveries.push((d.now, d.inline));
            let reply = replied(handle_delivery(&mut chain, d));
            core.apply_reply(reply);
        }
        (chain.log, core.finish().stats.events, deliveries)
    };
    let (one, events, _) = run(false);
    let (taken_on, taken_events, deliveries) = run(true);
    assert_eq!(taken_on, one);
    assert_eq!(taken_events, events);
    // One by one: 1 (manager), then its three at t = 1, then at t = 2 the robot (set up
    // first), the manager, and the manager's own.
    let robots: Vec<RobotId> = one.iter().map(|h| h.2).collect();
    assert_eq!(robots, [MANAGER, MANAGER, 0, MANAGER, 1, MANAGER, MANAGER]);
    // Taken on at once: the first manager event at t = 1 takes on the next (its own, first
    // scheduled) but not the robot's, which comes in a delivery of its own, as does the
    // manager's last at t = 1. At t = 2 the manager's event comes after the robot's, and
    // takes on the one it schedules for itself.
    assert_eq!(deliveries.len(), 5, "{deliveries:?}");
    assert_eq!(
        deliveries.iter().map(|d| d.1 > 0).collect::<Vec<_>>(),
        [true, false, true, false, true]
    );
}

/// A handler that does nothing.
struct Idle;

impl HandleEvent for Idle {
    fn handle_event(&mut self, _: Event, _: &mut Outbox) {}
}

/// Over many scrambled runs, passing on saves round trips, and some chains are long.
#[test]
fn passing_on_saves_round_trips() {
    let (mut own, mut trips, mut passed) = (0, 0, 0);
    for seed in 0..64 {
        own += scrambled(seed, 3, Hosting::TakeOn).3;
        let (_, _, _, d, p) = scrambled(seed, 3, Hosting::PassOn);
        (trips, passed) = (trips + d, passed + p);
    }
    assert!(
        passed > 0 && trips < own,
        "{trips} round trips against {own}"
    );
}

/// The scheduler lets hosts pass deliveries on only while it would deliver each event itself:
/// not once a robot has crashed (its events are then dropped), and not with a lead in the
/// robots' vote that a chain could bring to the limit.
#[test]
fn no_passing_on_after_a_crash_or_near_a_livelock() {
    let first_delivery = |crash: bool, lead_limit: u64| {
        let mut setup = Outbox::new(0.0, 0);
        if crash {
            setup.schedule(
                0.5,
                Target::EventManager,
                EventClass::Eventual,
                [Some(0), None],
                Payload::Crash { robot: 0 },
            );
        }
        setup.schedule(
            1.0,
            Target::Robot(1),
            EventClass::Eventual,
            [Some(1), None],
            timer(1),
        );
        let mut core = Core::new(5.0, setup, Observers::default());
        core.chains = true;
        core.pass_on = Some(std::sync::Arc::new(Everyone));
        core.set_lead_limit(lead_limit);
        // A crash has the motion manager stop the robot first.
        loop {
            match core.next() {
                Next::Deliver(Target::Robot(1), d) => return (d.inline, d.pass_on.is_some()),
                Next::Deliver(_, d) => core.apply_reply(replied(handle_delivery(&mut Idle, d))),
                Next::Finish => panic!("robot 1's timer is delivered"),
            }
        }
    };
    assert_eq!(first_delivery(false, LEAD_LIMIT), (CHAIN as u32 - 1, true));
    assert_eq!(first_delivery(true, LEAD_LIMIT), (0, false));
    assert_eq!(first_delivery(false, CHAIN as u64), (0, false));
}
