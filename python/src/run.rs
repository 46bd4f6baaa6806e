//! A run from Python: the scenario built with the Python algorithms in place, run by the
//! runner the command line uses (the same records, summary and recording), its records kept
//! as the engine made them. The trace's Arrow columns, the Neko log's lines and every robot's
//! kinematic states, from which [`RunCore::positions`] gives the exact positions at any
//! instant (docs/trace.md, "Rebuilding trajectories"), are made from the records when first
//! asked for.

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::{Arc, OnceLock};

use arrow_array::RecordBatch;
use nekosim::lcm::Lcm;
use nekosim::log::NekoLog;
use nekosim::protocols::codec::{install, Codecs};
use nekosim::recording::Target;
use nekosim::runner::{self, RunError, RunOptions, Summary};
use nekosim::scenario::{Overrides, Registry, ScenarioError, Source};
use nekosim::world::observation::{Observation, Record};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::algorithm::{Hosted, PyLcm, HOST_NAME, ROBOT_HOST_NAME};
use crate::columns::ArrowBatch;
use crate::robot::PyRobot;

/// A robot's kinematic state from `t` on: `pos + vel (t' - t)`.
#[derive(Clone, Copy, Debug)]
struct State {
    t: f64,
    pos: (f64, f64),
    vel: (f64, f64),
}

/// What the run leaves behind: its records as the engine made them. The trace's columns, the
/// log's lines and the robots' trajectories are views of them, each made when first asked for.
#[derive(Debug)]
struct Kept {
    records: Vec<Record>,
    /// How the stack's messages render, in the trace and the log.
    codecs: Arc<Codecs>,
    /// The log's lines before the first record's.
    obstacles: Vec<String>,
    log: OnceLock<Vec<String>>,
    states: OnceLock<BTreeMap<u32, Vec<State>>>,
}

impl Kept {
    /// The Neko log's lines.
    fn log(&self) -> &[String] {
        self.log.get_or_init(|| {
            // Messages render through the stack's codecs, as in the trace and the log.
            let _codecs = install(&self.codecs);
            let mut neko = NekoLog::new();
            let mut lines = self.obstacles.clone();
            lines.extend(self.records.iter().filter_map(|r| neko.line(r)));
            lines
        })
    }

    /// The trace as one record batch.
    fn trace(&self) -> Result<RecordBatch, arrow_schema::ArrowError> {
        let _codecs = install(&self.codecs);
        crate::columns::batch(&self.records)
    }

    /// Every robot's kinematic states, in time order.
    fn states(&self) -> &BTreeMap<u32, Vec<State>> {
        self.states.get_or_init(|| {
            let mut states: BTreeMap<u32, Vec<State>> = BTreeMap::new();
            for r in &self.records {
                let (robot, pos, vel) = match &r.obs {
                    Observation::Spawn { robot, pos, .. } => (*robot, *pos, Default::default()),
                    Observation::MotionStep { robot, state, .. }
                    | Observation::MotionFinish { robot, state, .. }
                    | Observation::Crash { robot, state } => (*robot, state.pos, state.vel),
                    _ => continue,
                };
                states.entry(robot).or_default().push(State {
                    t: r.t,
                    pos: (pos.x, pos.y),
                    vel: (vel.x, vel.y),
                });
            }
            states
        })
    }
}

/// Why a run from Python failed.
enum Failure {
    Scenario(ScenarioError),
    Run(RunError),
}

/// A finished run: its summary, records, log and trajectories.
#[derive(Debug)]
#[pyclass(module = "nekosim._nekosim", frozen)]
pub struct RunCore {
    summary: Summary,
    kept: Kept,
}

/// The registry of runs and checks from Python: the built-ins and the hosts of Python
/// algorithms ([`Hosted::rewrite`] points a scenario's Python algorithms at them).
pub fn registry() -> Registry {
    let mut registry = Registry::new();
    registry.algorithm::<Lcm<PyLcm>>(HOST_NAME);
    registry.algorithm::<PyRobot>(ROBOT_HOST_NAME);
    registry
}

/// Runs scenario `text` (named `file`) with the Python algorithms `algorithms`.
pub fn execute(
    py: Python<'_>,
    file: String,
    text: String,
    overrides: Overrides,
    algorithms: Vec<(String, Py<PyAny>)>,
    rrd: Option<PathBuf>,
) -> PyResult<RunCore> {
    let hosted = Hosted::new(algorithms);
    let inner = hosted.clone();
    // The engine calls Python algorithms from its own threads too (`arbiters`): the run holds
    // no Python lock, and each `compute` takes it.
    let outcome = py.detach(move || -> Result<(Summary, Kept), Failure> {
        let mut source = Source::parse(&file, &text).map_err(Failure::Scenario)?;
        inner.rewrite(&mut source);
        let registry = registry();
        let built = inner
            .building(|| source.build(overrides, &registry))
            .map_err(Failure::Scenario)?;
        let codecs = built.codecs.clone();
        let obstacles = nekosim::log::obstacle_lines(&built.world.obstacles);
        let records = Rc::new(RefCell::new(Vec::new()));
        let observe = {
            let records = records.clone();
            Box::new(move |r: &Record| records.borrow_mut().push(r.clone()))
        };
        let summary = runner::run_observed(
            built,
            RunOptions {
                recording: Target { rrd, connect: None },
                stop: Some(inner.stop.clone()),
                ..RunOptions::default()
            },
            Some(observe),
        )
        .map_err(Failure::Run)?;
        let kept = Kept {
            records: std::mem::take(&mut *records.borrow_mut()),
            codecs,
            obstacles,
            log: OnceLock::new(),
            states: OnceLock::new(),
        };
        Ok((summary, kept))
    });
    // The run is over: seed-style algorithms still waiting for a call end.
    let ending = hosted.clone();
    py.detach(move || ending.end());
    if let Some(e) = hosted.take_error() {
        return Err(e);
    }
    match outcome {
        Ok((summary, kept)) => Ok(RunCore { summary, kept }),
        Err(Failure::Scenario(e)) => Err(crate::scenario_error(py, &e)),
        Err(Failure::Run(e @ RunError::CreateOutput { .. })) => {
            Err(crate::error(py, e.to_string(), None, None, None))
        }
        Err(Failure::Run(RunError::Recording(e))) if e.is_input_error() => {
            Err(crate::error(py, e.to_string(), None, None, None))
        }
        Err(Failure::Run(e)) => Err(pyo3::exceptions::PyRuntimeError::new_err(e.to_string())),
    }
}

#[pymethods]
impl RunCore {
    /// The figures `nekosim run` prints, as a dict.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = &self.summary;
        let d = PyDict::new(py);
        d.set_item("name", &s.name)?;
        d.set_item("seed", s.seed)?;
        d.set_item("robots", s.robots)?;
        d.set_item("events", s.events)?;
        d.set_item("cancelled", s.cancelled)?;
        d.set_item("collisions", s.collisions)?;
        d.set_item("end_time", s.end_time)?;
        d.set_item("wall_seconds", s.wall_seconds)?;
        d.set_item("events_per_second", s.events_per_second())?;
        d.set_item("interrupted", s.interrupted)?;
        let c = &s.counts;
        let counts = PyDict::new(py);
        for (k, v) in [
            ("sent", c.sent),
            ("lost", c.lost),
            ("received", c.received),
            ("delivered", c.delivered),
            ("decisions", c.decisions),
            ("decided", c.decided),
            ("suspicions", c.suspicions),
            ("crashes", c.crashes),
        ] {
            counts.set_item(k, v)?;
        }
        d.set_item("counts", counts)?;
        match &s.latency {
            Some(l) => {
                let ld = PyDict::new(py);
                ld.set_item("deliveries", l.deliveries)?;
                ld.set_item("mean", l.mean)?;
                ld.set_item("p50", l.p50)?;
                ld.set_item("p99", l.p99)?;
                ld.set_item("throughput", l.throughput)?;
                d.set_item("latency", ld)?;
            }
            None => d.set_item("latency", py.None())?,
        }
        let predicates: Vec<String> = s.predicates.iter().map(|p| p.text()).collect();
        d.set_item("predicates", predicates)?;
        Ok(d)
    }

    /// The Neko log's lines, as `nekosim run --log` writes them.
    #[getter]
    fn log(&self, py: Python<'_>) -> Vec<String> {
        py.detach(|| self.kept.log().to_vec())
    }

    /// How many records the run made.
    fn __len__(&self) -> usize {
        self.kept.records.len()
    }

    /// The trace as one Arrow record batch (see the `columns` module).
    fn trace(&self, py: Python<'_>) -> PyResult<ArrowBatch> {
        py.detach(|| self.kept.trace())
            .map(ArrowBatch)
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
    }

    /// Every robot's position at simulated time `t`, from its last kinematic state at or
    /// before `t`: `(robots, xs, ys)`, robots in increasing id order, robots not yet born
    /// left out.
    fn positions(&self, py: Python<'_>, t: f64) -> (Vec<u32>, Vec<f64>, Vec<f64>) {
        let mut out = (Vec::new(), Vec::new(), Vec::new());
        for (robot, states) in py.detach(|| self.kept.states()) {
            let k = states.partition_point(|s| s.t <= t);
            let Some(s) = k.checked_sub(1).map(|k| states[k]) else {
                continue;
            };
            let dt = t - s.t;
            out.0.push(*robot);
            out.1.push(s.pos.0 + s.vel.0 * dt);
            out.2.push(s.pos.1 + s.vel.1 * dt);
        }
        out
    }
}
