//! Travelling behaviours (seed 7.2, after seed 5.1 and 5.2): [`Behaviour::GoTo`] and
//! [`Behaviour::Wander`] move the robot with one MOVETO at speeds drawn as the seed's built-in
//! algorithms draw them, and wait when a move took no time.
//!
//! [`Behaviour::GoTo`]: super::Behaviour::GoTo
//! [`Behaviour::Wander`]: super::Behaviour::Wander

use rand::Rng;

use super::runtime::{Runtime, Scope};
use super::tree::Speed;
use crate::robot::Robot;
use crate::world::geometry::Point;
use crate::world::motion::Motion;

/// Move and turn speeds, drawn in the seed's order: move speed, then turn speed (from its own
/// range, else the seed's rule `min move speed + move speed × U`).
pub(super) fn draw_speeds(robot: &Robot, ms: Speed, ts: Option<Speed>) -> (f64, f64) {
    let mut rng = robot.rng();
    let move_speed = ms.draw(&mut *rng);
    let turn_speed = match ts {
        Some(t) => t.draw(&mut *rng),
        None => ms.min() + move_speed * rng.gen::<f64>(),
    };
    (move_speed, turn_speed)
}

impl Runtime {
    /// MOVETO, or a wait of `retry` if it took no time (as [`crate::algorithm::move_or_wait`]).
    pub(super) async fn move_or_wait(
        &self,
        scope: &Scope,
        dest: Point,
        ms: f64,
        ts: f64,
        retry: f64,
    ) {
        let started = self.robot.now();
        self.motion(
            scope,
            Motion::MoveTo {
                dest,
                move_speed: ms,
                turn_speed: ts,
            },
        )
        .await;
        if self.robot.now() == started {
            self.robot.sleep(retry).await;
        }
    }
}
