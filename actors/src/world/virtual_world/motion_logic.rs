//! The motion manager's logic (seed 4.2.3, fig. 4.4): motion requests become motion events,
//! each step is applied when it happens, and collisions (seed 3.3, 4.4) end motions where the
//! robots touch.

use super::*;
use smallvec::smallvec;

use crate::world::motion::MotionPattern;

impl VirtualWorld {
    /// Ends `id`'s motion in progress, if any, with `outcome`; the robot rests where it is.
    /// Returns whether there was a motion to end.
    fn end_motion(&mut self, id: RobotId, outcome: MotionOutcome, out: &mut Outbox) -> bool {
        let now = out.now();
        let state = self.state_at(id, now);
        let r = &mut self.robots[id as usize];
        if r.motion.take().is_none() {
            return false;
        }
        r.rest = state.pose();
        let state = Kinematics::at_rest(r.rest);
        out.record_step(|| Observation::MotionFinish {
            robot: id,
            state,
            outcome: outcome.clone(),
        });
        out.notify(
            id,
            Notice::MotionEnded {
                ticket: r.ticket,
                outcome,
                state,
            },
        );
        true
    }

    /// A robot's own conditional event `id` fired: its handle is dropped and its slot released
    /// now rather than at the robot's next change of path (a million robots would otherwise
    /// keep the slots of their fired motion steps and crossings).
    fn fired(&mut self, robot: RobotId, id: EventId) {
        let r = &mut self.robots[robot as usize];
        if let Some(k) = r.own.iter().position(|h| EventId::from(*h) == id) {
            let h = r.own.swap_remove(k);
            self.claims.release(h);
        } else if r.obstacle.is_some_and(|h| EventId::from(h) == id) {
            if let Some(h) = r.obstacle.take() {
                self.claims.release(h);
            }
        }
    }

    /// Handles the event `id` addressed to the motion manager (seed fig. 4.4 and 4.6-4.8).
    pub fn handle_motion(&mut self, id: EventId, payload: Payload, out: &mut Outbox) {
        match payload {
            Payload::MotionStep { robot, .. }
            | Payload::CellCrossing { robot, .. }
            | Payload::Contact { robot, .. } => self.fired(robot, id),
            _ => {}
        }
        match payload {
            Payload::MotionRequest { robot, .. } if self.robots[robot as usize].crashed => {}
            Payload::MotionRequest {
                robot,
                ticket,
                motion,
                note,
            } => {
                if let Some(note) = note {
                    out.record(*note);
                }
                self.motion_request(robot, ticket, &motion, out)
            }
            Payload::Crash { robot } => {
                let now = out.now();
                self.end_motion(robot, MotionOutcome::Crashed, out);
                self.invalidate(robot, out);
                self.robots[robot as usize].crashed = true;
                let r = &mut self.robots[robot as usize];
                r.listening = None;
                out.record(Observation::Crash {
                    robot,
                    state: self.state_at(robot, now),
                });
                self.predict_all(robot, out);
            }
            Payload::MotionStep {
                robot,
                step,
                through,
            } => self.motion_steps(robot, step, through, out),
            Payload::Collision { a, b } => self.collision(a, Obstacle::Robot(b), None, out),
            Payload::Contact { robot, with, at } => self.collision(robot, with, Some(at), out),
            Payload::CellCrossing { robot, offset } => self.cross(robot, offset, out),
            Payload::Settle => self.settle_all(out),
            other => tracing::warn!(?other, "motion manager ignores an event it does not serve"),
        }
    }

    fn motion_request(&mut self, robot: RobotId, ticket: u64, motion: &Motion, out: &mut Outbox) {
        let now = out.now();
        self.end_motion(robot, MotionOutcome::Replaced, out);
        self.invalidate(robot, out);
        let from = self.robots[robot as usize].rest;
        out.record_step(|| Observation::MotionRequest {
            robot,
            ticket,
            motion: motion.clone(),
        });
        match motion.path(now, from, self.cfg.turn) {
            Err(e) => {
                let outcome = MotionOutcome::Rejected(e.to_string());
                out.record_step(|| Observation::MotionFinish {
                    robot,
                    state: Kinematics::at_rest(from),
                    outcome: outcome.clone(),
                });
                out.notify(
                    robot,
                    Notice::MotionEnded {
                        ticket,
                        outcome,
                        state: Kinematics::at_rest(from),
                    },
                );
            }
            Ok(pattern) => {
                let steps = steps_of(&pattern);
                let r = &mut self.robots[robot as usize];
                r.motion = Some(pattern);
                r.ticket = ticket;
                for (k, through, t) in step_events(&steps, 0) {
                    let class = if k == 0 {
                        EventClass::Eventual
                    } else {
                        EventClass::Conditional
                    };
                    let e = out.schedule_in(
                        &mut self.claims,
                        t,
                        Target::MotionManager,
                        class,
                        [Some(robot), None],
                        Payload::MotionStep {
                            robot,
                            step: k,
                            through,
                        },
                    );
                    r.own.push(e);
                }
                r.next_step = 0;
            }
        }
        self.predict_all(robot, out);
    }

    /// Steps `step` to `through` of `robot`'s motion, which happen at this instant, one
    /// after the other.
    fn motion_steps(&mut self, robot: RobotId, step: usize, through: usize, out: &mut Outbox) {
        for k in step..=through {
            if !self.motion_step(robot, k, out) {
                break;
            }
        }
    }

    /// Step `step` of `robot`'s motion; whether the motion goes on after it.
    fn motion_step(&mut self, robot: RobotId, step: usize, out: &mut Outbox) -> bool {
        let now = out.now();
        let r = &mut self.robots[robot as usize];
        if r.motion.is_none() {
            return false;
        }
        r.next_step = step as u32 + 1;
        let r = &self.robots[robot as usize];
        let m = r.motion.as_ref().map(Path::pattern).expect("checked above");
        let (crate::world::motion::MotionStep { kind, .. }, last) =
            m.step(step).expect("a step of the motion");
        out.record_step(|| Observation::MotionStep {
            robot,
            step: kind,
            state: m.state_at(now),
            progress: m.progress_at(now),
        });
        if last {
            let state = m.state_at(m.end_time());
            let ticket = r.ticket;
            let r = &mut self.robots[robot as usize];
            r.rest = state.pose();
            r.motion = None;
            self.settle(robot, now);
            out.record_step(|| Observation::MotionFinish {
                robot,
                state,
                outcome: MotionOutcome::Arrived,
            });
            out.notify(
                robot,
                Notice::MotionEnded {
                    ticket,
                    outcome: MotionOutcome::Arrived,
                    state,
                },
            );
        }
        !last
    }

    /// Robots and walls that `x` touches at `now` while moving towards them, other than those
    /// in `known` (contacts, their points aside): contacts at the same instant as a collision
    /// that stops `x`.
    fn simultaneous_contacts(
        &self,
        x: RobotId,
        now: f64,
        known: &[(RobotId, Obstacle, Option<Point>)],
    ) -> SmallVec<[(Obstacle, Option<Point>); 2]> {
        const TOUCH: f64 = 1e-9;
        let kx = self.state_at(x, now);
        let rx = self.radius(x);
        let mut out = SmallVec::new();
        let listed = |o: Obstacle| {
            known.iter().any(|&(p, q, _)| {
                (p == x && q == o) || (q == Obstacle::Robot(x) && Obstacle::Robot(p) == o)
            })
        };
        // The cell `x` is in now (it is registered in the cells ahead of it too).
        let here = self.grid.cell_of(kx.pos);
        if !self.cfg.ghost_mode {
            for o in self.grid.neighbours(here) {
                // A moving robot is registered in several cells.
                if o == x
                    || listed(Obstacle::Robot(o))
                    || out.iter().any(|(p, _)| *p == Obstacle::Robot(o))
                {
                    continue;
                }
                let ko = self.state_at(o, now);
                let d = kx.pos - ko.pos;
                if d.norm() - rx - self.radius(o) <= TOUCH && d.dot(&(kx.vel - ko.vel)) < 0.0 {
                    out.push((Obstacle::Robot(o), None));
                }
            }
        }
        if let WorldSize::Bounded { min, max } = self.cfg.size {
            if !listed(Obstacle::Boundary) {
                let hit = crate::world::geometry::first_wall_contact(
                    kx.pos,
                    kx.vel,
                    rx,
                    min,
                    max,
                    TOUCH / kx.vel.norm().max(1e-300),
                );
                if let Some((_, c)) = hit {
                    out.push((Obstacle::Boundary, Some(c)));
                }
            }
        }
        for i in self.obstacles.around(here) {
            let (k, prim) = self.obstacles.get(i);
            if listed(Obstacle::Object(k)) || out.iter().any(|(o, _)| *o == Obstacle::Object(k)) {
                continue;
            }
            let c = prim.nearest(kx.pos);
            if prim.distance(kx.pos) - rx <= TOUCH && (c - kx.pos).dot(&kx.vel) > 0.0 {
                out.push((Obstacle::Object(k), Some(c)));
            }
        }
        out
    }

    /// A collision stops both robots (seed 3.3); every other contact either of them makes at
    /// the same instant is a collision too.
    fn collision(&mut self, a: RobotId, b: Obstacle, contact: Option<Point>, out: &mut Outbox) {
        let now = out.now();
        // Inline: a collision has mostly one contact and stops two robots (on the heap, these
        // would be six allocations a collision).
        let mut contacts: SmallVec<[(RobotId, Obstacle, Option<Point>); 4]> =
            smallvec![(a, b, contact)];
        let mut stopped: SmallVec<[RobotId; 4]> = SmallVec::new();
        let mut k = 0;
        while k < contacts.len() {
            let (x, y, c) = contacts[k];
            k += 1;
            let kx = self.state_at(x, now);
            let other_pos = match y {
                Obstacle::Robot(y) => self.state_at(y, now).pos,
                Obstacle::Boundary | Obstacle::Object(_) => c.unwrap_or(kx.pos),
            };
            out.record(Observation::Collision {
                robot: x,
                other: y,
                pos: kx.pos,
                angle: kx.angle,
                other_pos,
            });
            let mut sides: SmallVec<[(RobotId, Obstacle); 2]> = smallvec![(x, y)];
            if let Obstacle::Robot(y) = y {
                sides.push((y, Obstacle::Robot(x)));
            }
            for (r, with) in sides {
                for (o, c) in self.simultaneous_contacts(r, now, &contacts) {
                    contacts.push((r, o, c));
                }
                if self.end_motion(r, MotionOutcome::Collided { with }, out) {
                    stopped.push(r);
                }
            }
        }
        for &x in &stopped {
            self.invalidate(x, out);
        }
        // A pair's collision has been consumed even if neither path changed: drop the pair's
        // remaining predictions and make them again from the new state.
        let pairs: SmallVec<[(RobotId, RobotId); 4]> = contacts
            .iter()
            .filter_map(|&(x, y, _)| match y {
                Obstacle::Robot(y) => Some((x, y)),
                Obstacle::Boundary | Obstacle::Object(_) => None,
            })
            .collect();
        for &(x, y) in &pairs {
            if let Some(ids) = self.robots[x as usize].pairs.remove(&y) {
                ids.into_iter().for_each(|h| self.drop_handle(h, out));
                self.robots[y as usize].pairs.remove(&x);
            }
        }
        // The robots stopped are predicted for at the end of the instant, if still at rest;
        // that covers their pairs too.
        for &x in &stopped {
            self.unsettle(x, out);
        }
        for &(x, y) in &pairs {
            if !self.is_unsettled(x)
                && !self.is_unsettled(y)
                && !self.robots[x as usize].pairs.contains_key(&y)
            {
                self.predict_pair(x, y, out);
            }
        }
        for &(x, y, _) in &contacts {
            let mut sides: SmallVec<[(RobotId, Obstacle); 2]> = smallvec![(x, y)];
            if let Obstacle::Robot(y) = y {
                sides.push((y, Obstacle::Robot(x)));
            }
            // Each contact sensor of a robot that touched something senses now, on the
            // sensor manager.
            for (robot, with) in sides {
                for &sensor in self.robots[robot as usize].contact() {
                    out.schedule(
                        out.now(),
                        Target::SensorManager,
                        EventClass::Eventual,
                        [Some(robot), None],
                        Payload::Touched {
                            robot,
                            sensor,
                            with,
                        },
                    );
                }
            }
        }
    }
}

/// The events that stand for a motion's `steps` from the `from`-th on: `(first step, last
/// step, instant)`. A step at the same instant as the one before it is handled with it, in
/// the same event: the two would be taken one right after the other anyway (scheduled by the
/// same handling, their causal keys follow each other), so the trace is the same, with one
/// event fewer (a MOVETO's finish-turn and start-forward, a noticeable share of a million
/// robots' events after the turning phase). A motion's first step stays alone: it is eventual,
/// the others conditional.
/// A motion's steps ([`MotionPattern::events`]); the built-in pattern's are asked one by one
/// ([`MotionPattern::step`]), which allocates nothing (where a vector would be an allocation
/// a request).
fn steps_of(path: &Path) -> SmallVec<[crate::world::motion::MotionStep; 4]> {
    match path {
        Path::Builtin(m) => {
            let mut steps = SmallVec::new();
            while let Some((step, last)) = m.step(steps.len()) {
                steps.push(step);
                if last {
                    break;
                }
            }
            steps
        }
        Path::Custom(m) => m.events().into(),
    }
}

pub(crate) fn step_events(
    steps: &[crate::world::motion::MotionStep],
    from: usize,
) -> SmallVec<[(usize, usize, f64); 4]> {
    let mut out: SmallVec<[(usize, usize, f64); 4]> = SmallVec::new();
    for (k, s) in steps.iter().enumerate().skip(from) {
        match out.last_mut() {
            Some((first, through, t)) if *first > 0 && *t == s.t => *through = k,
            _ => out.push((k, k, s.t)),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::step_events;
    use crate::world::motion::{MotionStep, StepKind};

    fn steps(times: &[f64]) -> Vec<MotionStep> {
        times
            .iter()
            .map(|&t| MotionStep {
                t,
                kind: StepKind::Custom("".into()),
            })
            .collect()
    }

    #[test]
    fn steps_at_the_instant_of_the_one_before_share_its_event_except_the_first() {
        // A MOVETO: start-turn, finish-turn and start-forward at one instant, finish-forward.
        assert_eq!(
            step_events(&steps(&[0.0, 2.0, 2.0, 12.0]), 0).to_vec(),
            vec![(0, 0, 0.0), (1, 2, 2.0), (3, 3, 12.0)]
        );
        // A turn of no length: the finish-turn is not the eventual start-turn's.
        assert_eq!(
            step_events(&steps(&[1.0, 1.0, 1.0, 5.0, 5.0, 5.0]), 0).to_vec(),
            vec![(0, 0, 1.0), (1, 2, 1.0), (3, 5, 5.0)]
        );
        // From a later step on (steps scheduled again).
        assert_eq!(
            step_events(&steps(&[0.0, 2.0, 2.0, 12.0]), 2).to_vec(),
            vec![(2, 2, 2.0), (3, 3, 12.0)]
        );
        assert!(step_events(&steps(&[0.0]), 1).is_empty());
    }
}
