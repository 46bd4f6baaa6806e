//! Liveness under fairness on an explicit-state transition system: the whole reachable graph
//! is built (within a budget), then `eventually P`, `eventually always P` and `always
//! eventually P` are decided by strongly connected components, as SPIN's `-a -f` decides them
//! by nested depth-first search, and a property that fails comes with a **lasso**: a stem from
//! an initial state, then a cycle the adversary can repeat forever.
//!
//! The system is any [`TransitionSystem`]: its states, its initial states, and each state's
//! successors, each labelled with the actors (robots, processes) that moved in that step. An
//! actor is *enabled* in a state when some step from it moves that actor. A state with no
//! step ends the run, and a run that ends stays in its last state forever (SPIN's stutter
//! extension): nothing is enabled there, so that stutter is fair under every fairness.
//!
//! Fairness constrains which infinite runs count:
//! - [`Fairness::None`]: every run;
//! - [`Fairness::Weak`]: no actor stays enabled from some point on without moving again (for
//!   Look-Compute-Move robots, which are all enabled until the run ends: every robot is
//!   activated infinitely often);
//! - [`Fairness::Strong`]: no actor is enabled infinitely often without moving infinitely
//!   often.
//!
//! Fairness is owed to **tasks**: by default one per actor, but a system may name finer ones
//! ([`TransitionSystem::tasks`]): a protocol stack owes it to every message in flight (fair
//! delivery) and every timer, and holds each task weakly or strongly
//! ([`Graph::check_under`]; a lossy link's fair loss is strong fairness on its messages). A
//! run may also be judged only under an assumption `<>[] A` (a failure detector's eventual
//! accuracy): a cycle outside `A` is not a counterexample. A state where a bound of the model
//! cut the run short ([`TransitionSystem::beyond`]) is never where a run ends, and the steps
//! left out there count as enabled, so a bound never makes a counterexample.
//!
//! Bounded fairness (no actor waits more than k steps of the others) is a property of the
//! adversary, so it belongs in the model: counters in the state, as spin-light's schedulers
//! keep them.
//!
//! A run of a finite graph ends in a cycle, so a property fails exactly when a fair cycle of
//! the right kind is reachable. Within a strongly connected component (SCC), one cycle can
//! visit every state and take every step, so under weak fairness a component holds a fair
//! cycle exactly when every actor either moves inside it or is disabled in one of its states.
//! Under strong fairness, a component in which some actor is enabled but never moves inside it
//! has a fair cycle only among its states where that actor is disabled: those are decomposed
//! again (the classic Streett emptiness refinement). The components are Tarjan's, computed
//! with an explicit stack (no recursion, so deep graphs cannot overflow the thread's stack).

use std::collections::{HashMap, VecDeque};
use std::fmt::Debug;
use std::hash::{BuildHasherDefault, Hash};

use crate::compact::Identity;

/// A set of actors, one bit each (at most 64 actors).
pub type Actors = u64;

/// An explicit-state transition system whose steps name the actors that moved.
pub trait TransitionSystem {
    type State: Clone + Eq + Hash + Debug;
    /// What a step did, for the report (the actors that moved are [`Self::moved`]).
    type Label: Clone + Debug;

    /// Every initial state.
    fn initial_states(&self) -> Vec<Self::State>;

    /// Pushes every step from `state` onto `out`; none when the run ends there.
    fn successors(&self, state: &Self::State, out: &mut Vec<(Self::Label, Self::State)>);

    /// The actors a step moved.
    fn moved(&self, label: &Self::Label) -> Actors;

    /// How many actors there are (numbered from 0).
    fn actors(&self) -> usize;

    /// Pushes the fairness [`Task`]s a step takes: by default one per actor it moved (task
    /// `a` is actor `a`). A system whose fairness is about more than its actors (every message
    /// in flight, every timer) names its own tasks here.
    fn tasks(&self, label: &Self::Label, out: &mut Vec<Task>) {
        let moved = self.moved(label);
        out.extend((0..64).filter(|a| moved & (1 << a) != 0));
    }

    /// Pushes the tasks of steps from `state` that the graph leaves out because they leave
    /// the model's bounds, and returns whether a bound cut the run short there. Such a state
    /// is never where a run ends, and the tasks count as enabled there (so a cycle that keeps
    /// one enabled without taking it is unfair). It is called right after
    /// [`Self::successors`] of the same state. By default nothing is left out.
    fn beyond(&self, _state: &Self::State, _out: &mut Vec<Task>) -> bool {
        false
    }
}

/// Something fairness forbids to put off for ever: an actor, a message in flight, a timer.
pub type Task = u32;

/// How a fairness constraint holds one task.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strength {
    /// A task enabled without interruption from some point on is eventually taken.
    Weak,
    /// A task enabled infinitely often is taken infinitely often.
    Strong,
}

/// Which infinite runs a liveness property is judged on (see the module's doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fairness {
    None,
    Weak,
    Strong,
}

/// The temporal shape of a liveness property over a state predicate `P`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Liveness {
    /// `<> P`: every fair run reaches a state where `P` holds.
    Eventually,
    /// `<>[] P`: every fair run reaches a point after which `P` always holds.
    EventuallyAlways,
    /// `[]<> P`: every fair run has `P` hold infinitely often.
    AlwaysEventually,
}

impl Liveness {
    /// The formula, as SPIN writes it, over `p`.
    pub fn formula(self, p: &str) -> String {
        match self {
            Self::Eventually => format!("<> {p}"),
            Self::EventuallyAlways => format!("<>[] {p}"),
            Self::AlwaysEventually => format!("[]<> {p}"),
        }
    }
}

/// Limits of an exploration; `None` is unlimited.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Limits {
    /// Unique states.
    pub max_states: Option<usize>,
    /// Bytes of the graph, as [`Graph::memory`] estimates them.
    pub max_memory: Option<u64>,
}

/// What stopped an exploration before it was exhaustive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Exceeded {
    States { limit: usize },
    Memory { limit: u64, estimate: u64 },
}

/// The reachable graph of a system: states in breadth-first order (so the stems found are
/// shortest), their steps, and the first step that reached each.
#[derive(Debug)]
pub struct Graph<T: TransitionSystem> {
    pub states: Vec<T::State>,
    /// Steps of state `i`: `edges[offsets[i]..offsets[i + 1]]`.
    offsets: Vec<usize>,
    edges: Vec<Edge>,
    labels: Vec<T::Label>,
    /// The states reached first from an initial state, and by which edge, for the stems.
    initial: Vec<bool>,
    /// The tasks enabled in each state: `enabled[spans[i]..spans[i + 1]]`, sorted.
    spans: Vec<usize>,
    enabled: Vec<Task>,
    /// The tasks of each edge: `edge_tasks[edges[k].tasks..edges[k + 1].tasks]`.
    edge_tasks: Vec<Task>,
    /// States where a bound cut the run short ([`TransitionSystem::beyond`]).
    cut: Vec<bool>,
    /// One more than the largest task.
    task_count: usize,
    /// Steps explored (with repetitions).
    pub transitions: usize,
}

#[derive(Clone, Copy, Debug)]
struct Edge {
    to: u32,
    /// Where its tasks start in [`Graph::edge_tasks`].
    tasks: u32,
}

/// Where each state of a graph is: keyed by a 64-bit fingerprint of the state, so that the
/// states are kept once (in [`Graph::states`]); states whose fingerprints collide are
/// compared in full and the later ones indexed by value.
struct Index<S> {
    first: HashMap<u64, u32, BuildHasherDefault<Identity>>,
    collided: HashMap<S, u32>,
}

impl<S: Eq + Hash> Index<S> {
    fn new() -> Self {
        Self {
            first: HashMap::default(),
            collided: HashMap::new(),
        }
    }

    /// The fingerprint of `s` (a fixed-key hash: the same on every run).
    fn fingerprint(s: &S) -> u64 {
        ahash::RandomState::with_seeds(0x6c69_7665, 0x6e65_7373, 0x6772_6170, 0x0068_6173)
            .hash_one(s)
    }

    /// The number of `s` among `states`, if it is there.
    fn get(&self, fp: u64, s: &S, states: &[S]) -> Option<u32> {
        match self.first.get(&fp) {
            Some(&i) if states[i as usize] == *s => Some(i),
            Some(_) => self.collided.get(s).copied(),
            None => None,
        }
    }

    /// Numbers `s` (not indexed yet) as `i`.
    fn insert(&mut self, fp: u64, s: &S, i: u32)
    where
        S: Clone,
    {
        if let std::collections::hash_map::Entry::Vacant(e) = self.first.entry(fp) {
            e.insert(i);
        } else {
            self.collided.insert(s.clone(), i);
        }
    }
}

/// Explores every state reachable from the initial states, breadth first.
pub fn explore<T: TransitionSystem>(system: &T, limits: Limits) -> Result<Graph<T>, Exceeded> {
    let mut index: Index<T::State> = Index::new();
    let mut g = Graph::<T> {
        states: Vec::new(),
        offsets: vec![0],
        edges: Vec::new(),
        labels: Vec::new(),
        initial: Vec::new(),
        spans: vec![0],
        enabled: Vec::new(),
        edge_tasks: Vec::new(),
        cut: Vec::new(),
        task_count: 0,
        transitions: 0,
    };
    let mut add = |s: T::State, g: &mut Graph<T>, initial: bool| -> Result<u32, Exceeded> {
        let fp = Index::fingerprint(&s);
        if let Some(i) = index.get(fp, &s, &g.states) {
            if initial {
                g.initial[i as usize] = true;
            }
            return Ok(i);
        }
        if let Some(limit) = limits.max_states {
            if g.states.len() >= limit {
                return Err(Exceeded::States { limit });
            }
        }
        let i = g.states.len() as u32;
        index.insert(fp, &s, i);
        g.states.push(s);
        g.initial.push(initial);
        Ok(i)
    };
    for s in system.initial_states() {
        add(s, &mut g, true)?;
    }
    let mut next = Vec::new();
    let mut enabled = Vec::new();
    let mut i = 0;
    while i < g.states.len() {
        next.clear();
        enabled.clear();
        system.successors(&g.states[i], &mut next);
        for (label, s) in next.drain(..) {
            let to = add(s, &mut g, false)?;
            let first = g.edge_tasks.len();
            system.tasks(&label, &mut g.edge_tasks);
            enabled.extend_from_slice(&g.edge_tasks[first..]);
            g.edges.push(Edge {
                to,
                tasks: first as u32,
            });
            g.labels.push(label);
        }
        let cut = system.beyond(&g.states[i], &mut enabled);
        g.cut
            .push(cut || g.edges.len() == g.offsets[i] && !enabled.is_empty());
        enabled.sort_unstable();
        enabled.dedup();
        if let Some(&last) = enabled.last() {
            g.task_count = g.task_count.max(last as usize + 1);
        }
        g.enabled.extend_from_slice(&enabled);
        g.spans.push(g.enabled.len());
        g.transitions += g.edges.len() - g.offsets[i];
        g.offsets.push(g.edges.len());
        if let Some(limit) = limits.max_memory {
            let estimate = g.memory();
            if estimate > limit {
                return Err(Exceeded::Memory { limit, estimate });
            }
        }
        i += 1;
    }
    Ok(g)
}

/// A counterexample to a liveness property: from `start` (an initial state), the `stem`'s
/// steps, then the `cycle`'s steps, which end where the cycle began and repeat forever. An
/// empty cycle means the run ends at the stem's last state and stays there.
#[derive(Clone, Debug, PartialEq)]
pub struct Lasso<S, L> {
    pub start: S,
    pub stem: Vec<(L, S)>,
    pub cycle: Vec<(L, S)>,
}

impl<S: Clone, L> Lasso<S, L> {
    /// The state where the cycle begins (and ends).
    pub fn entry(&self) -> &S {
        self.stem.last().map_or(&self.start, |(_, s)| s)
    }
}

/// A property's verdict on a whole graph.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict<S, L> {
    Holds,
    Fails(Lasso<S, L>),
}

impl<T: TransitionSystem> Graph<T> {
    /// Unique states.
    pub fn len(&self) -> usize {
        self.states.len()
    }

    pub fn is_empty(&self) -> bool {
        self.states.is_empty()
    }

    /// Distinct steps (edges).
    pub fn edge_count(&self) -> usize {
        self.edges.len()
    }

    /// An estimate of the graph's bytes: each state (as it is held, without what it points
    /// to) and its index entry, each edge and label, and the per-state bookkeeping.
    pub fn memory(&self) -> u64 {
        let state = std::mem::size_of::<T::State>() as u64;
        let per_state = state + 16 + 8 + 1 + 8 + 1;
        let per_edge = std::mem::size_of::<Edge>() as u64 + std::mem::size_of::<T::Label>() as u64;
        let tasks = (self.edge_tasks.len() + self.enabled.len()) as u64 * 4;
        self.states.len() as u64 * per_state + self.edges.len() as u64 * per_edge + tasks
    }

    fn out(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }

    /// The tasks edge `k` takes.
    fn taken(&self, k: usize) -> &[Task] {
        let end = self
            .edges
            .get(k + 1)
            .map_or(self.edge_tasks.len(), |e| e.tasks as usize);
        &self.edge_tasks[self.edges[k].tasks as usize..end]
    }

    /// The tasks enabled in state `i`.
    fn enabled(&self, i: usize) -> &[Task] {
        &self.enabled[self.spans[i]..self.spans[i + 1]]
    }

    fn is_enabled(&self, i: usize, task: Task) -> bool {
        self.enabled(i).binary_search(&task).is_ok()
    }

    /// Whether the run ends in state `i`: it has no step, and no bound cut it short there.
    fn ends(&self, i: usize) -> bool {
        self.out(i).is_empty() && !self.cut[i]
    }

    /// States where a bound cut the run short ([`TransitionSystem::beyond`]): no verdict
    /// rests on what happens after them.
    pub fn cut_states(&self) -> usize {
        self.cut.iter().filter(|c| **c).count()
    }

    /// Decides `kind` over the predicate `p` under `fairness`, the same for every task.
    pub fn check(
        &self,
        kind: Liveness,
        fairness: Fairness,
        p: impl Fn(&T::State) -> bool,
    ) -> Verdict<T::State, T::Label> {
        let strength = match fairness {
            Fairness::None => None,
            Fairness::Weak => Some(Strength::Weak),
            Fairness::Strong => Some(Strength::Strong),
        };
        self.check_under(kind, &|_| strength, &|_| true, p)
    }

    /// Decides `kind` over the predicate `p` on the runs that are fair for each task as
    /// `fair` says (`None`: the task may be put off for ever) and that satisfy the assumption
    /// `<>[] assume` (a run that does not is not judged: a failure detector's eventual
    /// accuracy, for instance).
    pub fn check_under(
        &self,
        kind: Liveness,
        fair: &dyn Fn(Task) -> Option<Strength>,
        assume: &dyn Fn(&T::State) -> bool,
        p: impl Fn(&T::State) -> bool,
    ) -> Verdict<T::State, T::Label> {
        let n = self.states.len();
        let holds: Vec<bool> = self.states.iter().map(&p).collect();
        let assumed: Vec<bool> = self.states.iter().map(assume).collect();
        // Where the stem may go, where the cycle may go, and what the cycle must visit.
        let (stem_in, mut cycle_in, must): (Vec<bool>, Vec<bool>, Vec<bool>) = match kind {
            Liveness::Eventually => {
                let avoid: Vec<bool> = holds.iter().map(|h| !h).collect();
                let seeds = (0..n).filter(|&i| self.initial[i] && avoid[i]).collect();
                let reach = self.reach(seeds, &avoid);
                (reach.clone(), reach, vec![true; n])
            }
            Liveness::EventuallyAlways => (vec![true; n], vec![true; n], holds.map_not()),
            Liveness::AlwaysEventually => (vec![true; n], holds.map_not(), vec![true; n]),
        };
        for (c, a) in cycle_in.iter_mut().zip(&assumed) {
            *c &= *a;
        }
        let strengths: Vec<Option<Strength>> =
            (0..self.task_count).map(|t| fair(t as Task)).collect();
        let Some(cycle) = self.fair_cycle(&cycle_in, &must, &strengths) else {
            return Verdict::Holds;
        };
        let seeds = (0..n).filter(|&i| self.initial[i] && stem_in[i]).collect();
        let stem = self
            .path(seeds, |i| cycle.first() == Some(&i), &stem_in)
            .expect("the cycle is reachable within the stem's states");
        let start = stem.states[0];
        let entry = *stem.states.last().expect("a path has a state");
        let cycle = self.close(entry, &cycle, &must, &strengths);
        Verdict::Fails(Lasso {
            start: self.states[start].clone(),
            stem: self.steps(&stem),
            cycle: self.steps(&cycle),
        })
    }

    /// The states reachable from `seeds` within `allowed`.
    fn reach(&self, seeds: Vec<usize>, allowed: &[bool]) -> Vec<bool> {
        let mut seen = vec![false; self.states.len()];
        let mut todo = seeds;
        for &s in &todo {
            seen[s] = true;
        }
        while let Some(i) = todo.pop() {
            for e in &self.edges[self.out(i)] {
                let j = e.to as usize;
                if allowed[j] && !seen[j] {
                    seen[j] = true;
                    todo.push(j);
                }
            }
        }
        seen
    }

    /// A shortest path from one of `seeds` to a state where `goal` holds, within `allowed`:
    /// its states and the edges between them (`edges[k]` leads from `states[k]`).
    fn path(
        &self,
        seeds: Vec<usize>,
        goal: impl Fn(usize) -> bool,
        allowed: &[bool],
    ) -> Option<Walk> {
        let mut parent: HashMap<usize, Option<(usize, usize)>> = HashMap::new();
        let mut queue = VecDeque::new();
        for s in seeds {
            if parent.insert(s, None).is_none() {
                queue.push_back(s);
            }
        }
        while let Some(i) = queue.pop_front() {
            if goal(i) {
                let mut walk = Walk {
                    states: vec![i],
                    edges: Vec::new(),
                };
                let mut at = i;
                while let Some(Some((p, k))) = parent.get(&at) {
                    walk.states.push(*p);
                    walk.edges.push(*k);
                    at = *p;
                }
                walk.states.reverse();
                walk.edges.reverse();
                return Some(walk);
            }
            for k in self.out(i) {
                let j = self.edges[k].to as usize;
                if allowed[j] && !parent.contains_key(&j) {
                    parent.insert(j, Some((i, k)));
                    queue.push_back(j);
                }
            }
        }
        None
    }

    /// The (label, state) steps of a walk.
    fn steps(&self, walk: &Walk) -> Vec<(T::Label, T::State)> {
        walk.edges
            .iter()
            .zip(&walk.states[1..])
            .map(|(&k, &s)| (self.labels[k].clone(), self.states[s].clone()))
            .collect()
    }

    /// A component (its states, sorted) holding a fair cycle within `allowed` that visits
    /// `must`, or a state of `allowed ∩ must` where the run ends (a one-state "component").
    fn fair_cycle(
        &self,
        allowed: &[bool],
        must: &[bool],
        strengths: &[Option<Strength>],
    ) -> Option<Vec<usize>> {
        let n = self.states.len();
        if let Some(end) = (0..n).find(|&i| allowed[i] && must[i] && self.ends(i)) {
            return Some(vec![end]);
        }
        let mut work: Vec<Vec<usize>> = vec![(0..n).filter(|&i| allowed[i]).collect()];
        let mut inside = vec![false; n];
        // Per task: taken inside the component, and in how many of its states it is enabled.
        let mut moved = vec![false; self.task_count];
        let mut count = vec![0usize; self.task_count];
        let mut touched: Vec<Task> = Vec::new();
        while let Some(set) = work.pop() {
            for scc in self.components(&set) {
                for &i in &scc {
                    inside[i] = true;
                }
                for &i in &scc {
                    for k in self.out(i) {
                        if inside[self.edges[k].to as usize] {
                            for &t in self.taken(k) {
                                moved[t as usize] = true;
                                touched.push(t);
                            }
                        }
                    }
                    for &t in self.enabled(i) {
                        count[t as usize] += 1;
                        touched.push(t);
                    }
                }
                let cyclic = scc.len() > 1
                    || self.edges[self.out(scc[0])]
                        .iter()
                        .any(|e| e.to as usize == scc[0]);
                let visits = scc.iter().any(|&i| must[i]);
                let verdict = if !cyclic || !visits {
                    Err(None)
                } else {
                    // A strong task enabled in the component but never taken there: a fair
                    // cycle avoids every state where it is enabled.
                    let mut starved: Vec<Task> = touched
                        .iter()
                        .copied()
                        .filter(|&t| {
                            strengths[t as usize] == Some(Strength::Strong)
                                && !moved[t as usize]
                                && count[t as usize] > 0
                        })
                        .collect();
                    starved.sort_unstable();
                    starved.dedup();
                    // A weak task enabled in every state but never taken: no cycle is fair.
                    let waits = touched.iter().any(|&t| {
                        strengths[t as usize] == Some(Strength::Weak)
                            && !moved[t as usize]
                            && count[t as usize] == scc.len()
                    });
                    if !starved.is_empty() {
                        let rest: Vec<usize> = scc
                            .iter()
                            .copied()
                            .filter(|&i| !starved.iter().any(|&t| self.is_enabled(i, t)))
                            .collect();
                        Err((!rest.is_empty()).then_some(rest))
                    } else if waits {
                        Err(None)
                    } else {
                        Ok(())
                    }
                };
                for &i in &scc {
                    inside[i] = false;
                }
                for t in touched.drain(..) {
                    moved[t as usize] = false;
                    count[t as usize] = 0;
                }
                match verdict {
                    Ok(()) => return Some(scc),
                    Err(Some(rest)) => work.push(rest),
                    Err(None) => {}
                }
            }
        }
        None
    }

    /// A cycle from `entry` within the component `scc` that visits `must` and is fair: it
    /// takes a step of every fair task taken inside the component, and visits a state where
    /// each weak task never taken there is disabled. Its states start and end at `entry`; no
    /// step when the run ends there.
    fn close(
        &self,
        entry: usize,
        scc: &[usize],
        must: &[bool],
        strengths: &[Option<Strength>],
    ) -> Walk {
        let mut cycle = Walk {
            states: vec![entry],
            edges: Vec::new(),
        };
        if scc.len() == 1 && self.ends(entry) {
            return cycle;
        }
        let mut allowed = vec![false; self.states.len()];
        for &i in scc {
            allowed[i] = true;
        }
        let goto = |cycle: &mut Walk, goal: &dyn Fn(usize) -> bool| {
            let at = *cycle.states.last().expect("non-empty");
            let p = self
                .path(vec![at], goal, &allowed)
                .expect("strongly connected");
            cycle.states.extend_from_slice(&p.states[1..]);
            cycle.edges.extend_from_slice(&p.edges);
        };
        let inner = |i: usize| self.out(i).filter(|&k| allowed[self.edges[k].to as usize]);
        let take = |cycle: &mut Walk, k: usize| {
            cycle.edges.push(k);
            cycle.states.push(self.edges[k].to as usize);
        };
        if !must[entry] {
            goto(&mut cycle, &|i| must[i]);
        }
        let mut moved_inside: Vec<Task> = scc
            .iter()
            .flat_map(|&i| inner(i))
            .flat_map(|k| self.taken(k).iter().copied())
            .collect();
        moved_inside.sort_unstable();
        moved_inside.dedup();
        for task in 0..self.task_count as Task {
            let Some(strength) = strengths[task as usize] else {
                continue;
            };
            let moves = |k: usize| self.taken(k).contains(&task);
            if moved_inside.binary_search(&task).is_ok() {
                goto(&mut cycle, &|i| inner(i).any(moves));
                let at = *cycle.states.last().expect("non-empty");
                let k = inner(at).find(|&k| moves(k)).expect("found");
                take(&mut cycle, k);
            } else if strength == Strength::Weak
                && !cycle.states.iter().any(|&i| !self.is_enabled(i, task))
                && scc.iter().any(|&i| !self.is_enabled(i, task))
            {
                goto(&mut cycle, &|i| !self.is_enabled(i, task));
            }
        }
        if cycle.edges.is_empty() {
            let k = inner(entry)
                .next()
                .expect("a cyclic component has an inner step");
            take(&mut cycle, k);
        }
        if *cycle.states.last().expect("non-empty") != entry {
            goto(&mut cycle, &|i| i == entry);
        }
        cycle
    }

    /// Tarjan's strongly connected components of the subgraph induced by `set`, with an
    /// explicit call stack.
    fn components(&self, set: &[usize]) -> Vec<Vec<usize>> {
        const NONE: u32 = u32::MAX;
        let n = self.states.len();
        let mut member = vec![false; n];
        for &i in set {
            member[i] = true;
        }
        let mut index = vec![NONE; n];
        let mut low = vec![0u32; n];
        let mut on_stack = vec![false; n];
        let mut stack: Vec<usize> = Vec::new();
        let mut calls: Vec<(usize, usize)> = Vec::new();
        let mut next = 0u32;
        let mut out = Vec::new();
        for &root in set {
            if index[root] != NONE {
                continue;
            }
            calls.push((root, self.offsets[root]));
            index[root] = next;
            low[root] = next;
            next += 1;
            stack.push(root);
            on_stack[root] = true;
            while let Some(&mut (v, ref mut k)) = calls.last_mut() {
                if *k < self.offsets[v + 1] {
                    let w = self.edges[*k].to as usize;
                    *k += 1;
                    if !member[w] {
                        continue;
                    }
                    if index[w] == NONE {
                        index[w] = next;
                        low[w] = next;
                        next += 1;
                        stack.push(w);
                        on_stack[w] = true;
                        calls.push((w, self.offsets[w]));
                    } else if on_stack[w] {
                        low[v] = low[v].min(index[w]);
                    }
                    continue;
                }
                calls.pop();
                if let Some(&(u, _)) = calls.last() {
                    low[u] = low[u].min(low[v]);
                }
                if low[v] == index[v] {
                    let mut scc = Vec::new();
                    loop {
                        let w = stack.pop().expect("v is on the stack");
                        on_stack[w] = false;
                        scc.push(w);
                        if w == v {
                            break;
                        }
                    }
                    scc.sort_unstable();
                    out.push(scc);
                }
            }
        }
        out
    }
}

/// States and the edges between them.
#[derive(Debug)]
struct Walk {
    states: Vec<usize>,
    edges: Vec<usize>,
}

trait MapNot {
    fn map_not(&self) -> Vec<bool>;
}

impl MapNot for Vec<bool> {
    fn map_not(&self) -> Vec<bool> {
        self.iter().map(|b| !b).collect()
    }
}

#[cfg(test)]
mod tests;
