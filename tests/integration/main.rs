//! All integration tests, one binary; modules are named by behaviour.

mod collisions;
mod common;
mod smoke;
