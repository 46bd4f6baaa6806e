//! A sweep's files: runs.csv (one row per run), summary.csv (the statistics of each point),
//! failures.txt (the failing runs with the command that replays each) and a plot per metric;
//! and runs.csv read back, for merging shards.

use std::collections::BTreeMap;
use std::path::Path;

use super::metric::{self, Check};
use super::{plot, stats};
use super::{Plan, Row, SweepError};
use crate::output::write_whole;

pub(super) fn write(path: &Path, content: &[u8]) -> Result<(), SweepError> {
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
pub(super) fn runs_csv(plan: &Plan, rows: &[Row], checks: &[Check]) -> Vec<u8> {
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
pub(super) fn read_runs(plan: &Plan, path: &Path) -> Result<Vec<Row>, SweepError> {
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

/// The texts of runs.csv and summary.csv, as [`finish`] writes them, without writing them.
pub fn tables(plan: &Plan, rows: &[Row]) -> (Vec<u8>, Vec<u8>) {
    let checks = plan.parsed_checks();
    (
        runs_csv(plan, rows, &checks),
        summary_csv(plan, rows, &checks),
    )
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
