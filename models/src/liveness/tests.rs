//! The liveness checks against a brute-force oracle on random small graphs: every closed
//! walk's summary (which states it visits, which actors it moves) is enumerated exhaustively,
//! which decides whether a fair violating lasso exists without components; and every lasso
//! the checker returns is replayed step by step against the graph.

use super::*;

/// A hand-made graph: `edges[i]` lists (target, actors) of state `i`.
#[derive(Debug)]
struct Hand {
    edges: Vec<Vec<(usize, Actors)>>,
    initial: Vec<usize>,
    /// Per state, steps left out by a bound: whether it is cut, and their actors.
    left: Vec<(bool, Actors)>,
}

impl TransitionSystem for Hand {
    type State = usize;
    /// (from, index of the step, actors).
    type Label = (usize, usize, Actors);

    fn initial_states(&self) -> Vec<usize> {
        self.initial.clone()
    }

    fn successors(&self, s: &usize, out: &mut Vec<((usize, usize, Actors), usize)>) {
        for (k, &(to, a)) in self.edges[*s].iter().enumerate() {
            out.push(((*s, k, a), to));
        }
    }

    fn moved(&self, l: &(usize, usize, Actors)) -> Actors {
        l.2
    }

    fn actors(&self) -> usize {
        2
    }

    fn beyond(&self, s: &usize, out: &mut Vec<Task>) -> bool {
        let (cut, actors) = self.left.get(*s).copied().unwrap_or((false, 0));
        out.extend((0..2).filter(|a| actors & (1 << a) != 0));
        cut
    }
}

impl Hand {
    fn new(edges: Vec<Vec<(usize, Actors)>>, initial: Vec<usize>) -> Self {
        let left = vec![(false, 0); edges.len()];
        Self {
            edges,
            initial,
            left,
        }
    }

    fn enabled(&self, s: usize) -> Actors {
        self.edges[s].iter().fold(self.left[s].1, |a, e| a | e.1)
    }

    /// The run ends in `s`: no step, none left out.
    fn ends(&self, s: usize) -> bool {
        self.edges[s].is_empty() && self.left[s] == (false, 0)
    }

    fn reach(&self, allowed: &dyn Fn(usize) -> bool) -> Vec<bool> {
        let mut seen = vec![false; self.edges.len()];
        let mut todo: Vec<usize> = self
            .initial
            .iter()
            .copied()
            .filter(|&i| allowed(i))
            .collect();
        for &i in &todo {
            seen[i] = true;
        }
        while let Some(i) = todo.pop() {
            for &(j, _) in &self.edges[i] {
                if allowed(j) && !seen[j] {
                    seen[j] = true;
                    todo.push(j);
                }
            }
        }
        seen
    }

    fn fair_each(&self, visited: u32, taken: Actors, strengths: [Option<Strength>; 2]) -> bool {
        let states = (0..self.edges.len()).filter(|i| visited & (1 << i) != 0);
        (0..2).all(|a| {
            let bit = 1 << a;
            match strengths[a] {
                None => true,
                Some(Strength::Weak) => {
                    taken & bit != 0 || states.clone().any(|i| self.enabled(i) & bit == 0)
                }
                Some(Strength::Strong) => {
                    taken & bit != 0 || states.clone().all(|i| self.enabled(i) & bit == 0)
                }
            }
        })
    }

    /// Whether a fair violating lasso exists: every closed walk's (visited states, moved
    /// actors) summary, from every reachable state.
    fn oracle(&self, kind: Liveness, fairness: Fairness, p: &[bool]) -> bool {
        let strength = match fairness {
            Fairness::None => None,
            Fairness::Weak => Some(Strength::Weak),
            Fairness::Strong => Some(Strength::Strong),
        };
        self.oracle_under(kind, [strength; 2], &vec![true; self.edges.len()], p)
    }

    /// [`Self::oracle`] with a strength per actor and the assumption `<>[] a`.
    fn oracle_under(
        &self,
        kind: Liveness,
        strengths: [Option<Strength>; 2],
        a: &[bool],
        p: &[bool],
    ) -> bool {
        let n = self.edges.len();
        let (stem_ok, in_cycle): (Vec<bool>, Vec<bool>) = match kind {
            Liveness::Eventually => {
                let r = self.reach(&|i| !p[i]);
                (r.clone(), r)
            }
            Liveness::EventuallyAlways => (self.reach(&|_| true), vec![true; n]),
            Liveness::AlwaysEventually => (self.reach(&|_| true), (0..n).map(|i| !p[i]).collect()),
        };
        let violates = |visited: u32| {
            let states = (0..n).filter(|i| visited & (1 << i) != 0);
            match kind {
                Liveness::EventuallyAlways => states.clone().any(|i| !p[i]),
                _ => true,
            }
        };
        let in_cycle: Vec<bool> = (0..n).map(|i| in_cycle[i] && a[i]).collect();
        for s in 0..n {
            if !stem_ok[s] || !in_cycle[s] {
                continue;
            }
            if self.ends(s) && violates(1 << s) && !p[s] {
                return true;
            }
            let mut seen = std::collections::HashSet::new();
            let mut todo = vec![(s, 1u32 << s, 0 as Actors)];
            seen.insert(todo[0]);
            while let Some((v, visited, taken)) = todo.pop() {
                for &(w, a) in &self.edges[v] {
                    if !in_cycle[w] {
                        continue;
                    }
                    let t = taken | a;
                    if w == s && violates(visited) && self.fair_each(visited, t, strengths) {
                        return true;
                    }
                    let next = (w, visited | (1 << w), t);
                    if seen.insert(next) {
                        todo.push(next);
                    }
                }
            }
        }
        false
    }

    /// Replays a lasso: real steps, from an initial state, back to its entry, fair, and
    /// violating `kind`.
    fn replay(
        &self,
        l: &Lasso<usize, (usize, usize, Actors)>,
        kind: Liveness,
        f: Fairness,
        p: &[bool],
    ) {
        let strength = match f {
            Fairness::None => None,
            Fairness::Weak => Some(Strength::Weak),
            Fairness::Strong => Some(Strength::Strong),
        };
        self.replay_under(l, kind, [strength; 2], p)
    }

    fn replay_under(
        &self,
        l: &Lasso<usize, (usize, usize, Actors)>,
        kind: Liveness,
        f: [Option<Strength>; 2],
        p: &[bool],
    ) {
        assert!(self.initial.contains(&l.start));
        let mut at = l.start;
        let mut stem_states = vec![at];
        for &((from, k, a), to) in &l.stem {
            assert_eq!(from, at);
            assert_eq!(self.edges[from][k], (to, a));
            at = to;
            stem_states.push(at);
        }
        let entry = at;
        let mut visited = 1u32 << at;
        let mut taken = 0;
        for &((from, k, a), to) in &l.cycle {
            assert_eq!(from, at);
            assert_eq!(self.edges[from][k], (to, a));
            at = to;
            visited |= 1 << at;
            taken |= a;
        }
        assert_eq!(at, entry, "the cycle ends where it began");
        if l.cycle.is_empty() {
            assert!(self.ends(entry), "an empty cycle ends the run");
        } else {
            assert!(self.fair_each(visited, taken, f), "{l:?}");
        }
        let states: Vec<usize> = (0..self.edges.len())
            .filter(|i| visited & (1 << i) != 0)
            .collect();
        match kind {
            Liveness::Eventually => {
                assert!(stem_states.iter().chain(&states).all(|&i| !p[i]), "{l:?}")
            }
            Liveness::EventuallyAlways => assert!(states.iter().any(|&i| !p[i]), "{l:?}"),
            Liveness::AlwaysEventually => assert!(states.iter().all(|&i| !p[i]), "{l:?}"),
        }
    }
}

/// A small xorshift: the tests need no crate for their random graphs.
struct Rng(u64);

impl Rng {
    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0 % n
    }
}

fn random_graph(rng: &mut Rng) -> (Hand, Vec<bool>) {
    let n = 1 + rng.below(6) as usize;
    let edges = (0..n)
        .map(|_| {
            (0..rng.below(4))
                .map(|_| (rng.below(n as u64) as usize, 1 + rng.below(3)))
                .collect()
        })
        .collect();
    let initial = (0..1 + rng.below(2))
        .map(|_| rng.below(n as u64) as usize)
        .collect();
    let p = (0..n).map(|_| rng.below(2) == 0).collect();
    (Hand::new(edges, initial), p)
}

#[test]
fn liveness_agrees_with_the_brute_force_oracle_on_random_graphs() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut fails = 0;
    let mut cases = 0;
    for _ in 0..3000 {
        let (h, p) = random_graph(&mut rng);
        let g = explore(&h, Limits::default()).expect("small");
        for kind in [
            Liveness::Eventually,
            Liveness::EventuallyAlways,
            Liveness::AlwaysEventually,
        ] {
            for f in [Fairness::None, Fairness::Weak, Fairness::Strong] {
                cases += 1;
                let expected = h.oracle(kind, f, &p);
                match g.check(kind, f, |&s| p[s]) {
                    Verdict::Holds => assert!(!expected, "{h:?} {p:?} {kind:?} {f:?}"),
                    Verdict::Fails(l) => {
                        assert!(expected, "{h:?} {p:?} {kind:?} {f:?} {l:?}");
                        h.replay(&l, kind, f, &p);
                        fails += 1;
                    }
                }
            }
        }
    }
    // Both verdicts are common, so neither side is vacuous.
    assert!(
        fails > cases / 5 && fails < cases * 4 / 5,
        "{fails} of {cases}"
    );
}

/// Mixed strengths, an assumption and steps left out by a bound, against the oracle: the
/// stack checks' fairness (weak delivery and timers, strong loss) and eventual accuracy.
#[test]
fn mixed_fairness_assumptions_and_bounds_agree_with_the_oracle() {
    let mut rng = Rng(0xD1B5_4A32_D192_ED03);
    let (mut fails, mut cases) = (0, 0);
    let strengths = [None, Some(Strength::Weak), Some(Strength::Strong)];
    for _ in 0..3000 {
        let (mut h, p) = random_graph(&mut rng);
        let n = h.edges.len();
        h.left = (0..n)
            .map(|_| match rng.below(4) {
                0 => (true, 0),
                1 => (false, 1 + rng.below(3)),
                _ => (false, 0),
            })
            .collect();
        let a: Vec<bool> = (0..n).map(|_| rng.below(4) != 0).collect();
        let g = explore(&h, Limits::default()).expect("small");
        for kind in [
            Liveness::Eventually,
            Liveness::EventuallyAlways,
            Liveness::AlwaysEventually,
        ] {
            let s = [
                strengths[rng.below(3) as usize],
                strengths[rng.below(3) as usize],
            ];
            cases += 1;
            let expected = h.oracle_under(kind, s, &a, &p);
            let verdict = g.check_under(kind, &|t| s[t as usize], &|&i| a[i], |&i| p[i]);
            match verdict {
                Verdict::Holds => assert!(!expected, "{h:?} {p:?} {a:?} {kind:?} {s:?}"),
                Verdict::Fails(l) => {
                    assert!(expected, "{h:?} {p:?} {a:?} {kind:?} {s:?} {l:?}");
                    h.replay_under(&l, kind, s, &p);
                    fails += 1;
                }
            }
        }
    }
    assert!(
        fails > cases / 10 && fails < cases * 9 / 10,
        "{fails} of {cases}"
    );
}

/// Two actors on a ring where only actor 0 moves away from the goal: weak fairness forces
/// actor 1, which leads to the goal; without fairness actor 0 may loop forever.
#[test]
fn fairness_decides_a_starved_actor() {
    // 0 -a0-> 0 (loop), 0 -a1-> 1 (goal, stays there by a0|a1 steps).
    let h = Hand::new(vec![vec![(0, 1), (1, 2)], vec![(1, 3)]], vec![0]);
    let g = explore(&h, Limits::default()).expect("small");
    let goal = |&s: &usize| s == 1;
    assert!(matches!(
        g.check(Liveness::Eventually, Fairness::None, goal),
        Verdict::Fails(_)
    ));
    assert_eq!(
        g.check(Liveness::Eventually, Fairness::Weak, goal),
        Verdict::Holds
    );
    assert_eq!(
        g.check(Liveness::EventuallyAlways, Fairness::Strong, goal),
        Verdict::Holds
    );
}

/// Weak and strong fairness differ where an actor is enabled only now and then.
#[test]
fn strong_fairness_is_stronger_than_weak() {
    // 0 -a0-> 1 -a0-> 0; actor 1 is enabled only in 1, where it leads to the goal 2.
    let h = Hand::new(vec![vec![(1, 1)], vec![(0, 1), (2, 2)], vec![]], vec![0]);
    let g = explore(&h, Limits::default()).expect("small");
    let goal = |&s: &usize| s == 2;
    let Verdict::Fails(l) = g.check(Liveness::Eventually, Fairness::Weak, goal) else {
        panic!("weak fairness lets actor 1 wait in state 0");
    };
    assert_eq!(l.cycle.len(), 2);
    assert_eq!(
        g.check(Liveness::Eventually, Fairness::Strong, goal),
        Verdict::Holds
    );
}

/// A run that ends stays in its last state: `<>[] P` holds there when `P` does.
#[test]
fn a_run_that_ends_stutters() {
    let h = Hand::new(vec![vec![(1, 1)], vec![]], vec![0]);
    let g = explore(&h, Limits::default()).expect("small");
    assert_eq!(
        g.check(Liveness::EventuallyAlways, Fairness::Weak, |&s| s == 1),
        Verdict::Holds
    );
    let Verdict::Fails(l) = g.check(Liveness::EventuallyAlways, Fairness::Weak, |&s| s == 0) else {
        panic!("the run ends in state 1 forever");
    };
    assert!(l.cycle.is_empty());
    assert_eq!(*l.entry(), 1);
}

#[test]
fn budgets_stop_the_exploration() {
    let h = Hand::new(vec![vec![(1, 1)], vec![(2, 1)], vec![(0, 1)]], vec![0]);
    let limits = Limits {
        max_states: Some(2),
        max_memory: None,
    };
    assert_eq!(
        explore(&h, limits).err(),
        Some(Exceeded::States { limit: 2 })
    );
    let limits = Limits {
        max_states: None,
        max_memory: Some(10),
    };
    assert!(matches!(
        explore(&h, limits),
        Err(Exceeded::Memory { limit: 10, .. })
    ));
}
