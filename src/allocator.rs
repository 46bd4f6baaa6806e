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
/// 150,771 allocations of `nekosim run` 1k x 330 s, 2.6 an actor message).
#[derive(Debug, Default, Clone, Copy)]
pub struct MiMalloc;

/// The alignment of every mimalloc block: its size classes are multiples of a word.
const WORD: usize = std::mem::size_of::<usize>();

#[allow(unsafe_code)]
// SAFETY: each method hands the layout to the mimalloc function that honours it: the plain
// ones only when the alignment is at most a word (every block mimalloc gives is), the aligned
// ones otherwise; memory is freed by `mi_free` whichever gave it, as mimalloc allows.
unsafe impl std::alloc::GlobalAlloc for MiMalloc {
    #[inline]
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        // SAFETY: see the impl.
        unsafe {
            if layout.align() <= WORD {
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
            if layout.align() <= WORD {
                libmimalloc_sys::mi_zalloc(layout.size()).cast()
            } else {
                libmimalloc_sys::mi_zalloc_aligned(layout.size(), layout.align()).cast()
            }
        }
    }

    #[inline]
    unsafe fn dealloc(&self, ptr: *mut u8, _layout: std::alloc::Layout) {
        // SAFETY: see the impl.
        unsafe { libmimalloc_sys::mi_free(ptr.cast()) }
    }

    #[inline]
    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new_size: usize) -> *mut u8 {
        // SAFETY: see the impl.
        unsafe {
            if layout.align() <= WORD {
                libmimalloc_sys::mi_realloc(ptr.cast(), new_size).cast()
            } else {
                libmimalloc_sys::mi_realloc_aligned(ptr.cast(), new_size, layout.align()).cast()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
