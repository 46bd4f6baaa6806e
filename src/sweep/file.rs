//! The sweep file (docs/sweeps.md): read, checked at FILE:LINE:COL before any run, and turned
//! into the [`Plan`] and each point's scenario.

use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};

use serde::Deserialize;

use super::metric::{self, Check, METRICS};
use super::{fnv1a, Axis, Plan};
use crate::scenario::{edit, spans, Overrides, Pos, Registry, ScenarioError, Source};

/// A sweep file loaded and checked, ready to run.
#[derive(Debug)]
pub struct Sweep {
    pub plan: Plan,
    /// Each point's scenario, or why it cannot be built (a row error for each of its runs).
    pub(super) points: Vec<Result<Source, String>>,
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
        Self::parse(path, file, &text, registry)
    }

    /// [`Sweep::load`] of sweep text already read: `file` names it in errors and `path` is
    /// where it stands (its scenario is relative to `path`'s directory).
    pub fn parse(
        path: &Path,
        file: String,
        text: &str,
        registry: &Registry,
    ) -> Result<Self, ScenarioError> {
        let at = |pos: Option<Pos>, message: String| ScenarioError {
            file: file.clone(),
            pos,
            message,
        };
        let raw: Raw = crate::scenario::read_ron(&file, text)?;
        let sp = spans(text);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_normalize_lexically() {
        assert_eq!(
            normalize(Path::new("examples/sweeps/../scenarios/a.ron")),
            PathBuf::from("examples/scenarios/a.ron")
        );
        assert_eq!(normalize(Path::new("../a.ron")), PathBuf::from("../a.ron"));
    }
}
