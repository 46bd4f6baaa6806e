//! Running a behaviour tree on a robot (seed 7.2): each primitive by its family's code, and
//! the combinators `Sequence`, `Repeat`, `Until` and `Race` over them (the parent module's
//! doc says how branches share the robot and are cancelled). A behaviour is an [`Algorithm`]
//! of its own.

use std::rc::Rc;

use rand::Rng;

use super::runtime::{Branch, Local, Runtime, Scope};
use super::travel::draw_speeds;
use super::tree::{Behaviour, Count, Target};
use crate::algorithm::{centroid, destination_area};
use crate::robot::{Algorithm, AlgorithmFuture, Robot};
use crate::world::geometry::Point;

impl Behaviour {
    /// Runs the behaviour on `robot` until it finishes (see the module doc for how branches
    /// share the robot). Incoming messages the behaviour takes from the robot while it waits for
    /// a sensor and does not use (no `Message` condition claims them) are dropped when it
    /// finishes.
    pub async fn run(&self, robot: &Robot) {
        let rt = Runtime::new(robot);
        self.exec(&rt, Rc::new(Vec::new())).await;
    }

    fn exec<'a>(&'a self, rt: &'a Runtime, scope: Scope) -> Local<'a> {
        Box::pin(async move {
            let robot = &rt.robot;
            match self {
                Behaviour::GoTo {
                    to,
                    move_speed,
                    turn_speed,
                    error,
                    retry,
                } => {
                    let dest = match *to {
                        Target::Point(x, y) => Point::new(x, y),
                        Target::Centroid => {
                            let all = robot.gps().all_positions(*error).await;
                            match centroid(all.into_iter().map(|(_, p)| p)) {
                                Some(c) => c,
                                None => return robot.sleep(*retry).await,
                            }
                        }
                    };
                    let (ms, ts) = draw_speeds(robot, *move_speed, *turn_speed);
                    rt.move_or_wait(&scope, dest, ms, ts, *retry).await;
                }
                Behaviour::Wander {
                    area,
                    move_speed,
                    turn_speed,
                    retry,
                } => {
                    let (lo, hi) = match *area {
                        Some(((x0, y0), (x1, y1))) => (Point::new(x0, y0), Point::new(x1, y1)),
                        None => destination_area(robot.info().world),
                    };
                    let (ms, ts) = draw_speeds(robot, *move_speed, *turn_speed);
                    let dest = {
                        let mut rng = robot.rng();
                        let (u, v): (f64, f64) = (rng.gen(), rng.gen());
                        Point::new(lo.x + (hi.x - lo.x) * u, lo.y + (hi.y - lo.y) * v)
                    };
                    rt.move_or_wait(&scope, dest, ms, ts, *retry).await;
                }
                Behaviour::Wait(t) => robot.sleep(*t).await,
                Behaviour::WaitFor(c) => rt.condition(&scope, *c).await,
                Behaviour::Avoid {
                    range,
                    turn_speed,
                    back_off,
                    move_speed,
                    retry,
                } => {
                    rt.avoid(
                        &scope,
                        *range,
                        *turn_speed,
                        back_off.unwrap_or(*range),
                        *move_speed,
                        *retry,
                    )
                    .await
                }
                Behaviour::Follow {
                    robot: target,
                    distance,
                    move_speed,
                    turn_speed,
                    period,
                } => {
                    rt.follow(
                        &scope,
                        *target,
                        *distance,
                        *move_speed,
                        *turn_speed,
                        *period,
                    )
                    .await
                }
                Behaviour::Sequence(v) => {
                    for b in v {
                        b.exec(rt, scope.clone()).await;
                    }
                }
                Behaviour::Repeat(Count::Times(n), b) => {
                    for _ in 0..*n {
                        b.exec(rt, scope.clone()).await;
                    }
                }
                Behaviour::Repeat(Count::Forever, b) => loop {
                    b.exec(rt, scope.clone()).await;
                },
                Behaviour::Until(c, b) => {
                    let c = *c;
                    rt.race(
                        &scope,
                        vec![
                            Box::new(move |s| b.exec(rt, s)) as Branch<'a>,
                            Box::new(move |s: Scope| {
                                Box::pin(async move { rt.condition(&s, c).await }) as Local<'a>
                            }),
                        ],
                    )
                    .await
                }
                Behaviour::Race(v) => {
                    rt.race(
                        &scope,
                        v.iter()
                            .map(|b| Box::new(move |s| b.exec(rt, s)) as Branch<'a>)
                            .collect(),
                    )
                    .await
                }
            }
        })
    }
}

impl Algorithm for Behaviour {
    fn name(&self) -> &str {
        "Behaviour"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let b = self.clone();
        Box::pin(async move { b.run(&robot).await })
    }
}
