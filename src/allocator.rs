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

#[cfg(test)]
mod tests {
    use super::*;

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
