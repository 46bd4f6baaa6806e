//! Behaviours around the other robots (seed 7.2): [`Behaviour::Avoid`] turns away and backs
//! off when another robot comes near, [`Behaviour::Follow`] keeps a robot at a distance.
//!
//! [`Behaviour::Avoid`]: super::Behaviour::Avoid
//! [`Behaviour::Follow`]: super::Behaviour::Follow

use std::future::{pending, poll_fn};
use std::task::Poll;

use super::runtime::{Runtime, Scope};
use crate::world::geometry::{shortest_turn, vector_heading};
use crate::world::motion::Motion;
use crate::world::sensor::builtins::Gap;
use crate::world::{MotionOutcome, RobotId};

impl Runtime {
    #[allow(clippy::too_many_arguments)]
    pub(super) async fn avoid(
        &self,
        scope: &Scope,
        range: f64,
        turn_speed: f64,
        back_off: f64,
        move_speed: f64,
        retry: f64,
    ) {
        let k = self.activate(scope, Some(range)).await;
        let gaps = self
            .interrupt(k)
            .await
            .decode::<Vec<Gap>>()
            .unwrap_or_default();
        self.deactivate(k).await;
        let started = self.robot.now();
        // Stop where we are (replacing any motion) and learn the heading.
        let here = self
            .motion(
                scope,
                Motion::Forward {
                    distance: 0.0,
                    move_speed: 1.0,
                },
            )
            .await
            .state;
        let nearest = gaps
            .iter()
            .min_by(|a, b| {
                a.distance
                    .total_cmp(&b.distance)
                    .then(a.robot.cmp(&b.robot))
            })
            .map(|g| g.robot);
        let other = match nearest {
            Some(id) => self
                .robot
                .gps()
                .all_positions(0.0)
                .await
                .into_iter()
                .find(|(r, _)| *r == id)
                .map(|(_, p)| p),
            None => None,
        };
        if let Some(p) = other.filter(|p| *p != here.pos) {
            let angle = shortest_turn(here.angle, vector_heading(here.pos - p));
            self.motion(scope, Motion::Turn { angle, turn_speed }).await;
            if back_off > 0.0 {
                self.motion(
                    scope,
                    Motion::Forward {
                        distance: back_off,
                        move_speed,
                    },
                )
                .await;
            }
        }
        if crate::algorithm::took_no_time(started, self.robot.now()) {
            self.robot.sleep(retry).await;
        }
    }

    pub(super) async fn follow(
        &self,
        scope: &Scope,
        target: RobotId,
        distance: f64,
        move_speed: f64,
        turn_speed: f64,
        period: f64,
    ) {
        let me = self.robot.id();
        if target == me || target as usize >= self.robot.info().count {
            self.robot
                .log(format!("Follow: there is no other robot {target}"));
            return pending().await;
        }
        let mut running: Option<u64> = None;
        loop {
            if let Some(t) = running {
                let end = poll_fn(|cx| Poll::Ready(self.try_motion_end(t, cx))).await;
                match end.map(|e| e.outcome) {
                    // Another branch took the body over.
                    Some(MotionOutcome::Replaced) => return pending().await,
                    Some(_) => running = None,
                    None => {}
                }
            }
            let all = self.robot.gps().all_positions(0.0).await;
            let find = |id| all.iter().find(|(r, _)| *r == id).map(|(_, p)| *p);
            let next = match (find(me), find(target)) {
                (Some(mine), Some(theirs)) if (theirs - mine).norm() > distance => {
                    let gap = (theirs - mine).norm();
                    Some(Motion::MoveTo {
                        dest: theirs + (mine - theirs) * (distance / gap),
                        move_speed,
                        turn_speed,
                    })
                }
                _ if running.is_some() => Some(Motion::Forward {
                    distance: 0.0,
                    move_speed: 1.0,
                }),
                _ => None,
            };
            if let Some(m) = next {
                let t = self.start_motion(scope, m);
                if let Some(old) = running.replace(t) {
                    self.motion_end(old).await;
                }
            }
            self.robot.sleep(period).await;
        }
    }
}
