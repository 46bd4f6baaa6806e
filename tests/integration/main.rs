//! All integration tests, one binary; modules are named by behaviour.

mod cancellation;
mod collisions;
mod determinism;
mod virtual_time;
mod common;
mod scale;
mod sensors;
mod smoke;
