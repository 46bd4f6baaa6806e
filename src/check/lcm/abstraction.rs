//! The finite model of two luminous Look-Compute-Move robots under a rule table: the
//! abstraction of Défago, Heriban, Tixeuil and Wada ("Using model checking to formally verify
//! rendezvous algorithms for robots with lights in Euclidean space", RAS 163, 2023), step for
//! step as spin-light's Robots.pml and Schedulers.pml define it (github.com/xdefago/spin-light;
//! MIT licence), with the algorithm read from the very [`RuleTable`] the simulator runs.
//!
//! The plane is abstracted to the relative position of the two robots: `Far` (a non-rigid move
//! may stop short of its destination), `Near` (every move reaches its destination) and `Same`.
//! A robot carries its light, its pending move (`Stay`, `ToHalf`, `ToOther`, or `Miss`: a
//! destination computed from a snapshot that the other robot's move has since made stale),
//! whether it is moving or computing, the colour its Compute is writing, and the command it
//! computed. The scheduler keeps each robot's next phase and, under bounded fairness, how many
//! steps in a row each robot has taken. One [`Step`] is one atomic block of a Schedulers.pml
//! loop; the scheduler stops when the robots are gathered (Types.pml's `GATHERED`), so a
//! gathered state has no step.

use nekosim_actors::lcm::rule_table::{Move, RuleTable};
use nekosim_actors::lcm::settings::{Lights, Register, Synchrony};
use nekosim_actors::lcm::Light;
use nekosim_models::liveness::{Actors, TransitionSystem};
use serde::Serialize;

/// The relative position of the two robots.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum Position {
    Far,
    Near,
    Same,
}

/// A robot's pending move.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum Pending {
    Stay,
    ToHalf,
    ToOther,
    /// A move whose destination is no longer where the other robot's move left the pair.
    Miss,
}

/// A phase of the Look-Compute-Move cycle, as the scheduler activates it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum Phase {
    Look,
    BeginCompute,
    EndCompute,
    BeginMove,
    EndMove,
}

impl Phase {
    fn next(self) -> Self {
        match self {
            Self::Look => Self::BeginCompute,
            Self::BeginCompute => Self::EndCompute,
            Self::EndCompute => Self::BeginMove,
            Self::BeginMove => Self::EndMove,
            Self::EndMove => Self::Look,
        }
    }
}

/// One robot's part of the state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct Robot {
    pub light: Light,
    pub pending: Pending,
    pub moving: bool,
    pub computing: bool,
    /// The colour being written during Compute (what a regular register may show).
    pub pending_light: Light,
    /// The move and light computed at the last Look.
    pub command: (Pending, Light),
}

/// A state of the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct State {
    pub position: Position,
    pub robots: [Robot; 2],
    /// The phase each robot's next activation runs (the asynchronous schedulers').
    pub phase: [Phase; 2],
    /// Steps in a row each robot has taken, under bounded fairness.
    pub count: [u8; 2],
}

impl State {
    /// Types.pml's `GATHERED`: on one point with no move pending; the scheduler stops.
    pub fn gathered(&self) -> bool {
        self.position == Position::Same && self.robots.iter().all(|r| r.pending == Pending::Stay)
    }
}

/// One step of the scheduler: the phases it ran, robot by robot, in order.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Step {
    pub phases: Vec<(usize, Phase)>,
}

/// spin-light's 12 scheduler variants (Schedulers.pml), each a synchrony model and a register.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Variant {
    Centralized,
    Fsync,
    Ssync,
    Async,
    AsyncRegular,
    AsyncSafe,
    AsyncMoveAtomic,
    AsyncMoveRegular,
    AsyncMoveSafe,
    AsyncLcAtomic,
    AsyncLcStrict,
    AsyncCmAtomic,
}

impl Variant {
    pub const ALL: [Variant; 12] = [
        Self::Centralized,
        Self::Fsync,
        Self::Ssync,
        Self::Async,
        Self::AsyncRegular,
        Self::AsyncSafe,
        Self::AsyncMoveAtomic,
        Self::AsyncMoveRegular,
        Self::AsyncMoveSafe,
        Self::AsyncLcAtomic,
        Self::AsyncLcStrict,
        Self::AsyncCmAtomic,
    ];

    /// The variant of a synchrony model and a register. The register matters only where a
    /// Look can meet a Compute in progress, which spin-light models for ASYNC and ASYNC with
    /// atomic moves; elsewhere it is refused.
    pub fn of(s: Synchrony, r: Register) -> Option<Self> {
        Some(match (s, r) {
            (Synchrony::Async, Register::Atomic) => Self::Async,
            (Synchrony::Async, Register::Regular) => Self::AsyncRegular,
            (Synchrony::Async, Register::Safe) => Self::AsyncSafe,
            (Synchrony::AsyncMoveAtomic, Register::Atomic) => Self::AsyncMoveAtomic,
            (Synchrony::AsyncMoveAtomic, Register::Regular) => Self::AsyncMoveRegular,
            (Synchrony::AsyncMoveAtomic, Register::Safe) => Self::AsyncMoveSafe,
            (_, Register::Regular | Register::Safe) => return None,
            (Synchrony::Centralized, _) => Self::Centralized,
            (Synchrony::Fsync, _) => Self::Fsync,
            (Synchrony::Ssync, _) => Self::Ssync,
            (Synchrony::AsyncLcAtomic, _) => Self::AsyncLcAtomic,
            (Synchrony::AsyncLcStrict, _) => Self::AsyncLcStrict,
            (Synchrony::AsyncCmAtomic, _) => Self::AsyncCmAtomic,
        })
    }

    /// Schedulers.pml's name (`-DSCHEDULER=...`).
    pub fn spin_name(self) -> &'static str {
        match self {
            Self::Centralized => "CENTRALIZED",
            Self::Fsync => "FSYNC",
            Self::Ssync => "SSYNC",
            Self::Async => "ASYNC",
            Self::AsyncRegular => "ASYNC_REGULAR",
            Self::AsyncSafe => "ASYNC_SAFE",
            Self::AsyncMoveAtomic => "ASYNC_MOVE_ATOMIC",
            Self::AsyncMoveRegular => "ASYNC_MOVE_REGULAR",
            Self::AsyncMoveSafe => "ASYNC_MOVE_SAFE",
            Self::AsyncLcAtomic => "ASYNC_LC_ATOMIC",
            Self::AsyncLcStrict => "ASYNC_LC_STRICT",
            Self::AsyncCmAtomic => "ASYNC_CM_ATOMIC",
        }
    }

    /// The register a Look reads a light being written through.
    pub fn register(self) -> Register {
        match self {
            Self::AsyncRegular | Self::AsyncMoveRegular => Register::Regular,
            Self::AsyncSafe | Self::AsyncMoveSafe => Register::Safe,
            _ => Register::Atomic,
        }
    }

    /// Scheduler steps per cycle (Schedulers.pml's `PHASES_PER_CYCLE`).
    pub fn phases_per_cycle(self) -> u32 {
        match self {
            Self::Centralized | Self::Fsync | Self::Ssync => 1,
            Self::Async | Self::AsyncRegular | Self::AsyncSafe => 5,
            Self::AsyncMoveAtomic | Self::AsyncMoveRegular | Self::AsyncMoveSafe => 4,
            Self::AsyncLcAtomic | Self::AsyncLcStrict | Self::AsyncCmAtomic => 3,
        }
    }

    /// spin-light's bound on the steps one robot takes in a row:
    /// `FAIR_LIMIT(PHASES_PER_CYCLE, NUM_COLORS) = (1 + colours) * phases per cycle`.
    pub fn fair_limit(self, colours: usize) -> u32 {
        (1 + colours as u32) * self.phases_per_cycle()
    }
}

/// The model of one rule table under one variant.
#[derive(Clone, Debug)]
pub struct Abstraction<'a> {
    pub table: &'a RuleTable,
    pub lights: Lights,
    pub variant: Variant,
    /// Non-rigid: the robots may start `Far`.
    pub rigid: bool,
    /// At most this many steps in a row by one robot (bounded fairness); `None`: no bound.
    pub bound: Option<u32>,
}

impl Abstraction<'_> {
    fn colours(&self) -> Light {
        self.table.lights.len() as Light
    }

    /// The command a robot computes from what it sees: its light, the light it read and
    /// whether the two share a point, as the runtime's view shows them to the table.
    fn compute(&self, me: Light, seen: Light, same: bool) -> (Move, Light) {
        let one = self.colours() == 1;
        let mine = (self.lights.own_visible() || one).then_some(me);
        let theirs = (self.lights.others_visible() || one).then_some(seen);
        match self.table.rule(mine, theirs, same) {
            Some(rule) => (rule.go, rule.light.unwrap_or(me)),
            None => (Move::Stay, me),
        }
    }

    /// The colours robot `me`'s Look in `s` may read of the other's light: the one it shows,
    /// or, while the other computes, what the variant's register returns.
    pub fn readable(&self, s: &State, me: usize) -> Vec<Light> {
        let o = s.robots[1 - me];
        if !o.computing {
            return vec![o.light];
        }
        match self.variant.register() {
            Register::Atomic => vec![o.light],
            Register::Regular => vec![o.pending_light, o.light],
            Register::Safe => (0..self.colours()).collect(),
        }
    }

    /// Robot `me`'s Look in `s` having read `seen` of the other's light: the state after it.
    pub fn look(&self, s: &State, me: usize, seen: Light) -> State {
        let o = s.robots[1 - me];
        let mut t = *s;
        let same = t.position == Position::Same;
        let (go, light) = self.compute(t.robots[me].light, seen, same);
        let go = match go {
            Move::Stay => Pending::Stay,
            Move::ToHalf => Pending::ToHalf,
            Move::ToOther => Pending::ToOther,
        };
        t.robots[me].command = (go, light);
        t.robots[me].pending = if same && !o.moving {
            Pending::Stay
        } else if o.moving && go != Pending::Stay {
            Pending::Miss
        } else {
            go
        };
        t
    }

    /// Robot `me` runs `phase` in `s`; a Look under a regular or safe register may read
    /// several colours, so each outcome is pushed onto `out`.
    fn run(&self, s: &State, me: usize, phase: Phase, out: &mut Vec<State>) {
        let other = 1 - me;
        let mut s = *s;
        match phase {
            Phase::Look => {
                let mut outcomes: Vec<State> = Vec::new();
                for c in self.readable(&s, me) {
                    let t = self.look(&s, me, c);
                    if !outcomes.contains(&t) {
                        outcomes.push(t);
                    }
                }
                out.extend(outcomes);
                return;
            }
            Phase::BeginCompute => {
                let r = &mut s.robots[me];
                r.computing = true;
                r.pending_light = r.command.1;
            }
            Phase::EndCompute => {
                let r = &mut s.robots[me];
                r.computing = false;
                r.light = r.command.1;
            }
            Phase::BeginMove => {
                let r = &mut s.robots[me];
                if r.pending != Pending::Stay {
                    r.moving = true;
                }
            }
            Phase::EndMove => {
                if s.robots[me].moving {
                    let mine = s.robots[me].pending;
                    debug_assert_ne!(mine, Pending::Stay);
                    let theirs = &mut s.robots[other].pending;
                    let miss = |p: &mut Pending| {
                        if *p != Pending::Stay {
                            *p = Pending::Miss;
                        }
                    };
                    s.position = match (s.position, mine) {
                        (Position::Far, _) => {
                            miss(theirs);
                            Position::Near
                        }
                        (_, Pending::Miss) => {
                            miss(theirs);
                            Position::Near
                        }
                        (p, Pending::ToOther) => {
                            if p != Position::Same {
                                miss(theirs);
                            }
                            Position::Same
                        }
                        (p, Pending::ToHalf) => {
                            match *theirs {
                                Pending::ToHalf => *theirs = Pending::ToOther,
                                Pending::Stay => {}
                                _ => *theirs = Pending::Miss,
                            }
                            p
                        }
                        (_, Pending::Stay) => unreachable!("a moving robot has a move"),
                    };
                }
                let r = &mut s.robots[me];
                r.moving = false;
                r.pending = Pending::Stay;
            }
        }
        out.push(s);
    }

    /// Runs `phases` in order from `s`, every outcome of every Look.
    fn run_all(&self, s: &State, phases: &[(usize, Phase)]) -> Vec<State> {
        let mut states = vec![*s];
        for &(r, p) in phases {
            let mut next = Vec::new();
            for t in &states {
                self.run(t, r, p, &mut next);
            }
            states = next;
        }
        states
    }

    /// The robots the bounded-fairness counters let the scheduler pick alone, each with the
    /// counters after the pick.
    fn picks(&self, s: &State) -> Vec<(usize, [u8; 2])> {
        (0..2)
            .filter(|&r| self.bound.is_none_or(|k| u32::from(s.count[r]) < k))
            .map(|r| {
                let mut count = [0; 2];
                if self.bound.is_some() {
                    count[r] = s.count[r] + 1;
                }
                (r, count)
            })
            .collect()
    }

    /// Every step the variant's scheduler can take from `s`.
    pub fn steps(&self, s: &State) -> Vec<(Step, State)> {
        use Phase::*;
        let mut out = Vec::new();
        if s.gathered() {
            return out;
        }
        let cycle = |r: usize| {
            [
                (r, Look),
                (r, BeginCompute),
                (r, EndCompute),
                (r, BeginMove),
                (r, EndMove),
            ]
        };
        let mut push = |phases: Vec<(usize, Phase)>, count: [u8; 2], phase: [Phase; 2]| {
            for mut t in self.run_all(s, &phases) {
                t.count = count;
                t.phase = phase;
                out.push((
                    Step {
                        phases: phases.clone(),
                    },
                    t,
                ));
            }
        };
        let both = || {
            let mut v = vec![(0, Look), (1, Look)];
            v.extend_from_slice(&cycle(0)[1..]);
            v.extend_from_slice(&cycle(1)[1..]);
            v
        };
        match self.variant {
            Variant::Fsync => push(both(), [0; 2], s.phase),
            Variant::Centralized | Variant::Ssync => {
                if self.variant == Variant::Ssync {
                    push(both(), [0; 2], s.phase);
                }
                for (r, count) in self.picks(s) {
                    push(cycle(r).to_vec(), count, s.phase);
                }
            }
            Variant::Async | Variant::AsyncRegular | Variant::AsyncSafe => {
                for (r, count) in self.picks(s) {
                    let mut phase = s.phase;
                    phase[r] = s.phase[r].next();
                    push(vec![(r, s.phase[r])], count, phase);
                }
            }
            Variant::AsyncMoveAtomic | Variant::AsyncMoveRegular | Variant::AsyncMoveSafe => {
                for (r, count) in self.picks(s) {
                    let mut phase = s.phase;
                    let mut phases = vec![(r, s.phase[r])];
                    if s.phase[r] == BeginMove {
                        phases.push((r, EndMove));
                        phase[r] = Look;
                    } else {
                        phase[r] = s.phase[r].next();
                    }
                    push(phases, count, phase);
                }
            }
            Variant::AsyncLcAtomic | Variant::AsyncLcStrict => {
                if self.variant == Variant::AsyncLcAtomic && s.phase == [Look, Look] {
                    let phases = vec![
                        (0, Look),
                        (1, Look),
                        (0, BeginCompute),
                        (0, EndCompute),
                        (1, BeginCompute),
                        (1, EndCompute),
                    ];
                    push(phases, [0; 2], [BeginMove; 2]);
                }
                for (r, count) in self.picks(s) {
                    let mut phase = s.phase;
                    let mut phases = vec![(r, s.phase[r])];
                    if s.phase[r] == Look {
                        phases.extend([(r, BeginCompute), (r, EndCompute)]);
                        phase[r] = BeginMove;
                    } else {
                        phase[r] = s.phase[r].next();
                    }
                    push(phases, count, phase);
                }
            }
            Variant::AsyncCmAtomic => {
                for (r, count) in self.picks(s) {
                    let mut phase = s.phase;
                    let mut phases = vec![(r, s.phase[r])];
                    if s.phase[r] == BeginCompute {
                        phases.extend([(r, EndCompute), (r, BeginMove), (r, EndMove)]);
                        phase[r] = Look;
                    } else {
                        phase[r] = s.phase[r].next();
                    }
                    push(phases, count, phase);
                }
            }
        }
        out
    }
}

impl TransitionSystem for Abstraction<'_> {
    type State = State;
    type Label = Step;

    /// Every pair of lights and every position class the movement allows (MainGathering.pml's
    /// `init`): `Near` and `Same` when rigid, and `Far` too when not.
    fn initial_states(&self) -> Vec<State> {
        let robot = |light| Robot {
            light,
            pending: Pending::Stay,
            moving: false,
            computing: false,
            pending_light: 0,
            command: (Pending::Stay, 0),
        };
        let positions: &[Position] = if self.rigid {
            &[Position::Near, Position::Same]
        } else {
            &[Position::Far, Position::Near, Position::Same]
        };
        let mut v = Vec::new();
        for a in 0..self.colours() {
            for b in 0..self.colours() {
                for &position in positions {
                    v.push(State {
                        position,
                        robots: [robot(a), robot(b)],
                        phase: [Phase::Look; 2],
                        count: [0; 2],
                    });
                }
            }
        }
        v
    }

    fn successors(&self, s: &State, out: &mut Vec<(Step, State)>) {
        out.extend(self.steps(s));
    }

    fn moved(&self, step: &Step) -> Actors {
        step.phases.iter().fold(0, |a, &(r, _)| a | 1 << r)
    }

    fn actors(&self) -> usize {
        2
    }
}
