//! The pure world kernel: geometry, motion patterns, collision prediction, the spatial index
//! and the virtual world (seed 3.2, 4.2.4). Nothing here depends on actix, so it can be
//! property-tested directly; the actors in the crate root host it.

pub mod collision;
pub mod geometry;
pub mod motion;
