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
//!
//! The sweep is split by concept: [`file`] reads and checks the sweep file, [`execution`] runs
//! the runs, [`outputs`] writes and reads the CSV, summary, failure and plot files, and
//! [`shard`] writes shards and merges them; [`metric`], [`stats`] and [`plot`] are what a run
//! measures, the statistics of a point and the plots.

pub mod execution;
pub mod file;
pub mod metric;
pub mod outputs;
pub mod plot;
pub mod shard;
pub mod stats;

use serde::{Deserialize, Serialize};

use metric::Check;

pub use execution::{run, Outcome, Progress, SweepOptions};
pub use file::Sweep;
pub use outputs::{finish, tables};
pub use shard::{binary, finish_shard, merge, Manifest};

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

/// Why outputs could not be written or shards not merged.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The user's input: a bad output directory, shards that do not fit together.
    #[error("{0}")]
    Input(String),
    #[error("{path}: cannot write: {error}")]
    Write { path: String, error: std::io::Error },
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
}
