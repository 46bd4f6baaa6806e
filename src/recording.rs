//! Rerun recordings of a run: the seed's animation module (seed 4.5.2, animation settings of
//! 6.1) rebuilt as a stream of drawings for the Rerun viewer, live (`--connect`) or saved
//! (`--rrd FILE`). docs/visualization.md describes what a recording shows.
//!
//! The module has two halves, so that what is drawn can be tested without Rerun:
//!
//! - [`Recorder`] (always compiled, pure): turns the run's [`Record`]s, the same stream the
//!   JSONL trace and the Neko log are written from, into calls on a [`Canvas`]. It keeps the
//!   little state a drawing needs (each robot's kinematic state, last corner, sensor, the
//!   message copies in flight and lost, [`flights`]) and samples the animation frames.
//! - [`rerun_canvas::RerunCanvas`] (cargo feature `rerun`): a [`Canvas`] that writes Rerun
//!   entities, buffered per entity and sent as columns.
//!
//! The pure half is [`canvas`] (what can be drawn), [`colour`], [`flights`] and [`recorder`].
//!
//! **Input.** The recorder consumes [`Record`]s rather than JSONL lines: they are what the
//! engine produces, they are typed, and the trace is a projection of them, so every trace
//! object corresponds to exactly one record. `nekosim check --rrd` turns a counterexample into
//! `Record`s (spawns, sends, receives, crashes) and feeds them through the same recorder.
//!
//! **Animation.** Between two kinematic records of a robot (spawn, motion step, motion finish,
//! crash) the built-in motion patterns are exactly linear in time: the position is
//! `pos_k + vel_k (t - t_k)` and the heading `angle_k + omega_k (t - t_k)` (seed eq. 3.1-3.2,
//! the patterns' `state_at`). Frames at `k / framerate` evaluate these formulas for every
//! moving robot; they never come from slicing the engine's time. A user-defined curved pattern
//! only exposes its step states in the record stream, so its frames follow the chord between
//! steps (the same limitation as rebuilding trajectories from the trace, docs/trace.md).
//!
//! **Determinism.** Everything drawn is a function of the records and the scenario: frames
//! are on simulated time, `events/s` counts events per simulated second, and robot and layer
//! colours come from ids and names, never from a hash map's order or the wall clock. Buffers
//! are sent when they reach a size, never on a timer, so the .rrd file's chunks and ids
//! ([`rrd_file`]) are a function of the run too.
//!
//! [`Record`]: nekosim_actors::world::observation::Record

pub mod canvas;
pub mod colour;
pub mod flights;
pub mod recorder;

#[cfg(feature = "rerun")]
pub mod names;
#[cfg(feature = "rerun")]
pub mod rerun_canvas;
#[cfg(feature = "rerun")]
pub mod rrd_file;

pub use canvas::{
    level_of, Canvas, Flight, Level, Mark, Metrics, NoCanvas, Sight, Stamp, ROBOT_GROUP,
};
pub use colour::{layer_colour, robot_colour, Rgb, GREY};
pub use flights::LOST_SECONDS;
pub use recorder::Recorder;

/// Why a recording could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordingError {
    /// The .rrd file (or its directory) could not be created: the user's input. Fatal before
    /// the run starts.
    #[error("{path}: cannot create the recording: {message}")]
    Create { path: String, message: String },
    /// The viewer URL is not a Rerun gRPC proxy URL: the user's input.
    #[error("{url}: not a Rerun viewer URL ({message}); expected e.g. rerun+http://127.0.0.1:9876/proxy")]
    Url { url: String, message: String },
    /// No viewer answered at the URL (none running, or another address): the user's input.
    #[error("{url}: cannot stream to the Rerun viewer: {message}; start one with `rerun` or check --connect")]
    Unreachable { url: String, message: String },
    /// Rerun refused data or could not finish the file (an internal error).
    #[error("recording: {0}")]
    Rerun(String),
    /// This build has no Rerun support (cargo feature `rerun` off): the user's input.
    #[error("this nekosim was built without Rerun support (cargo feature `rerun`); --rrd and --connect are unavailable")]
    Unsupported,
    /// The finished .rrd file could not be moved into place. (The cause is in the message, not
    /// a `source`, so that error chains do not print it twice.)
    #[error("{path}: cannot write the recording: {error}")]
    Write { path: String, error: std::io::Error },
}

impl RecordingError {
    /// Whether the user's input is at fault (exit 2) rather than nekosim or Rerun (exit 1).
    pub fn is_input_error(&self) -> bool {
        matches!(
            self,
            RecordingError::Create { .. }
                | RecordingError::Url { .. }
                | RecordingError::Unreachable { .. }
                | RecordingError::Unsupported
        )
    }
}

/// Where a recording goes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Target {
    /// Save to this .rrd file.
    pub rrd: Option<std::path::PathBuf>,
    /// Stream to the viewer at this gRPC URL (`Some(None)`: the SDK's default URL).
    pub connect: Option<Option<String>>,
}

impl Target {
    /// Whether anything is to be recorded.
    pub fn is_some(&self) -> bool {
        self.rrd.is_some() || self.connect.is_some()
    }
}

/// Animation frames per simulated second when a scenario does not say.
pub const DEFAULT_FRAMERATE: f64 = 25.0;

/// The highest animation rate a scenario may ask for [frames per simulated second]: a frame is
/// a row per moving robot group, so a rate far beyond what a viewer can show would only make
/// the run crawl (at 10^9 frames per second a 20 s run draws 2 x 10^10 rows per group).
pub const MAX_FRAMERATE: f64 = 1000.0;

/// How long a leg of a robot's path stays drawn behind it [simulated s] (the default
/// blueprint's visible time range of `world/paths`).
pub const TRAIL_SECONDS: f64 = 10.0;

/// Window of the `events_per_second` metric [simulated s]: one second, so the rate does not
/// depend on the sampling period (a frame period is too short to count events meaningfully).
pub const EVENT_RATE_WINDOW: f64 = 1.0;
