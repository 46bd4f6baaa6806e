//! How the branches of one running behaviour share the robot (seed 7.2): the notices taken
//! from the robot's inbox that no branch has claimed yet, who owns the running motion and the
//! active push sensors, and the race that runs branches at once and cancels the losers.

use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::future::{pending, poll_fn, Future};
use std::pin::{pin, Pin};
use std::rc::Rc;
use std::task::{Context, Poll};

use crate::robot::{MotionEnd, MotionTicket, Robot};
use crate::world::event::Notice;
use crate::world::motion::Motion;
use crate::world::sensor::{SensorKind, SensorValue};
use crate::world::MotionOutcome;

/// Who owns a motion or a sensor: a branch, by its path of scope numbers from the root (a
/// branch owns what its sub-branches own).
pub(super) type Scope = Rc<Vec<u32>>;

fn within(owner: &Scope, scope: &Scope) -> bool {
    owner.starts_with(scope)
}

/// What the branches of one running behaviour share: the robot, the notices taken from the
/// robot's inbox that no branch has claimed yet, and who owns the running motion and the
/// active push sensors.
pub(super) struct Runtime {
    pub(super) robot: Robot,
    /// Notices taken from the robot (while draining for an interrupt) and not yet claimed.
    held: RefCell<VecDeque<Notice>>,
    /// How many notices were ever moved into `held`: a race polls its branches again while
    /// this grows, so that a branch polled before the move still sees its notice at this
    /// instant.
    moved: Cell<u64>,
    /// The motion the behaviour started last, while it runs, and its owner.
    motion: RefCell<Option<(u64, Scope)>>,
    /// The push sensors the behaviour activated and their owners.
    sensors: RefCell<Vec<(SensorKind, Scope)>>,
    next_scope: Cell<u32>,
}

pub(super) type Local<'a> = Pin<Box<dyn Future<Output = ()> + 'a>>;

/// A branch of a race: builds its future given its scope.
pub(super) type Branch<'a> = Box<dyn FnOnce(Scope) -> Local<'a> + 'a>;

/// Polls `f` once, now: for the robot's own waits, which are ready as soon as their notice is
/// in the inbox.
fn poll_now<T>(f: impl Future<Output = T>, cx: &mut Context<'_>) -> Option<T> {
    match pin!(f).poll(cx) {
        Poll::Ready(v) => Some(v),
        Poll::Pending => None,
    }
}

impl Runtime {
    /// A runtime for one behaviour run on `robot`.
    pub(super) fn new(robot: &Robot) -> Self {
        Runtime {
            robot: robot.clone(),
            held: RefCell::new(VecDeque::new()),
            moved: Cell::new(0),
            motion: RefCell::new(None),
            sensors: RefCell::new(Vec::new()),
            next_scope: Cell::new(0),
        }
    }

    fn child(&self, scope: &Scope) -> Scope {
        let k = self.next_scope.get();
        self.next_scope.set(k + 1);
        let mut s = (**scope).clone();
        s.push(k);
        Rc::new(s)
    }

    /// Removes and returns the first held notice `pick` accepts.
    fn claim<T>(&self, pick: impl Fn(&Notice) -> Option<T>) -> Option<T> {
        let mut held = self.held.borrow_mut();
        let (i, v) = held
            .iter()
            .enumerate()
            .find_map(|(i, n)| pick(n).map(|v| (i, v)))?;
        held.remove(i);
        Some(v)
    }

    /// Moves every interrupt, motion end and message waiting in the robot's inbox into `held`
    /// (the robot offers no wait for interrupts alone).
    fn drain(&self, cx: &mut Context<'_>) {
        while let Some(n) = poll_now(self.robot.next_notice(), cx) {
            self.held.borrow_mut().push_back(n);
            self.moved.set(self.moved.get() + 1);
        }
    }

    fn ended(&self, ticket: u64, end: MotionEnd) -> MotionEnd {
        let mut m = self.motion.borrow_mut();
        if m.as_ref().is_some_and(|(t, _)| *t == ticket) {
            *m = None;
        }
        end
    }

    /// The end of motion `ticket`, if it has ended.
    pub(super) fn try_motion_end(&self, ticket: u64, cx: &mut Context<'_>) -> Option<MotionEnd> {
        let end = self
            .claim(|n| match n {
                Notice::MotionEnded {
                    ticket: t,
                    outcome,
                    state,
                } if *t == ticket => Some(MotionEnd {
                    outcome: outcome.clone(),
                    state: *state,
                }),
                _ => None,
            })
            .or_else(|| poll_now(self.robot.wait_motion(MotionTicket(ticket)), cx))?;
        Some(self.ended(ticket, end))
    }

    /// Waits for the end of motion `ticket`, however it ends.
    pub(super) async fn motion_end(&self, ticket: u64) -> MotionEnd {
        poll_fn(|cx| match self.try_motion_end(ticket, cx) {
            Some(e) => Poll::Ready(e),
            None => Poll::Pending,
        })
        .await
    }

    /// Starts `motion` for `scope`, replacing any running one.
    pub(super) fn start_motion(&self, scope: &Scope, motion: Motion) -> u64 {
        let t = self.robot.start_motion(motion).0;
        *self.motion.borrow_mut() = Some((t, scope.clone()));
        t
    }

    /// Performs `motion` for `scope`. If another branch replaces it, the branch waits until it
    /// is cancelled.
    pub(super) async fn motion(&self, scope: &Scope, motion: Motion) -> MotionEnd {
        let t = self.start_motion(scope, motion);
        let end = self.motion_end(t).await;
        if end.outcome == MotionOutcome::Replaced {
            pending::<()>().await;
        }
        end
    }

    /// Waits for an interrupt of `sensor`: its value.
    pub(super) async fn interrupt(&self, sensor: SensorKind) -> SensorValue {
        let pick = |n: &Notice| match n {
            Notice::Interrupt { sensor: s, value } if *s == sensor => Some(value.clone()),
            _ => None,
        };
        poll_fn(|cx| {
            if let Some(v) = self.claim(pick) {
                return Poll::Ready(v);
            }
            self.drain(cx);
            match self.claim(pick) {
                Some(v) => Poll::Ready(v),
                None => Poll::Pending,
            }
        })
        .await
    }

    /// Waits for a message or indication and consumes it.
    pub(super) async fn message(&self) {
        poll_fn(|cx| {
            if self
                .claim(|n| matches!(n, Notice::Incoming { .. }).then_some(()))
                .is_some()
                || poll_now(self.robot.receive(), cx).is_some()
            {
                Poll::Ready(())
            } else {
                Poll::Pending
            }
        })
        .await
    }

    /// Drops the queued interrupts of `sensor` (from an earlier activation).
    async fn purge(&self, sensor: SensorKind) {
        poll_fn(|cx| {
            self.drain(cx);
            Poll::Ready(())
        })
        .await;
        self.held
            .borrow_mut()
            .retain(|n| !matches!(n, Notice::Interrupt { sensor: s, .. } if *s == sensor));
    }

    /// Activates push proximity (`Some(range)`) or contact (`None`) for `scope`.
    pub(super) async fn activate(&self, scope: &Scope, proximity: Option<f64>) -> SensorKind {
        let kind = match proximity {
            Some(_) => SensorKind::PUSH_PROXIMITY,
            None => SensorKind::CONTACT,
        };
        self.purge(kind).await;
        // Owned before the request is answered, so a branch cancelled meanwhile still has it
        // deactivated.
        self.sensors.borrow_mut().push((kind, scope.clone()));
        match proximity {
            Some(range) => {
                self.robot.activate_proximity(range, 0.0).await;
            }
            None => self.robot.activate_contact().await,
        }
        kind
    }

    pub(super) async fn deactivate(&self, sensor: SensorKind) {
        self.sensors.borrow_mut().retain(|(k, _)| *k != sensor);
        if sensor == SensorKind::CONTACT {
            self.robot.deactivate_contact().await;
        } else {
            self.robot.deactivate_proximity().await;
        }
        self.purge(sensor).await;
    }

    /// Stops what the cancelled branch `scope` left running: its motion and its sensors.
    async fn cancel(&self, scope: &Scope) {
        let owned = self
            .motion
            .borrow()
            .as_ref()
            .filter(|(_, owner)| within(owner, scope))
            .map(|(t, _)| *t);
        if let Some(t) = owned {
            let done = poll_fn(|cx| Poll::Ready(self.try_motion_end(t, cx))).await;
            if done.is_none() {
                let stop = self.start_motion(
                    scope,
                    Motion::Forward {
                        distance: 0.0,
                        move_speed: 1.0,
                    },
                );
                self.motion_end(t).await;
                self.motion_end(stop).await;
            }
        }
        let sensors: Vec<SensorKind> = self
            .sensors
            .borrow()
            .iter()
            .filter(|(_, owner)| within(owner, scope))
            .map(|(k, _)| *k)
            .collect();
        for k in sensors {
            self.deactivate(k).await;
        }
    }

    /// Runs `branches` at once; the first to finish wins and the others are cancelled.
    pub(super) async fn race<'a>(&'a self, scope: &Scope, branches: Vec<Branch<'a>>) {
        let scopes: Vec<Scope> = branches.iter().map(|_| self.child(scope)).collect();
        let mut futures: Vec<Local<'a>> = branches
            .into_iter()
            .zip(&scopes)
            .map(|(b, s)| b(s.clone()))
            .collect();
        let winner = poll_fn(|cx| loop {
            let moved = self.moved.get();
            for (i, f) in futures.iter_mut().enumerate() {
                if f.as_mut().poll(cx).is_ready() {
                    return Poll::Ready(i);
                }
            }
            if self.moved.get() == moved {
                return Poll::Pending;
            }
        })
        .await;
        drop(futures);
        for (i, s) in scopes.iter().enumerate() {
            if i != winner {
                self.cancel(s).await;
            }
        }
    }
}
