//! A check from Python (docs/check.md): `nekosim check` of a scenario's protocol stack (or a
//! shipped model) with the command's options, its report as the command prints it, how it
//! concluded, and the counterexample's (or witness's) records as Arrow columns, the records
//! `nekosim check --trace` writes.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};

use nekosim::check::{self, CheckArgs, CheckError, Conclusion, Live};
use nekosim::models::{NetworkKind, Strategy};
use nekosim::scenario::Source;

use crate::algorithm::Hosted;
use crate::columns::ArrowBatch;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

use serde_json::Value;

/// A finished check: the report, the exit code it stands for, the trace's records.
#[derive(Debug)]
#[pyclass(module = "nekosim._nekosim", frozen)]
pub struct CheckCore {
    /// The report, as `nekosim check` prints it.
    #[pyo3(get)]
    report: String,
    /// The command's exit code for this conclusion: 0 holds, 1 fails, 3 unsettled.
    #[pyo3(get)]
    code: u8,
    records: Vec<Value>,
}

/// A file of this process's own in the temporary directory, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Self {
        static NEXT: AtomicU64 = AtomicU64::new(0);
        Self(std::env::temp_dir().join(format!(
            "nekosim-check-{}-{}.jsonl",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        )))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

fn bad(message: String) -> PyErr {
    PyValueError::new_err(message)
}

/// Runs `nekosim check MODEL` with the options given (each `None` as the command's default).
#[pyfunction]
#[pyo3(signature = (model, layer = None, processes = None, requests = None, crashes = None,
    network = None, strategy = "bfs", seed = 0, max_states = None, max_memory = None,
    depth = None, threads = 1, timers = None, rounds = None, symmetry = false,
    keep_going = false, rrd = None, goals = None, algorithms = Vec::new()))]
#[allow(clippy::too_many_arguments)]
pub fn check_core(
    py: Python<'_>,
    model: String,
    layer: Option<String>,
    processes: Option<u32>,
    requests: Option<u32>,
    crashes: Option<u32>,
    network: Option<&str>,
    strategy: &str,
    seed: u64,
    max_states: Option<usize>,
    max_memory: Option<&str>,
    depth: Option<usize>,
    threads: usize,
    timers: Option<u32>,
    rounds: Option<u64>,
    symmetry: bool,
    keep_going: bool,
    rrd: Option<PathBuf>,
    goals: Option<Vec<String>>,
    algorithms: Vec<(String, Py<PyAny>)>,
) -> PyResult<CheckCore> {
    let goals = goals
        .unwrap_or_default()
        .iter()
        .map(|g| check::lcm_search::parse_goal(g))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| bad(format!("goals: {e}")))?;
    let network = match network {
        None => None,
        Some("unordered") => Some(NetworkKind::Unordered),
        Some("ordered") => Some(NetworkKind::Ordered),
        Some("lossy") => Some(NetworkKind::Lossy),
        Some(other) => {
            return Err(bad(format!(
                "network {other:?}: expected \"unordered\", \"ordered\" or \"lossy\""
            )))
        }
    };
    let strategy = match strategy {
        "bfs" => Strategy::Bfs,
        "dfs" => Strategy::Dfs,
        "simulation" => Strategy::Simulation { seed },
        other => {
            return Err(bad(format!(
                "strategy {other:?}: expected \"bfs\", \"dfs\" or \"simulation\""
            )))
        }
    };
    let max_memory = max_memory
        .map(check::parse_size)
        .transpose()
        .map_err(|e| bad(format!("max_memory: {e}")))?;
    let trace = Scratch::new();
    let args = CheckArgs {
        model,
        layer,
        processes,
        requests,
        crashes,
        network,
        depth,
        threads,
        trace: Some(trace.0.clone()),
        rrd,
        timers,
        rounds,
        strategy,
        max_states,
        max_memory,
        symmetry,
        keep_going,
        goals,
        ..CheckArgs::default()
    };
    let mut out = Vec::new();
    let hosted = Hosted::new(algorithms);
    let outcome = py.detach(|| {
        let registry = crate::run::registry();
        // A Look-Compute-Move scenario naming Python algorithms is searched with them in
        // place, through the very hosts a run uses.
        if !hosted.algorithms.is_empty() && std::path::Path::new(&args.model).is_file() {
            let mut source = Source::load(std::path::Path::new(&args.model))?;
            hosted.rewrite(&mut source);
            if source.scenario.lcm.is_some() && source.scenario.stack.is_empty() {
                let watch = check::lcm::Watch {
                    max_memory: args.max_memory.or_else(check::default_memory_budget),
                    interrupt: None,
                };
                return hosted.building(|| {
                    check::lcm_search::check(&source, &registry, &args, &watch, &mut out)
                });
            }
        }
        check::check_live(&args, &registry, &mut out, &Live::default())
    });
    if let Some(e) = hosted.take_error() {
        return Err(e);
    }
    let conclusion = match outcome {
        Ok(c) => c,
        Err(CheckError::Scenario(e)) => return Err(crate::scenario_error(py, &e)),
        Err(CheckError::Recording(e)) if !e.is_input_error() => {
            return Err(PyRuntimeError::new_err(e.to_string()))
        }
        Err(e) => return Err(crate::error(py, e.to_string(), None, None, None)),
    };
    // No trace file: nothing failed and nothing was witnessed.
    let text = std::fs::read_to_string(&trace.0).unwrap_or_default();
    let records = text
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(serde_json::from_str)
        .collect::<Result<Vec<Value>, _>>()
        .map_err(|e| PyRuntimeError::new_err(format!("the check's trace: {e}")))?;
    Ok(CheckCore {
        report: String::from_utf8_lossy(&out).into_owned(),
        code: match conclusion {
            Conclusion::Holds => 0,
            other => other.exit_code(),
        },
        records,
    })
}

#[pymethods]
impl CheckCore {
    /// The counterexample's (or witness's) records as one Arrow record batch.
    fn trace(&self, py: Python<'_>) -> PyResult<ArrowBatch> {
        py.detach(|| crate::columns::batch(&self.records))
            .map(ArrowBatch)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    fn __len__(&self) -> usize {
        self.records.len()
    }
}
