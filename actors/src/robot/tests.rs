//! A robot's handling: its buffers, its random stream and what it asks for.
use super::*;
use crate::world::event::{Effect, Event, EventClass, EventId, Payload, Target, NO_ROBOT};
use rand::{Rng, RngCore};

/// Sleeps one second at a time, forever.
#[derive(Debug)]
struct Sleeper;

impl Algorithm for Sleeper {
    fn name(&self) -> &str {
        "Sleeper"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        Box::pin(async move {
            loop {
                robot.sleep(1.0).await;
            }
        })
    }
}

/// Robot 0's handling of `payload` at `now`, as the scheduler's `seq`-th event.
fn handle(actor: &mut RobotActor, now: f64, seq: u64, payload: Payload) -> Vec<Effect> {
    let event = Event {
        time: now,
        id: EventId {
            cause: seq - 1,
            index: 0,
        },
        target: Target::Robot(0),
        class: EventClass::Eventual,
        concerns: [0, NO_ROBOT],
        payload,
    };
    crate::handler::handle_one(actor, now, seq, event, Vec::new(), true)
}

/// The tickets of the timers a handling asks for.
fn timers(effects: &[Effect]) -> Vec<u64> {
    (effects.iter())
        .filter_map(|e| match e {
            Effect::Schedule(Event {
                payload: Payload::Timer { ticket, .. },
                ..
            }) => Some(*ticket),
            _ => None,
        })
        .collect()
}

/// An inbox that a handling leaves empty keeps no buffer (320 bytes a robot, 320 MB at a
/// million robots once each has had a notice); a notice nobody took yet stays.
#[test]
fn an_inbox_left_empty_keeps_no_buffer() {
    let info = RobotInfo {
        id: 0,
        count: 1,
        radius: 5.0,
        world: WorldSize::Infinite,
        steps: true,
    };
    let mut actor = RobotActor::new(info, Box::new(Sleeper), 7, Default::default());
    let start = Payload::Notice(Box::new(Notice::Start));
    let [first] = timers(&handle(&mut actor, 0.0, 1, start))[..] else {
        panic!("one timer asked for");
    };
    let inbox = |a: &RobotActor| {
        let io = a.handle.shared.io.borrow();
        (io.inbox.len(), io.inbox.capacity())
    };
    // A timer's notice the sleeper does not wait for stays in the inbox.
    let stray = Payload::Timer {
        robot: 0,
        ticket: first + 100,
    };
    assert!(timers(&handle(&mut actor, 0.5, 2, stray)).is_empty());
    assert_eq!(inbox(&actor).0, 1);
    // The awaited one is taken, along with nothing else.
    let due = Payload::Timer {
        robot: 0,
        ticket: first,
    };
    assert_eq!(timers(&handle(&mut actor, 1.0, 3, due)).len(), 1);
    assert_eq!(inbox(&actor).0, 1);
    // A second sleeper has its notice taken and its inbox left empty: no buffer kept.
    let mut other = RobotActor::new(info, Box::new(Sleeper), 7, Default::default());
    let start = Payload::Notice(Box::new(Notice::Start));
    let [ticket] = timers(&handle(&mut other, 0.0, 1, start))[..] else {
        panic!("one timer asked for");
    };
    let due = Payload::Timer { robot: 0, ticket };
    assert_eq!(timers(&handle(&mut other, 1.0, 2, due)).len(), 1);
    assert_eq!(inbox(&other), (0, 0));
}

/// An inbox emptied while its thread has a spare already is freed, not kept by its robot.
#[test]
fn an_inbox_emptied_keeps_no_buffer_beside_the_spare() {
    let mut spare = VecDeque::with_capacity(4);
    spare.push_back(Notice::Start);
    spare.clear();
    Spare::take_back(&mut spare, Vec::new());
    assert_eq!(spare.capacity(), 0, "given to the thread");
    let mut own = VecDeque::with_capacity(4);
    own.push_back(Notice::Start);
    own.clear();
    Spare::take_back(&mut own, Vec::new());
    assert_eq!(own.capacity(), 0, "freed: the thread has a spare");
    assert!(SPARE.with_borrow(|s| s.inbox.capacity()) >= 4);
}

/// Draws a number into `drawn` (room kept for eight), then sleeps a second, forever.
#[derive(Debug)]
struct Drawer {
    drawn: std::sync::Arc<std::sync::Mutex<Vec<f64>>>,
}

impl Algorithm for Drawer {
    fn name(&self) -> &str {
        "Drawer"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let drawn = self.drawn.clone();
        Box::pin(async move {
            loop {
                let x: f64 = robot.rng().gen();
                drawn.lock().expect("not poisoned").push(x);
                robot.sleep(1.0).await;
            }
        })
    }
}

/// Once its thread has spare buffers, a robot's handling of a notice allocates
/// nothing of its own: the inbox, the outbox and the live generator are the thread's,
/// lent and given back. Two robots take turns, so each handling uses the buffers the other
/// robot's handling gave back; the numbers drawn are those of each robot's own stream.
#[test]
fn a_robots_handling_borrows_its_buffers_and_gives_them_back() {
    let info = |id| RobotInfo {
        id,
        count: 2,
        radius: 5.0,
        world: WorldSize::Infinite,
        steps: true,
    };
    let drawn = [0, 1].map(|_| std::sync::Arc::new(std::sync::Mutex::new(Vec::with_capacity(8))));
    let mut robots = [0, 1].map(|id| {
        let drawer = Drawer {
            drawn: drawn[id as usize].clone(),
        };
        RobotActor::new(info(id), Box::new(drawer), 7, Default::default())
    });
    let mut tickets = [0, 0];
    let mut seq = 0;
    for round in 0..4 {
        for (id, actor) in robots.iter_mut().enumerate() {
            seq += 1;
            let payload = if round == 0 {
                Payload::Notice(Box::new(Notice::Start))
            } else {
                Payload::Timer {
                    robot: id as RobotId,
                    ticket: tickets[id],
                }
            };
            let event = Event {
                time: f64::from(round),
                id: EventId {
                    cause: seq - 1,
                    index: 0,
                },
                target: Target::Robot(id as RobotId),
                class: EventClass::Eventual,
                concerns: [id as RobotId, NO_ROBOT],
                payload,
            };
            let effects = Vec::with_capacity(8);
            let before = crate::allocations::on_this_thread();
            let effects =
                crate::handler::handle_one(actor, f64::from(round), seq, event, effects, true);
            let made = crate::allocations::on_this_thread() - before;
            // The first handlings start the algorithm (its future) and fill the spares.
            if round >= 2 {
                assert_eq!(made, 0, "robot {id}, round {round}: {made} allocations");
            }
            let [timer] = timers(&effects)[..] else {
                panic!("one timer asked for");
            };
            tickets[id] = timer;
        }
    }
    for (id, drawn) in drawn.iter().enumerate() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        rng.set_stream(id as u64);
        let expected: Vec<f64> = (0..4).map(|_| rng.gen()).collect();
        assert_eq!(*drawn.lock().unwrap(), expected, "robot {id}'s stream");
    }
}

/// A stream at rest resumes exactly where it stopped, whatever seed the generator built
/// between its handlings had (the thread keeps the key of the last seed only): streams
/// of two seeds, taking turns, draw what one generator each, never rebuilt, draws.
#[test]
fn a_stream_resumes_across_handlings_of_other_seeds() {
    let mut streams = [(7, 3), (8, 3), (7, 4)].map(|(seed, id)| (Stream::new(seed), id));
    let mut drawn = [(); 3].map(|_| Vec::new());
    for round in 0..5 {
        for (k, (stream, id)) in streams.iter_mut().enumerate() {
            let rng = stream.live(*id);
            // An odd number of words at times: a handling may stop inside a block.
            drawn[k].push(rng.next_u64());
            if round % 2 == 0 {
                drawn[k].push(u64::from(rng.next_u32()));
            }
            stream.rest();
        }
    }
    for (k, &(seed, id)) in [(7, 3), (8, 3), (7, 4)].iter().enumerate() {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(id);
        let expected: Vec<u64> = (0..5)
            .flat_map(|round| {
                let a = rng.next_u64();
                let b = (round % 2 == 0).then(|| u64::from(rng.next_u32()));
                std::iter::once(a).chain(b)
            })
            .collect();
        assert_eq!(drawn[k], expected, "stream {k}");
    }
}

/// A stream folded back between draws gives the very numbers of one generator drawn
/// without a break: 32- and 64-bit words, floats, across block boundaries.
#[test]
fn a_stream_at_rest_resumes_where_it_stopped() {
    let mut whole = ChaCha8Rng::seed_from_u64(99);
    whole.set_stream(7);
    let mut stream = Stream::new(99);
    for k in 0..500u32 {
        match k % 4 {
            0 => assert_eq!(stream.live(7).next_u32(), whole.next_u32()),
            1 => assert_eq!(stream.live(7).next_u64(), whole.next_u64()),
            2 => assert_eq!(stream.live(7).gen::<f64>(), whole.gen::<f64>()),
            _ => {
                let draws = (k % 7) as usize;
                for _ in 0..draws {
                    assert_eq!(stream.live(7).next_u64(), whole.next_u64());
                }
            }
        }
        if k % 3 != 0 {
            stream.rest();
            assert!(stream.live.is_none());
        }
    }
    assert_eq!(stream.live(7).get_word_pos(), whole.get_word_pos());
}

/// A robot's shared state (its settings, layer ids and buffers) stays small: a million robots
/// hold one each, so every word is megabytes.
#[test]
fn a_robots_shared_state_stays_small() {
    assert!(
        std::mem::size_of::<Shared>() <= 176,
        "{}",
        std::mem::size_of::<Shared>()
    );
}
