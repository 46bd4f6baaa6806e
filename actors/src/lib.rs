//! The nekosim engine: a deterministic, event-driven simulator of cooperative mobile robots,
//! rebuilt from the Neko robot simulation engine (Sangsubhan, 2009; "the seed").
//!
//! - [`world`]: the pure kernel (geometry, motion patterns, exact collision prediction, the
//!   spatial index, the virtual world), free of actix.
//! - [`handler`]: what each actor's logic is to the engine (an event in, effects into an
//!   outbox); [`host`]: how the product hosts handlers in actix actors.
//! - [`scheduler`]: the virtual-time scheduler actor and its ordering contract; [`kernel`]: the
//!   same handling code driven without actors (the reference the engine bench compares with).
//! - [`motion_manager`], [`sensor_manager`], [`robot`], [`sensor`]: the other actors.
//! - [`layer`]: protocol layers hosted as actors; [`protocol_record`]: what a hosted stack
//!   records, shared by every host of a stack.
//! - [`lcm`]: Look-Compute-Move robots (oblivious or luminous, under an adversary).
//! - [`algorithm`]: built-in robot algorithms; [`behaviour`]: composable behaviours (seed 7.2);
//!   [`config`]: what an algorithm's configuration is; [`registry`]: algorithms by name, and
//!   [`builtins`]: the built-in ones registered there; [`simulation`]: building and running a run.

pub mod algorithm;
pub mod behaviour;
pub mod builtins;
pub mod config;
pub mod handler;
pub mod host;
pub mod kernel;
pub mod layer;
pub mod lcm;
pub mod motion_manager;
pub mod network;
pub mod protocol_record;
pub mod random;
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
/// that a hot path allocates nothing. A `GlobalAlloc` has no safe form, so this is the crate's
/// one `unsafe` module, and it exists in test builds only.
#[cfg(test)]
#[allow(unsafe_code)]
pub(crate) mod allocations {
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    thread_local! {
        static COUNT: Cell<u64> = const { Cell::new(0) };
    }

    fn count() {
        let _ = COUNT.try_with(|c| c.set(c.get() + 1));
    }

    /// Allocations made on this thread so far.
    pub(crate) fn on_this_thread() -> u64 {
        COUNT.with(Cell::get)
    }

    struct Counting;

    // SAFETY: every call goes to the system allocator unchanged; counting touches a
    // thread-local cell only, which allocates nothing and has no destructor.
    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            count();
            unsafe { System.alloc(layout) }
        }
        unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
            count();
            unsafe { System.alloc_zeroed(layout) }
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            count();
            unsafe { System.realloc(ptr, layout, new_size) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            unsafe { System.dealloc(ptr, layout) }
        }
    }

    #[global_allocator]
    static COUNTING: Counting = Counting;
}
