//! All integration tests, one binary; modules are named by behaviour.

mod behaviours;
mod cancellation;
mod check;
mod cli;
mod collisions;
mod common;
mod communication;
mod dask_sweep;
mod determinism;
mod kernel;
mod lcm;
mod lcm_algorithms;
mod lcm_check;
mod lcm_search;
mod mutated_inputs;
mod obstacles;
mod python_package;
mod real_network;
mod recording;
#[cfg(feature = "rerun")]
mod rerun_reader;
mod scale;
mod seed_semantics;
mod sensors;
mod smoke;
mod spin;
mod sweep;
mod user_network;
mod user_protocol;
mod user_sensor;
mod virtual_time;
