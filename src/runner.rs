//! Running a built scenario with its outputs: the Neko log and the JSONL trace are streamed to
//! files that appear only when the run succeeded (see [`crate::output`]).

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::Instant;

use nekosim_actors::scheduler::Observers;
use nekosim_actors::{SimConfig, SimError};

use crate::log::NekoLog;
use crate::output::AtomicFile;
use crate::scenario::Built;
use crate::trace::to_json;

/// Where a run writes and who watches it.
#[derive(Default)]
pub struct RunOptions {
    pub log: Option<PathBuf>,
    pub trace: Option<PathBuf>,
    /// Called with the virtual time now and then.
    pub progress: Option<Box<dyn FnMut(f64)>>,
}

impl std::fmt::Debug for RunOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunOptions")
            .field("log", &self.log)
            .field("trace", &self.trace)
            .finish()
    }
}

/// What a run did.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub name: String,
    pub seed: u64,
    pub robots: usize,
    pub events: u64,
    /// Conditional events cancelled before they fired.
    pub cancelled: u64,
    pub collisions: u64,
    /// Simulated time at the end [s].
    pub end_time: f64,
    /// Wall-clock time of the run [s] (the only wall-clock reading, outside the simulation).
    pub wall_seconds: f64,
}

impl Summary {
    /// Events per wall-clock second.
    pub fn events_per_second(&self) -> f64 {
        if self.wall_seconds > 0.0 {
            self.events as f64 / self.wall_seconds
        } else {
            0.0
        }
    }
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RunError {
    /// An output file could not be created (bad path: the user's input).
    #[error("{path}: cannot create the output file: {source}")]
    CreateOutput {
        path: String,
        source: std::io::Error,
    },
    /// An output file could not be written (an internal error; nothing is left behind).
    #[error("{path}: cannot write the output file: {source}")]
    WriteOutput {
        path: String,
        source: std::io::Error,
    },
    /// The simulation failed.
    #[error(transparent)]
    Sim(#[from] SimError),
}

fn create(path: &Option<PathBuf>) -> Result<Option<AtomicFile>, RunError> {
    path.as_deref()
        .map(|p: &Path| {
            AtomicFile::create(p).map_err(|source| RunError::CreateOutput {
                path: p.display().to_string(),
                source,
            })
        })
        .transpose()
}

/// Runs `built`, writing the requested outputs.
pub fn run(built: Built, opts: RunOptions) -> Result<Summary, RunError> {
    let log = create(&opts.log)?;
    let trace = create(&opts.trace)?;
    let outputs = Rc::new(RefCell::new((log, trace, NekoLog::new())));
    let sink = {
        let outputs = outputs.clone();
        Box::new(move |r: &nekosim_actors::world::observation::Record| {
            let mut o = outputs.borrow_mut();
            let (log, trace, neko) = &mut *o;
            if let Some(f) = log.as_mut() {
                f.line(&neko.line(r));
            }
            if let Some(f) = trace.as_mut() {
                f.line(&to_json(r).to_string());
            }
        })
    };
    let robots = built.robots.len();
    let started = Instant::now();
    let out = nekosim_actors::run(SimConfig {
        seed: built.seed,
        until: built.until,
        world: built.world,
        robots: built.robots,
        arbiters: built.arbiters,
        record: false,
        observers: Observers {
            keep: false,
            sink: Some(sink),
            progress: opts.progress,
        },
        comms: built.comms,
    })?;
    let wall_seconds = started.elapsed().as_secs_f64();
    let (log, trace, _) = Rc::try_unwrap(outputs)
        .map_err(|_| SimError::System("an output is still in use".into()))?
        .into_inner();
    for (file, path) in [(log, &opts.log), (trace, &opts.trace)] {
        if let (Some(f), Some(p)) = (file, path) {
            f.commit().map_err(|source| RunError::WriteOutput {
                path: p.display().to_string(),
                source,
            })?;
        }
    }
    Ok(Summary {
        name: built.name,
        seed: built.seed,
        robots,
        events: out.stats.events,
        cancelled: out.stats.cancelled,
        collisions: out.stats.collisions,
        end_time: out.stats.end_time,
        wall_seconds,
    })
}
