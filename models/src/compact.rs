//! Compact breadth-first search: stateright's actor semantics (its [`ActorModel`] decides every
//! step), explored by a checker that keeps each state as a handful of integers.
//!
//! A state of an actor model is a product: one state per process (with its timers, crash flag
//! and storage), the messages in flight and the history. Reached states share most of their
//! parts, so each distinct part is stored once, in an interning [`Table`], and a state is the
//! list of its parts' numbers (SPIN's "collapse compression"): `[history, process 0, ..,
//! process n-1, envelope, envelope, ..]`, the envelopes sorted (an unordered network is a
//! multiset) or in channel order (an ordered one). The frontier holds these records in blocks
//! of `u32`s, the visited set one 64-bit fingerprint and the parent's per state; a state is
//! expanded back into stateright's [`ActorModelState`] only while its successors are made.
//!
//! What it finds is what stateright's own breadth-first checker finds: the same states, the
//! same counts (generated, unique, depth) and, on one thread, the same first discovery of each
//! property, reconstructed into a [`Path`] by replaying the model along the parents'
//! fingerprints. It implements stateright's [`Checker`], so budgets and verdicts treat it like
//! stateright's checkers. With a partial-order reduction ([`crate::reduction`]) it explores
//! fewer states, reaching the same verdicts. When memory runs short it spills its visited set
//! and frontier to disk ([`crate::spill`]), exploring the same states in the same order.

use std::collections::{HashMap, VecDeque};
use std::fmt::Debug;
use std::hash::{BuildHasherDefault, Hash, Hasher};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, RwLock};
use std::thread::JoinHandle;

use dashmap::mapref::entry::Entry;
use dashmap::DashMap;
use stateright::actor::{Actor, ActorModel, ActorModelState, Envelope, Network};
use stateright::{Checker, Expectation, Model, Path};

use crate::reduction::{self, Invisible};
use crate::spill::{Spill, Store};

mod level;
mod packer;

pub use packer::{Packer, Table, Unpacked};

use level::{Block, Stored};

/// The images of a state under a model's symmetries ([`crate::symmetry`]): the search keeps
/// the least record of a state and its images.
pub type Images<A, H> =
    Arc<dyn Fn(&ActorModelState<A, H>) -> Vec<ActorModelState<A, H>> + Send + Sync>;

/// Whether a message in flight is spent: its delivery changes nothing now and in any state
/// its receiver reaches later (given every process's state and crash flag). The search
/// forgets such a message, on a network that reorders messages, as if it had been delivered.
pub type Spent<A> = Arc<
    dyn Fn(&[Arc<<A as Actor>::State>], &[bool], Envelope<&<A as Actor>::Msg>) -> bool
        + Send
        + Sync,
>;

/// The reductions a search applies; the default applies none.
pub struct Reductions<A: Actor, H> {
    /// Symmetry ([`crate::symmetry`]): the images of a state; one state of each class is
    /// explored.
    pub images: Option<Images<A, H>>,
    /// Partial-order reduction ([`crate::reduction`]): which steps may undo a discovery.
    pub invisible: Option<Invisible<A, H>>,
    /// Spent messages are forgotten.
    pub spent: Option<Spent<A>>,
}

impl<A: Actor, H> Debug for Reductions<A, H> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reductions")
            .field("images", &self.images.is_some())
            .field("invisible", &self.invisible.is_some())
            .field("spent", &self.spent.is_some())
            .finish()
    }
}

impl<A: Actor, H> Default for Reductions<A, H> {
    fn default() -> Self {
        Self {
            images: None,
            invisible: None,
            spent: None,
        }
    }
}

/// A step of an actor model.
type ModelAction<A, C, H> = <ActorModel<A, C, H> as Model>::Action;

/// A path of an actor model.
type ModelPath<A, C, H> = Path<ActorModelState<A, H>, ModelAction<A, C, H>>;

/// Records per frontier block: the unit of work a thread takes (at most).
const BLOCK: usize = 1024;

/// A fingerprint is already a hash: an index keyed by fingerprints (the visited set, the
/// liveness graph's) uses it as it is.
#[derive(Default)]
pub(crate) struct Identity(u64);

impl Hasher for Identity {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = self.0.rotate_left(8) ^ u64::from(b);
        }
    }
    fn write_u64(&mut self, n: u64) {
        self.0 = n;
    }
}

/// What the visited set keeps of a state: its parent's fingerprint and the depth it was
/// first reached at (1 for an initial state, whose parent field means nothing).
#[derive(Clone, Copy)]
struct Seen {
    parent: u64,
    depth: u32,
}

/// Fingerprint → how the state was first reached.
type Visited = DashMap<u64, Seen, BuildHasherDefault<Identity>>;

/// A step's successor while a state is expanded with a partial-order reduction.
#[derive(Clone, Copy)]
enum Slot {
    /// Not made yet.
    Unknown,
    /// The step changes nothing or leaves the model.
    Gone,
    /// Its record is `arena[at..at + len]`; `visible` when it may undo a discovery.
    Packed {
        at: usize,
        len: usize,
        fp: u64,
        visible: bool,
    },
}

/// The fingerprint of a record (a fixed-key hash: the same on every run).
fn fingerprint(record: &[u32]) -> u64 {
    ahash::RandomState::with_seeds(0x6e65_6b6f, 0x0073_696d, 0x636f_6d70, 0x0061_6374)
        .hash_one(record)
}

/// What every search thread shares.
struct Search<A, C, H>
where
    A: Actor,
    A::Msg: Ord,
    A::Timer: Ord,
    H: Clone + Debug + Hash,
{
    model: Arc<ActorModel<A, C, H>>,
    packer: Packer<A, H>,
    images: Option<Images<A, H>>,
    /// The partial-order reduction, when on: which steps may undo a discovery.
    reduction: Option<Invisible<A, H>>,
    closed: Option<Arc<AtomicBool>>,
    visited: Visited,
    unique: AtomicUsize,
    generated: AtomicUsize,
    max_depth: AtomicUsize,
    target_max_depth: Option<usize>,
    finish_on_failure: bool,
    /// First discovery of each property: the fingerprint of the state it was found at.
    discoveries: Mutex<Vec<Option<u64>>>,
    found: Vec<AtomicBool>,
    done: AtomicBool,
    /// The current depth's blocks, and the next block to take.
    level: RwLock<Vec<Mutex<Stored>>>,
    cursor: AtomicUsize,
    /// The next depth's blocks, as threads finish them.
    next: Mutex<Vec<Stored>>,
    /// Whether the threads go on to the next depth after a pause (the leader says).
    advance: AtomicBool,
    /// Records per block made ([`BLOCK`], or fewer to spill small searches).
    block: usize,
    spill: Option<Arc<Store>>,
}

/// Stateright's breadth-first search over compact states (see the module doc).
pub struct CompactBfs<A, C, H>
where
    A: Actor,
    A::Msg: Ord,
    A::Timer: Ord,
    H: Clone + Debug + Hash,
{
    search: Arc<Search<A, C, H>>,
    handles: Vec<JoinHandle<()>>,
}

impl<A, C, H> Debug for CompactBfs<A, C, H>
where
    A: Actor,
    A::Msg: Ord,
    A::Timer: Ord,
    H: Clone + Debug + Hash,
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CompactBfs")
            .field("unique", &self.search.unique.load(Ordering::Relaxed))
            .finish_non_exhaustive()
    }
}

/// Whether [`CompactBfs`] can explore `model`: its network is not duplicating and its
/// properties are `always` or `sometimes` (an `eventually` needs per-path bits).
pub fn supports<A, C, H>(model: &ActorModel<A, C, H>) -> bool
where
    A: Actor,
    A::Msg: Ord,
    A::Timer: Ord,
    H: Clone + Debug + Hash,
{
    model
        .properties()
        .iter()
        .all(|p| p.expectation != Expectation::Eventually)
        && model
            .init_states()
            .iter()
            .all(|s| !matches!(s.network, Network::UnorderedDuplicating(..)))
}

impl<A, C, H> CompactBfs<A, C, H>
where
    A: Actor + Send + Sync + 'static,
    A::Msg: Ord + Send + Sync,
    A::Timer: Ord + Send + Sync,
    A::State: Eq + Send + Sync,
    A::Storage: Clone + Eq + Hash + Send + Sync,
    A::Random: Clone + Eq + Hash + Send + Sync,
    C: Send + Sync + 'static,
    H: Clone + Debug + Hash + PartialEq + Send + Sync + 'static,
{
    /// Starts the search on `threads` threads. States at depth `target_max_depth` and
    /// deeper are not checked (stateright's meaning; initial states are at depth 1). With
    /// `finish_on_failure`, the search ends at the first `always` counterexample. With
    /// `reductions.images`, one state of each symmetry class is explored. Once `closed` is set
    /// (a budget ran out, and the model's boundary takes no new state), the states held are
    /// still checked but no longer expanded: every successor would be outside. With
    /// `reductions.invisible`, a state is expanded by a persistent set of steps where one is
    /// proven ([`crate::reduction`]); it is ignored with a depth bound, which it would not
    /// respect. With `reductions.spent`, spent messages are forgotten.
    ///
    /// # Panics
    /// If `!supports(&model)`.
    pub fn spawn(
        model: ActorModel<A, C, H>,
        threads: usize,
        target_max_depth: Option<usize>,
        finish_on_failure: bool,
        reductions: Reductions<A, H>,
        closed: Option<Arc<AtomicBool>>,
    ) -> Self {
        let how = (threads, target_max_depth, finish_on_failure);
        Self::spawn_spilling(model, how, reductions, closed, None)
    }

    /// [`Self::spawn`] with `(threads, target_max_depth, finish_on_failure)` and, with
    /// `spill`, the visited set and the frontier going to disk when [`Store::look`] asks for
    /// it or [`Spill::after_states`] says ([`crate::spill`]); a spill that fails closes the
    /// boundary as a budget does.
    ///
    /// # Panics
    /// If `!supports(&model)`.
    pub fn spawn_spilling(
        model: ActorModel<A, C, H>,
        (threads, target_max_depth, finish_on_failure): (usize, Option<usize>, bool),
        reductions: Reductions<A, H>,
        closed: Option<Arc<AtomicBool>>,
        spill: Option<Spill>,
    ) -> Self {
        let Reductions {
            images,
            invisible: reduction,
            spent,
        } = reductions;
        assert!(supports(&model), "compact search: unsupported model");
        let init: Vec<_> = model
            .init_states()
            .into_iter()
            .filter(|s| Model::within_boundary(&model, s))
            .collect();
        let ordered = init
            .first()
            .is_some_and(|s| matches!(s.network, Network::Ordered(_)));
        let properties = model.properties().len();
        let search = Arc::new(Search {
            packer: Packer::new(model.actors.len(), ordered, spent),
            model: Arc::new(model),
            images,
            reduction: reduction.filter(|_| ordered && target_max_depth.is_none()),
            closed,
            visited: Visited::default(),
            unique: AtomicUsize::new(0),
            generated: AtomicUsize::new(init.len()),
            max_depth: AtomicUsize::new(0),
            target_max_depth,
            finish_on_failure,
            discoveries: Mutex::new(vec![None; properties]),
            found: (0..properties).map(|_| AtomicBool::new(false)).collect(),
            done: AtomicBool::new(false),
            level: RwLock::new(Vec::new()),
            cursor: AtomicUsize::new(0),
            next: Mutex::new(Vec::new()),
            advance: AtomicBool::new(false),
            // A spill waits for the blocks being expanded: they are a small part of what
            // memory holds between two spills.
            block: spill
                .as_ref()
                .and_then(|s| s.after_states)
                .map_or(BLOCK, |n| (n / 4).clamp(1, BLOCK)),
            spill: spill.map(|s| Arc::new(Store::new(s))),
        });
        let mut first = Block::default();
        let (mut rec, mut tmp) = (Vec::new(), Vec::new());
        for s in init {
            search
                .packer
                .pack_least(s, None, search.images.as_ref(), &mut rec, &mut tmp);
            let fp = fingerprint(&rec);
            let root = Seen {
                parent: fp,
                depth: 1,
            };
            if search.visited.insert(fp, root).is_none() {
                search.unique.fetch_add(1, Ordering::Relaxed);
                first.push(&rec);
            }
        }
        *search.level.write().expect("level lock") = vec![Mutex::new(Stored::Memory(first))];
        let threads = threads.max(1);
        let barrier = Arc::new(std::sync::Barrier::new(threads));
        let handles = (0..threads)
            .map(|t| {
                let search = Arc::clone(&search);
                let barrier = Arc::clone(&barrier);
                std::thread::Builder::new()
                    .name(format!("compact-bfs-{t}"))
                    .spawn(move || search.work(t == 0, &barrier))
                    .expect("spawn a checker thread")
            })
            .collect();
        Self { search, handles }
    }

    /// Whether the search reached `s` (with symmetry, a state of its class).
    pub fn reached(&self, s: &ActorModelState<A, H>) -> bool {
        let (mut rec, mut tmp) = (Vec::new(), Vec::new());
        let search = &self.search;
        search
            .packer
            .pack_least(s.clone(), None, search.images.as_ref(), &mut rec, &mut tmp);
        search.seen(fingerprint(&rec)).is_some()
    }

    /// The disk side of the search, when it may spill.
    pub fn spill(&self) -> Option<Arc<Store>> {
        self.search.spill.clone()
    }

    /// The tables' sizes: distinct histories, process parts and envelopes.
    pub fn parts(&self) -> (usize, usize, usize) {
        let p = &self.search.packer;
        (p.history.len(), p.procs.len(), p.envelopes.len())
    }
}

impl<A, C, H> Search<A, C, H>
where
    A: Actor,
    A::Msg: Ord,
    A::Timer: Ord,
    A::State: Eq,
    A::Storage: Clone + Eq + Hash,
    A::Random: Clone + Eq + Hash,
    H: Clone + Debug + Hash + PartialEq,
{
    /// Checks and expands every record of `block` (all at `depth`), adding new successors to
    /// `out` (handed over whenever it fills a block).
    fn expand_block(&self, block: &Block, depth: usize, out: &mut Block) {
        let model = &*self.model;
        let properties = model.properties();
        let mut actions = Vec::new();
        let (mut rec, mut tmp) = (Vec::new(), Vec::new());
        let mut slots = Vec::new();
        let mut arena = Vec::new();
        self.max_depth.fetch_max(depth, Ordering::Relaxed);
        if self.target_max_depth.is_some_and(|d| depth >= d) {
            return;
        }
        for parent in block.records() {
            if self.done.load(Ordering::Relaxed) {
                return;
            }
            let unpacked = self.packer.unpack(parent);
            let state = &unpacked.state;
            let fp = fingerprint(parent);
            let mut awaiting = false;
            for (i, p) in properties.iter().enumerate() {
                if self.found[i].load(Ordering::Relaxed) {
                    continue;
                }
                let holds = (p.condition)(model, state);
                let discovery = match p.expectation {
                    Expectation::Always => !holds,
                    Expectation::Sometimes => holds,
                    Expectation::Eventually => unreachable!("not supported"),
                };
                if discovery {
                    self.discover(i, fp, p.expectation == Expectation::Always);
                } else {
                    awaiting = true;
                }
            }
            if !awaiting {
                self.done.store(true, Ordering::Relaxed);
                return;
            }
            if self
                .closed
                .as_ref()
                .is_some_and(|c| c.load(Ordering::Relaxed))
            {
                continue;
            }
            model.actions(state, &mut actions);
            let sets = match &self.reduction {
                Some(_) if reduction::reducible(&actions) => {
                    let owners: Vec<Option<usize>> = actions.iter().map(reduction::owner).collect();
                    reduction::process_sets(state, &owners)
                }
                _ => Vec::new(),
            };
            if let (Some(invisible), false) = (&self.reduction, sets.is_empty()) {
                slots.clear();
                slots.resize(actions.len(), Slot::Unknown);
                arena.clear();
                let chosen = self.persistent(
                    invisible,
                    (parent, &unpacked),
                    (&actions, &sets),
                    depth,
                    (&mut slots, &mut arena),
                );
                for (i, action) in actions.iter().enumerate() {
                    if chosen.is_some_and(|mask| {
                        reduction::owner(action).is_none_or(|p| mask & (1 << p) == 0)
                    }) {
                        continue;
                    }
                    if let Slot::Unknown = slots[i] {
                        slots[i] = self.make(
                            (parent, &unpacked),
                            action,
                            None,
                            &mut arena,
                            (&mut rec, &mut tmp),
                        );
                    }
                    if let Slot::Packed {
                        at, len, fp: next, ..
                    } = slots[i]
                    {
                        self.admit(&arena[at..at + len], next, fp, depth, out);
                    }
                }
                actions.clear();
                continue;
            }
            for action in actions.drain(..) {
                let Some(next) = model.next_state(state, action) else {
                    continue;
                };
                if !Model::within_boundary(model, &next) {
                    continue;
                }
                self.packer.pack_least(
                    next,
                    Some((parent, &unpacked)),
                    self.images.as_ref(),
                    &mut rec,
                    &mut tmp,
                );
                let next_fp = fingerprint(&rec);
                self.admit(&rec, next_fp, fp, depth, out);
            }
        }
    }

    /// Counts the successor `rec` (fingerprint `fp`) of the state `parent` at `depth`, and
    /// adds it to `out` if it is new.
    fn admit(&self, rec: &[u32], fp: u64, parent: u64, depth: usize, out: &mut Block) {
        self.generated.fetch_add(1, Ordering::Relaxed);
        if let Entry::Vacant(e) = self.visited.entry(fp) {
            e.insert(Seen {
                parent,
                depth: u32::try_from(depth + 1).expect("a depth fits in u32"),
            });
            self.unique.fetch_add(1, Ordering::Relaxed);
            out.push(rec);
            if out.count >= self.block {
                let full = std::mem::take(out);
                self.next
                    .lock()
                    .expect("next lock")
                    .push(Stored::Memory(full));
            }
        }
    }

    /// The successor of `parent` by `action`, packed at the end of `arena`, and (with
    /// `invisible`) whether the step may undo a discovery.
    fn make(
        &self,
        (rec, parent): (&[u32], &Unpacked<A, H>),
        action: &ModelAction<A, C, H>,
        invisible: Option<&Invisible<A, H>>,
        arena: &mut Vec<u32>,
        (packed, tmp): (&mut Vec<u32>, &mut Vec<u32>),
    ) -> Slot {
        let model = &*self.model;
        let Some(next) = model.next_state(&parent.state, action.clone()) else {
            return Slot::Gone;
        };
        if !Model::within_boundary(model, &next) {
            return Slot::Gone;
        }
        let visible = match (invisible, reduction::owner(action)) {
            (Some(f), Some(p)) => !f(&parent.state, p, &next),
            _ => true,
        };
        self.packer
            .pack_least(next, Some((rec, parent)), self.images.as_ref(), packed, tmp);
        let fp = fingerprint(packed);
        let at = arena.len();
        arena.extend_from_slice(packed);
        Slot::Packed {
            at,
            len: packed.len(),
            fp,
            visible,
        }
    }

    /// The first of `sets` (processes as bit masks, persistent at `parent`, at `depth`)
    /// that passes the other conditions of [`crate::reduction`]: it holds a step, none that
    /// may undo a discovery, and none leading to a state seen at `depth` or before (the cycle
    /// proviso). The successors made on the way are kept in `slots`.
    fn persistent(
        &self,
        invisible: &Invisible<A, H>,
        parent: (&[u32], &Unpacked<A, H>),
        (actions, sets): (&[ModelAction<A, C, H>], &[u64]),
        depth: usize,
        (slots, arena): (&mut [Slot], &mut Vec<u32>),
    ) -> Option<u64> {
        let (mut rec, mut tmp) = (Vec::new(), Vec::new());
        'sets: for &mask in sets {
            let mut any = false;
            for (i, action) in actions.iter().enumerate() {
                if reduction::owner(action).is_none_or(|p| mask & (1 << p) == 0) {
                    continue;
                }
                if let Slot::Unknown = slots[i] {
                    slots[i] =
                        self.make(parent, action, Some(invisible), arena, (&mut rec, &mut tmp));
                }
                if let Slot::Packed { fp, visible, .. } = slots[i] {
                    if visible || self.seen_by(fp, depth) {
                        continue 'sets;
                    }
                    any = true;
                }
            }
            if any {
                return Some(mask);
            }
        }
        None
    }

    /// Records the first discovery of property `i`.
    fn discover(&self, i: usize, fp: u64, failure: bool) {
        let mut d = self.discoveries.lock().expect("discoveries lock");
        if d[i].is_none() {
            d[i] = Some(fp);
            self.found[i].store(true, Ordering::Relaxed);
            if failure && self.finish_on_failure {
                self.done.store(true, Ordering::Relaxed);
            }
        }
    }

    /// The path to the state with fingerprint `fp`: the parents' fingerprints back to an
    /// initial state, then the model replayed forward, choosing at each step the action whose
    /// successor has the next fingerprint.
    fn path(&self, fp: u64) -> Option<ModelPath<A, C, H>> {
        let mut fps = VecDeque::from([fp]);
        loop {
            let seen = self.seen(*fps.front()?)?;
            if seen.depth <= 1 {
                break;
            }
            fps.push_front(seen.parent);
        }
        let model = &*self.model;
        let (mut rec, mut tmp) = (Vec::new(), Vec::new());
        let images = self.images.as_ref();
        let root = fps.pop_front()?;
        let init = model.init_states().into_iter().find(|s| {
            self.packer
                .pack_least(s.clone(), None, images, &mut rec, &mut tmp);
            fingerprint(&rec) == root
        })?;
        let mut state = init.clone();
        let mut actions = Vec::new();
        for want in fps {
            let mut candidates = Vec::new();
            model.actions(&state, &mut candidates);
            let (action, next) = candidates.into_iter().find_map(|a| {
                let next = model.next_state(&state, a.clone())?;
                self.packer
                    .pack_least(next.clone(), None, images, &mut rec, &mut tmp);
                (fingerprint(&rec) == want).then_some((a, next))
            })?;
            actions.push(action);
            state = next;
        }
        Path::from_actions(model, init, &actions)
    }
}

impl<A, C, H> Checker<ActorModel<A, C, H>> for CompactBfs<A, C, H>
where
    A: Actor,
    A::Msg: Ord,
    A::Timer: Ord,
    A::State: Eq,
    A::Storage: Clone + Eq + Hash,
    A::Random: Clone + Eq + Hash,
    H: Clone + Debug + Hash + PartialEq,
{
    fn model(&self) -> &ActorModel<A, C, H> {
        &self.search.model
    }

    fn state_count(&self) -> usize {
        self.search.generated.load(Ordering::Relaxed)
    }

    fn unique_state_count(&self) -> usize {
        self.search.unique.load(Ordering::Relaxed)
    }

    fn max_depth(&self) -> usize {
        self.search.max_depth.load(Ordering::Relaxed)
    }

    fn discoveries(&self) -> HashMap<&'static str, ModelPath<A, C, H>> {
        let found = self
            .search
            .discoveries
            .lock()
            .expect("discoveries lock")
            .clone();
        let properties = self.search.model.properties();
        found
            .into_iter()
            .enumerate()
            .filter_map(|(i, fp)| Some((properties[i].name, self.search.path(fp?)?)))
            .collect()
    }

    fn handles(&mut self) -> Vec<JoinHandle<()>> {
        std::mem::take(&mut self.handles)
    }

    fn is_done(&self) -> bool {
        // A thread ends only once the search is done, or when it panicked (then `join`
        // passes the panic on instead of the caller waiting for ever).
        self.search.done.load(Ordering::Relaxed) || self.handles.iter().any(|h| h.is_finished())
    }
}
