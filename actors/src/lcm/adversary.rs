//! The adversary (Flocchini, Prencipe and Santoro 2019, section 1.1.4): when each robot
//! Looks, how long its Compute and Move last, where a non-rigid move stops, and its local
//! frame.
//!
//! The random adversary is a pure function of the run's seed: a robot's durations, stops and
//! frames come from its own stream ([`Stream::Adversary`]), and a round's choice of robots
//! from the run-wide [`Stream::Rounds`] read at the round's own position, so every robot's
//! host asks the same adversary and gets the same answer without any shared state. The
//! scripted adversary replays the activations a scenario lists.

use rand::{Rng, RngCore};
use rand_chacha::ChaCha8Rng;

use super::frame::{Changes, Frame};
use super::settings::{Activation, AdversaryKind, LcmSettings, Movement, Synchrony};
use crate::random::{rng, Stream};
use crate::world::RobotId;

/// One activation of a robot: the instants its Look happens, its Compute ends and its Move
/// ends [s], and for a non-rigid move the scripted fraction of the way where it stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    pub look: f64,
    pub compute_end: f64,
    /// When the Move starts (the end of the Compute, unless a script says later).
    pub move_start: f64,
    pub move_end: f64,
    pub stop: Option<f64>,
    /// What the Look reads of a light being written, where the register allows it.
    pub read: Option<super::view::Light>,
    /// The round it belongs to, under a synchrony model of rounds.
    pub round: Option<u64>,
}

/// Words of [`Stream::Rounds`] each round owns: its leader's, then a coin per robot.
const ROUND_WORDS: u128 = 1 << 34;

/// One robot's adversary.
#[derive(Clone, Debug)]
pub struct Adversary {
    settings: std::sync::Arc<LcmSettings>,
    seed: u64,
    robot: RobotId,
    own: ChaCha8Rng,
    next_round: u64,
    script: Vec<Activation>,
    next_script: usize,
    fixed_frame: Option<Frame>,
}

impl Adversary {
    /// The adversary of `robot` in the run seeded with `seed`.
    pub fn new(settings: std::sync::Arc<LcmSettings>, seed: u64, robot: RobotId) -> Self {
        let mut script: Vec<Activation> = match &settings.adversary {
            AdversaryKind::Scripted(all) => {
                all.iter().filter(|a| a.robot == robot).copied().collect()
            }
            AdversaryKind::Random => Vec::new(),
        };
        script.sort_by(|a, b| a.look.total_cmp(&b.look));
        Self {
            own: rng(seed, Stream::Adversary(robot)),
            settings,
            seed,
            robot,
            next_round: 0,
            script,
            next_script: 0,
            fixed_frame: None,
        }
    }

    /// The robot's next activation whose Look is at `now` or later, or `None` when there is
    /// none (a script has ended, or the robot is not among the run's Look-Compute-Move robots).
    pub fn next(&mut self, now: f64) -> Option<Plan> {
        if let AdversaryKind::Scripted(_) = self.settings.adversary {
            while let Some(a) = self.script.get(self.next_script) {
                self.next_script += 1;
                if a.look >= now {
                    return Some(Plan {
                        look: a.look,
                        compute_end: a.compute,
                        move_start: a.start_move.unwrap_or(a.compute),
                        move_end: a.move_end,
                        stop: a.stop,
                        read: a.read,
                        round: None,
                    });
                }
            }
            return None;
        }
        let t = self.settings.cycle;
        let s = self.settings.synchrony;
        if s.in_rounds() {
            let roster = self.settings.roster.robots();
            if !roster.contains(&self.robot) {
                return None;
            }
            let first = (now / t).ceil().max(0.0) as u64;
            let mut k = self.next_round.max(first);
            while !self.activated(k, roster) {
                k += 1;
            }
            self.next_round = k + 1;
            let start = k as f64 * t;
            return Some(Plan {
                look: start,
                compute_end: start + t / 4.0,
                move_start: start + t / 4.0,
                move_end: start + 3.0 * t / 4.0,
                stop: None,
                read: None,
                round: Some(k),
            });
        }
        let phase = |rng: &mut ChaCha8Rng| rng.gen_range(t / 6.0..t / 2.0);
        if matches!(s, Synchrony::AsyncMoveAtomic | Synchrony::AsyncCmAtomic) {
            return Some(self.atomic_moves(now));
        }
        let look = now + phase(&mut self.own);
        let compute = match s {
            Synchrony::AsyncLcAtomic | Synchrony::AsyncLcStrict => 0.0,
            _ => phase(&mut self.own),
        };
        let moving = phase(&mut self.own);
        Some(Plan {
            look,
            compute_end: look + compute,
            move_start: look + compute,
            move_end: look + compute + moving,
            stop: None,
            read: None,
            round: None,
        })
    }

    /// An activation under `AsyncMoveAtomic` or `AsyncCmAtomic`: time is cut into slots of
    /// half a cycle; every robot Looks in even slots only and moves in odd slots only, so no
    /// Look ever sees a robot in mid-move, and moves (with the Compute before them, under
    /// `AsyncCmAtomic`) are atomic to every observer while robots still act asynchronously. The
    /// schedules are a part of what these models allow, as a random adversary samples.
    fn atomic_moves(&mut self, now: f64) -> Plan {
        let slot = self.settings.cycle / 2.0;
        let rng = &mut self.own;
        // A Look in the first even slot after a wait, anywhere in it.
        let ready = now + rng.gen_range(0.0..slot);
        let mut k = (ready / slot).ceil() as u64;
        if k % 2 == 1 {
            k += 1;
        }
        let look = (k as f64 + rng.gen_range(0.0..1.0)) * slot;
        let compute_end = match self.settings.synchrony {
            // Compute and Move together, in the next odd slot.
            Synchrony::AsyncCmAtomic => (k as f64 + 1.0 + rng.gen_range(0.0..0.5)) * slot,
            _ => look + rng.gen_range(0.0..slot),
        };
        let mut m = (compute_end / slot).floor() as u64;
        if m % 2 == 0 {
            m += 1;
        }
        let move_start = compute_end.max(m as f64 * slot);
        let end = (m as f64 + 1.0) * slot;
        let move_end = move_start + (end - move_start) * rng.gen_range(0.25..1.0);
        Plan {
            look,
            compute_end,
            move_start,
            move_end,
            stop: None,
            read: None,
            round: None,
        }
    }

    /// Whether round `k` activates this robot.
    fn activated(&self, k: u64, roster: &[RobotId]) -> bool {
        match self.settings.synchrony {
            Synchrony::Fsync => true,
            Synchrony::Centralized => leader(self.seed, k, roster) == Some(self.robot),
            Synchrony::Ssync => {
                leader(self.seed, k, roster) == Some(self.robot) || coin(self.seed, k, self.robot)
            }
            _ => false,
        }
    }

    /// The robot's local frame for its next Look.
    pub fn frame(&mut self) -> Frame {
        let frames = self.settings.frames;
        match (frames.changes, self.fixed_frame) {
            (Changes::Fixed, Some(f)) => f,
            _ => {
                let f = frames.draw(&mut self.own);
                self.fixed_frame = Some(f);
                f
            }
        }
    }

    /// How far along a path of `length` [units] the move of `plan` stops: all of it when rigid;
    /// else at least the movement's δ (or the whole path if shorter), where the script says,
    /// or at random (half the time all of it).
    pub fn stop(&mut self, plan: &Plan, length: f64) -> f64 {
        let Movement::NonRigid { delta } = self.settings.movement else {
            return length;
        };
        let least = delta.min(length);
        match plan.stop {
            Some(f) if f >= 1.0 => length,
            Some(f) => (f * length).clamp(least, length),
            None if self.own.gen_bool(0.5) => length,
            None => (least + self.own.gen_range(0.0..1.0) * (length - least)).min(length),
        }
    }
}

/// The robot round `k` always activates (SSYNC's non-empty subset, the centralised
/// scheduler's one robot).
fn leader(seed: u64, k: u64, roster: &[RobotId]) -> Option<RobotId> {
    if roster.is_empty() {
        return None;
    }
    let mut r = rng(seed, Stream::Rounds);
    r.set_word_pos(u128::from(k) * ROUND_WORDS);
    let i = (r.next_u64() % roster.len() as u64) as usize;
    Some(roster[i])
}

/// Whether round `k` activates `robot` besides its leader (a fair coin).
fn coin(seed: u64, k: u64, robot: RobotId) -> bool {
    let mut r = rng(seed, Stream::Rounds);
    r.set_word_pos(u128::from(k) * ROUND_WORDS + 2 + 2 * u128::from(robot));
    r.next_u32() & 1 == 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    fn settings(s: Synchrony) -> Arc<LcmSettings> {
        let st = LcmSettings {
            synchrony: s,
            ..Default::default()
        };
        st.roster.set((0..5).collect());
        Arc::new(st)
    }

    /// Every SSYNC round activates at least one robot, and the robots' own adversaries agree
    /// on which (each robot asks alone).
    #[test]
    fn every_ssync_round_activates_someone() {
        let st = settings(Synchrony::Ssync);
        let mut rounds = vec![0u32; 200];
        for r in 0..5 {
            let mut a = Adversary::new(st.clone(), 9, r);
            while let Some(p) = a.next(0.0) {
                let k = p.round.expect("a round") as usize;
                if k >= rounds.len() {
                    break;
                }
                rounds[k] += 1;
            }
        }
        assert!(rounds.iter().all(|&n| n >= 1), "{rounds:?}");
        assert!(rounds.iter().any(|&n| n > 1 && n < 5), "{rounds:?}");
    }

    /// A centralised round activates exactly one robot.
    #[test]
    fn a_centralized_round_activates_one_robot() {
        let st = settings(Synchrony::Centralized);
        let mut rounds = vec![0u32; 100];
        for r in 0..5 {
            let mut a = Adversary::new(st.clone(), 4, r);
            while let Some(p) = a.next(0.0) {
                let k = p.round.expect("a round") as usize;
                if k >= rounds.len() {
                    break;
                }
                rounds[k] += 1;
            }
        }
        assert!(rounds.iter().all(|&n| n == 1), "{rounds:?}");
    }

    /// A non-rigid move goes at least δ (or all the way when shorter) and never beyond.
    #[test]
    fn a_non_rigid_stop_respects_delta() {
        let st = Arc::new(LcmSettings {
            movement: Movement::NonRigid { delta: 2.0 },
            ..Default::default()
        });
        let mut a = Adversary::new(st, 1, 0);
        let plan = a.next(0.0).expect("a plan");
        for _ in 0..1000 {
            let s = a.stop(&plan, 10.0);
            assert!((2.0..=10.0).contains(&s), "{s}");
            assert_eq!(a.stop(&plan, 1.5), 1.5);
        }
    }
}
