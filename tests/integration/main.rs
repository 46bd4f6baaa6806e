//! All integration tests, one binary; modules are named by behaviour.

mod common;
mod smoke;
