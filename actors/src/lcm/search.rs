//! Searching for counterexamples where exhaustive checking is impossible: three or more
//! robots, or algorithms that compute on exact positions (the centre of gravity, the enclosing
//! circle), whose configurations do not fall into finitely many classes.
//!
//! The search hosts the algorithm's own `compute`, through the same view, frames, destination
//! and stop functions as the simulator's robot host ([`super::runtime`]), over an adversary
//! of rounds: each round a non-empty subset of the robots Looks at its start, computes, and
//! moves until the adversary's stop, picked from a finite menu (fractions of the way, never
//! short of the movement's δ). This is the scripted adversary's round, so every schedule found
//! replays exactly in the simulator ([`Schedule::activations`]). Two searches:
//!
//! - **bounded**: every schedule of the menu up to a depth, configurations already met at the
//!   same depth skipped (depth-first, exhaustive for that menu and depth, and no more);
//! - **random**: seeded runs in the manner of PCT (Burckhardt, Kothari, Musuvathi and
//!   Nagarakatte, "A randomized scheduler with probabilistic guarantees of finding bugs",
//!   ASPLOS 2010): each run gives the robots random priorities and changes them at `d - 1`
//!   random rounds; the robot of highest priority leads each round, the others join it at
//!   random.
//!
//! Both report what they covered and claim nothing beyond it.

use std::collections::HashSet;
use std::sync::Arc;

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::adversary::{Adversary, Plan};
use super::look::{Sighted, Snapshot};
use super::predicate::{diameter, gathered};
use super::runtime::{destination, view_of};
use super::settings::{Activation, AdversaryKind, LcmSettings, Movement};
use super::view::{Light, LookComputeMove, SAME_POINT};
use crate::random::{rng, Stream};
use crate::world::geometry::Point;
use crate::world::RobotId;

/// What is searched: robots `0..n` born at `start`, robot `i` running `algorithms[i]`, under
/// `settings`, in the run seeded with `seed` (which gives the frames and the first lights, as
/// in a run).
#[derive(Clone, Debug)]
pub struct Problem {
    pub algorithms: Vec<Arc<dyn LookComputeMove>>,
    pub settings: Arc<LcmSettings>,
    pub seed: u64,
    pub start: Vec<Point>,
}

/// What must hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Goal {
    /// No two robots on one point, at a round's end or in mid-move, unless all are gathered.
    CollisionFree,
    /// The robots' diameter never grows from a round to the next (what convergence algorithms
    /// that keep every robot in the others' convex hull guarantee).
    DiameterNeverGrows,
    /// Every robot on one point once every robot has completed `cycles` cycles.
    GatheredWithin { cycles: u32 },
    /// The robots within `epsilon` of each other once every robot has completed `cycles`
    /// cycles.
    ConvergedWithin { epsilon: f64, cycles: u32 },
}

impl Goal {
    /// Its name in reports.
    pub fn name(&self) -> String {
        match self {
            Goal::CollisionFree => "collision-free".into(),
            Goal::DiameterNeverGrows => "diameter never grows".into(),
            Goal::GatheredWithin { cycles } => format!("gathered within {cycles} cycles"),
            Goal::ConvergedWithin { epsilon, cycles } => {
                format!("converged to {epsilon} within {cycles} cycles")
            }
        }
    }
}

/// One round: the robots activated, and for each where its move stops (the fraction of the
/// way; the movement's δ still applies).
#[derive(Clone, Debug, PartialEq)]
pub struct Round {
    pub active: Vec<RobotId>,
    pub stops: Vec<f64>,
}

/// A schedule of rounds from the start.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Schedule(pub Vec<Round>);

impl Schedule {
    /// The scripted adversary's activations that play this schedule, rounds of `cycle`
    /// seconds as the simulator's rounds are.
    pub fn activations(&self, cycle: f64) -> Vec<Activation> {
        let mut out = Vec::new();
        for (k, round) in self.0.iter().enumerate() {
            let start = k as f64 * cycle;
            for (&robot, &stop) in round.active.iter().zip(&round.stops) {
                out.push(Activation {
                    robot,
                    look: start,
                    compute: start + cycle / 4.0,
                    start_move: None,
                    move_end: start + 3.0 * cycle / 4.0,
                    stop: Some(stop),
                    read: None,
                });
            }
        }
        out
    }

    /// The scripted adversary as a scenario writes it (`lcm.adversary`).
    pub fn scripted(&self, cycle: f64) -> String {
        let acts: Vec<String> = self
            .activations(cycle)
            .iter()
            .map(|a| {
                format!(
                    "(robot: {}, look: {:?}, compute: {:?}, move: {:?}, stop: Some({:?}))",
                    a.robot,
                    a.look,
                    a.compute,
                    a.move_end,
                    a.stop.unwrap_or(1.0)
                )
            })
            .collect();
        format!("Scripted([{}])", acts.join(", "))
    }
}

/// A schedule that breaks a goal, and how.
#[derive(Clone, Debug, PartialEq)]
pub struct Violation {
    pub goal: Goal,
    pub schedule: Schedule,
    /// Where the robots stand at the end of the schedule.
    pub positions: Vec<Point>,
    pub reason: String,
}

/// What a search covered.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Coverage {
    /// Rounds deep.
    pub depth: usize,
    /// The menu of stop fractions.
    pub stops: Vec<f64>,
    /// Runs (random search) or schedules completed to the depth (bounded search).
    pub runs: u64,
    /// Rounds played.
    pub rounds: u64,
    /// Configurations met once per depth (bounded search).
    pub states: u64,
    /// Whether the bounded search went through its whole menu to its depth (false when a
    /// budget stopped it).
    pub complete: bool,
    /// Whether the caller's [`Limits::halt`] stopped it.
    pub halted: bool,
}

/// What a bounded search may spend: at most `max_rounds` rounds; and either search stops as
/// soon as `halt`, asked before the first round and every [`POLL_EVERY`] rounds after, says so
/// (the caller's memory budget, Ctrl-C).
#[derive(Clone, Copy)]
pub struct Limits<'a> {
    pub max_rounds: u64,
    pub halt: &'a dyn Fn() -> bool,
}

impl std::fmt::Debug for Limits<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Limits")
            .field("max_rounds", &self.max_rounds)
            .finish_non_exhaustive()
    }
}

/// Rounds between two questions to [`Limits::halt`].
pub const POLL_EVERY: u64 = 1024;

impl Coverage {
    /// Whether the caller's halt stops the search before the next round: asked once the
    /// rounds played reach `*next`, which then moves [`POLL_EVERY`] rounds on.
    fn halt(&mut self, next: &mut u64, halt: &dyn Fn() -> bool) -> bool {
        if !self.halted && self.rounds >= *next {
            *next = self.rounds + POLL_EVERY;
            self.halted = halt();
        }
        self.halted
    }
}

/// A search's outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    pub coverage: Coverage,
    pub violation: Option<Violation>,
}

/// The robots between rounds.
#[derive(Clone, Debug)]
struct World {
    at: Vec<Point>,
    lights: Vec<Light>,
    cycles: Vec<u32>,
    adversaries: Vec<Adversary>,
}

impl Problem {
    fn colours(&self, r: usize) -> u8 {
        self.algorithms[r].colours().max(1)
    }

    /// The robots at the start, with the lights a run gives them.
    fn first(&self) -> World {
        let n = self.start.len();
        // The frames come from each robot's adversary stream, as under a scripted adversary,
        // whose activations draw nothing else from it.
        let scripted = Arc::new(LcmSettings {
            adversary: AdversaryKind::Scripted(Vec::new()),
            ..(*self.settings).clone()
        });
        World {
            at: self.start.clone(),
            lights: (0..n as RobotId)
                .map(|r| {
                    let colours = self.colours(r as usize);
                    if colours > 1 {
                        let drawn = rng(self.seed, Stream::Robot(r)).gen_range(0..colours);
                        match self.settings.initial_lights.get(r as usize) {
                            Some(&l) if l < colours => l,
                            _ => drawn,
                        }
                    } else {
                        0
                    }
                })
                .collect(),
            cycles: vec![0; n],
            adversaries: (0..n as RobotId)
                .map(|r| Adversary::new(scripted.clone(), self.seed, r))
                .collect(),
        }
    }

    /// The snapshot robot `r` takes of `w`.
    fn snapshot(&self, w: &World, r: usize) -> Snapshot {
        let me = w.at[r];
        let lit = self.colours(r) > 1;
        let others = (0..w.at.len())
            .filter(|&o| o != r)
            .filter(|&o| {
                self.settings
                    .visibility
                    .is_none_or(|v| (w.at[o] - me).norm() <= v)
            })
            .map(|o| Sighted {
                robot: o as RobotId,
                at: w.at[o],
                light: (lit && self.colours(o) > 1).then_some(w.lights[o]),
            })
            .collect();
        Snapshot {
            me,
            light: lit.then_some(w.lights[r]),
            others,
        }
    }

    /// Where each robot of `round` goes, as the simulator's host computes it: its destination
    /// (none: it stays) and its new light.
    fn decide(&self, w: &mut World, round: &[RobotId]) -> Vec<(Option<Point>, Option<Light>)> {
        let snapshots: Vec<Snapshot> = round
            .iter()
            .map(|&r| self.snapshot(w, r as usize))
            .collect();
        round
            .iter()
            .zip(snapshots)
            .map(|(&r, snap)| {
                let colours = self.colours(r as usize);
                let frame = w.adversaries[r as usize].frame();
                let view = view_of(&snap, frame, &self.settings, colours > 1);
                let d = self.algorithms[r as usize].compute(&view);
                let to =
                    d.to.map(|l| destination(&snap, frame, l))
                        .filter(|&p| p != snap.me);
                let light = d
                    .light
                    .filter(|&l| colours > 1 && l < colours && l != w.lights[r as usize]);
                (to, light)
            })
            .collect()
    }

    /// Plays `round` on `w` with its stops; `Err` names a collision during it.
    fn play(&self, w: &mut World, round: &Round) -> Result<(), String> {
        let decisions = self.decide(w, &round.active);
        let from = w.at.clone();
        let mut to = w.at.clone();
        for ((&r, &stop), (dest, light)) in round.active.iter().zip(&round.stops).zip(decisions) {
            let i = r as usize;
            if let Some(l) = light {
                w.lights[i] = l;
            }
            w.cycles[i] += 1;
            if let Some(dest) = dest {
                let length = (dest - from[i]).norm();
                let plan = Plan {
                    look: 0.0,
                    compute_end: 0.0,
                    move_start: 0.0,
                    move_end: 1.0,
                    stop: Some(stop),
                    read: None,
                    round: None,
                };
                let reach = w.adversaries[i].stop(&plan, length);
                to[i] = if reach >= length {
                    dest
                } else {
                    from[i] + (dest - from[i]) * (reach / length)
                };
            }
        }
        w.at = to;
        if gathered(&w.at) {
            return Ok(());
        }
        // Every mover glides over the same interval, so relative motions are straight lines.
        let n = w.at.len();
        for a in 0..n {
            for b in a + 1..n {
                let p0 = from[a] - from[b];
                let v = (w.at[a] - from[a]) - (w.at[b] - from[b]);
                let vv = v.norm_squared();
                let s = if vv > 0.0 {
                    (-p0.dot(&v) / vv).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let closest = p0 + v * s;
                let scale = from[a].coords.amax().max(from[b].coords.amax()).max(1.0);
                if s > 0.0 && closest.norm() <= SAME_POINT * scale {
                    let at = from[a] + (w.at[a] - from[a]) * s;
                    return Err(format!(
                        "robots {a} and {b} meet at ({}, {}) while the robots are not gathered",
                        at.x, at.y
                    ));
                }
            }
        }
        Ok(())
    }

    /// Whether the goals hold after a round; the first broken one and why.
    fn judge(
        &self,
        before: &World,
        w: &World,
        collided: Option<String>,
        goals: &[Goal],
    ) -> Option<(Goal, String)> {
        let least = w.cycles.iter().copied().min().unwrap_or(0);
        for &g in goals {
            match g {
                Goal::DiameterNeverGrows => {
                    let (d0, d1) = (diameter(&before.at), diameter(&w.at));
                    let scale = before
                        .at
                        .iter()
                        .map(|p| p.coords.amax())
                        .fold(1.0, f64::max);
                    if d1 > d0 + SAME_POINT * scale {
                        return Some((g, format!("the diameter grew from {d0} to {d1}")));
                    }
                }
                Goal::CollisionFree => {
                    if let Some(why) = &collided {
                        return Some((g, why.clone()));
                    }
                }
                Goal::GatheredWithin { cycles } if least >= cycles && !gathered(&w.at) => {
                    return Some((
                        g,
                        format!(
                            "every robot completed {least} cycles and the robots are not gathered (diameter {})",
                            diameter(&w.at)
                        ),
                    ));
                }
                Goal::ConvergedWithin { epsilon, cycles }
                    if least >= cycles && diameter(&w.at) > epsilon =>
                {
                    return Some((
                        g,
                        format!(
                            "every robot completed {least} cycles and the diameter is {}",
                            diameter(&w.at)
                        ),
                    ));
                }
                _ => {}
            }
        }
        None
    }

    /// The stop fractions of `menu` that the movement allows (a rigid move goes all the way).
    fn stops(&self, menu: &[f64]) -> Vec<f64> {
        match self.settings.movement {
            Movement::Rigid => vec![1.0],
            Movement::NonRigid { .. } => menu.to_vec(),
        }
    }
}

/// Every round of `n` robots with stops from `stops`: each non-empty subset, each of its
/// robots with each stop.
fn rounds(n: usize, stops: &[f64]) -> Vec<Round> {
    let mut out = Vec::new();
    for mask in 1u64..(1 << n) {
        let active: Vec<RobotId> = (0..n as RobotId).filter(|r| mask >> r & 1 == 1).collect();
        let k = active.len();
        let combos = stops.len().pow(k as u32);
        for c in 0..combos {
            let mut c = c;
            let chosen = (0..k)
                .map(|_| {
                    let s = stops[c % stops.len()];
                    c /= stops.len();
                    s
                })
                .collect();
            out.push(Round {
                active: active.clone(),
                stops: chosen,
            });
        }
    }
    out
}

/// A configuration at a depth: exact positions' bits, lights and cycle counts (frames follow
/// the cycle counts).
type Key = (usize, Vec<u64>, Vec<Light>, Vec<u32>);

/// The key of a configuration at `depth`.
fn key(w: &World, depth: usize) -> Key {
    (
        depth,
        w.at.iter()
            .flat_map(|p| [p.x.to_bits(), p.y.to_bits()])
            .collect(),
        w.lights.clone(),
        w.cycles.clone(),
    )
}

/// Every schedule of the menu's rounds up to `depth` rounds, until a goal breaks or `limits`
/// stop it (at most 12 robots: every subset is a round). The depth grows one round at a time
/// (iterative deepening), so a violation found is one of the shortest.
pub fn bounded(p: &Problem, menu: &[f64], depth: usize, goals: &[Goal], limits: Limits) -> Outcome {
    let stops = p.stops(menu);
    let all = rounds(p.start.len().min(12), &stops);
    let mut coverage = Coverage {
        depth: 0,
        stops: stops.clone(),
        complete: true,
        ..Coverage::default()
    };
    let first = p.first();
    for limit in 1..=depth {
        let mut seen = HashSet::new();
        let mut path = Vec::new();
        coverage.runs = 0;
        let violation = dfs(
            p,
            &all,
            &first,
            limit,
            goals,
            limits,
            &mut path,
            &mut seen,
            &mut coverage,
        );
        coverage.states = seen.len() as u64;
        if violation.is_some() || !coverage.complete {
            return Outcome {
                coverage,
                violation,
            };
        }
        coverage.depth = limit;
    }
    Outcome {
        coverage,
        violation: None,
    }
}

#[allow(clippy::too_many_arguments)]
fn dfs(
    p: &Problem,
    all: &[Round],
    w: &World,
    left: usize,
    goals: &[Goal],
    limits: Limits,
    path: &mut Vec<Round>,
    seen: &mut HashSet<Key>,
    coverage: &mut Coverage,
) -> Option<Violation> {
    if left == 0 {
        coverage.runs += 1;
        return None;
    }
    for round in all {
        // Rounds are played one at a time: the halt is asked at each multiple of POLL_EVERY.
        let mut ask = coverage.rounds.next_multiple_of(POLL_EVERY);
        if coverage.rounds >= limits.max_rounds || coverage.halt(&mut ask, limits.halt) {
            coverage.complete = false;
            return None;
        }
        coverage.rounds += 1;
        let mut next = w.clone();
        let collided = p.play(&mut next, round).err();
        path.push(round.clone());
        if let Some((goal, reason)) = p.judge(w, &next, collided, goals) {
            return Some(Violation {
                goal,
                schedule: Schedule(path.clone()),
                positions: next.at,
                reason,
            });
        }
        if seen.insert(key(&next, left - 1)) {
            if let Some(v) = dfs(p, all, &next, left - 1, goals, limits, path, seen, coverage) {
                return Some(v);
            }
        }
        path.pop();
    }
    None
}

/// `runs` random schedules of `depth` rounds with `d - 1` priority changes each, seeded with
/// `seed`, until a goal breaks or `halt` stops it (asked as [`Limits::halt`] is).
#[allow(clippy::too_many_arguments)]
pub fn random(
    p: &Problem,
    menu: &[f64],
    depth: usize,
    runs: u64,
    d: usize,
    seed: u64,
    goals: &[Goal],
    halt: &dyn Fn() -> bool,
) -> Outcome {
    let stops = p.stops(menu);
    let n = p.start.len();
    let mut coverage = Coverage {
        depth,
        stops: stops.clone(),
        complete: false,
        ..Coverage::default()
    };
    let mut chooser = ChaCha8Rng::seed_from_u64(seed);
    let mut ask = 0;
    for _ in 0..runs {
        if coverage.halt(&mut ask, halt) {
            break;
        }
        coverage.runs += 1;
        let mut priority: Vec<usize> = (0..n).collect();
        priority.shuffle(&mut chooser);
        let changes: Vec<usize> = (0..d.saturating_sub(1))
            .map(|_| chooser.gen_range(0..depth.max(1)))
            .collect();
        let mut w = p.first();
        let mut path = Vec::new();
        for k in 0..depth {
            // At a change point the leader drops to the lowest priority.
            if changes.contains(&k) {
                let top = (0..n).max_by_key(|&r| priority[r]).unwrap_or(0);
                priority[top] = 0;
                for (r, q) in priority.iter_mut().enumerate() {
                    if r != top {
                        *q += 1;
                    }
                }
            }
            let leader = (0..n).max_by_key(|&r| priority[r]).unwrap_or(0);
            let active: Vec<RobotId> = (0..n)
                .filter(|&r| r == leader || chooser.gen_bool(0.5))
                .map(|r| r as RobotId)
                .collect();
            let chosen = active
                .iter()
                .map(|_| stops[chooser.gen_range(0..stops.len())])
                .collect();
            let round = Round {
                active,
                stops: chosen,
            };
            coverage.rounds += 1;
            let before = w.clone();
            let collided = p.play(&mut w, &round).err();
            path.push(round);
            if let Some((goal, reason)) = p.judge(&before, &w, collided, goals) {
                return Outcome {
                    coverage,
                    violation: Some(Violation {
                        goal,
                        schedule: Schedule(path),
                        positions: w.at,
                        reason,
                    }),
                };
            }
        }
    }
    Outcome {
        coverage,
        violation: None,
    }
}

/// The robots' positions after each round of `schedule`, as the search plays it (what a
/// replay in the simulator must show).
pub fn positions(p: &Problem, schedule: &Schedule) -> Vec<Vec<Point>> {
    let mut w = p.first();
    schedule
        .0
        .iter()
        .map(|round| {
            let _ = p.play(&mut w, round);
            w.at.clone()
        })
        .collect()
}
