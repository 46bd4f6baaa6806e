//! The allocator's setting for large runs (issue 17).
//!
//! The `nekosim` binary and the benches allocate with mimalloc, which by default gives memory
//! that has stayed free for a second back to the operating system. A large run's start-up
//! frees big transient buffers (the setup's effects, the queue's first instant, tables that
//! grew) and then needs as much memory again, which the system must fault in and zero anew:
//! a million robots for one simulated second took 8,400 to 11,500 page faults and 12.5 to 18 s
//! on the development machine, against 1,900 faults and 10.9 to 11.9 s when freed memory is
//! kept (docs/performance.md). A run's memory hardly shrinks once started, so keeping freed
//! memory costs little: its peak RSS was 3.26 GB instead of 3.24.

/// mimalloc's `mi_option_purge_delay`: its place in `mi_option_e`, the same in mimalloc 2 and
/// 3 (the test below checks it names the purge delay).
const PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// The environment variable with which a user sets the purge delay themselves.
const PURGE_DELAY_VAR: &str = "MIMALLOC_PURGE_DELAY";

/// Keeps freed memory in the process for reuse instead of giving it back to the operating
/// system, unless the user set `MIMALLOC_PURGE_DELAY`. Call it first thing in `main`.
pub fn keep_freed_memory() {
    if std::env::var_os(PURGE_DELAY_VAR).is_none() {
        set_purge_delay(-1);
    }
}

/// mimalloc's purge delay now in force [ms]; -1: never.
#[allow(unsafe_code)]
pub fn purge_delay() -> std::ffi::c_long {
    // SAFETY: `mi_option_get` reads an integer from mimalloc's option table; it has no
    // preconditions.
    unsafe { libmimalloc_sys::mi_option_get(PURGE_DELAY) }
}

#[allow(unsafe_code)]
fn set_purge_delay(ms: std::ffi::c_long) {
    // SAFETY: `mi_option_set` stores an integer in mimalloc's option table; any value is valid
    // for the purge delay (-1: never purge), and mimalloc reads it at each purge.
    unsafe { libmimalloc_sys::mi_option_set(PURGE_DELAY, ms) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_option_set_is_the_purge_delay() {
        if std::env::var_os(PURGE_DELAY_VAR).is_some() {
            return;
        }
        // mimalloc 3's default purge delay: no neighbouring option defaults to 1000.
        assert_eq!(purge_delay(), 1000);
        keep_freed_memory();
        assert_eq!(purge_delay(), -1);
    }
}
