//! Parameter sweeps and replications (docs/sweeps.md): a sweep file names a scenario, axes
//! (paths into it, each with its values), seeds, metrics and checks; `nekosim sweep` runs every
//! (point, seed) pair, `--jobs` at a time, and writes one CSV row per run, the statistics of
//! each point, the failing runs with the command that replays each, and a plot per metric.
//!
//! This goes past the seed, whose experiments (chapter 5) are single runs; it is how its
//! figures (e.g. the latency test of 5.3) would be produced over many seeds.
//!
//! Every output byte is a function of the sweep file, the scenario and the binary: runs are
//! numbered point-major (`run = point * seeds + seed index`, the first axis varying slowest),
//! rows are written in that order, and wall-clock time goes only to the terminal. `--shard
//! I/N` runs the runs whose number is I modulo N and writes them with a manifest
//! (`shard.json`); [`merge`] puts shards back together into the very files the whole sweep
//! writes.

pub mod metric;
pub mod plot;
pub mod stats;

use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};

use crate::output::write_whole;
use crate::runner::{self, RunOptions};
use crate::scenario::{edit, spans, Overrides, Pos, Registry, ScenarioError, Source};
use metric::{Check, METRICS};

/// One axis: a path into the scenario and the values (RON text) it takes.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Axis {
    pub path: String,
    pub values: Vec<String>,
}

/// Everything the outputs depend on besides the runs themselves; a shard's manifest carries
/// it, so shards merge without the sweep file.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Plan {
    /// The sweep file, as given on the command line.
    pub sweep: String,
    /// The scenario, as a path from where the sweep was started (for replay commands).
    pub scenario: String,
    pub axes: Vec<Axis>,
    pub seeds: Vec<u64>,
    /// The metrics of the CSV columns: those asked for, then those only the checks read.
    pub columns: Vec<String>,
    /// The metrics asked for (plotted and summarised first).
    pub metrics: Vec<String>,
    pub checks: Vec<String>,
    /// FNV-1a of the sweep file's and the scenario's text.
    pub fingerprint: String,
}

impl Plan {
    /// Number of points (the product of the axes' lengths; 1 without axes).
    pub fn points(&self) -> usize {
        self.axes.iter().map(|a| a.values.len()).product()
    }

    /// Number of runs.
    pub fn runs(&self) -> usize {
        self.points() * self.seeds.len()
    }

    /// The value index of each axis at `point`.
    pub fn coordinates(&self, point: usize) -> Vec<usize> {
        let mut rest = point;
        let mut out = vec![0; self.axes.len()];
        for (k, a) in self.axes.iter().enumerate().rev() {
            out[k] = rest % a.values.len();
            rest /= a.values.len();
        }
        out
    }

    /// `(point, seed)` of run `run`.
    pub fn run_of(&self, run: usize) -> (usize, u64) {
        (run / self.seeds.len(), self.seeds[run % self.seeds.len()])
    }

    /// The checks, parsed (they were checked when the sweep file was loaded).
    pub fn parsed_checks(&self) -> Vec<Check> {
        self.checks
            .iter()
            .filter_map(|c| Check::parse(c).ok())
            .collect()
    }

    /// The command that replays `run`, writing a recording to watch.
    pub fn replay(&self, run: usize) -> String {
        let (point, seed) = self.run_of(run);
        let mut cmd = format!("nekosim run {} --seed {seed}", quote(&self.scenario));
        for (a, i) in self.axes.iter().zip(self.coordinates(point)) {
            cmd.push_str(&format!(
                " --set {}",
                quote(&format!("{}={}", a.path, a.values[i]))
            ));
        }
        cmd.push_str(&format!(" --rrd run-{run}.rrd"));
        cmd
    }
}

/// `s` for a POSIX shell: as is when plain, else in single quotes.
fn quote(s: &str) -> String {
    if s.chars()
        .all(|c| c.is_ascii_alphanumeric() || "-_./:=,+".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// A sweep file loaded and checked, ready to run.
#[derive(Debug)]
pub struct Sweep {
    pub plan: Plan,
    /// Each point's scenario, or why it cannot be built (a row error for each of its runs).
    points: Vec<Result<Source, String>>,
}

/// The sweep file's shape (positions come from the text).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Sweep")]
struct Raw {
    scenario: String,
    seeds: Seeds,
    #[serde(default)]
    axes: BTreeMap<String, Vec<serde::de::IgnoredAny>>,
    #[serde(default)]
    metrics: Option<Vec<String>>,
    #[serde(default)]
    checks: Vec<String>,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum Seeds {
    Range { start: u64, count: u64 },
    List(Vec<u64>),
}

/// FNV-1a, 64 bits.
fn fnv1a(parts: &[&[u8]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in parts {
        for b in part.iter().chain(b"\0") {
            h ^= u64::from(*b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

/// The line and column of byte `at` of `text`.
fn pos_of(text: &str, at: usize) -> Pos {
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
    Pos { line, col }
}

/// `a/b/../c` as `a/c`, without touching the file system.
fn normalize(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir
                if matches!(out.components().next_back(), Some(Component::Normal(_))) =>
            {
                out.pop();
            }
            other => out.push(other),
        }
    }
    if out.as_os_str().is_empty() {
        out.push(".");
    }
    out
}

impl Sweep {
    /// Reads and checks the sweep file at `path`: its shape, the scenario, every axis path
    /// and value (each set alone into the scenario, which must then build), the seeds, the
    /// metrics and the checks. Every problem is reported at FILE:LINE:COL before any run.
    pub fn load(path: &Path, registry: &Registry) -> Result<Self, ScenarioError> {
        let (file, text) = crate::scenario::read_file(path, "sweep")?;
        let at = |pos: Option<Pos>, message: String| ScenarioError {
            file: file.clone(),
            pos,
            message,
        };
        let raw: Raw = crate::scenario::read_ron(&file, &text)?;
        let sp = spans(&text);
        let pos = |p: &str| sp.starts.get(p).copied();

        // The scenario, relative to the sweep file.
        let scenario_path = path.parent().unwrap_or(Path::new("")).join(&raw.scenario);
        let scenario_text = std::fs::read_to_string(&scenario_path).map_err(|e| {
            at(
                pos("scenario"),
                format!(
                    "cannot read the scenario {}: {e} (the path is relative to the sweep file)",
                    scenario_path.display()
                ),
            )
        })?;
        let scenario_file = normalize(&scenario_path).display().to_string();
        let base = Source::parse(&scenario_file, &scenario_text)?;
        base.build(Overrides::default(), registry)?;

        // Seeds.
        let seeds: Vec<u64> = match raw.seeds {
            Seeds::Range { start, count } => (0..count).map(|k| start + k).collect(),
            Seeds::List(v) => v,
        };
        if seeds.is_empty() {
            return Err(at(
                pos("seeds"),
                "no seeds; expected Range(start: S, count: N) with N >= 1, or a list [1, 2, 3]"
                    .into(),
            ));
        }

        // Axes, in the order written; each value set alone must give a scenario that builds.
        let written = spans(&scenario_text).ranges;
        let mut axes = Vec::new();
        for (map, key, key_pos) in &sp.keys {
            if map != "axes" {
                continue;
            }
            let n = raw.axes.get(key).map_or(0, Vec::len);
            if n == 0 {
                return Err(at(
                    Some(*key_pos),
                    format!("axis `{key}` has no values; expected a list such as [1.0, 2.0]"),
                ));
            }
            let mut values = Vec::new();
            for k in 0..n {
                let vp = format!("axes.{key}[{k}]");
                let value = sp
                    .ranges
                    .get(&vp)
                    .map(|r| text[r.clone()].trim().to_string())
                    .ok_or_else(|| {
                        at(Some(*key_pos), format!("axis `{key}`: value {k} not found"))
                    })?;
                let edited = edit::set(&scenario_text, key, &value)
                    .map_err(|e| at(Some(*key_pos), format!("axis `{key}`: {e}")))?;
                // A field the scenario leaves out was added: if it does not parse, the path
                // is what is wrong, else the value.
                let place = if written.contains_key(key) {
                    pos(&vp)
                } else {
                    Some(*key_pos)
                };
                let wrong =
                    |e: ScenarioError| at(place, format!("axis `{key}` = {value}: {}", e.message));
                let source = Source::parse(&scenario_file, &edited).map_err(wrong)?;
                // A value wrong on its own (a negative radius) is refused now; one that only
                // fails beside the scenario's other values (too many robots for its world)
                // may be right beside another axis' values: its runs say so if not.
                if let Err(e) = source.build(Overrides::default(), registry) {
                    let span = spans(&edited).ranges.get(key.as_str()).cloned();
                    let inside = match (e.pos, span) {
                        (Some(p), Some(r)) => {
                            let (a, b) = (pos_of(&edited, r.start), pos_of(&edited, r.end));
                            (a.line, a.col) <= (p.line, p.col) && (p.line, p.col) < (b.line, b.col)
                        }
                        _ => false,
                    };
                    if inside {
                        return Err(wrong(e));
                    }
                }
                values.push(value);
            }
            axes.push(Axis {
                path: key.clone(),
                values,
            });
        }

        // Metrics and checks.
        let metrics: Vec<String> = match &raw.metrics {
            None => METRICS.iter().map(|m| m.name.to_string()).collect(),
            Some(list) => {
                for (k, name) in list.iter().enumerate() {
                    if metric::find(name).is_none() {
                        return Err(at(
                            pos(&format!("metrics[{k}]")),
                            format!(
                                "unknown metric `{name}`; known: {}",
                                METRICS
                                    .iter()
                                    .map(|m| m.name)
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            ),
                        ));
                    }
                }
                if list.is_empty() {
                    return Err(at(
                        pos("metrics"),
                        "no metrics; leave the field out for every metric".into(),
                    ));
                }
                list.clone()
            }
        };
        let mut columns = metrics.clone();
        for (k, c) in raw.checks.iter().enumerate() {
            let check = Check::parse(c).map_err(|e| {
                // Inside the string: one past its opening quote.
                let p = pos(&format!("checks[{k}]")).map(|p| Pos {
                    line: p.line,
                    col: p.col + 1 + c[..e.offset].chars().count(),
                });
                at(p, e.message)
            })?;
            for m in check.metrics() {
                if !columns.iter().any(|c| c == m) {
                    columns.push(m.to_string());
                }
            }
        }

        let plan = Plan {
            sweep: file.clone(),
            scenario: normalize(&scenario_path).display().to_string(),
            axes,
            seeds,
            columns,
            metrics,
            checks: raw.checks.clone(),
            fingerprint: format!(
                "{:016x}",
                fnv1a(&[text.as_bytes(), scenario_text.as_bytes()])
            ),
        };
        let points = (0..plan.points())
            .map(|p| {
                let mut t = scenario_text.clone();
                for (a, i) in plan.axes.iter().zip(plan.coordinates(p)) {
                    t = edit::set(&t, &a.path, &a.values[i]).map_err(|e| e.to_string())?;
                }
                Source::parse(&scenario_file, &t).map_err(|e| e.to_string())
            })
            .collect();
        Ok(Self { plan, points })
    }
}

/// One run's outcome: its metrics (in [`Plan::columns`]' order), or the error that ended it.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub run: usize,
    pub values: Vec<Option<f64>>,
    pub error: Option<String>,
}

impl Row {
    /// The checks that fail for this row (all of them for a run that errored).
    pub fn failed<'c>(&self, plan: &Plan, checks: &'c [Check]) -> Vec<&'c Check> {
        let value = |m: &str| {
            plan.columns
                .iter()
                .position(|c| c == m)
                .and_then(|i| self.values[i])
        };
        checks
            .iter()
            .filter(|c| self.error.is_some() || !c.holds(&value))
            .collect()
    }

    /// Whether the run ended normally and every check holds.
    pub fn ok(&self, plan: &Plan, checks: &[Check]) -> bool {
        self.error.is_none() && self.failed(plan, checks).is_empty()
    }
}

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

/// Why outputs could not be written or shards not merged.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The user's input: a bad output directory, shards that do not fit together.
    #[error("{0}")]
    Input(String),
    #[error("{path}: cannot write: {error}")]
    Write { path: String, error: std::io::Error },
}

fn write(path: &Path, content: &[u8]) -> Result<(), SweepError> {
    write_whole(path, content).map_err(|error| SweepError::Write {
        path: path.display().to_string(),
        error,
    })
}

/// A number as CSV text: the shortest text that reads back as the same number.
fn num(v: Option<f64>) -> String {
    v.map(|v| format!("{v}")).unwrap_or_default()
}

/// The header of runs.csv.
fn runs_header(plan: &Plan) -> Vec<String> {
    let mut h = vec!["run".to_string(), "point".to_string()];
    h.extend(plan.axes.iter().map(|a| a.path.clone()));
    h.push("seed".into());
    h.extend(plan.columns.iter().cloned());
    h.push("ok".into());
    h.push("error".into());
    h
}

/// runs.csv: one row per run, in run order.
fn runs_csv(plan: &Plan, rows: &[Row], checks: &[Check]) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let _ = w.write_record(runs_header(plan));
    for r in rows {
        let (point, seed) = plan.run_of(r.run);
        let mut rec = vec![r.run.to_string(), point.to_string()];
        rec.extend(
            plan.axes
                .iter()
                .zip(plan.coordinates(point))
                .map(|(a, i)| a.values[i].clone()),
        );
        rec.push(seed.to_string());
        rec.extend(r.values.iter().map(|v| num(*v)));
        rec.push(r.ok(plan, checks).to_string());
        rec.push(r.error.clone().unwrap_or_default());
        let _ = w.write_record(rec);
    }
    w.into_inner().unwrap_or_default()
}

/// Reads runs.csv back (a shard's).
fn read_runs(plan: &Plan, path: &Path) -> Result<Vec<Row>, SweepError> {
    let bad = |m: String| SweepError::Input(format!("{}: {m}", path.display()));
    let mut r = csv::Reader::from_path(path).map_err(|e| bad(e.to_string()))?;
    let header: Vec<String> = r
        .headers()
        .map_err(|e| bad(e.to_string()))?
        .iter()
        .map(str::to_string)
        .collect();
    if header != runs_header(plan) {
        return Err(bad("its columns are not this sweep's".into()));
    }
    let first = 3 + plan.axes.len();
    let mut rows = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(|e| bad(e.to_string()))?;
        let field = |i: usize| rec.get(i).unwrap_or("");
        let run: usize = field(0)
            .parse()
            .map_err(|_| bad(format!("bad run number {:?}", field(0))))?;
        let values = (0..plan.columns.len())
            .map(|k| {
                let t = field(first + k);
                if t.is_empty() {
                    Ok(None)
                } else {
                    t.parse::<f64>()
                        .map(Some)
                        .map_err(|_| bad(format!("run {run}: bad number {t:?}")))
                }
            })
            .collect::<Result<_, _>>()?;
        let error = field(first + plan.columns.len() + 1);
        rows.push(Row {
            run,
            values,
            error: (!error.is_empty()).then(|| error.to_string()),
        });
    }
    Ok(rows)
}

/// summary.csv: per point, its runs, errors and failing runs, and each metric's statistics.
fn summary_csv(plan: &Plan, rows: &[Row], checks: &[Check]) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut h = vec!["point".to_string()];
    h.extend(plan.axes.iter().map(|a| a.path.clone()));
    h.extend(["runs", "errors", "failing"].map(String::from));
    for m in &plan.columns {
        for s in ["n", "mean", "sd", "ci95_low", "ci95_high"] {
            h.push(format!("{m}_{s}"));
        }
    }
    let _ = w.write_record(&h);
    for (point, rows) in by_point(plan, rows) {
        let mut rec = vec![point.to_string()];
        rec.extend(
            plan.axes
                .iter()
                .zip(plan.coordinates(point))
                .map(|(a, i)| a.values[i].clone()),
        );
        rec.push(rows.len().to_string());
        rec.push(
            rows.iter()
                .filter(|r| r.error.is_some())
                .count()
                .to_string(),
        );
        rec.push(
            rows.iter()
                .filter(|r| !r.ok(plan, checks))
                .count()
                .to_string(),
        );
        for k in 0..plan.columns.len() {
            let values: Vec<f64> = rows.iter().filter_map(|r| r.values[k]).collect();
            match stats::stats(&values) {
                Some(s) => rec.extend([
                    s.n.to_string(),
                    num(Some(s.mean)),
                    num(s.sd),
                    num(s.ci95.map(|c| c.0)),
                    num(s.ci95.map(|c| c.1)),
                ]),
                None => rec.extend([
                    "0".to_string(),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                ]),
            }
        }
        let _ = w.write_record(rec);
    }
    w.into_inner().unwrap_or_default()
}

/// The rows of each point, points in order.
fn by_point<'r>(plan: &Plan, rows: &'r [Row]) -> BTreeMap<usize, Vec<&'r Row>> {
    let mut m: BTreeMap<usize, Vec<&Row>> = BTreeMap::new();
    for r in rows {
        m.entry(plan.run_of(r.run).0).or_default().push(r);
    }
    m
}

/// failures.txt: each failing run, why, and the command that replays it.
fn failures_txt(plan: &Plan, rows: &[Row], checks: &[Check]) -> Vec<u8> {
    let failing: Vec<&Row> = rows.iter().filter(|r| !r.ok(plan, checks)).collect();
    let mut out = format!(
        "# {} of {} runs failed (sweep {}); replay one with its command, then open its recording with `rerun run-N.rrd`\n",
        failing.len(),
        rows.len(),
        plan.sweep
    );
    for r in failing {
        let (point, seed) = plan.run_of(r.run);
        let why = match &r.error {
            Some(e) => format!("error: {e}"),
            None => r
                .failed(plan, checks)
                .iter()
                .map(|c| {
                    let vals: Vec<String> = c
                        .metrics()
                        .map(|m| {
                            let v = plan
                                .columns
                                .iter()
                                .position(|c| c == m)
                                .and_then(|i| r.values[i]);
                            format!("{m} = {}", v.map_or("none".into(), |v| format!("{v}")))
                        })
                        .collect();
                    format!("`{}` does not hold ({})", c.text, vals.join(", "))
                })
                .collect::<Vec<_>>()
                .join("; "),
        };
        out.push_str(&format!(
            "\nrun {} (point {point}, seed {seed}): {why}\n  {}\n",
            r.run,
            plan.replay(r.run)
        ));
    }
    out.into_bytes()
}

/// The plot of each asked-for metric.
fn plots(plan: &Plan, rows: &[Row]) -> Result<Vec<(String, String)>, String> {
    let grouped = by_point(plan, rows);
    let (x_name, x_values) = match plan.axes.first() {
        Some(a) => (a.path.clone(), a.values.clone()),
        None => ("scenario".to_string(), vec!["(as written)".to_string()]),
    };
    let mut out = Vec::new();
    for name in &plan.metrics {
        let k = plan.columns.iter().position(|c| c == name).unwrap_or(0);
        let unit = metric::find(name).map_or("", |m| m.unit);
        // One line per combination of the other axes' values, in point order.
        let mut lines: BTreeMap<Vec<usize>, plot::Line> = BTreeMap::new();
        for (&point, rows) in &grouped {
            let c = plan.coordinates(point);
            let others = c.get(1..).unwrap_or(&[]).to_vec();
            // Axes of one value are the same for every line: left out of the labels.
            let label = plan
                .axes
                .iter()
                .zip(&c)
                .skip(1)
                .filter(|(a, _)| a.values.len() > 1)
                .map(|(a, i)| format!("{}={}", a.path, a.values[*i]))
                .collect::<Vec<_>>()
                .join(", ");
            let values: Vec<f64> = rows.iter().filter_map(|r| r.values[k]).collect();
            let line = lines.entry(others).or_insert_with(|| plot::Line {
                label,
                points: Vec::new(),
            });
            if let Some(s) = stats::stats(&values) {
                line.points
                    .push((c.first().copied().unwrap_or(0), s.mean, s.ci95));
            }
        }
        let lines: Vec<plot::Line> = lines.into_values().collect();
        out.push((
            name.clone(),
            plot::svg(name, unit, &x_name, &x_values, &lines)?,
        ));
    }
    Ok(out)
}

/// Writes the whole sweep's files into `out`: runs.csv, summary.csv, failures.txt and
/// plots/METRIC.svg.
pub fn finish(plan: &Plan, rows: &[Row], out: &Path) -> Result<(), SweepError> {
    let checks = plan.parsed_checks();
    write(&out.join("runs.csv"), &runs_csv(plan, rows, &checks))?;
    write(&out.join("summary.csv"), &summary_csv(plan, rows, &checks))?;
    write(
        &out.join("failures.txt"),
        &failures_txt(plan, rows, &checks),
    )?;
    let plots = plots(plan, rows).map_err(|e| SweepError::Write {
        path: out.join("plots").display().to_string(),
        error: std::io::Error::other(e),
    })?;
    for (name, svg) in plots {
        write(
            &out.join("plots").join(format!("{name}.svg")),
            svg.as_bytes(),
        )?;
    }
    Ok(())
}

/// A shard's manifest (`shard.json`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Manifest {
    pub plan: Plan,
    /// The binary that ran the shard ([`binary`]).
    pub binary: String,
    pub shard: usize,
    pub of: usize,
    /// Rows the shard holds.
    pub rows: usize,
}

/// What identifies this binary: its version, and its executable's size with a hash of 64
/// chunks of 64 KiB spread over it (a different build differs there; reading the whole
/// executable, hundreds of MB in a debug build, would cost each shard seconds).
pub fn binary() -> String {
    fn sample(path: &Path) -> std::io::Result<String> {
        use std::io::{Read, Seek, SeekFrom};
        let mut f = std::fs::File::open(path)?;
        let len = f.metadata()?.len();
        const CHUNK: u64 = 64 * 1024;
        let mut buf = vec![0u8; CHUNK as usize];
        let mut h = fnv1a(&[&len.to_le_bytes()]);
        for k in 0..64u64 {
            let at = (len.saturating_sub(CHUNK)) * k / 63;
            f.seek(SeekFrom::Start(at))?;
            let n = f.read(&mut buf)?;
            h ^= fnv1a(&[&buf[..n]]).rotate_left(k as u32);
        }
        Ok(format!("{len} bytes, {h:016x}"))
    }
    let exe = std::env::current_exe()
        .and_then(|p| sample(&p))
        .unwrap_or_else(|_| "unknown executable".into());
    format!("nekosim {} ({exe})", env!("CARGO_PKG_VERSION"))
}

/// Writes a shard's rows and manifest into `out`.
pub fn finish_shard(
    plan: &Plan,
    rows: &[Row],
    (shard, of): (usize, usize),
    out: &Path,
) -> Result<(), SweepError> {
    let checks = plan.parsed_checks();
    write(&out.join("runs.csv"), &runs_csv(plan, rows, &checks))?;
    let m = Manifest {
        plan: plan.clone(),
        binary: binary(),
        shard,
        of,
        rows: rows.len(),
    };
    let json = serde_json::to_string_pretty(&m).map_err(|e| SweepError::Write {
        path: out.join("shard.json").display().to_string(),
        error: std::io::Error::other(e),
    })?;
    write(&out.join("shard.json"), format!("{json}\n").as_bytes())
}

/// Merges shard directories into the whole sweep's files in `out`, refusing missing,
/// duplicated, incomplete or mismatched shards (other sweep file, scenario or binary).
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<Outcome, SweepError> {
    let input = SweepError::Input;
    let mut manifests: Vec<(Manifest, &PathBuf)> = Vec::new();
    for d in dirs {
        let path = d.join("shard.json");
        let text = std::fs::read_to_string(&path).map_err(|e| {
            input(format!(
                "{}: not a shard ({e}); expected the output of `nekosim sweep --shard I/N`",
                path.display()
            ))
        })?;
        let m: Manifest =
            serde_json::from_str(&text).map_err(|e| input(format!("{}: {e}", path.display())))?;
        manifests.push((m, d));
    }
    let Some((first, first_dir)) = manifests.first().cloned() else {
        return Err(input("no shard directories given".into()));
    };
    let mut seen: Vec<Option<&PathBuf>> = vec![None; first.of];
    for (m, d) in &manifests {
        if m.plan != first.plan {
            return Err(input(format!(
                "{}: a shard of another sweep (file or scenario differ from {})",
                d.display(),
                first_dir.display()
            )));
        }
        if m.binary != first.binary {
            return Err(input(format!(
                "{}: run by another binary ({}) than {} ({})",
                d.display(),
                m.binary,
                first_dir.display(),
                first.binary
            )));
        }
        if m.of != first.of || m.shard >= m.of {
            return Err(input(format!(
                "{}: shard {}/{} does not fit shards of {}",
                d.display(),
                m.shard,
                m.of,
                first.of
            )));
        }
        if let Some(other) = seen[m.shard] {
            return Err(input(format!(
                "shard {}/{} given twice: {} and {}",
                m.shard,
                m.of,
                other.display(),
                d.display()
            )));
        }
        seen[m.shard] = Some(d);
    }
    if let Some(missing) = seen.iter().position(Option::is_none) {
        return Err(input(format!("shard {missing}/{} is missing", first.of)));
    }
    let plan = &first.plan;
    let mut rows = Vec::new();
    for (m, d) in &manifests {
        let shard_rows = read_runs(plan, &d.join("runs.csv"))?;
        let expected = (0..plan.runs()).filter(|r| r % m.of == m.shard).count();
        if shard_rows.len() != m.rows
            || shard_rows.len() != expected
            || shard_rows
                .iter()
                .any(|r| r.run % m.of != m.shard || r.run >= plan.runs())
        {
            return Err(input(format!(
                "{}: shard {}/{} is incomplete or altered ({} rows, {} expected)",
                d.display(),
                m.shard,
                m.of,
                shard_rows.len(),
                expected
            )));
        }
        rows.extend(shard_rows);
    }
    rows.sort_by_key(|r| r.run);
    finish(plan, &rows, out)?;
    let checks = plan.parsed_checks();
    Ok(Outcome {
        failing: rows.iter().filter(|r| !r.ok(plan, &checks)).count(),
        errors: rows.iter().filter(|r| r.error.is_some()).count(),
        rows,
        interrupted: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan() -> Plan {
        Plan {
            sweep: "s.ron".into(),
            scenario: "sc.ron".into(),
            axes: vec![
                Axis {
                    path: "robots[0].count".into(),
                    values: vec!["10".into(), "20".into(), "30".into()],
                },
                Axis {
                    path: "network".into(),
                    values: vec!["Reliable(delay: 1.0)".into(), "Lossy".into()],
                },
            ],
            seeds: vec![5, 6],
            columns: vec!["collisions".into()],
            metrics: vec!["collisions".into()],
            checks: vec![],
            fingerprint: String::new(),
        }
    }

    #[test]
    fn runs_are_numbered_point_major_with_the_first_axis_slowest() {
        let p = plan();
        assert_eq!(p.points(), 6);
        assert_eq!(p.runs(), 12);
        assert_eq!(p.coordinates(0), [0, 0]);
        assert_eq!(p.coordinates(1), [0, 1]);
        assert_eq!(p.coordinates(5), [2, 1]);
        assert_eq!(p.run_of(3), (1, 6));
        assert_eq!(
            p.replay(3),
            "nekosim run sc.ron --seed 6 --set 'robots[0].count=10' --set network=Lossy --rrd run-3.rrd"
        );
        assert_eq!(
            p.replay(0),
            "nekosim run sc.ron --seed 5 --set 'robots[0].count=10' --set 'network=Reliable(delay: 1.0)' --rrd run-0.rrd"
        );
    }

    #[test]
    fn paths_normalize_lexically() {
        assert_eq!(
            normalize(Path::new("examples/sweeps/../scenarios/a.ron")),
            PathBuf::from("examples/scenarios/a.ron")
        );
        assert_eq!(normalize(Path::new("../a.ron")), PathBuf::from("../a.ron"));
    }
}
