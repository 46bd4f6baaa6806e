//! Running a built scenario with its outputs: the Neko log and the JSONL trace are streamed to
//! files that appear only when the run succeeded (see [`crate::output`]); a Rerun recording
//! ([`crate::recording`]) is drawn from the same records and is complete whenever the run
//! started, also when it failed.

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;
use std::time::Instant;

use nekosim_actors::scheduler::Observers;
use nekosim_actors::world::observation::{Observation, Record};
use nekosim_actors::{SimConfig, SimError};
use nekosim_protocols::codec::{install, Codecs};

use crate::log::NekoLog;
use crate::output::AtomicFile;
use crate::recording::{RecordingError, Target};
use crate::scenario::Built;
use crate::trace::to_line;
use nekosim_actors::lcm::predicate::{Monitor, Report};

/// Where a run writes and who watches it.
#[derive(Default)]
pub struct RunOptions {
    pub log: Option<PathBuf>,
    pub trace: Option<PathBuf>,
    /// Where a Rerun recording goes, if anywhere.
    pub recording: Target,
    /// Called with the virtual time now and then.
    pub progress: Option<Box<dyn FnMut(f64, u64)>>,
    /// Called while the run starts with the robots spawned so far and their number.
    pub startup: Option<Box<dyn FnMut(usize, usize)>>,
    /// Set (e.g. on Ctrl-C) to end the run at the virtual time reached; the outputs are then
    /// written as for a run that ended there, and [`Summary::interrupted`] says so.
    pub stop: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    /// The process exits after this run (`nekosim run`): the run's actors, world and queue
    /// are left to the exit instead of being dropped ([`nekosim_actors::run_then_exit`]:
    /// dropping a million robots' state frees millions of allocations for nothing). Never for
    /// a run that others follow in the same process, such as a sweep's.
    pub exit_after: bool,
    /// A document shown beside the recording's drawings, in Markdown (what a replayed
    /// counterexample is and where its cycle lies).
    pub note: Option<String>,
    /// Instants the recording marks on its timeline [s], each with a line saying what
    /// happens there.
    pub milestones: Vec<(f64, String)>,
}

impl std::fmt::Debug for RunOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunOptions")
            .field("log", &self.log)
            .field("trace", &self.trace)
            .field("recording", &self.recording)
            .field("stop", &self.stop)
            .field("exit_after", &self.exit_after)
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
    /// Delivery latency of messages broadcast by the algorithms, if any were delivered.
    pub latency: Option<Latency>,
    /// Whether the run was stopped before its end ([`RunOptions::stop`]).
    pub interrupted: bool,
    /// Messages, deliveries, decisions and crashes counted over the run.
    pub counts: Counts,
    /// When each of the scenario's predicates first held, and whether it kept holding.
    pub predicates: Vec<Report>,
}

/// What the run's communication and faults amounted to, counted from its records.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Counts {
    /// Message copies handed to the network (one per receiver), every layer.
    pub sent: u64,
    /// Copies the network lost (no arrival time at the send).
    pub lost: u64,
    /// Copies received.
    pub received: u64,
    /// Deliveries of broadcast layers (one per message per delivering robot).
    pub delivered: u64,
    /// Decisions of consensus layers (one per instance per deciding robot).
    pub decisions: u64,
    /// Robots that decided at least once and had not crashed by the end (so that `decided ==
    /// live_robots` says every correct robot decided).
    pub decided: u64,
    /// Suspicions raised by failure detectors.
    pub suspicions: u64,
    /// Robots that crashed.
    pub crashes: u64,
    deciders: std::collections::BTreeSet<u32>,
    crashed: std::collections::BTreeSet<u32>,
}

impl Counts {
    fn observe(&mut self, r: &Record) {
        match &r.obs {
            Observation::Send { to, arrive, .. } => {
                self.sent += to.len() as u64;
                self.lost += arrive.iter().filter(|a| a.is_none()).count() as u64;
            }
            Observation::Receive { .. } => self.received += 1,
            Observation::Deliver { .. } => self.delivered += 1,
            Observation::Decide { robot, .. } => {
                self.decisions += 1;
                self.deciders.insert(*robot);
            }
            Observation::Suspect { .. } => self.suspicions += 1,
            Observation::Crash { robot, .. } => {
                self.crashes += 1;
                self.crashed.insert(*robot);
            }
            _ => {}
        }
    }

    /// The counts once the run is over.
    fn settle(mut self) -> Self {
        self.decided = self.deciders.difference(&self.crashed).count() as u64;
        self
    }
}

/// Delivery latency and throughput of broadcasts (Neko's latency test), in simulated time.
#[derive(Clone, Debug, PartialEq)]
pub struct Latency {
    /// Deliveries counted (one per message per delivering robot).
    pub deliveries: usize,
    pub mean: f64,
    pub p50: f64,
    pub p99: f64,
    /// Deliveries per simulated second between the first broadcast and the last delivery.
    pub throughput: f64,
}

/// Matches deliveries to the broadcasts that caused them: broadcast number `n` of robot `o`
/// on a layer is the message with id `o:n` on that layer.
#[derive(Debug, Default)]
struct LatencyMeter {
    counts: std::collections::HashMap<(String, u32), u64>,
    sent: std::collections::HashMap<(String, u32, u64), f64>,
    samples: Vec<f64>,
    first: Option<f64>,
    last: f64,
}

impl LatencyMeter {
    fn observe(&mut self, r: &Record) {
        match &r.obs {
            Observation::Request {
                robot, layer, op, ..
            } if op == "broadcast" => {
                let n = self.counts.entry((layer.clone(), *robot)).or_insert(0);
                self.sent.insert((layer.clone(), *robot, *n), r.t);
                *n += 1;
                self.first.get_or_insert(r.t);
            }
            Observation::Deliver { layer, id, .. } => {
                if let Some(t0) = self.sent.get(&(layer.clone(), id.origin, id.n)) {
                    self.samples.push(r.t - t0);
                    self.last = r.t;
                }
            }
            _ => {}
        }
    }

    fn finish(mut self) -> Option<Latency> {
        if self.samples.is_empty() {
            return None;
        }
        self.samples.sort_by(f64::total_cmp);
        let n = self.samples.len();
        let rank = |q: f64| self.samples[((q * n as f64).ceil() as usize).clamp(1, n) - 1];
        let span = self.last - self.first.unwrap_or(0.0);
        Some(Latency {
            deliveries: n,
            mean: self.samples.iter().sum::<f64>() / n as f64,
            p50: rank(0.5),
            p99: rank(0.99),
            throughput: if span > 0.0 { n as f64 / span } else { 0.0 },
        })
    }
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
    #[error("{path}: cannot create the output file: {error}")]
    CreateOutput { path: String, error: std::io::Error },
    /// An output file could not be written (an internal error; nothing is left behind).
    /// (The causes are in the messages, not `source`s, so that error chains print them once.)
    #[error("{path}: cannot write the output file: {error}")]
    WriteOutput { path: String, error: std::io::Error },
    /// The simulation failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The Rerun recording failed (its variants say whether it is the user's input).
    #[error(transparent)]
    Recording(#[from] RecordingError),
}

fn create(path: &Option<PathBuf>) -> Result<Option<AtomicFile>, RunError> {
    path.as_deref()
        .map(|p: &Path| {
            AtomicFile::create(p).map_err(|error| RunError::CreateOutput {
                path: p.display().to_string(),
                error,
            })
        })
        .transpose()
}

/// Runs `built`, writing the requested outputs.
pub fn run(built: Built, opts: RunOptions) -> Result<Summary, RunError> {
    run_observed(built, opts, None)
}

/// What [`run_observed`] calls with every record.
pub type Observe = Box<dyn FnMut(&Record)>;

/// [`run`], also calling `observe` with every record in order, beside the outputs (the Python
/// bindings keep a run's records this way).
pub fn run_observed(
    built: Built,
    opts: RunOptions,
    mut observe: Option<Observe>,
) -> Result<Summary, RunError> {
    let mut log = create(&opts.log)?;
    if let Some(f) = log.as_mut() {
        for line in crate::log::obstacle_lines(&built.world.obstacles) {
            f.line(&line);
        }
    }
    let trace = create(&opts.trace)?;
    let mut recorder = start_recording(&built, &opts.recording)?;
    if let (Some(r), Some(note)) = (recorder.as_mut(), &opts.note) {
        crate::recording::Canvas::note(r.canvas_mut(), note);
    }
    if let Some(r) = recorder.as_mut() {
        for (t, text) in &opts.milestones {
            let at = crate::recording::Stamp { t: *t, seq: None };
            crate::recording::Canvas::milestone(r.canvas_mut(), at, text);
        }
    }
    // Counting messages, decisions and crashes for the summary reads no robot's step records;
    // everything else that may be here does.
    let summary_only = observe.is_none()
        && log.is_none()
        && trace.is_none()
        && recorder.is_none()
        && built.predicates.is_empty();
    let outputs = Rc::new(RefCell::new((
        log,
        trace,
        NekoLog::new(),
        LatencyMeter::default(),
        Counts::default(),
        Monitor::new(built.predicates.clone()),
    )));
    let codecs = built.codecs.clone();
    let recorder = recorder
        .map(|r| Background::start(r, codecs.clone()))
        .transpose()?;
    let recorder = Rc::new(RefCell::new(recorder));
    let sink = {
        let outputs = outputs.clone();
        let recorder = recorder.clone();
        Box::new(move |r: &Record| {
            if let Some(f) = observe.as_mut() {
                f(r);
            }
            let mut o = outputs.borrow_mut();
            let (log, trace, neko, meter, counts, monitor) = &mut *o;
            meter.observe(r);
            counts.observe(r);
            monitor.observe(r);
            let mut recorder = recorder.borrow_mut();
            // Messages render through the stack's codecs, in the outputs that write them
            // (installing them for every record of a run without such outputs would be work
            // for nothing).
            let _codecs =
                (log.is_some() || trace.is_some() || recorder.is_some()).then(|| install(&codecs));
            if let Some(rec) = recorder.as_mut() {
                rec.record(r);
            }
            if let Some(f) = log.as_mut() {
                if let Some(line) = neko.line(r) {
                    f.line(&line);
                }
            }
            if let Some(f) = trace.as_mut() {
                f.line(&to_line(r));
            }
        })
    };
    let robots = built.robots.len();
    let started = Instant::now();
    let host = if opts.exit_after {
        nekosim_actors::run_then_exit
    } else {
        nekosim_actors::run
    };
    let out = host(SimConfig {
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
            startup: opts.startup,
            stop: opts.stop,
            summary_only,
        },
        comms: built.comms,
        sensors: built.sensors,
    });
    let wall_seconds = started.elapsed().as_secs_f64();
    // The recording is finished whatever the outcome: a failed run's recording shows what
    // happened up to the failure.
    let end = out.as_ref().map_or(f64::NAN, |o| o.stats.end_time);
    let recorded = recorder
        .borrow_mut()
        .take()
        .map_or(Ok(()), |r| r.finish(end));
    let out = out?;
    recorded?;
    let (log, trace, _, meter, counts, mut monitor) = Rc::try_unwrap(outputs)
        .map_err(|_| SimError::System("an output is still in use".into()))?
        .into_inner();
    for (file, path) in [(log, &opts.log), (trace, &opts.trace)] {
        if let (Some(f), Some(p)) = (file, path) {
            f.commit().map_err(|error| RunError::WriteOutput {
                path: p.display().to_string(),
                error,
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
        latency: meter.finish(),
        interrupted: out.stats.interrupted,
        counts: counts.settle(),
        predicates: monitor.reports(),
    })
}

#[cfg(feature = "rerun")]
type Recorder = crate::recording::Recorder<crate::recording::rerun_canvas::RerunCanvas>;

/// Without Rerun there is never a recorder.
#[cfg(not(feature = "rerun"))]
type Recorder = crate::recording::Recorder<crate::recording::NoCanvas>;

#[cfg(feature = "rerun")]
fn start_recording(built: &Built, target: &Target) -> Result<Option<Recorder>, RunError> {
    if !target.is_some() {
        return Ok(None);
    }
    // The recording id: what names the run (recordings of one run are one recording).
    let id = format!(
        "{} seed {} until {} robots {}",
        built.name,
        built.seed,
        built.until,
        built.robots.len()
    );
    let world = built.view;
    let layout = crate::recording::rerun_canvas::Layout::run(
        world,
        built.robots.len(),
        (built.messages, built.deliveries),
        built.labels,
        built.until,
    );
    let canvas =
        crate::recording::rerun_canvas::RerunCanvas::start(&built.name, &id, target, &layout)?;
    let mut recorder = crate::recording::Recorder::new(canvas, &built.world.size, built.framerate);
    recorder.obstacles(&built.world.obstacles);
    Ok(Some(recorder))
}

#[cfg(not(feature = "rerun"))]
fn start_recording(_: &Built, target: &Target) -> Result<Option<Recorder>, RunError> {
    if target.is_some() {
        return Err(RecordingError::Unsupported.into());
    }
    Ok(None)
}

/// Records sent to the recording thread at a time.
const RECORD_BATCH: usize = 1024;

/// Batches of records in flight to the recording thread before the run waits for it.
const BATCHES_IN_FLIGHT: usize = 16;

/// What the run sends the recording thread.
enum ToRecorder {
    Records(Vec<Record>),
    /// The run ended at this simulated time: finish the recording.
    Finish(f64),
}

/// The recorder on its own thread: the run hands it copies of the records in batches, so
/// drawing and Rerun's encoding overlap with the simulation, and the thread also finishes the
/// recording (docs/performance.md).
struct Background {
    batch: Vec<Record>,
    tx: Option<std::sync::mpsc::SyncSender<ToRecorder>>,
    thread: Option<std::thread::JoinHandle<Result<(), RecordingError>>>,
}

impl Background {
    fn start(mut recorder: Recorder, codecs: Arc<Codecs>) -> Result<Self, RunError> {
        let (tx, rx) = std::sync::mpsc::sync_channel::<ToRecorder>(BATCHES_IN_FLIGHT);
        let thread = std::thread::Builder::new()
            .name("nekosim-recording".into())
            .spawn(move || {
                let _codecs = install(&codecs);
                for msg in rx {
                    match msg {
                        ToRecorder::Records(batch) => {
                            for r in &batch {
                                recorder.record(r);
                            }
                        }
                        ToRecorder::Finish(end) => return finish_recording(recorder, end),
                    }
                }
                // The run went away without finishing (it panicked): dropping the recorder
                // still completes the file.
                Ok(())
            })
            .map_err(|e| {
                RecordingError::Rerun(format!("cannot start the recording thread: {e}"))
            })?;
        Ok(Self {
            batch: Vec::with_capacity(RECORD_BATCH),
            tx: Some(tx),
            thread: Some(thread),
        })
    }

    fn record(&mut self, r: &Record) {
        self.batch.push(r.clone());
        if self.batch.len() >= RECORD_BATCH {
            self.send();
        }
    }

    fn send(&mut self) {
        if self.batch.is_empty() {
            return;
        }
        let batch = std::mem::replace(&mut self.batch, Vec::with_capacity(RECORD_BATCH));
        // A closed channel means the thread panicked; `finish` reports it.
        if let Some(tx) = &self.tx {
            if tx.send(ToRecorder::Records(batch)).is_err() {
                self.tx = None;
            }
        }
    }

    /// Hands over the remaining records, has the thread finish the recording at simulated time
    /// `end`, and waits for it; a panic on the recording thread is resumed here.
    fn finish(mut self, end: f64) -> Result<(), RecordingError> {
        self.send();
        if let Some(tx) = self.tx.take() {
            let _ = tx.send(ToRecorder::Finish(end));
        }
        let Some(thread) = self.thread.take() else {
            return Ok(());
        };
        match thread.join() {
            Ok(r) => r,
            Err(panic) => std::panic::resume_unwind(panic),
        }
    }
}

impl Drop for Background {
    fn drop(&mut self) {
        // Unwinding without `finish`: let the thread end, so the recorder (and its file) is
        // dropped in order.
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Draws the last frames and completes the recording.
fn finish_recording(mut r: Recorder, end: f64) -> Result<(), RecordingError> {
    r.finish(end);
    #[cfg(feature = "rerun")]
    r.canvas_mut().finish()?;
    Ok(())
}
