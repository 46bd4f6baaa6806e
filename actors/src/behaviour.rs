//! Composable behaviours: reusable motion algorithms (seed 7.2, future work: "improvement of
//! reusability for motion algorithms ... to allow user to reuse the old motion algorithm
//! cooperating with new algorithm without having to re-write the code").
//!
//! A [`Behaviour`] is a tree of primitive behaviours ([`Behaviour::GoTo`],
//! [`Behaviour::Wander`], [`Behaviour::Wait`], [`Behaviour::WaitFor`], [`Behaviour::Avoid`],
//! [`Behaviour::Follow`]) combined by [`Behaviour::Sequence`], [`Behaviour::Repeat`],
//! [`Behaviour::Until`] and [`Behaviour::Race`]. The same value is a scenario's algorithm
//! (`algorithm: Behaviour(Repeat(Forever, Wander()))`, registered as `Behaviour`) and a Rust
//! value a user's algorithm runs on its robot (`behaviour.run(&robot).await`). The seed's random
//! movement (5.1) is `Repeat(Forever, Wander())` and its gathering (5.2) is
//! `Repeat(Forever, GoTo(to: Centroid))`: they draw the same random numbers in the same order
//! and issue the same requests as [`crate::algorithm::RandomMovement`] and
//! [`crate::algorithm::Gathering`], so their traces are byte-identical for the same seed.
//!
//! # Concurrency and cancellation
//!
//! The branches of a `Race` (and the body and condition of an `Until`) run at once on one robot:
//! one future polled branch by branch, in order, at each event, and only with the robot's seeded
//! random stream and virtual time, so a run stays deterministic. The first branch to finish wins
//! (ties go to the earlier branch); the others are cancelled at that same instant:
//!
//! - a motion a cancelled branch started and that is still running is stopped in the world by a
//!   replacing zero-length `Forward` (its `motion_finish` is `replaced` at the winner's instant);
//! - every push sensor a cancelled branch activated (the push proximity of `Avoid` and
//!   `Proximity`, the contact sensor of `Contact`) is deactivated, and its interrupts still
//!   queued are dropped.
//!
//! The robot has one body: when a branch starts a motion while another branch's motion runs, the
//! newer replaces the older (as [`Robot::start_motion`] does), and the branch whose motion was
//! replaced waits, doing nothing more, until its combinator ends and cancels it. Losing branches'
//! pending timers and sensor readings are simply ignored.
//!
//! A behaviour that moves and took no virtual time at all (blocked at its very start, or
//! already there) waits `retry` seconds, as [`crate::algorithm::move_or_wait`] does, so that a
//! `Repeat(Forever, ..)` never spins at one instant.
//!
//! # Where the parts are
//!
//! `tree` is the language (the enum a scenario and a Rust program write), `config` reads and
//! checks it as an algorithm's configuration, `composition` walks a tree on a robot,
//! `runtime` is what the branches of one running behaviour share (and the race that cancels
//! the losers), and `travel` (`GoTo`, `Wander`), `neighbours` (`Avoid`, `Follow`) and
//! `condition` (`WaitFor`, the end of `Until`) run the primitives.
//!
//! [`Robot::start_motion`]: crate::robot::Robot::start_motion

mod composition;
mod condition;
mod config;
mod neighbours;
mod runtime;
mod travel;
mod tree;

pub use config::BehaviourConfig;
pub use tree::{Behaviour, Condition, Count, Speed, Target};
