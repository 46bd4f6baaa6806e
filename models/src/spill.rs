//! Spilling a breadth-first search to disk, so that a search whose visited set and frontier
//! outgrow the memory budget goes on instead of stopping.
//!
//! The method is Stern and Dill's disk-based breadth-first search (Murphi), on the compact
//! search of [`crate::compact`]. When the process's resident memory nears its budget
//! ([`SPILL_HEADROOM`]), when the visited set's table would double past the budget, or when
//! the visited set holds [`Spill::after_states`] states, the search pauses between two blocks
//! and empties its memory into a directory of its own:
//!
//! - the visited set joins the **run**: every fingerprint moved out of memory so far, with
//!   its parent's and its depth, sorted by fingerprint in compressed chunks, and read through
//!   an index of each chunk's first fingerprint and a Bloom filter;
//! - the frontier's blocks that are not being expanded (the rest of the current level and
//!   what is made of the next) go, compressed, to one file per level, and are read back in
//!   the same order.
//!
//! A successor is then entered in memory when memory does not hold it; whether the run holds
//! it is asked once for all the states a level entered (**delayed duplicate detection**): at
//! the end of the level, and before each spill within it, before any of them is expanded.
//! Those the run holds were reached before: they leave the visited set and the frontier again,
//! so the states expanded at each level, their order, and the counts and depths are those of
//! the search in memory. The cycle proviso of partial-order reduction and the counterexamples'
//! parents look in the run too.
//!
//! A disk budget ([`Spill::max_disk`]) bounds the bytes the files take at once; a write
//! that would pass it, or fails, is not made: what memory holds stays there, and the search
//! stops as a budget stops it ([`Stopped::Disk`], [`Stopped::DiskError`]). The directory is
//! created at the first spill and removed with everything in it when the search is dropped,
//! also after a budget stop, Ctrl-C or a panic. docs/model-checking.md, "Spilling to disk".

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufReader, Read, Seek, SeekFrom, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock, RwLock};

use crate::budget::Stopped;

/// Where and when a breadth-first search spills to disk.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Spill {
    /// The directory of the spill files: the search creates it at its first spill (its parent
    /// must exist, and it must not) and removes it when it ends.
    pub dir: PathBuf,
    /// Also spill whenever the visited set holds this many states in memory (a way for tests
    /// to spill small searches); `None`: only when the memory budget is near.
    pub after_states: Option<usize>,
    /// The bytes the spill files may take at once; `None`: what the file system holds.
    pub max_disk: Option<u64>,
}

/// What a search has spilled so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Spilled {
    /// Times the search emptied its memory to disk.
    pub spills: usize,
    /// Visited states in the run on disk.
    pub states: usize,
    /// Frontier states on disk, not expanded yet.
    pub frontier: usize,
    /// What the spill files take now \[bytes\].
    pub bytes: u64,
    /// The most they took at once \[bytes\].
    pub peak_bytes: u64,
    /// What was written in all \[bytes\].
    pub written: u64,
}

/// A memory budget asks for a spill at `1 - 1/SPILL_HEADROOM` of its size, well below the
/// line where it stops the search ([`crate::budget::MEMORY_HEADROOM`]): what memory gains
/// until the spill is made and the spill's own buffers fit between the two.
pub const SPILL_HEADROOM: u64 = 4;

/// Memory must hold at least `1/REGROWTH` of the most visited states a spill moved out
/// before it is asked for another: a spill frees a worthwhile part of memory, and what stays
/// resident (the interning tables, and memory the allocator keeps) never makes the search
/// spill over and over. The allocator's resident size is no measure of what a spill freed.
const REGROWTH: usize = 2;

/// A visited state as the run keeps it: fingerprint, parent's fingerprint, depth.
pub(crate) type Entry = (u64, u64, u32);

/// States per chunk of the run: the unit a lookup reads.
const CHUNK: usize = 1024;

/// The visited set is merged into the run in `1 << SLICE_BITS` slices of fingerprints (by
/// their top bits), so that only a slice of it is sorted at once.
pub(crate) const SLICE_BITS: u32 = 4;

/// The slice of a fingerprint ([`SLICE_BITS`]).
pub(crate) fn slice_of(fp: u64) -> usize {
    (fp >> (64 - SLICE_BITS)) as usize
}

/// Bloom filter bits per state of the run: about 1 % of lookups of a new state read a chunk.
const BLOOM_BITS: usize = 10;
const BLOOM_HASHES: usize = 7;

/// Why a spill was not made.
#[derive(Debug)]
pub(crate) enum Failure {
    /// The disk budget would be passed.
    Full,
    Io(io::Error),
}

impl From<io::Error> for Failure {
    fn from(e: io::Error) -> Self {
        Failure::Io(e)
    }
}

/// A set of fingerprints with false positives only ([`BLOOM_BITS`]).
#[derive(Debug)]
struct Bloom {
    bits: Vec<u64>,
}

impl Bloom {
    fn new(states: usize) -> Self {
        Self {
            bits: vec![0; (states * BLOOM_BITS).div_ceil(64).max(1)],
        }
    }

    /// The bits of `fp`: a fingerprint is already a hash, so two halves of it make the
    /// probes (double hashing), each reduced to the filter's size by a multiply.
    fn probes(&self, fp: u64) -> [usize; BLOOM_HASHES] {
        let m = (self.bits.len() * 64) as u128;
        let step = fp.rotate_left(32) | 1;
        std::array::from_fn(|i| {
            let h = fp.wrapping_add((i as u64).wrapping_mul(step));
            ((u128::from(h) * m) >> 64) as usize
        })
    }

    fn insert(&mut self, fp: u64) {
        for b in self.probes(fp) {
            self.bits[b / 64] |= 1 << (b % 64);
        }
    }

    fn may_hold(&self, fp: u64) -> bool {
        self.probes(fp)
            .iter()
            .all(|&b| self.bits[b / 64] & (1 << (b % 64)) != 0)
    }
}

/// A chunk of the run: its first fingerprint and where its bytes are.
#[derive(Clone, Copy, Debug)]
struct Chunk {
    first: u64,
    at: u64,
    len: u32,
}

/// The visited states on disk, sorted by fingerprint.
#[derive(Debug)]
struct Run {
    path: PathBuf,
    file: Mutex<File>,
    chunks: Vec<Chunk>,
    states: usize,
    bytes: u64,
    bloom: Bloom,
}

impl Run {
    /// The entries of chunk `i`.
    fn read(&self, i: usize) -> io::Result<Vec<Entry>> {
        let c = self.chunks[i];
        let mut bytes = vec![0; c.len as usize];
        {
            let mut f = self.file.lock().expect("run lock");
            f.seek(SeekFrom::Start(c.at))?;
            f.read_exact(&mut bytes)?;
        }
        decode(&bytes)
    }

    /// The chunk that would hold `fp`.
    fn chunk_of(&self, fp: u64) -> Option<usize> {
        self.chunks
            .partition_point(|c| c.first <= fp)
            .checked_sub(1)
    }

    fn get(&self, fp: u64) -> io::Result<Option<(u64, u32)>> {
        if !self.bloom.may_hold(fp) {
            return Ok(None);
        }
        let Some(i) = self.chunk_of(fp) else {
            return Ok(None);
        };
        let entries = self.read(i)?;
        Ok(entries
            .binary_search_by_key(&fp, |e| e.0)
            .ok()
            .map(|k| (entries[k].1, entries[k].2)))
    }
}

/// A frontier file: one level's blocks.
#[derive(Debug)]
struct Level {
    depth: usize,
    path: PathBuf,
    file: File,
    end: u64,
    states: usize,
}

/// The disk side of one search (see the module doc): its files, what the supervisor asks of
/// it, and what it has spilled.
#[derive(Debug)]
pub struct Store {
    dir: PathBuf,
    after_states: Option<usize>,
    max_disk: Option<u64>,
    created: Mutex<bool>,
    /// The supervisor asks for a spill ([`Store::look`]).
    requested: AtomicBool,
    failure: OnceLock<Stopped>,
    run: RwLock<Option<Run>>,
    has_run: AtomicBool,
    levels: Mutex<Vec<Level>>,
    files: AtomicUsize,
    used: AtomicU64,
    report: Mutex<Spilled>,
    /// The most visited states memory held at a spill.
    most: AtomicUsize,
    /// The memory budget and the resident memory last seen [bytes] ([`Store::look`]).
    budget: AtomicU64,
    resident: AtomicU64,
}

impl Store {
    pub(crate) fn new(spill: Spill) -> Self {
        Self {
            dir: spill.dir,
            after_states: spill.after_states,
            max_disk: spill.max_disk,
            created: Mutex::new(false),
            requested: AtomicBool::new(false),
            failure: OnceLock::new(),
            run: RwLock::new(None),
            has_run: AtomicBool::new(false),
            levels: Mutex::new(Vec::new()),
            files: AtomicUsize::new(0),
            used: AtomicU64::new(0),
            report: Mutex::new(Spilled::default()),
            most: AtomicUsize::new(0),
            budget: AtomicU64::new(0),
            resident: AtomicU64::new(0),
        }
    }

    /// What has been spilled so far.
    pub fn report(&self) -> Spilled {
        *self.report.lock().expect("report lock")
    }

    /// Why spilling stopped the search, if it did.
    pub fn failure(&self) -> Option<Stopped> {
        self.failure.get().copied()
    }

    /// Looks at the process's `resident` memory against its budget `limit` (bytes), and asks
    /// for a spill when it nears the budget ([`SPILL_HEADROOM`]).
    pub fn look(&self, resident: u64, limit: u64) {
        self.budget.store(limit, Ordering::Relaxed);
        self.resident.store(resident, Ordering::Relaxed);
        if resident >= limit - limit / SPILL_HEADROOM {
            self.requested.store(true, Ordering::Relaxed);
        }
    }

    /// Whether the search should spill now, `in_memory` giving the visited states memory
    /// holds: [`Spill::after_states`] of them, or asked for ([`Self::look`]) once memory
    /// holds enough of them again ([`REGROWTH`]).
    pub(crate) fn wanted(&self, in_memory: impl Fn() -> usize) -> bool {
        self.failure.get().is_none()
            && (self.after_states.is_some_and(|n| in_memory() >= n)
                || (self.requested.load(Ordering::Relaxed)
                    && in_memory() >= self.most.load(Ordering::Relaxed) / REGROWTH))
    }

    /// Whether `bytes` more fit under the line where the memory budget asks for a spill
    /// ([`SPILL_HEADROOM`]), by the resident memory last seen (they do without a budget, or
    /// before the first look); never once spilling failed.
    pub(crate) fn fits(&self, bytes: u64) -> bool {
        let limit = self.budget.load(Ordering::Relaxed);
        let line = limit - limit / SPILL_HEADROOM;
        self.failure.get().is_some()
            || limit == 0
            || self.resident.load(Ordering::Relaxed).saturating_add(bytes) < line
    }

    /// Records why the search cannot spill (the first reason only).
    pub(crate) fn fail(&self, why: Failure) {
        let stop = match why {
            Failure::Full => Stopped::Disk {
                limit: self.max_disk.unwrap_or(u64::MAX),
            },
            Failure::Io(e) => Stopped::DiskError { kind: e.kind() },
        };
        let _ = self.failure.set(stop);
    }

    /// Whether the run holds any state.
    pub(crate) fn has_run(&self) -> bool {
        self.has_run.load(Ordering::Relaxed)
    }

    /// Whether the run may hold `fp` (false positives only).
    pub(crate) fn may_hold(&self, fp: u64) -> bool {
        let run = self.run.read().expect("run lock");
        run.as_ref().is_some_and(|r| r.bloom.may_hold(fp))
    }

    /// The parent and depth of `fp` in the run, if it holds it.
    pub(crate) fn get(&self, fp: u64) -> io::Result<Option<(u64, u32)>> {
        let run = self.run.read().expect("run lock");
        match run.as_ref() {
            Some(r) => r.get(fp),
            None => Ok(None),
        }
    }

    /// Those of the sorted fingerprints `fps` the run holds, each chunk read once.
    pub(crate) fn held(&self, fps: &[u64]) -> io::Result<Vec<u64>> {
        let run = self.run.read().expect("run lock");
        let Some(run) = run.as_ref() else {
            return Ok(Vec::new());
        };
        let mut found = Vec::new();
        let mut at = 0;
        while at < fps.len() {
            let Some(i) = run.chunk_of(fps[at]) else {
                at += 1;
                continue;
            };
            let end = run.chunks.get(i + 1).map_or(u64::MAX, |c| c.first);
            let entries = run.read(i)?;
            while at < fps.len() && (fps[at] < end || i + 1 == run.chunks.len()) {
                if entries.binary_search_by_key(&fps[at], |e| e.0).is_ok() {
                    found.push(fps[at]);
                }
                at += 1;
            }
        }
        Ok(found)
    }

    /// The directory, created at the first spill.
    fn dir(&self) -> io::Result<&std::path::Path> {
        let mut created = self.created.lock().expect("dir lock");
        if !*created {
            fs::create_dir(&self.dir)?;
            *created = true;
        }
        Ok(&self.dir)
    }

    /// A new file in the directory.
    fn create(&self, what: &str) -> io::Result<(PathBuf, File)> {
        let n = self.files.fetch_add(1, Ordering::Relaxed);
        let path = self.dir()?.join(format!("{what}-{n}"));
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create_new(true)
            .open(&path)?;
        Ok((path, file))
    }

    /// Counts `n` bytes about to be written, unless they would pass the disk budget.
    fn reserve(&self, n: u64) -> Result<(), Failure> {
        let used = self.used.fetch_add(n, Ordering::Relaxed) + n;
        if self.max_disk.is_some_and(|max| used > max) {
            self.used.fetch_sub(n, Ordering::Relaxed);
            return Err(Failure::Full);
        }
        let mut r = self.report.lock().expect("report lock");
        r.bytes = used;
        r.peak_bytes = r.peak_bytes.max(used);
        r.written += n;
        Ok(())
    }

    /// Counts `n` bytes deleted.
    fn release(&self, n: u64) {
        let used = self.used.fetch_sub(n, Ordering::Relaxed) - n;
        self.report.lock().expect("report lock").bytes = used;
    }

    /// Merges the visited states memory holds (`in_memory` of them; `slice(s, out)` puts
    /// those of slice `s`, [`slice_of`], in `out`) into a new run, none of which the run holds.
    /// On failure the run is as it was, and no file is left of the new one.
    pub(crate) fn merge(
        &self,
        in_memory: usize,
        mut slice: impl FnMut(usize, &mut Vec<Entry>),
    ) -> Result<(), Failure> {
        let mut run = self.run.write().expect("run lock");
        let old = run.as_ref();
        let mut reader = match old {
            Some(r) => Some(Reader::open(r)?),
            None => None,
        };
        self.most.fetch_max(in_memory, Ordering::Relaxed);
        let mut writer = Writer::new(self, old.map_or(0, |r| r.states) + in_memory)?;
        // One buffer for every slice: the allocator need not find room for each.
        let mut buffer = Vec::with_capacity((in_memory >> SLICE_BITS) * 9 / 8);
        let result = (|| -> Result<(), Failure> {
            for s in 0..1 << SLICE_BITS {
                buffer.clear();
                slice(s, &mut buffer);
                buffer.sort_unstable_by_key(|e| e.0);
                let mut mine = buffer.iter().copied().peekable();
                loop {
                    let theirs = match &mut reader {
                        Some(r) => r.peek()?.filter(|e| slice_of(e.0) == s),
                        None => None,
                    };
                    let take_mine = match (mine.peek(), theirs) {
                        (None, None) => break,
                        (Some(m), Some(t)) => {
                            debug_assert_ne!(m.0, t.0, "a state both in memory and on disk");
                            m.0 < t.0
                        }
                        (m, _) => m.is_some(),
                    };
                    let e = if take_mine {
                        mine.next().expect("peeked")
                    } else {
                        reader.as_mut().expect("peeked").next()?
                    };
                    writer.push(e)?;
                }
            }
            Ok(())
        })();
        match result.and_then(|()| writer.finish()) {
            Ok(new) => {
                let states = new.states;
                if let Some(old) = run.replace(new) {
                    let _ = fs::remove_file(&old.path);
                    self.release(old.bytes);
                }
                self.has_run.store(true, Ordering::Relaxed);
                self.report.lock().expect("report lock").states = states;
                Ok(())
            }
            Err(e) => Err(e),
        }
    }

    /// Writes a frontier block of level `depth` (`count` states in `words`): where it is.
    pub(crate) fn write_block(
        &self,
        depth: usize,
        words: &[u32],
        count: usize,
    ) -> Result<(u64, u32), Failure> {
        let mut raw = Vec::with_capacity(words.len() * 4);
        for w in words {
            raw.extend_from_slice(&w.to_le_bytes());
        }
        let bytes = lz4_flex::compress_prepend_size(&raw);
        let mut levels = self.levels.lock().expect("levels lock");
        let i = match levels.iter().position(|l| l.depth == depth) {
            Some(i) => i,
            None => {
                let (path, file) = self.create(&format!("frontier-{depth}"))?;
                levels.push(Level {
                    depth,
                    path,
                    file,
                    end: 0,
                    states: 0,
                });
                levels.len() - 1
            }
        };
        self.reserve(bytes.len() as u64)?;
        let level = &mut levels[i];
        let at = level.end;
        let written = level
            .file
            .seek(SeekFrom::Start(at))
            .and_then(|_| level.file.write_all(&bytes));
        if let Err(e) = written {
            self.release(bytes.len() as u64);
            return Err(e.into());
        }
        level.end += bytes.len() as u64;
        level.states += count;
        self.report.lock().expect("report lock").frontier += count;
        Ok((at, bytes.len() as u32))
    }

    /// The words of the frontier block of level `depth` at `at`.
    pub(crate) fn read_block(&self, depth: usize, at: u64, len: u32) -> io::Result<Vec<u32>> {
        let mut bytes = vec![0; len as usize];
        {
            let mut levels = self.levels.lock().expect("levels lock");
            let level = levels
                .iter_mut()
                .find(|l| l.depth == depth)
                .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, "no such level"))?;
            level.file.seek(SeekFrom::Start(at))?;
            level.file.read_exact(&mut bytes)?;
        }
        let raw = lz4_flex::decompress_size_prepended(&bytes).map_err(invalid)?;
        Ok(raw
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }

    /// Removes level `depth`'s frontier file: its blocks are expanded.
    pub(crate) fn end_level(&self, depth: usize) {
        let mut levels = self.levels.lock().expect("levels lock");
        if let Some(i) = levels.iter().position(|l| l.depth == depth) {
            let level = levels.swap_remove(i);
            drop(level.file);
            let _ = fs::remove_file(&level.path);
            self.release(level.end);
            self.report.lock().expect("report lock").frontier -= level.states;
        }
    }

    /// Counts a spill done, and answers the supervisor's request.
    pub(crate) fn spilled(&self) {
        self.requested.store(false, Ordering::Relaxed);
        self.report.lock().expect("report lock").spills += 1;
    }
}

impl Drop for Store {
    fn drop(&mut self) {
        if *self.created.get_mut().expect("dir lock") {
            let _ = fs::remove_dir_all(&self.dir);
        }
    }
}

/// Reads a run's chunks in order.
struct Reader {
    file: BufReader<File>,
    chunks: std::vec::IntoIter<Chunk>,
    entries: std::vec::IntoIter<Entry>,
    peeked: Option<Entry>,
}

impl Reader {
    fn open(run: &Run) -> io::Result<Self> {
        let file = File::open(&run.path)?;
        Ok(Self {
            file: BufReader::with_capacity(1 << 16, file),
            chunks: run.chunks.clone().into_iter(),
            entries: Vec::new().into_iter(),
            peeked: None,
        })
    }

    fn peek(&mut self) -> io::Result<Option<Entry>> {
        if self.peeked.is_none() {
            self.peeked = loop {
                if let Some(e) = self.entries.next() {
                    break Some(e);
                }
                let Some(c) = self.chunks.next() else {
                    break None;
                };
                let mut bytes = vec![0; c.len as usize];
                self.file.read_exact(&mut bytes)?;
                self.entries = decode(&bytes)?.into_iter();
            };
        }
        Ok(self.peeked)
    }

    fn next(&mut self) -> io::Result<Entry> {
        self.peek()?;
        self.peeked
            .take()
            .ok_or_else(|| invalid("the run ended early"))
    }
}

/// Writes a new run, entry by entry in fingerprint order; dropped unfinished, it removes its
/// file.
struct Writer<'a> {
    store: &'a Store,
    path: PathBuf,
    file: Option<io::BufWriter<File>>,
    at: u64,
    chunks: Vec<Chunk>,
    pending: Vec<Entry>,
    states: usize,
    bloom: Bloom,
}

impl<'a> Writer<'a> {
    fn new(store: &'a Store, states: usize) -> Result<Self, Failure> {
        let (path, file) = store.create("visited")?;
        Ok(Self {
            store,
            path,
            file: Some(io::BufWriter::with_capacity(1 << 16, file)),
            at: 0,
            chunks: Vec::new(),
            pending: Vec::with_capacity(CHUNK),
            states: 0,
            bloom: Bloom::new(states),
        })
    }

    fn push(&mut self, e: Entry) -> Result<(), Failure> {
        self.bloom.insert(e.0);
        self.pending.push(e);
        self.states += 1;
        if self.pending.len() == CHUNK {
            self.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), Failure> {
        if self.pending.is_empty() {
            return Ok(());
        }
        let bytes = encode(&self.pending);
        self.store.reserve(bytes.len() as u64)?;
        self.chunks.push(Chunk {
            first: self.pending[0].0,
            at: self.at,
            len: bytes.len() as u32,
        });
        self.at += bytes.len() as u64;
        self.pending.clear();
        self.file
            .as_mut()
            .expect("open until finished")
            .write_all(&bytes)?;
        Ok(())
    }

    fn finish(mut self) -> Result<Run, Failure> {
        self.flush()?;
        let file = self
            .file
            .take()
            .expect("open until finished")
            .into_inner()
            .map_err(|e| e.into_error())?;
        Ok(Run {
            path: std::mem::take(&mut self.path),
            file: Mutex::new(file),
            chunks: std::mem::take(&mut self.chunks),
            states: self.states,
            bytes: self.at,
            bloom: std::mem::replace(&mut self.bloom, Bloom { bits: Vec::new() }),
        })
    }
}

impl Drop for Writer<'_> {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            let _ = fs::remove_file(&self.path);
            self.store.release(self.at);
        }
    }
}

fn invalid(e: impl ToString) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, e.to_string())
}

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn get_varint(bytes: &[u8], at: &mut usize) -> io::Result<u64> {
    let mut v = 0u64;
    for shift in (0..64).step_by(7) {
        let b = *bytes
            .get(*at)
            .ok_or_else(|| invalid("a chunk ends early"))?;
        *at += 1;
        v |= u64::from(b & 0x7f) << shift;
        if b < 0x80 {
            return Ok(v);
        }
    }
    Err(invalid("a number is too long"))
}

/// A chunk's bytes: its count; the fingerprints as differences from the one before (they
/// are sorted); the parents; the depths; all compressed.
fn encode(entries: &[Entry]) -> Vec<u8> {
    let mut raw = Vec::with_capacity(entries.len() * 15);
    put_varint(&mut raw, entries.len() as u64);
    let mut prev = 0;
    for e in entries {
        put_varint(&mut raw, e.0 - prev);
        prev = e.0;
    }
    for e in entries {
        raw.extend_from_slice(&e.1.to_le_bytes());
    }
    for e in entries {
        put_varint(&mut raw, u64::from(e.2));
    }
    lz4_flex::compress_prepend_size(&raw)
}

fn decode(bytes: &[u8]) -> io::Result<Vec<Entry>> {
    let raw = lz4_flex::decompress_size_prepended(bytes).map_err(invalid)?;
    let at = &mut 0;
    let n = get_varint(&raw, at)? as usize;
    if n > CHUNK {
        return Err(invalid("a chunk is too long"));
    }
    let mut entries = Vec::with_capacity(n);
    let mut fp = 0u64;
    for _ in 0..n {
        fp = fp.wrapping_add(get_varint(&raw, at)?);
        entries.push((fp, 0, 0));
    }
    for e in &mut entries {
        let b = raw
            .get(*at..*at + 8)
            .ok_or_else(|| invalid("a chunk ends early"))?;
        e.1 = u64::from_le_bytes(b.try_into().expect("8 bytes"));
        *at += 8;
    }
    for e in &mut entries {
        e.2 = u32::try_from(get_varint(&raw, at)?).map_err(invalid)?;
    }
    Ok(entries)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn store(dir: &std::path::Path, max_disk: Option<u64>) -> Store {
        Store::new(Spill {
            dir: dir.join("spill"),
            after_states: None,
            max_disk,
        })
    }

    /// A fixed pseudo-random sequence of fingerprints (splitmix64).
    fn fps(seed: u64, n: usize) -> Vec<u64> {
        let mut x = seed;
        (0..n)
            .map(|_| {
                x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
                let mut z = x;
                z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
                z ^ (z >> 31)
            })
            .collect()
    }

    fn merge(s: &Store, entries: &[Entry]) -> Result<(), Failure> {
        s.merge(entries.len(), |k, out| {
            out.extend(entries.iter().filter(|e| slice_of(e.0) == k))
        })
    }

    #[test]
    fn memory_near_its_budget_asks_for_a_spill_once_it_holds_enough_again() {
        let tmp = std::env::temp_dir().join(format!("nekosim-spill-ask-{}", std::process::id()));
        fs::create_dir_all(&tmp).unwrap();
        let s = store(&tmp, None);
        let limit = 1600;
        s.look(1000, limit);
        assert!(!s.wanted(|| 0));
        // 3/4 of the budget.
        s.look(1199, limit);
        assert!(!s.wanted(|| 0));
        s.look(1200, limit);
        assert!(s.wanted(|| 0));
        let entries: Vec<Entry> = fps(5, 1000).into_iter().map(|fp| (fp, 0, 2)).collect();
        merge(&s, &entries).unwrap();
        s.spilled();
        assert!(!s.wanted(|| 1000));
        // Asked again, it waits until memory holds half the most states a spill moved.
        s.look(1500, limit);
        assert!(!s.wanted(|| 499));
        assert!(s.wanted(|| 500));
        // 1100 resident: 100 bytes more reach the line where the budget asks for a spill.
        s.look(1100, limit);
        assert!(s.fits(99) && !s.fits(100));
        drop(s);
        fs::remove_dir_all(&tmp).unwrap();
    }

    #[test]
    fn chunks_decode_to_what_was_encoded() {
        let mut entries: Vec<Entry> = fps(1, CHUNK)
            .into_iter()
            .enumerate()
            .map(|(i, fp)| (fp, fp.rotate_left(7), i as u32 % 40))
            .collect();
        entries.sort_unstable();
        assert_eq!(decode(&encode(&entries)).unwrap(), entries);
        assert!(decode(&encode(&entries)[..20]).is_err());
    }

    #[test]
    fn runs_hold_exactly_what_was_merged_into_them() {
        let tmp = std::env::temp_dir().join(format!("nekosim-spill-test-{}", std::process::id()));
        fs::create_dir_all(&tmp).unwrap();
        let s = store(&tmp, None);
        let all = fps(7, 5000);
        let entry = |(i, &fp): (usize, &u64)| (fp, i as u64, 1 + i as u32 / 100);
        let (a, b) = all.split_at(3000);
        let first: Vec<Entry> = a.iter().enumerate().map(entry).collect();
        let second: Vec<Entry> = b
            .iter()
            .enumerate()
            .map(|(i, fp)| entry((i + 3000, fp)))
            .collect();
        merge(&s, &first).unwrap();
        merge(&s, &second).unwrap();
        assert_eq!(s.report().states, 5000);
        for (i, fp) in all.iter().enumerate() {
            assert_eq!(s.get(*fp).unwrap(), Some((i as u64, 1 + i as u32 / 100)));
        }
        let others = fps(8, 5000);
        assert!(others.iter().all(|fp| s.get(*fp).unwrap().is_none()));
        let mut asked: Vec<u64> = all.iter().step_by(3).chain(&others).copied().collect();
        asked.sort_unstable();
        let mut want: Vec<u64> = all.iter().step_by(3).copied().collect();
        want.sort_unstable();
        assert_eq!(s.held(&asked).unwrap(), want);
        // One run file is left of the two merges, and nothing of it when the store is dropped.
        assert_eq!(fs::read_dir(tmp.join("spill")).unwrap().count(), 1);
        drop(s);
        assert!(!tmp.join("spill").exists());
        fs::remove_dir_all(&tmp).unwrap();
    }

    #[test]
    fn a_spill_past_the_disk_budget_is_not_made_and_leaves_no_file() {
        let tmp = std::env::temp_dir().join(format!("nekosim-spill-full-{}", std::process::id()));
        fs::create_dir_all(&tmp).unwrap();
        let s = store(&tmp, Some(20_000));
        let entries: Vec<Entry> = fps(3, 1000).into_iter().map(|fp| (fp, 0, 2)).collect();
        merge(&s, &entries).unwrap();
        let used = s.report().bytes;
        let more: Vec<Entry> = fps(4, 3000).into_iter().map(|fp| (fp, 0, 3)).collect();
        assert!(matches!(merge(&s, &more), Err(Failure::Full)));
        assert_eq!(s.report().bytes, used);
        assert_eq!(s.report().states, 1000);
        assert_eq!(fs::read_dir(tmp.join("spill")).unwrap().count(), 1);
        assert!(entries.iter().all(|e| s.get(e.0).unwrap() == Some((0, 2))));
        let block: Vec<u32> = (0..5000).map(|i| i % 16).collect();
        let (at, len) = s.write_block(3, &block, 10).unwrap();
        assert_eq!(s.read_block(3, at, len).unwrap(), block);
        assert_eq!(s.report().frontier, 10);
        s.end_level(3);
        assert_eq!(s.report().frontier, 0);
        assert_eq!(s.report().bytes, used);
        drop(s);
        assert!(!tmp.join("spill").exists());
        fs::remove_dir_all(&tmp).unwrap();
    }
}
