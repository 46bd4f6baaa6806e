//! Running a sweep: every (point, seed) pair of the [`Plan`] (or of one shard), `jobs` at a
//! time, each an ordinary run whose metrics become a [`Row`]. Rows come back in run order
//! whatever order the runs finish in, so the outputs do not depend on the scheduling.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use super::file::Sweep;
use super::{metric, Row};
use crate::runner::{self, RunOptions};
use crate::scenario::{Overrides, Registry};

/// A sweep's progress report: (runs done, runs to do, failing so far).
pub type Progress = Box<dyn Fn(usize, usize, usize) + Sync>;

/// How a sweep runs.
#[derive(Default)]
pub struct SweepOptions {
    /// Runs at a time (at least 1).
    pub jobs: usize,
    /// Run only the runs `I mod N` (`Some((I, N))`).
    pub shard: Option<(usize, usize)>,
    /// Called after each run.
    pub progress: Option<Progress>,
    /// Set (e.g. on Ctrl-C) to stop: runs under way end, none start.
    pub stop: Option<Arc<AtomicBool>>,
}

impl std::fmt::Debug for SweepOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SweepOptions")
            .field("jobs", &self.jobs)
            .field("shard", &self.shard)
            .finish()
    }
}

/// What a sweep did.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// The rows of the runs done, in run order.
    pub rows: Vec<Row>,
    /// Runs that did not pass (an error or a failing check).
    pub failing: usize,
    /// Runs that ended with an error.
    pub errors: usize,
    /// Whether the sweep was stopped before every run was done.
    pub interrupted: bool,
}

/// Runs `sweep`'s runs (or its shard's), `jobs` at a time.
pub fn run(sweep: &Sweep, registry: &Registry, opts: &SweepOptions) -> Outcome {
    let plan = &sweep.plan;
    let checks = plan.parsed_checks();
    let todo: Vec<usize> = (0..plan.runs())
        .filter(|r| opts.shard.is_none_or(|(i, n)| r % n == i))
        .collect();
    let stop = opts.stop.clone().unwrap_or_default();
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let failing = AtomicUsize::new(0);
    let slots: Mutex<Vec<Option<Row>>> = Mutex::new(vec![None; todo.len()]);
    let worker = || loop {
        if stop.load(Ordering::Relaxed) {
            break;
        }
        let k = next.fetch_add(1, Ordering::Relaxed);
        let Some(&r) = todo.get(k) else { break };
        let Some(row) = run_one(sweep, registry, r, &stop) else {
            break;
        };
        if !row.ok(plan, &checks) {
            failing.fetch_add(1, Ordering::Relaxed);
        }
        slots.lock().expect("no run panics while holding the lock")[k] = Some(row);
        let d = done.fetch_add(1, Ordering::Relaxed) + 1;
        if let Some(p) = &opts.progress {
            p(d, todo.len(), failing.load(Ordering::Relaxed));
        }
    };
    std::thread::scope(|s| {
        for _ in 1..opts.jobs.max(1) {
            s.spawn(worker);
        }
        worker();
    });
    let slots = slots.into_inner().expect("workers ended");
    let interrupted = slots.iter().any(Option::is_none);
    let rows: Vec<Row> = slots.into_iter().flatten().collect();
    Outcome {
        failing: rows.iter().filter(|r| !r.ok(plan, &checks)).count(),
        errors: rows.iter().filter(|r| r.error.is_some()).count(),
        rows,
        interrupted,
    }
}

/// Runs number `run`; `None` when it was stopped before its end.
fn run_one(sweep: &Sweep, registry: &Registry, run: usize, stop: &Arc<AtomicBool>) -> Option<Row> {
    let plan = &sweep.plan;
    let (point, seed) = plan.run_of(run);
    let failed = |error: String| Row {
        run,
        values: vec![None; plan.columns.len()],
        error: Some(error),
    };
    let source = match &sweep.points[point] {
        Ok(s) => s,
        Err(e) => return Some(failed(e.clone())),
    };
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let built = source
            .build(
                Overrides {
                    seed: Some(seed),
                    until: None,
                },
                registry,
            )
            .map_err(|e| e.to_string())?;
        runner::run(
            built,
            RunOptions {
                stop: Some(stop.clone()),
                ..RunOptions::default()
            },
        )
        .map_err(|e| one_line(&e))
    }));
    Some(match outcome {
        Ok(Ok(summary)) if summary.interrupted => return None,
        Ok(Ok(summary)) => Row {
            run,
            values: plan
                .columns
                .iter()
                .map(|m| metric::value(m, &summary))
                .collect(),
            error: None,
        },
        Ok(Err(e)) => failed(e),
        Err(panic) => failed(format!(
            "panic: {}",
            panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("(no message)")
        )),
    })
}

/// An error and its causes on one line.
fn one_line(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(c) = source {
        s.push_str(&format!(": {c}"));
        source = c.source();
    }
    s.replace('\n', " ")
}
