//! Asking the processor to bring the engine's own memory into cache before it is read.
//!
//! A million robots' states, events and grid cells are spread over gigabytes, and each
//! event's first touch of them is a cache miss. Where the engine knows what comes next (the
//! queue's next entries), it asks for that memory ahead, so that the miss overlaps the work of
//! the event at hand. A prefetch is only a hint: it reads no value, changes nothing and cannot
//! fault, so no output depends on it. It is asked for the engine's own data structures only,
//! never for memory another crate lays out.

/// Asks for the cache lines of `r` (a no-op on processors other than x86-64).
#[inline(always)]
pub fn prefetch<T>(r: &T) {
    prefetch_at(r as *const T as usize, std::mem::size_of::<T>().max(1));
}

/// Asks for the cache lines of the `bytes` bytes from address `addr` on. A prefetch never
/// faults, so a stale address only costs the lines asked for (a no-op on processors other
/// than x86-64).
///
/// Stable Rust has no safe prefetch (`core::hint::prefetch_read` is unstable), so this is the
/// crate's one `unsafe` block outside its test allocator.
#[inline(always)]
#[allow(unsafe_code)]
pub fn prefetch_at(addr: usize, bytes: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        const LINE: usize = 64;
        let end = addr.wrapping_add(bytes);
        let mut line = addr - addr % LINE;
        while line < end {
            // SAFETY: `_mm_prefetch` only hints the cache: it reads no value and never faults,
            // whatever the address. SSE, which it needs, is part of every x86-64 processor.
            unsafe {
                std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                    line as *const i8,
                );
            }
            line = line.wrapping_add(LINE);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (addr, bytes);
}
