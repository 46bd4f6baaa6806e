//! Travelling behaviours (seed 7.2, after seed 5.1 and 5.2): [`Behaviour::GoTo`] and
//! [`Behaviour::Wander`] move the robot with one MOVETO at speeds drawn as the seed's built-in
//! algorithms draw them, and wait when a move took no time.
//!
//! [`Behaviour::GoTo`]: super::Behaviour::GoTo
//! [`Behaviour::Wander`]: super::Behaviour::Wander

use rand::Rng;

use super::runtime::{Runtime, Scope};
use super::tree::{Speed, Target};
use crate::algorithm::{centroid, destination_area};
use crate::robot::Robot;
use crate::world::geometry::Point;
use crate::world::motion::Motion;

/// Move and turn speeds, drawn in the seed's order: move speed, then turn speed (from its own
/// range, else the seed's rule `min move speed + move speed × U`).
fn draw_speeds(robot: &Robot, ms: Speed, ts: Option<Speed>) -> (f64, f64) {
    let mut rng = robot.rng();
    let move_speed = ms.draw(&mut *rng);
    let turn_speed = match ts {
        Some(t) => t.draw(&mut *rng),
        None => ms.min() + move_speed * rng.gen::<f64>(),
    };
    (move_speed, turn_speed)
}

impl Runtime {
    /// [`Behaviour::GoTo`]: one MOVETO to a point, or to the centroid of all robots' GPS
    /// positions read now (seed 5.2); a wait of `retry` when there is no position to go to.
    ///
    /// [`Behaviour::GoTo`]: super::Behaviour::GoTo
    pub(super) async fn go_to(
        &self,
        scope: &Scope,
        to: Target,
        move_speed: Speed,
        turn_speed: Option<Speed>,
        error: f64,
        retry: f64,
    ) {
        let robot = &self.robot;
        let dest = match to {
            Target::Point(x, y) => Point::new(x, y),
            Target::Centroid => {
                let all = robot.gps().all_positions(error).await;
                match centroid(all.into_iter().map(|(_, p)| p)) {
                    Some(c) => c,
                    None => return robot.sleep(retry).await,
                }
            }
        };
        let (ms, ts) = draw_speeds(robot, move_speed, turn_speed);
        self.move_or_wait(scope, dest, ms, ts, retry).await;
    }

    /// [`Behaviour::Wander`]: one MOVETO to a random point of `area` (by default the world's
    /// destination area), speeds drawn first and the point after, as seed 5.1 draws them.
    ///
    /// [`Behaviour::Wander`]: super::Behaviour::Wander
    pub(super) async fn wander(
        &self,
        scope: &Scope,
        area: Option<((f64, f64), (f64, f64))>,
        move_speed: Speed,
        turn_speed: Option<Speed>,
        retry: f64,
    ) {
        let robot = &self.robot;
        let (lo, hi) = match area {
            Some(((x0, y0), (x1, y1))) => (Point::new(x0, y0), Point::new(x1, y1)),
            None => destination_area(robot.info().world),
        };
        let (ms, ts) = draw_speeds(robot, move_speed, turn_speed);
        let dest = {
            let mut rng = robot.rng();
            let (u, v): (f64, f64) = (rng.gen(), rng.gen());
            Point::new(lo.x + (hi.x - lo.x) * u, lo.y + (hi.y - lo.y) * v)
        };
        self.move_or_wait(scope, dest, ms, ts, retry).await;
    }

    /// MOVETO, or a wait of `retry` if it took no time (as [`crate::algorithm::move_or_wait`]).
    async fn move_or_wait(&self, scope: &Scope, dest: Point, ms: f64, ts: f64, retry: f64) {
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
        if crate::algorithm::took_no_time(started, self.robot.now()) {
            self.robot.sleep(retry).await;
        }
    }
}
