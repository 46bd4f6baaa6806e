//! The global allocator of the `nekosim` command and the benches: mimalloc, through the
//! `mimalloc` crate's safe `GlobalAlloc`.
//!
//! A large run allocates and frees many small blocks (actor messages, effects, events) across
//! a heap of gigabytes; mimalloc's per-thread free lists serve them faster than the system
//! allocator, and the benches use the same allocator so that their figures are the command's.
//! The crate builds mimalloc's stable v2 line (its `v2` feature, `Cargo.toml`): on these runs
//! it is faster and smaller than the v3 line the crate defaults to. docs/architecture.md lists
//! the gains.

/// The allocator: `#[global_allocator] static GLOBAL: nekosim::allocator::MiMalloc = nekosim::allocator::MiMalloc;`
pub use mimalloc::MiMalloc;
