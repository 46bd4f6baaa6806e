//! The levels of the compact search: the frontier's blocks of records, each in memory or
//! spilled to disk, the threads' loop over a level's blocks, and what the leader does while
//! the others wait, between two levels or for a spill ([`crate::spill`]): the states a level
//! entered are checked against the spilled visited set (delayed duplicate detection) before
//! any of them is expanded, and then memory is emptied to disk.

use std::fmt::Debug;
use std::hash::Hash;
use std::sync::atomic::Ordering;
use std::sync::Mutex;

use stateright::actor::Actor;

use super::{fingerprint, Search, Seen};
use crate::spill::{self, Failure, Store};

/// A block of frontier records: `[len, words..]` each, all of one depth.
#[derive(Default)]
pub(super) struct Block {
    pub(super) words: Vec<u32>,
    pub(super) count: usize,
    /// None of its records is a state the spilled visited set holds ([`crate::spill`]).
    confirmed: bool,
}

impl Block {
    /// The block of `words` as [`Block::records`] reads them.
    fn of_words(words: Vec<u32>, count: usize) -> Self {
        Self {
            words,
            count,
            confirmed: true,
        }
    }

    /// Keeps the records `keep` says, in order.
    fn retain(&mut self, mut keep: impl FnMut(&[u32]) -> bool) {
        let mut kept = Block::default();
        for rec in self.records() {
            if keep(rec) {
                kept.push(rec);
            }
        }
        *self = kept;
    }

    pub(super) fn push(&mut self, rec: &[u32]) {
        self.words
            .push(u32::try_from(rec.len()).expect("a record fits in u32 words"));
        self.words.extend_from_slice(rec);
        self.count += 1;
    }

    pub(super) fn records(&self) -> impl Iterator<Item = &[u32]> {
        let mut at = 0;
        std::iter::from_fn(move || {
            let len = *self.words.get(at)? as usize;
            let rec = &self.words[at + 1..at + 1 + len];
            at += 1 + len;
            Some(rec)
        })
    }
}

/// A block of the frontier where it is kept.
pub(super) enum Stored {
    Memory(Block),
    /// In the level's spill file ([`Store::write_block`]).
    Disk {
        at: u64,
        len: u32,
        count: usize,
    },
    /// Expanded, and let go.
    Spent,
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
    /// One thread's loop: take blocks of the current depth until none is left (or a spill is
    /// wanted), wait for the others, and (the leader) swap in the next depth or spill.
    pub(super) fn work(&self, leader: bool, barrier: &std::sync::Barrier) {
        let mut depth = 1;
        loop {
            {
                let level = self.level.read().expect("level lock");
                let mut out = Block::default();
                loop {
                    if self.done.load(Ordering::Relaxed) || self.spill_wanted() {
                        break;
                    }
                    let i = self.cursor.fetch_add(1, Ordering::Relaxed);
                    let Some(slot) = level.get(i) else { break };
                    // The block is this thread's alone, and let go once expanded.
                    let taken =
                        std::mem::replace(&mut *slot.lock().expect("slot lock"), Stored::Spent);
                    match taken {
                        Stored::Memory(block) => self.expand_block(&block, depth, &mut out),
                        Stored::Disk { at, len, count } => {
                            let Some(block) = self.read_block(depth, at, len, count) else {
                                break;
                            };
                            self.expand_block(&block, depth, &mut out);
                        }
                        Stored::Spent => unreachable!("a block is taken once"),
                    }
                }
                if out.count > 0 {
                    self.next
                        .lock()
                        .expect("next lock")
                        .push(Stored::Memory(out));
                }
            }
            barrier.wait();
            if leader {
                self.pause(depth);
            }
            barrier.wait();
            if self.done.load(Ordering::Relaxed) {
                return;
            }
            if self.advance.load(Ordering::Relaxed) {
                depth += 1;
            }
        }
    }

    /// Whether the threads should pause for a spill: the store wants one, or the visited set
    /// is about to double its table and both tables would pass the line where the memory
    /// budget asks for a spill.
    fn spill_wanted(&self) -> bool {
        let Some(store) = self.spill.as_deref() else {
            return false;
        };
        if store.wanted(|| self.visited.len()) {
            return true;
        }
        let (len, room) = (self.visited.len(), self.visited.capacity());
        // A table of `room` states has about `room * 8 / 7` slots of a state and a byte.
        let slot = std::mem::size_of::<(u64, Seen)>() as u64 + 1;
        let table = room as u64 * 8 / 7 * slot;
        len > 0 && len >= room - room / 16 && !store.fits(2 * table)
    }

    /// The leader's work while the other threads wait, at `depth`: checks the states the
    /// level entered against the spilled visited set, spills if wanted, and, once the level
    /// is expanded, swaps in the next one.
    fn pause(&self, depth: usize) {
        let mut level = self.level.write().expect("level lock");
        let mut next = self.next.lock().expect("next lock");
        let taken = self.cursor.load(Ordering::Relaxed).min(level.len());
        let expanded = taken == level.len();
        if let Some(store) = self.spill.as_deref() {
            // Also when the search ends: its unique states are then counted exactly.
            self.confirm(store, depth, &mut next);
            if !self.done.load(Ordering::Relaxed) && self.spill_wanted() {
                let rest = level[taken..]
                    .iter_mut()
                    .map(|slot| slot.get_mut().expect("slot lock"));
                if let Err(why) = self.spill_out(store, depth, rest, &mut next) {
                    store.fail(why);
                    self.close();
                }
            }
        }
        if expanded {
            let next = std::mem::take(&mut *next);
            if next.is_empty() {
                self.done.store(true, Ordering::Relaxed);
            }
            *level = next.into_iter().map(Mutex::new).collect();
            self.cursor.store(0, Ordering::Relaxed);
            if let Some(store) = &self.spill {
                store.end_level(depth);
            }
        }
        self.advance.store(expanded, Ordering::Relaxed);
    }

    /// Removes from the visited set and from `next` the states the level at `depth` entered
    /// that the spilled visited set holds: they were reached before (delayed duplicate
    /// detection, [`crate::spill`]).
    fn confirm(&self, store: &Store, depth: usize, next: &mut Vec<Stored>) {
        if !store.has_run() {
            return;
        }
        let entered = u32::try_from(depth + 1).expect("a depth fits in u32");
        let mut fps: Vec<u64> = self
            .visited
            .iter()
            .filter(|e| e.depth == entered && store.may_hold(*e.key()))
            .map(|e| *e.key())
            .collect();
        fps.sort_unstable();
        let again = match store.held(&fps) {
            Ok(again) => again,
            Err(e) => {
                // What the level entered cannot be told new: the search cannot go on exactly.
                store.fail(Failure::Io(e));
                self.done.store(true, Ordering::Relaxed);
                return;
            }
        };
        for fp in &again {
            self.visited.remove(fp);
        }
        self.unique.fetch_sub(again.len(), Ordering::Relaxed);
        for stored in next.iter_mut() {
            if let Stored::Memory(b) = stored {
                if !b.confirmed {
                    if !again.is_empty() {
                        b.retain(|rec| again.binary_search(&fingerprint(rec)).is_err());
                    }
                    b.confirmed = true;
                }
            }
        }
        next.retain(|s| !matches!(s, Stored::Memory(b) if b.count == 0));
    }

    /// Moves the visited set and the blocks in memory (`rest` of the level at `depth`, not
    /// expanded yet, and `next`) to disk. What is not moved stays in memory.
    fn spill_out<'a>(
        &self,
        store: &Store,
        depth: usize,
        rest: impl Iterator<Item = &'a mut Stored>,
        next: &'a mut [Stored],
    ) -> Result<(), Failure> {
        store.merge(self.visited.len(), |s, out| {
            let of_slice = self
                .visited
                .iter()
                .filter(|e| spill::slice_of(*e.key()) == s);
            out.extend(of_slice.map(|e| (*e.key(), e.parent, e.depth)));
        })?;
        // The visited set keeps its room, which it fills again: growing again would take
        // its old and new tables at once.
        self.visited.clear();
        let blocks = rest
            .map(|b| (depth, b))
            .chain(next.iter_mut().map(|b| (depth + 1, b)));
        for (d, stored) in blocks {
            if let Stored::Memory(b) = stored {
                let (at, len) = store.write_block(d, &b.words, b.count)?;
                *stored = Stored::Disk {
                    at,
                    len,
                    count: b.count,
                };
            }
        }
        store.spilled();
        Ok(())
    }

    /// A spilled block of the level at `depth`; `None` if it cannot be read, and then the
    /// search ends.
    fn read_block(&self, depth: usize, at: u64, len: u32, count: usize) -> Option<Block> {
        let store = self.spill.as_deref().expect("spilled blocks have a store");
        match store.read_block(depth, at, len) {
            Ok(words) => Some(Block::of_words(words, count)),
            Err(e) => {
                store.fail(Failure::Io(e));
                self.done.store(true, Ordering::Relaxed);
                None
            }
        }
    }

    /// Closes the model's boundary, as a budget does; without one, ends the search.
    fn close(&self) {
        match &self.closed {
            Some(c) => c.store(true, Ordering::Relaxed),
            None => self.done.store(true, Ordering::Relaxed),
        }
    }

    /// How the state with fingerprint `fp` was first reached, in memory or on disk.
    pub(super) fn seen(&self, fp: u64) -> Option<Seen> {
        if let Some(s) = self.visited.get(&fp) {
            return Some(*s);
        }
        let store = self.spill.as_deref().filter(|s| s.has_run())?;
        let (parent, depth) = store
            .get(fp)
            .expect("the spilled visited set is readable")?;
        Some(Seen { parent, depth })
    }

    /// Whether the state with fingerprint `fp` was reached at `depth` or before.
    pub(super) fn seen_by(&self, fp: u64, depth: usize) -> bool {
        if self
            .visited
            .get(&fp)
            .is_some_and(|s| s.depth as usize <= depth)
        {
            return true;
        }
        // Memory may hold a state this level entered that the disk holds from before.
        match self.spill.as_deref().filter(|s| s.has_run()) {
            None => false,
            Some(store) => match store.get(fp) {
                Ok(seen) => seen.is_some_and(|(_, d)| d as usize <= depth),
                Err(e) => {
                    store.fail(Failure::Io(e));
                    self.done.store(true, Ordering::Relaxed);
                    true
                }
            },
        }
    }
}
