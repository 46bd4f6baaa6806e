//! The nekosim engine: a deterministic, event-driven simulator of cooperative mobile robots,
//! rebuilt from the Neko robot simulation engine (Sangsubhan, 2009; "the seed").
//!
//! - [`world`]: the pure kernel (geometry, motion patterns, exact collision prediction, the
//!   spatial index, the virtual world), free of actix.
//! - [`scheduler`]: the virtual-time scheduler actor and its ordering contract; [`kernel`]: the
//!   same handling code driven without actors (the reference the engine bench compares with).
//! - [`motion_manager`], [`sensor_manager`], [`robot`], [`sensor`]: the other actors.
//! - [`layer`]: protocol layers hosted as actors; [`protocol_record`]: what a hosted stack
//!   records, shared by every host of a stack.
//! - [`algorithm`]: built-in robot algorithms; [`behaviour`]: composable behaviours (seed 7.2);
//!   [`simulation`]: building and running a run.

pub mod algorithm;
pub mod behaviour;
pub mod kernel;
pub mod layer;
pub mod motion_manager;
pub mod network;
pub mod protocol_record;
pub mod registry;
pub mod robot;
pub mod scheduler;
pub mod sensor;
pub mod sensor_manager;
pub mod simulation;
pub mod world;

pub use robot::{Algorithm, AlgorithmFuture, MotionEnd, Received, Robot};
pub use simulation::{run, run_then_exit, Comms, Fault, SimConfig, SimError};

/// The unit tests' allocator: the system's, counting each thread's allocations, for the tests
/// that a hot path allocates nothing (issue 17), noting small blocks as the binary's allocator
/// does ([`crate::world::prefetch::note_small_block`]) and telling whether a block watched
/// was freed.
#[cfg(test)]
#[allow(unsafe_code)]
pub(crate) mod allocations {
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    thread_local! {
        static COUNT: Cell<u64> = const { Cell::new(0) };
        /// Of them, blocks of at most 16 bytes.
        static TINY: Cell<u64> = const { Cell::new(0) };
    }

    fn count() {
        let _ = COUNT.try_with(|c| c.set(c.get() + 1));
    }

    /// Allocations of at most 16 bytes made on this thread so far.
    pub(crate) fn tiny_on_this_thread() -> u64 {
        TINY.with(Cell::get)
    }

    /// Allocations made on this thread so far.
    pub(crate) fn on_this_thread() -> u64 {
        COUNT.with(Cell::get)
    }

    thread_local! {
        /// A block whose freeing on this thread is looked for ([`watch`]), and whether it was.
        static WATCHED: Cell<(usize, bool)> = const { Cell::new((0, false)) };
    }

    /// Looks for the freeing of the block at `addr` on this thread from now on.
    pub(crate) fn watch(addr: usize) {
        WATCHED.with(|w| w.set((addr, false)));
    }

    /// Whether the block watched was freed on this thread since [`watch`].
    pub(crate) fn watched_freed() -> bool {
        WATCHED.with(|w| w.get().1)
    }

    struct Counting;

    // SAFETY: every call goes to the system allocator unchanged; counting, noting and watching
    // touch thread-local cells only, which allocate nothing and have no destructor.
    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            count();
            if layout.size() <= 16 {
                let _ = TINY.try_with(|c| c.set(c.get() + 1));
            }
            let p = unsafe { System.alloc(layout) };
            crate::world::prefetch::note_small_block(layout.size(), p as usize);
            p
        }
        unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
            count();
            if layout.size() <= 16 {
                let _ = TINY.try_with(|c| c.set(c.get() + 1));
            }
            let p = unsafe { System.alloc_zeroed(layout) };
            crate::world::prefetch::note_small_block(layout.size(), p as usize);
            p
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            count();
            unsafe { System.realloc(ptr, layout, new_size) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            let _ = WATCHED.try_with(|w| {
                if w.get().0 == ptr as usize {
                    w.set((ptr as usize, true));
                }
            });
            unsafe { System.dealloc(ptr, layout) }
        }
    }

    #[global_allocator]
    static COUNTING: Counting = Counting;
}
