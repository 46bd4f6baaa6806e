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
    /// The last blocks of at most 16 and at most 32 bytes the global allocator handed out on
    /// this thread, if it says so ([`note_small_block`]); `0` for none since the last
    /// [`take_small_block`] of that size.
    static SMALL_BLOCKS: std::cell::Cell<[usize; 2]> = const { std::cell::Cell::new([0; 2]) };
}

/// The largest block [bytes] whose address a global allocator notes ([`note_small_block`]):
/// an actix mailbox's queue node of a message (a link and the message's box, 24 bytes).
pub const SMALL_BLOCK_MAX: usize = 32;

/// Notes the address of a block of `size` bytes just handed out on this thread (nothing if
/// `size` is over [`SMALL_BLOCK_MAX`]). For a global allocator to call (the `nekosim`
/// binary's and benches' one does): it neither allocates nor registers a destructor. Only a
/// hint, like a prefetch: an allocator that never calls it leaves the look-ahead without the
/// mailboxes' nodes ([`take_small_block`]).
#[inline]
pub fn note_small_block(size: usize, addr: usize) {
    if size <= SMALL_BLOCK_MAX {
        let _ = SMALL_BLOCKS.try_with(|b| {
            let [tiny, _] = b.get();
            b.set([if size <= 16 { addr } else { tiny }, addr]);
        });
    }
}

/// The address of the last block of at most `max` bytes (16 or 32) noted on this thread
/// since the last such call, or `0`. Right after sending an event to a robot actor, the last
/// of at most 32 bytes is the mailbox's node of that message, which the robot's next message
/// reads when it is sent and when it is taken out (actix's queue keeps the last node taken
/// out as its end). Right after starting a robot actor, the last of at most 16 bytes is the
/// end of its mailbox's queue of parked senders, which stays empty and is read each time a
/// message is taken out. Both are cold at a million robots unless asked for ahead.
#[inline]
pub fn take_small_block(max: usize) -> usize {
    let k = usize::from(max > 16);
    SMALL_BLOCKS
        .try_with(|b| {
            let mut v = b.get();
            let addr = std::mem::replace(&mut v[k], 0);
            b.set(v);
            addr
        })
        .unwrap_or(0)
}
