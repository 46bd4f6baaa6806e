//! Running a behaviour tree on a robot (seed 7.2): each primitive by its family's code, and
//! the combinators `Sequence`, `Repeat`, `Until` and `Race` over them (the parent module's
//! doc says how branches share the robot and are cancelled). A behaviour is an [`Algorithm`]
//! of its own.

use std::rc::Rc;

use super::runtime::{Branch, Local, Runtime, Scope};
use super::tree::{Behaviour, Count};
use crate::robot::{Algorithm, AlgorithmFuture, Robot};

impl Behaviour {
    /// Runs the behaviour on `robot` until it finishes (see [`crate::behaviour`] for how
    /// branches share the robot). Incoming messages the behaviour takes from the robot while it
    /// waits for a sensor and does not use (no `Message` condition claims them) are dropped
    /// when it finishes.
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
                    rt.go_to(&scope, *to, *move_speed, *turn_speed, *error, *retry)
                        .await
                }
                Behaviour::Wander {
                    area,
                    move_speed,
                    turn_speed,
                    retry,
                } => {
                    rt.wander(&scope, *area, *move_speed, *turn_speed, *retry)
                        .await
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
