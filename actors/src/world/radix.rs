//! The order of pending events (seed 4.2.3, the event manager's queue): a monotone radix queue
//! of `(time, cause, index)` keys.
//!
//! A discrete-event run never schedules into its past: every new event is at or after the
//! event being handled. Such a *monotone* queue can be a radix heap instead of a binary heap
//! (Ahuja, Mehlhorn, Orlin and Tarjan, 1990): entries live in buckets by the highest digit
//! in which their time differs from the time `last` of the events being taken now, and by
//! that digit's value, and a bucket is only sorted out when every earlier one is empty.
//! Pushing is an append; taking the next entry is a pop from the front of the current
//! instant's run; each entry moves down a few buckets in its life, by sequential copies.
//! Digits are of four bits (sixteen values), so an entry moves down about a quarter as many
//! times as with one bucket per bit (with binary digits, redistributing buckets would be a
//! noticeable share of a 1k-robot run's instructions). Its cost does not grow with the
//! number of pending events as a binary heap's does (at a million robots, five million
//! pending events: 22 levels of cache misses per pop).
//!
//! Ties at one instant are taken in `(cause, index)` order (the ordering contract, docs/
//! architecture.md). A handling's new events all have a larger causal key than any pending
//! event (their cause is the processing number being handled now), so an event for the
//! current instant joins the end of its run; the entries a bucket hands to a new instant are
//! sorted once.
//!
//! A bucket of a few entries is not sorted out digit by digit: its entries are sorted at once
//! into the run of entries taken next, which then spans several instants, up to the bucket's
//! largest key (`limit`), and an entry pushed at or before that key is put in its place in
//! the run. At a thousand robots nearly every event taken empties the run and the first
//! bucket holds a handful of entries: moving each down a bucket at a time would make sorting
//! out buckets a noticeable share of a run's instructions.

use std::collections::VecDeque;

/// An event's place in the order: time (as [`time_key`]), then cause, then index; `slot`
/// says where the owner keeps the event (it never decides the order: the first three are
/// unique). 24 bytes, as without it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Entry {
    pub key: u64,
    pub cause: u64,
    pub index: u32,
    pub slot: u32,
}

/// `t` as an integer whose unsigned order is `f64::total_cmp`'s.
pub fn time_key(t: f64) -> u64 {
    let bits = t.to_bits();
    if bits >> 63 == 1 {
        !bits
    } else {
        bits | 1 << 63
    }
}

/// The time of a key made by [`time_key`].
pub fn key_time(key: u64) -> f64 {
    f64::from_bits(if key >> 63 == 1 {
        key & !(1 << 63)
    } else {
        !key
    })
}

/// Above this capacity the current instant's emptied deque is given back rather than kept for
/// reuse, so the burst of a large run's first instant does not stay allocated for the rest of
/// it.
const KEEP: usize = 1 << 16;

/// Entries in a block of a bucket (24 KB).
const BLOCK: usize = 1 << 10;

/// How many entries ahead [`RadixQueue::retain`] shows the owner the entry it will ask about.
const AHEAD: usize = 16;

/// Bits of a digit of the keys.
const DIGIT_BITS: u32 = 4;
/// Values of a digit.
const DIGITS: usize = 1 << DIGIT_BITS;
/// Buckets: one per digit place and value (16 x 16). Their order is the keys' order.
const BUCKETS: usize = 64 / DIGIT_BITS as usize * DIGITS;

/// A bucket of at most this many entries is sorted into the run at once ([`RadixQueue::refill`]).
const SMALL: usize = 32;

/// The bucket of `key` (after `last`): the place of the highest digit in which the two
/// differ, then `key`'s value there.
fn bucket_of(key: u64, last: u64) -> usize {
    let high = 63 - (key ^ last).leading_zeros();
    let place = high / DIGIT_BITS;
    let digit = (key >> (place * DIGIT_BITS)) as usize & (DIGITS - 1);
    place as usize * DIGITS + digit
}

/// A bucket: its entries in blocks of [`BLOCK`] entries, the last one possibly partly filled.
/// Blocks come from and go back to the queue's pool, so that sorting a bucket out into the
/// lower ones reuses the memory it frees as it goes. With one growing vector per bucket, the
/// copies of reallocation and the first touch of the new memory (a page fault each 2 MB on
/// this machine) would keep the kernel clearing pages throughout a million-robot run's
/// steady state.
type Bucket = Vec<Vec<Entry>>;

/// The radix queue. Entries that the owner no longer wants (cancelled events) stay until they
/// come up and are skipped there, or until the owner drops them ([`RadixQueue::retain`]).
#[derive(Debug)]
pub struct RadixQueue {
    /// The key from which the buckets' digits are counted ([`bucket_of`]); every entry in
    /// `buckets` is after it.
    last: u64,
    /// The largest key that goes to `now` rather than to a bucket (at least `last`; larger
    /// when a small bucket was sorted into `now` at once): every entry in `buckets` is after
    /// it.
    limit: u64,
    /// Entries at `limit` or before, in order: the front is next.
    now: VecDeque<Entry>,
    /// `buckets[i]`: entries whose key is in bucket `i` ([`bucket_of`]).
    buckets: Vec<Bucket>,
    /// Which buckets hold entries, a bit each.
    full: [u64; BUCKETS / 64],
    /// Empty blocks (capacity [`BLOCK`]) for any bucket.
    pool: Vec<Vec<Entry>>,
    len: usize,
}

impl Default for RadixQueue {
    fn default() -> Self {
        Self {
            last: time_key(0.0),
            limit: time_key(0.0),
            now: VecDeque::new(),
            buckets: (0..BUCKETS).map(|_| Vec::new()).collect(),
            full: [0; BUCKETS / 64],
            pool: Vec::new(),
            len: 0,
        }
    }
}

/// Appends `e` to `bucket`, opening a block from `pool` when the last one is full.
fn append(bucket: &mut Bucket, pool: &mut Vec<Vec<Entry>>, e: Entry) {
    match bucket.last_mut() {
        Some(block) if block.len() < BLOCK => block.push(e),
        _ => {
            let mut block = pool.pop().unwrap_or_else(|| Vec::with_capacity(BLOCK));
            block.push(e);
            bucket.push(block);
        }
    }
}

/// Moves the entries of `blocks` that `keep` accepts to the front, in order, and returns how
/// many there are; the rest of the entries are left as they were. Every block but the last
/// holds `width` entries, and the kept ones close up behind the reading. `ahead` is shown each entry [`AHEAD`] entries before
/// `keep` is asked about it ([`RadixQueue::retain`]).
fn close_up<B: AsMut<[Entry]>>(
    blocks: &mut [B],
    width: usize,
    ahead: &mut impl FnMut(&Entry),
    keep: &mut impl FnMut(&Entry) -> bool,
) -> usize {
    let n: usize = blocks.iter_mut().map(|b| b.as_mut().len()).sum();
    // Cursors (block, entry): the entry read, the place of the next one kept, the entry shown.
    let next = |(b, i): (usize, usize)| {
        if i + 1 == width {
            (b + 1, 0)
        } else {
            (b, i + 1)
        }
    };
    let (mut read, mut write, mut shown) = ((0, 0), (0, 0), (0, 0));
    for _ in 0..AHEAD.min(n) {
        shown = next(shown);
    }
    let mut kept = 0;
    for r in 0..n {
        if r + AHEAD < n {
            ahead(&blocks[shown.0].as_mut()[shown.1]);
            shown = next(shown);
        }
        let e = blocks[read.0].as_mut()[read.1];
        read = next(read);
        if keep(&e) {
            blocks[write.0].as_mut()[write.1] = e;
            write = next(write);
            kept += 1;
        }
    }
    kept
}

impl RadixQueue {
    /// Entries held, skipped ones included.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no entry is held.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Adds an entry.
    pub fn push(&mut self, e: Entry) {
        self.len += 1;
        if e.key > self.limit {
            // After every entry of `now`, and in a bucket no lower than the first full one
            // when `now` was filled (the buckets' order is the keys' order).
            self.append(bucket_of(e.key, self.last), e);
        } else if self.now.back().is_none_or(|b| *b < e) {
            self.now.push_back(e);
        } else {
            // Not after the run's end: an event between two instants of a run filled from a
            // small bucket, or one scheduled before the current instant (which the scheduler
            // forbids) or out of causal order.
            let at = self.now.partition_point(|x| x < &e);
            self.now.insert(at, e);
        }
    }

    /// Puts back the entry just taken (it is before every other).
    pub fn push_front(&mut self, e: Entry) {
        self.len += 1;
        self.now.push_front(e);
    }

    /// The next entry, without taking it.
    pub fn peek(&mut self) -> Option<&Entry> {
        if self.now.is_empty() {
            self.refill();
        }
        self.now.front()
    }

    /// The entry `n` places after the next one (0: the next), without taking any. When the
    /// current instant has too few entries this moves on to the following instants early:
    /// their entries join the run behind the current one, which stays first (an entry pushed
    /// later between two instants is put in its place in the run), so the order taken is the
    /// same.
    pub fn peek_nth(&mut self, n: usize) -> Option<&Entry> {
        while self.now.len() <= n && self.first_full().is_some() {
            self.refill();
        }
        self.now.get(n)
    }

    /// Takes the next entry.
    pub fn pop(&mut self) -> Option<Entry> {
        if self.now.is_empty() {
            self.refill();
        }
        let e = self.now.pop_front()?;
        self.len -= 1;
        Some(e)
    }

    /// Moves on to the next instant: the first non-empty bucket's smallest key becomes
    /// `last`, and its entries move to `now` (those at `last`, sorted, behind any entries
    /// still there, which are before them) or to lower buckets. A bucket of at most [`SMALL`]
    /// entries moves to `now` whole, sorted, and its largest key becomes `limit`.
    fn refill(&mut self) {
        if self.now.is_empty() && self.now.capacity() > KEEP {
            self.now = VecDeque::new();
        }
        let Some(i) = self.first_full() else {
            return;
        };
        self.full[i / 64] &= !(1 << (i % 64));
        let kept = self.now.len();
        let mut bucket = std::mem::take(&mut self.buckets[i]);
        if let [block] = bucket.as_mut_slice() {
            if block.len() <= SMALL {
                // Every later bucket holds keys above all of these, and stays right for any
                // `last` in this bucket's range: the smallest, as below.
                self.now.extend(block.drain(..));
                let (_, run) = self.now.make_contiguous().split_at_mut(kept);
                run.sort_unstable();
                self.last = run[0].key;
                self.limit = run[run.len() - 1].key;
                self.pool.append(&mut bucket);
                self.buckets[i] = bucket;
                return;
            }
        }
        self.last = bucket
            .iter()
            .flatten()
            .map(|e| e.key)
            .min()
            .expect("non-empty bucket");
        self.limit = self.last;
        for mut block in bucket.drain(..) {
            for e in block.drain(..) {
                if e.key == self.last {
                    self.now.push_back(e);
                } else {
                    let b = bucket_of(e.key, self.last);
                    debug_assert!(b < i, "an entry moved up");
                    self.append(b, e);
                }
            }
            self.pool.push(block);
        }
        let (_, run) = self.now.make_contiguous().split_at_mut(kept);
        run.sort_unstable();
        // The emptied list of blocks is kept for the bucket's next entries.
        self.buckets[i] = bucket;
    }

    /// Drops the entries that `keep` refuses and keeps the others in their order. `ahead` is
    /// shown each entry [`AHEAD`] entries before `keep` is asked about it, so that the owner
    /// can ask for the memory `keep` will read (at a million robots each look-up is a cache
    /// miss of its own, and a few dozen of them can be under way at once). A bucket's kept
    /// entries close up into its first blocks; the blocks emptied go to the pool.
    pub fn retain(&mut self, mut ahead: impl FnMut(&Entry), mut keep: impl FnMut(&Entry) -> bool) {
        let now = self.now.make_contiguous();
        let width = now.len().max(1);
        let kept = close_up(&mut [now], width, &mut ahead, &mut keep);
        self.now.truncate(kept);
        let mut len = kept;
        for b in 0..BUCKETS {
            if self.full[b / 64] & (1 << (b % 64)) == 0 {
                continue;
            }
            let bucket = &mut self.buckets[b];
            // Every block but the last is full ([`append`]).
            debug_assert!(bucket.iter().rev().skip(1).all(|x| x.len() == BLOCK));
            let kept = close_up(bucket, BLOCK, &mut ahead, &mut keep);
            let blocks = kept.div_ceil(BLOCK);
            for mut block in bucket.drain(blocks..) {
                block.clear();
                self.pool.push(block);
            }
            if let Some(last) = bucket.last_mut() {
                last.truncate(kept - (blocks - 1) * BLOCK);
            } else {
                self.full[b / 64] &= !(1 << (b % 64));
            }
            len += kept;
        }
        self.len = len;
    }

    /// Appends `e` to bucket `b`.
    fn append(&mut self, b: usize, e: Entry) {
        self.full[b / 64] |= 1 << (b % 64);
        append(&mut self.buckets[b], &mut self.pool, e);
    }

    /// The first bucket that holds entries.
    fn first_full(&self) -> Option<usize> {
        let (w, bits) = self.full.iter().enumerate().find(|(_, &b)| b != 0)?;
        Some(w * 64 + bits.trailing_zeros() as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::BTreeSet;

    #[test]
    fn time_keys_order_as_total_cmp() {
        let times = [
            f64::NEG_INFINITY,
            -3.5,
            -1e-300,
            -0.0,
            0.0,
            1e-300,
            0.1,
            1.0,
            1.0 + f64::EPSILON,
            7e9,
            f64::INFINITY,
        ];
        for a in times {
            assert_eq!(key_time(time_key(a)).to_bits(), a.to_bits());
            for b in times {
                assert_eq!(time_key(a).cmp(&time_key(b)), a.total_cmp(&b), "{a} {b}");
            }
        }
    }

    #[derive(Clone, Debug)]
    enum Op {
        /// An entry this far after the last key taken (0: the current instant).
        Push(u8, u32),
        Pop,
        Peek,
        /// The entry this many places after the next.
        PeekNth(u8),
        /// Drop the entries whose index is a multiple of this (plus 2).
        Retain(u8),
    }

    fn ops() -> impl Strategy<Value = Vec<Op>> {
        prop::collection::vec(
            prop_oneof![
                3 => (0u8..6, 0u32..1000).prop_map(|(k, d)| Op::Push(k, d)),
                2 => Just(Op::Pop),
                1 => Just(Op::Peek),
                2 => (0u8..4).prop_map(Op::PeekNth),
                1 => (0u8..4).prop_map(Op::Retain),
            ],
            0..400,
        )
    }

    proptest! {
        /// Against a sorted set: every pop is the set's least element, and a look at the entry
        /// `n` places after the next the set's element there, for monotone pushes at the current instant (in causal order),
        /// just after it and far ahead.
        #[test]
        fn pops_in_key_order(ops in ops()) {
            let mut q = RadixQueue::default();
            let mut oracle = BTreeSet::new();
            let mut now = 0.0f64;
            let mut cause = 0u64;
            for op in ops {
                match op {
                    Op::Push(kind, d) => {
                        cause += 1;
                        let t = match kind {
                            0 => now,
                            1 => now + f64::from(d) * 1e-9,
                            2 => now + f64::from(d) * 1e-3,
                            3 => now + f64::from(d),
                            4 => now + f64::from(d) * 1e6,
                            _ => (now * 8.0).ceil() / 8.0 + 0.125,
                        };
                        // Future instants also get entries out of causal order (which the
                        // engine does not make, but the queue must still order).
                        let c = if kind == 5 { u64::from(d) } else { cause };
                        let e = Entry { key: time_key(t), cause: c, index: cause as u32, slot: cause as u32 ^ 0x5555 };
                        q.push(e);
                        oracle.insert(e);
                    }
                    Op::Peek => {
                        let got = q.peek().copied();
                        prop_assert_eq!(got.as_ref(), oracle.first());
                    }
                    Op::PeekNth(n) => {
                        let got = q.peek_nth(usize::from(n)).copied();
                        prop_assert_eq!(got.as_ref(), oracle.iter().nth(usize::from(n)));
                    }
                    Op::Retain(m) => {
                        let drop = |e: &Entry| e.index % (u32::from(m) + 2) == 0;
                        q.retain(|_| (), |e| !drop(e));
                        oracle.retain(|e| !drop(e));
                    }
                    Op::Pop => {
                        let got = q.pop();
                        prop_assert_eq!(got, oracle.pop_first());
                        if let Some(e) = got {
                            now = key_time(e.key);
                        }
                    }
                }
                prop_assert_eq!(q.len(), oracle.len());
            }
            while let Some(e) = oracle.pop_first() {
                prop_assert_eq!(q.pop(), Some(e));
            }
            prop_assert!(q.pop().is_none());
        }
    }

    /// Buckets of many blocks: 200,000 entries over many instants, pushed while the queue is
    /// being emptied (blocks freed by one bucket's sort refill others), against a sorted set.
    #[test]
    fn many_blocks_pop_in_key_order() {
        let mut q = RadixQueue::default();
        let mut oracle = BTreeSet::new();
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut rand = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let mut now = 0.0f64;
        for cause in 0..200_000u64 {
            let t = now + (rand() % 100_000) as f64 * 1e-3;
            let e = Entry {
                key: time_key(t),
                cause,
                index: 0,
                slot: cause as u32,
            };
            q.push(e);
            oracle.insert(e);
            if rand() % 5 == 0 {
                // Looking ahead moves on to the next instants early.
                let n = (rand() % 4) as usize;
                let got = q.peek_nth(n).copied();
                assert_eq!(got.as_ref(), oracle.iter().nth(n));
            }
            if cause % 50_000 == 49_999 {
                // Drop a third, with what is shown ahead and asked about logged: each entry
                // shown is asked about after exactly AHEAD others are; only the first few of
                // each bucket (and of the current run) are not shown.
                let log = std::cell::RefCell::new(Vec::new());
                let drop = |e: &Entry| e.cause % 3 == 0;
                q.retain(
                    |e| log.borrow_mut().push((true, *e)),
                    |e| {
                        log.borrow_mut().push((false, *e));
                        !drop(e)
                    },
                );
                oracle.retain(|e| !drop(e));
                let log = log.into_inner();
                let asks: Vec<Entry> = log.iter().filter(|x| !x.0).map(|x| x.1).collect();
                let (mut shown, mut asked_before) = (0, 0);
                for (was_shown, e) in &log {
                    if *was_shown {
                        shown += 1;
                        assert_eq!(asks.get(asked_before + AHEAD), Some(e));
                    } else {
                        asked_before += 1;
                    }
                }
                assert!(asks.len() - shown <= AHEAD * (BUCKETS + 1));
                assert!(shown > 0);
                for bucket in &q.buckets {
                    assert!(bucket.iter().all(|b| !b.is_empty()));
                    assert!(bucket.iter().rev().skip(1).all(|b| b.len() == BLOCK));
                }
                assert_eq!(q.len(), oracle.len());
                assert_eq!(
                    q.buckets.iter().flatten().map(Vec::len).sum::<usize>() + q.now.len(),
                    oracle.len()
                );
            }
            if rand() % 3 == 0 {
                let got = q.pop();
                assert_eq!(got, oracle.pop_first());
                now = key_time(got.expect("an entry").key);
            }
        }
        assert!(q.pool.len() + q.buckets.iter().map(Vec::len).sum::<usize>() > 64);
        while let Some(e) = oracle.pop_first() {
            assert_eq!(q.pop(), Some(e));
        }
        assert!(q.pop().is_none());
    }

    #[test]
    fn a_million_entries_at_one_instant_keep_their_causal_order() {
        let mut q = RadixQueue::default();
        for cause in 0..1_000_000u64 {
            q.push(Entry {
                key: time_key(0.0),
                cause,
                index: 0,
                slot: 0,
            });
        }
        for cause in 0..1_000_000u64 {
            assert_eq!(q.pop().map(|e| e.cause), Some(cause));
        }
    }
}
