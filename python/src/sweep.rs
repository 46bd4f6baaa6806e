//! A sweep from Python (docs/sweeps.md): the sweep file read and checked as `nekosim sweep`
//! reads it, its runs (all, or one shard's, so that a Dask task can run a part), and the
//! texts of runs.csv and summary.csv that `nekosim sweep --out` writes for the same rows.

use std::path::{Path, PathBuf};

use nekosim::scenario::Registry;
use nekosim::sweep::{self, Row, Sweep, SweepOptions};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

/// One run's row as Python holds it: (run number, metric values, error).
type RowTuple = (usize, Vec<Option<f64>>, Option<String>);

/// A sweep file loaded and checked.
#[derive(Debug)]
#[pyclass(module = "nekosim._nekosim", frozen)]
pub struct SweepCore {
    sweep: Sweep,
}

#[pymethods]
impl SweepCore {
    /// Reads and checks the sweep file at `path`.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let sweep = py
            .detach(|| Sweep::load(&path, &Registry::new()))
            .map_err(|e| crate::scenario_error(py, &e))?;
        Ok(Self { sweep })
    }

    /// Reads and checks sweep text named `name` in errors, standing at `path` (its scenario
    /// is relative to `path`'s directory).
    #[staticmethod]
    fn parse(py: Python<'_>, text: String, name: String, path: PathBuf) -> PyResult<Self> {
        let sweep = py
            .detach(|| Sweep::parse(Path::new(&path), name, &text, &Registry::new()))
            .map_err(|e| crate::scenario_error(py, &e))?;
        Ok(Self { sweep })
    }

    /// Number of runs (points times seeds).
    #[getter]
    fn runs(&self) -> usize {
        self.sweep.plan.runs()
    }

    /// Runs the sweep's runs, or with `shard = (I, N)` those whose number is I modulo N,
    /// `jobs` at a time; returns their rows in run order.
    #[pyo3(signature = (jobs = 1, shard = None))]
    fn execute(
        &self,
        py: Python<'_>,
        jobs: usize,
        shard: Option<(usize, usize)>,
    ) -> PyResult<Vec<RowTuple>> {
        if let Some((i, n)) = shard {
            if n == 0 || i >= n {
                return Err(pyo3::exceptions::PyValueError::new_err(format!(
                    "shard {i}/{n}: expected I/N with 0 <= I < N"
                )));
            }
        }
        let outcome = py.detach(|| {
            sweep::run(
                &self.sweep,
                &Registry::new(),
                &SweepOptions {
                    jobs: jobs.max(1),
                    shard,
                    ..SweepOptions::default()
                },
            )
        });
        Ok(outcome
            .rows
            .into_iter()
            .map(|r| (r.run, r.values, r.error))
            .collect())
    }

    /// The texts of runs.csv and summary.csv for `rows` (in any order; each run once).
    fn tables<'py>(
        &self,
        py: Python<'py>,
        mut rows: Vec<RowTuple>,
    ) -> PyResult<(Bound<'py, PyBytes>, Bound<'py, PyBytes>)> {
        let plan = &self.sweep.plan;
        rows.sort_by_key(|r| r.0);
        for (k, r) in rows.iter().enumerate() {
            if r.0 != k || r.1.len() != plan.columns.len() {
                return Err(pyo3::exceptions::PyValueError::new_err(format!(
                    "the rows are not this sweep's {} runs, each once (run {} at {k})",
                    plan.runs(),
                    r.0
                )));
            }
        }
        if rows.len() != plan.runs() {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "{} rows for a sweep of {} runs",
                rows.len(),
                plan.runs()
            )));
        }
        let rows: Vec<Row> = rows
            .into_iter()
            .map(|(run, values, error)| Row { run, values, error })
            .collect();
        let (runs, summary) = sweep::tables(plan, &rows);
        Ok((PyBytes::new(py, &runs), PyBytes::new(py, &summary)))
    }
}
