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

thread_local! {
    /// The last small block the global allocator handed out on this thread, if it says so
    /// ([`note_small_block`]); `0` when none was noted since [`take_small_block`].
    static SMALL_BLOCK: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// The largest block [bytes] whose address a global allocator notes ([`note_small_block`]):
/// an actix mailbox's queue node (a link and a message's box, 24 bytes).
pub const SMALL_BLOCK_MAX: usize = 32;

/// Notes the address of a block of at most [`SMALL_BLOCK_MAX`] bytes just handed out on this
/// thread. For a global allocator to call (the `nekosim` binary's and benches' one does): it
/// neither allocates nor registers a destructor. Only a hint, like a prefetch: an allocator
/// that never calls it leaves the look-ahead without the nodes ([`take_small_block`]).
#[inline]
pub fn note_small_block(addr: usize) {
    let _ = SMALL_BLOCK.try_with(|b| b.set(addr));
}

/// The address of the last small block noted on this thread since the last call, or `0`.
/// The scheduler asks it right after sending an event to a robot actor: the block is then
/// the mailbox's node of that message, which the robot's next message reads when it is sent
/// and when it is taken out (actix's queue keeps the last node taken as its end), cold at a
/// million robots unless asked for ahead.
#[inline]
pub fn take_small_block() -> usize {
    SMALL_BLOCK.try_with(|b| b.replace(0)).unwrap_or(0)
}
