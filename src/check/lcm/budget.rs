//! What stops a check of robot algorithms before it has covered what it was asked, besides
//! its state budget: the process's resident memory reaching `--max-memory` (by default half the
//! machine's memory, at most 4 GiB, as for stack checks), and Ctrl-C. Both are polled while the
//! search runs, so neither an out-of-memory kill nor an unanswered Ctrl-C ends it silently: the
//! check says what it covered and exits 3 (a budget) or 130 (Ctrl-C).

use std::cell::Cell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use nekosim_models::liveness::{Actors, Exceeded, Limits, Task, TransitionSystem};

/// States (or rounds) between two polls: reading the resident memory costs a file read.
pub const POLL_EVERY: u64 = 1024;

/// A check's budget: the exploration's own limits, and what is polled.
#[derive(Clone, Debug, Default)]
pub struct Budget {
    pub limits: Limits,
    pub watch: Watch,
}

/// Why a check stopped before it was exhaustive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Open {
    /// A limit of the exploration.
    Exceeded(Exceeded),
    /// The watch, after `states` states were expanded.
    Halted { halt: Halt, states: u64 },
}

/// What is polled.
#[derive(Clone, Debug, Default)]
pub struct Watch {
    /// The resident memory the process may reach [bytes]; `None`: unlimited.
    pub max_memory: Option<u64>,
    /// Set by Ctrl-C.
    pub interrupt: Option<Arc<AtomicBool>>,
}

/// Why a watched search stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Halt {
    /// The process's resident memory reached the budget [bytes].
    Memory { resident: u64, limit: u64 },
    /// Ctrl-C.
    Interrupted,
}

impl Watch {
    /// Why the search must stop now, if it must.
    pub fn halt(&self) -> Option<Halt> {
        if self
            .interrupt
            .as_ref()
            .is_some_and(|i| i.load(Ordering::Relaxed))
        {
            return Some(Halt::Interrupted);
        }
        let limit = self.max_memory?;
        let resident = nekosim_models::resident_memory()?;
        (resident >= limit).then_some(Halt::Memory { resident, limit })
    }
}

impl Halt {
    /// What stopped the search, in a report's words.
    pub fn text(self) -> String {
        match self {
            Self::Memory { resident, limit } => format!(
                "the memory budget (resident {} of {})",
                super::super::size_text(resident),
                super::super::size_text(limit)
            ),
            Self::Interrupted => "Ctrl-C".into(),
        }
    }
}

/// `system` explored under a [`Watch`]: the watch is polled at the first state expanded and
/// every [`POLL_EVERY`] after; once it halts, no state has a step, so the exploration ends at
/// once, and its graph, which is then incomplete, must be discarded ([`Self::halted`]).
#[derive(Debug)]
pub struct Watched<'a, T> {
    pub system: &'a T,
    pub watch: &'a Watch,
    expanded: Cell<u64>,
    halted: Cell<Option<Halt>>,
}

impl<'a, T> Watched<'a, T> {
    pub fn new(system: &'a T, watch: &'a Watch) -> Self {
        Self {
            system,
            watch,
            expanded: Cell::new(0),
            halted: Cell::new(None),
        }
    }

    /// Why the exploration was stopped, and how many states it had expanded by then.
    pub fn halted(&self) -> Option<(Halt, u64)> {
        self.halted
            .get()
            .map(|h| (h, self.expanded.get().saturating_sub(1)))
    }
}

impl<T: TransitionSystem> TransitionSystem for Watched<'_, T> {
    type State = T::State;
    type Label = T::Label;

    fn initial_states(&self) -> Vec<T::State> {
        self.system.initial_states()
    }

    fn successors(&self, state: &T::State, out: &mut Vec<(T::Label, T::State)>) {
        if self.halted.get().is_some() {
            return;
        }
        let n = self.expanded.get();
        self.expanded.set(n + 1);
        if n % POLL_EVERY == 0 {
            if let Some(h) = self.watch.halt() {
                self.halted.set(Some(h));
                return;
            }
        }
        self.system.successors(state, out);
    }

    fn moved(&self, label: &T::Label) -> Actors {
        self.system.moved(label)
    }

    fn actors(&self) -> usize {
        self.system.actors()
    }

    fn tasks(&self, label: &T::Label, out: &mut Vec<Task>) {
        self.system.tasks(label, out)
    }

    fn beyond(&self, state: &T::State, out: &mut Vec<Task>) -> bool {
        // Once halted, the graph is discarded: nothing is left out worth naming.
        self.halted.get().is_none() && self.system.beyond(state, out)
    }
}
