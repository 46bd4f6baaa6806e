//! The allocator's settings for large runs (issue 17).
//!
//! The `nekosim` binary and the benches allocate with mimalloc, which by default gives memory
//! that has stayed free for a second back to the operating system. A large run's start-up
//! frees big transient buffers (the setup's effects, the queue's first instant, tables that
//! grew) and then needs as much memory again, which the system must fault in and zero anew:
//! a million robots for one simulated second took 8,400 to 11,500 page faults and 12.5 to 18 s
//! on the development machine, against 1,900 faults and 10.9 to 11.9 s when freed memory is
//! kept (docs/performance.md). A run's memory hardly shrinks once started, so keeping freed
//! memory costs little: its peak RSS was 3.26 GB instead of 3.24.
//!
//! mimalloc also visits every page of the heap every 10,000 allocations that miss its fast
//! path; at a million robots that was 4 % of the run, so the binary asks for the visits a
//! hundred times less often.
//!
//! Small blocks freed are kept, a few of each size class per thread, and handed out again
//! before mimalloc is asked ([`MiMalloc`]): an actor message frees and allocates small blocks
//! that at a million robots are cold, and mimalloc's bookkeeping of them (the page record a
//! free reads, the link an allocation reads from its block) was 9.4 % of the samples of a
//! million robots' later phase, 0.4 % with the blocks kept (docs/performance.md).

/// mimalloc's `mi_option_purge_delay`: its place in `mi_option_e`, the same in mimalloc 2 and
/// 3 (the test below checks it names the purge delay).
const PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// The environment variable with which a user sets the purge delay themselves.
const PURGE_DELAY_VAR: &str = "MIMALLOC_PURGE_DELAY";

/// mimalloc 3's `mi_option_generic_collect`: every this many allocations that miss the fast
/// path, mimalloc visits every page of the thread's heap. At a million robots the heap holds
/// tens of thousands of pages and the visits were 4 % of the run's samples (issue 17); a run
/// frees little that such a visit would give back.
const GENERIC_COLLECT: libmimalloc_sys::mi_option_t = 34;

/// The environment variable with which a user sets that interval themselves.
const GENERIC_COLLECT_VAR: &str = "MIMALLOC_GENERIC_COLLECT";

/// The interval set: mimalloc's largest.
const GENERIC_COLLECT_EVERY: std::ffi::c_long = 1_000_000;

/// Keeps freed memory in the process for reuse instead of giving it back to the operating
/// system, unless the user set `MIMALLOC_PURGE_DELAY`, and collects the heap a hundred times
/// less often, unless the user set `MIMALLOC_GENERIC_COLLECT`. Call it first thing in `main`.
pub fn keep_freed_memory() {
    if std::env::var_os(PURGE_DELAY_VAR).is_none() {
        set_option(PURGE_DELAY, -1);
    }
    if std::env::var_os(GENERIC_COLLECT_VAR).is_none() {
        set_option(GENERIC_COLLECT, GENERIC_COLLECT_EVERY);
    }
}

/// mimalloc's purge delay now in force [ms]; -1: never.
pub fn purge_delay() -> std::ffi::c_long {
    option(PURGE_DELAY)
}

/// How many allocations off mimalloc's fast path pass between two collections of the heap.
pub fn generic_collect() -> std::ffi::c_long {
    option(GENERIC_COLLECT)
}

#[allow(unsafe_code)]
fn option(o: libmimalloc_sys::mi_option_t) -> std::ffi::c_long {
    // SAFETY: `mi_option_get` reads an integer from mimalloc's option table; it has no
    // preconditions.
    unsafe { libmimalloc_sys::mi_option_get(o) }
}

#[allow(unsafe_code)]
fn set_option(o: libmimalloc_sys::mi_option_t, v: std::ffi::c_long) {
    // SAFETY: `mi_option_set` stores an integer in mimalloc's option table; any value is valid
    // for both options set here (the purge delay, -1: never; the collection interval, which
    // mimalloc clamps to 1..=1,000,000), and mimalloc reads them when it purges or collects.
    unsafe { libmimalloc_sys::mi_option_set(o, v) }
}

/// The global allocator of the binary and the benches: mimalloc, asked through its plain entry
/// points (`mi_malloc`, `mi_zalloc`, `mi_realloc`) when the alignment asked for is at most a
/// word, which every mimalloc block has, and through its aligned ones otherwise.
/// `mimalloc::MiMalloc` always takes the aligned ones, which at every allocation test the
/// alignment first and, when the page has no free block, go through two more layers before
/// mimalloc's generic path (issue 17: 68 instructions an allocation on average over the
/// 150,771 allocations of `nekosim run` 1k x 330 s, 2.6 an actor message). Blocks of up to
/// 256 bytes, aligned to a word at most, are freed into a small ring per size class and
/// thread ([`Kept`]) and taken from it first.
#[derive(Debug, Default, Clone, Copy)]
pub struct MiMalloc;

/// The alignment of every mimalloc block: its size classes are multiples of a word.
const WORD: usize = std::mem::size_of::<usize>();

/// Small blocks freed on this thread and kept for the next allocations of their class
/// (issue 17). At a million robots most blocks an actor message frees are cold: a robot's
/// mailbox frees, with each message, the queue node of its message before, allocated seconds
/// ago. `mi_free` then reads the block's page record, and a later `mi_malloc` from its page
/// reads the link written into the block: memory not touched for seconds. This cache neither
/// reads nor writes a block it keeps, and hands blocks out oldest first to a new owner, who
/// writes them before reading. Blocks of a class are the size of the class ([`class`]: every
/// block of that class asked of mimalloc is asked at that size), so any is as good as another.
/// A thread's kept blocks go back to mimalloc when the thread ends ([`release`]).
struct Kept {
    /// Per class, up to [`KEEP`] blocks in a ring: `first[c]` the oldest, `len[c]` of them.
    blocks: [[*mut u8; KEEP]; CLASSES],
    first: [u8; CLASSES],
    len: [u8; CLASSES],
    /// Whether the thread keeps blocks: [`NOT_YET`] until it first frees a small block, then
    /// [`KEEPING`] once its end will release them, or [`NEVER`] (after the release, or when
    /// the release could not be arranged).
    state: u8,
}

const NOT_YET: u8 = 0;
const KEEPING: u8 = 1;
const NEVER: u8 = 2;

/// Blocks kept per class.
const KEEP: usize = 16;

use nekosim_actors::world::prefetch::note_small_block;

/// Classes of blocks kept: the sizes of mimalloc's own up to 256 bytes.
const CLASSES: usize = 13;

/// The largest block kept [bytes].
const KEPT_MAX: usize = 256;

/// The class of a block of `size` bytes (1 to [`KEPT_MAX`]) and the size of its blocks,
/// mimalloc's own size classes: a word, then two words up to 128 bytes, then four classes
/// for each doubling (its blocks are aligned to two words).
#[inline]
fn class(size: usize) -> (usize, usize) {
    if size <= WORD {
        (0, WORD)
    } else if size <= 128 {
        let c = size.div_ceil(16);
        (c, c * 16)
    } else {
        let c = size.div_ceil(32);
        (c + 4, c * 32)
    }
}

/// Whether blocks of `layout` are kept: small, and aligned to a word at most.
#[inline]
fn kept(layout: std::alloc::Layout) -> bool {
    layout.size() <= KEPT_MAX && layout.align() <= WORD
}

thread_local! {
    /// This thread's kept blocks. Without a destructor (a global allocator may not register
    /// one while it allocates): a thread's end releases them through a POSIX thread key
    /// instead ([`release`]).
    static KEPT: std::cell::UnsafeCell<Kept> = const {
        std::cell::UnsafeCell::new(Kept {
            blocks: [[std::ptr::null_mut(); KEEP]; CLASSES],
            first: [0; CLASSES],
            len: [0; CLASSES],
            state: NOT_YET,
        })
    };
}

/// Arranges for [`release`] to run when this thread ends: a POSIX thread key, made once per
/// process, whose destructor it is, set to a non-null value on this thread. Neither call
/// allocates through the global allocator. Whether it could be arranged (never off Unix,
/// where threads then keep no blocks).
#[cfg(unix)]
#[allow(unsafe_code)]
fn release_at_exit() -> bool {
    static KEY: std::sync::OnceLock<Option<libc::pthread_key_t>> = std::sync::OnceLock::new();
    let key = KEY.get_or_init(|| {
        let mut key: libc::pthread_key_t = 0;
        // SAFETY: `key` is written by the call; `release` has the destructor's signature.
        (unsafe { libc::pthread_key_create(&mut key, Some(release)) } == 0).then_some(key)
    });
    // SAFETY: the key was made above; the value is only a non-null marker.
    key.is_some_and(
        |key| unsafe { libc::pthread_setspecific(key, std::ptr::dangling::<libc::c_void>()) } == 0,
    )
}

#[cfg(not(unix))]
fn release_at_exit() -> bool {
    false
}

/// Gives a thread's kept blocks back to mimalloc as the thread ends (the thread key's
/// destructor), after which the thread keeps none.
#[cfg(unix)]
#[allow(unsafe_code)]
unsafe extern "C" fn release(_: *mut libc::c_void) {
    let _ = KEPT.try_with(|k| {
        // SAFETY: only this thread reaches its `Kept`, and no call here reenters (`mi_free`
        // does not allocate).
        let k = unsafe { &mut *k.get() };
        k.state = NEVER;
        for c in 0..CLASSES {
            while let Some(p) = k.pop(c) {
                #[cfg(test)]
                tests::released(p);
                // SAFETY: a kept block is live and owned by the ring alone.
                unsafe { libmimalloc_sys::mi_free(p.cast()) };
            }
        }
    });
}

impl Kept {
    /// Takes the oldest block of class `c`, if any.
    #[inline]
    fn pop(&mut self, c: usize) -> Option<*mut u8> {
        (self.len[c] > 0).then(|| {
            let at = self.first[c] as usize;
            self.first[c] = ((at + 1) % KEEP) as u8;
            self.len[c] -= 1;
            self.blocks[c][at]
        })
    }

    /// Keeps `p`, a block of class `c`, unless the class has [`KEEP`] already or the thread
    /// keeps none; the thread's first block kept arranges the release at its end.
    #[inline]
    fn push(&mut self, c: usize, p: *mut u8) -> bool {
        if self.state != KEEPING {
            if self.state == NEVER || !release_at_exit() {
                self.state = NEVER;
                return false;
            }
            self.state = KEEPING;
        }
        let n = self.len[c] as usize;
        if n == KEEP {
            return false;
        }
        self.blocks[c][(self.first[c] as usize + n) % KEEP] = p;
        self.len[c] += 1;
        true
    }

    /// The oldest block of class `c` this thread keeps, if any.
    #[inline]
    #[allow(unsafe_code)]
    fn take(c: usize) -> Option<*mut u8> {
        // SAFETY: only this thread reaches its `Kept`, and no call here reenters.
        KEPT.try_with(|k| unsafe { &mut *k.get() }.pop(c))
            .ok()
            .flatten()
    }

    /// Keeps `p`, a block of class `c`, on this thread if it can ([`Kept::push`]).
    #[inline]
    #[allow(unsafe_code)]
    fn keep(c: usize, p: *mut u8) -> bool {
        // SAFETY: only this thread reaches its `Kept`; `push` allocates nothing through the
        // global allocator (`release_at_exit`), so no call here reenters.
        KEPT.try_with(|k| unsafe { &mut *k.get() }.push(c, p))
            .unwrap_or(false)
    }
}

#[allow(unsafe_code)]
// SAFETY: each method hands the layout to the mimalloc function that honours it: the plain
// ones only when the alignment is at most a word (every block mimalloc gives is), the aligned
// ones otherwise; memory is freed by `mi_free` whichever gave it, as mimalloc allows. A block
// of a kept layout ([`kept`]) is always asked of mimalloc at its class's size ([`class`]),
// also when grown or shrunk into that layout, so a kept block serves any size of its class;
// it is handed out once, being out of the ring once taken.
unsafe impl std::alloc::GlobalAlloc for MiMalloc {
    #[inline]
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        // SAFETY: see the impl.
        unsafe {
            if kept(layout) {
                let (c, size) = class(layout.size());
                let p = Kept::take(c).unwrap_or_else(|| libmimalloc_sys::mi_malloc(size).cast());
                note_small_block(layout.size(), p as usize);
                p
            } else if layout.align() <= WORD {
                libmimalloc_sys::mi_malloc(layout.size()).cast()
            } else {
                libmimalloc_sys::mi_malloc_aligned(layout.size(), layout.align()).cast()
            }
        }
    }

    #[inline]
    unsafe fn alloc_zeroed(&self, layout: std::alloc::Layout) -> *mut u8 {
        // SAFETY: see the impl.
        unsafe {
            if kept(layout) {
                let p = libmimalloc_sys::mi_zalloc(class(layout.size()).1).cast();
                note_small_block(layout.size(), p as usize);
                p
            } else if layout.align() <= WORD {
                libmimalloc_sys::mi_zalloc(layout.size()).cast()
            } else {
                libmimalloc_sys::mi_zalloc_aligned(layout.size(), layout.align()).cast()
            }
        }
    }

    #[inline]
    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        if kept(layout) && Kept::keep(class(layout.size()).0, ptr) {
            return;
        }
        // SAFETY: see the impl.
        unsafe { libmimalloc_sys::mi_free(ptr.cast()) }
    }

    #[inline]
    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new_size: usize) -> *mut u8 {
        // SAFETY: see the impl.
        unsafe {
            if layout.align() <= WORD {
                let size = if new_size <= KEPT_MAX {
                    class(new_size).1
                } else {
                    new_size
                };
                libmimalloc_sys::mi_realloc(ptr.cast(), size).cast()
            } else {
                libmimalloc_sys::mi_realloc_aligned(ptr.cast(), new_size, layout.align()).cast()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each block of at most 32 bytes handed out, fresh, kept or zeroed, is noted for the scheduler's
    /// look-ahead into robots' mailboxes, among those of at most 16 bytes if it is one, and
    /// no larger one is.
    #[test]
    #[allow(unsafe_code)]
    fn small_blocks_are_noted() {
        use nekosim_actors::world::prefetch::take_small_block;
        use std::alloc::{GlobalAlloc, Layout};
        let a = MiMalloc;
        for size in 1..=64 {
            let layout = Layout::from_size_align(size, 8).expect("a layout");
            for round in 0..4 {
                take_small_block(16);
                take_small_block(32);
                // SAFETY: a non-zero size; the block is freed once with its layout, and is
                // kept for the next round's allocation. Every other round asks for zeros (a
                // compiler turns an allocation written with zeros into one).
                let p = unsafe {
                    if round % 2 == 0 {
                        a.alloc(layout)
                    } else {
                        a.alloc_zeroed(layout)
                    }
                } as usize;
                let noted = [take_small_block(16), take_small_block(32)];
                let expected = match size {
                    ..=16 => [p, p],
                    17..=32 => [0, p],
                    _ => [0, 0],
                };
                assert_eq!(noted, expected, "{size} bytes, round {round}");
                // SAFETY: as above.
                unsafe { a.dealloc(p as *mut u8, layout) };
            }
        }
    }

    /// Blocks of every alignment up to a page, and of sizes that are not multiples of it, come
    /// back aligned, keep their bytes when grown and shrunk, and are zero when asked so.
    #[test]
    #[allow(unsafe_code)]
    fn blocks_are_aligned_and_keep_their_bytes() {
        use std::alloc::{GlobalAlloc, Layout};
        let a = MiMalloc;
        for align in [1, 2, 4, 8, 16, 32, 64, 4096] {
            for size in [1, 3, 8, 24, 40, 100, 1000, 70_000] {
                let layout = Layout::from_size_align(size, align).expect("a layout");
                // SAFETY: non-zero sizes; each block is freed once with its layout.
                unsafe {
                    let p = a.alloc(layout);
                    assert!(!p.is_null() && p as usize % align == 0, "{size} {align}");
                    for k in 0..size {
                        *p.add(k) = (k % 251) as u8;
                    }
                    let q = a.realloc(p, layout, 2 * size + 5);
                    assert!(!q.is_null() && q as usize % align == 0, "{size} {align}");
                    assert!((0..size).all(|k| *q.add(k) == (k % 251) as u8));
                    let grown = Layout::from_size_align(2 * size + 5, align).expect("a layout");
                    let r = a.realloc(q, grown, size / 2 + 1);
                    assert!(r as usize % align == 0);
                    assert!((0..size / 2 + 1).all(|k| *r.add(k) == (k % 251) as u8));
                    a.dealloc(
                        r,
                        Layout::from_size_align(size / 2 + 1, align).expect("a layout"),
                    );
                    let z = a.alloc_zeroed(layout);
                    assert!(z as usize % align == 0 && (0..size).all(|k| *z.add(k) == 0));
                    a.dealloc(z, layout);
                }
            }
        }
    }

    /// The kept classes are mimalloc's own size classes up to 256 bytes (`mi_good_size`, the
    /// size of the block mimalloc gives for a size): keeping blocks by class wastes nothing.
    #[test]
    #[allow(unsafe_code)]
    fn kept_classes_are_mimallocs() {
        let mut seen = Vec::new();
        for size in 1..=KEPT_MAX {
            let (c, block) = class(size);
            // SAFETY: `mi_good_size` only computes.
            let good = unsafe { libmimalloc_sys::mi_good_size(size) };
            assert_eq!(block, good, "size {size}");
            assert!(c < CLASSES && block >= size);
            assert_eq!(class(block), (c, block), "a class's size is in its class");
            if seen.last() != Some(&c) {
                assert!(!seen.contains(&c), "class {c} is one run of sizes");
                seen.push(c);
            }
        }
        assert_eq!(seen, (0..CLASSES).collect::<Vec<_>>());
    }

    /// A random mix of allocations, frees and reallocations, of kept layouts and others, with
    /// each live block filled with its own byte: no two live blocks overlap (a block handed
    /// out twice would overwrite another's bytes), every block is as large as its class and
    /// as aligned as asked, and grown or shrunk blocks keep their bytes.
    #[test]
    #[allow(unsafe_code)]
    fn kept_blocks_are_handed_out_once() {
        use std::alloc::{GlobalAlloc, Layout};
        let a = MiMalloc;
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = |n: u64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % n
        };
        let mut live: Vec<(*mut u8, Layout, u8)> = Vec::new();
        let check = |p: *mut u8, l: Layout, tag: u8| {
            // SAFETY: `p` is live with `l.size()` bytes.
            assert!(
                (0..l.size()).all(|k| unsafe { *p.add(k) } == tag),
                "bytes kept"
            );
        };
        let fill = |p: *mut u8, l: Layout, tag: u8| {
            assert!(!p.is_null() && p as usize % l.align() == 0);
            if kept(l) {
                // SAFETY: `p` is a live mimalloc block.
                let usable = unsafe { libmimalloc_sys::mi_usable_size(p.cast()) };
                assert!(
                    usable >= class(l.size()).1,
                    "a kept block serves its whole class"
                );
            }
            // SAFETY: `p` is live with `l.size()` bytes.
            unsafe { std::ptr::write_bytes(p, tag, l.size()) };
        };
        for step in 0..40_000u32 {
            let tag = (step % 251) as u8 + 1;
            match next(10) {
                0..=4 if live.len() < 2_000 => {
                    let size = 1 + next(400) as usize;
                    let align = 1 << next(5);
                    let l = Layout::from_size_align(size, align).expect("a layout");
                    // SAFETY: a non-zero size.
                    let p = unsafe {
                        if next(8) == 0 {
                            a.alloc_zeroed(l)
                        } else {
                            a.alloc(l)
                        }
                    };
                    fill(p, l, tag);
                    live.push((p, l, tag));
                }
                0..=7 if !live.is_empty() => {
                    let (p, l, t) = live.swap_remove(next(live.len() as u64) as usize);
                    check(p, l, t);
                    // SAFETY: `p` is live, allocated with `l`, and freed once.
                    unsafe { a.dealloc(p, l) };
                }
                _ if !live.is_empty() => {
                    let k = next(live.len() as u64) as usize;
                    let (p, l, t) = live[k];
                    check(p, l, t);
                    let size = 1 + next(400) as usize;
                    // SAFETY: `p` is live with `l`; a non-zero new size.
                    let q = unsafe { a.realloc(p, l, size) };
                    let grown = Layout::from_size_align(size, l.align()).expect("a layout");
                    check(
                        q,
                        Layout::from_size_align(size.min(l.size()), 1).expect("a layout"),
                        t,
                    );
                    fill(q, grown, tag);
                    live[k] = (q, grown, tag);
                }
                _ => {}
            }
        }
        for (p, l, t) in live {
            check(p, l, t);
            // SAFETY: `p` is live, allocated with `l`, and freed once.
            unsafe { a.dealloc(p, l) };
        }
    }

    /// Blocks freed on another thread than the one that allocated them are kept by the
    /// freeing thread and serve its allocations.
    #[test]
    #[allow(unsafe_code)]
    fn blocks_freed_on_another_thread_serve_it() {
        use std::alloc::{GlobalAlloc, Layout};
        let l = Layout::from_size_align(40, 8).expect("a layout");
        // SAFETY: a non-zero size; each block is written within its size.
        let blocks: Vec<usize> = (0..KEEP)
            .map(|k| unsafe {
                let p = MiMalloc.alloc(l);
                std::ptr::write_bytes(p, k as u8, l.size());
                p as usize
            })
            .collect();
        let theirs = blocks.clone();
        let reused = std::thread::spawn(move || {
            for &p in &theirs {
                // SAFETY: each block is live, allocated with `l`, and freed once.
                unsafe { MiMalloc.dealloc(p as *mut u8, l) };
            }
            allocate_and_free(l)
        })
        .join()
        .expect("the thread ends");
        let mut a = blocks.clone();
        let mut b = reused;
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(
            a, b,
            "the other thread's allocations took the blocks it kept"
        );
    }

    /// Allocates [`KEEP`] blocks of layout `l` on this thread, then frees them (the thread
    /// keeps them): their addresses.
    #[allow(unsafe_code)]
    fn allocate_and_free(l: std::alloc::Layout) -> Vec<usize> {
        use std::alloc::GlobalAlloc;
        // SAFETY: a non-zero size.
        let blocks: Vec<usize> = (0..KEEP)
            .map(|_| unsafe { MiMalloc.alloc(l) } as usize)
            .collect();
        for &p in &blocks {
            // SAFETY: each block is live, allocated with `l`, and freed once.
            unsafe { MiMalloc.dealloc(p as *mut u8, l) };
        }
        blocks
    }

    /// Blocks [`release`] gave back to mimalloc, in the tests.
    #[cfg(unix)]
    static RELEASED: std::sync::Mutex<Vec<usize>> = std::sync::Mutex::new(Vec::new());

    #[cfg(unix)]
    pub(super) fn released(p: *mut u8) {
        RELEASED
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .push(p as usize);
    }

    /// The blocks a thread keeps go back to mimalloc when it ends.
    #[cfg(unix)]
    #[test]
    fn a_threads_kept_blocks_go_back_when_it_ends() {
        use std::alloc::Layout;
        let l = Layout::from_size_align(200, 8).expect("a layout");
        let kept = std::thread::spawn(move || allocate_and_free(l))
            .join()
            .expect("the thread ends");
        let released = RELEASED
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        assert!(
            kept.iter().all(|p| released.contains(p)),
            "every kept block released"
        );
    }

    #[test]
    fn the_options_set_are_the_purge_delay_and_the_collection_interval() {
        if std::env::var_os(PURGE_DELAY_VAR).is_some()
            || std::env::var_os(GENERIC_COLLECT_VAR).is_some()
        {
            return;
        }
        // mimalloc 3's defaults: no other option defaults to 1000 or to 10,000.
        assert_eq!(purge_delay(), 1000);
        assert_eq!(generic_collect(), 10_000);
        keep_freed_memory();
        assert_eq!(purge_delay(), -1);
        assert_eq!(generic_collect(), GENERIC_COLLECT_EVERY);
    }
}
