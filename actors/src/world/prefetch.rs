//! Asking the processor to bring memory into cache before it is read (issue 17, scale is
//! designed in). A million robots' state, events and cells are spread over gigabytes: each
//! event's first touch of them is a cache miss. Where the engine knows what comes next (the
//! queue's next entry), it asks for that memory ahead, so the miss overlaps the work of the
//! event at hand. A prefetch is only a hint: it reads nothing, changes nothing and cannot fault,
//! so no output depends on it.

/// Asks for the cache lines of `r` (a no-op on processors other than x86-64).
#[inline(always)]
pub fn prefetch<T>(r: &T) {
    prefetch_at(r as *const T as usize, std::mem::size_of::<T>().max(1));
}

/// Asks for the cache lines of the `bytes` bytes from address `addr` on, which need not be
/// memory of this program's any more: a prefetch never faults, and a stale address only
/// costs the lines asked for (a no-op on processors other than x86-64).
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
