//! The native part of the Python package `nekosim` (docs/python.md): scenarios loaded and
//! edited as the command line does, runs whose records come back as Arrow columns, and
//! algorithms written in Python: Look-Compute-Move ones hosted by the engine's
//! `LookComputeMove` trait, and seed-style ones that block on their robot's calls. The
//! package's Python modules (python/nekosim/) wrap these classes into pandas.

mod algorithm;
mod cells;
mod check;
mod columns;
mod robot;
mod run;
mod scenario;
mod sweep;

use pyo3::prelude::*;

/// A `nekosim.ScenarioError` (a `ValueError` with `.file`, `.line` and `.col`) for `e`.
pub(crate) fn scenario_error(py: Python<'_>, e: &nekosim::scenario::ScenarioError) -> PyErr {
    let (line, col) = e.pos.map_or((None, None), |p| (Some(p.line), Some(p.col)));
    error(py, e.to_string(), Some(e.file.clone()), line, col)
}

/// A `nekosim.ScenarioError` with `message` (the whole `FILE:LINE:COL: ...` line) and its
/// location, where one applies.
pub(crate) fn error(
    py: Python<'_>,
    message: String,
    file: Option<String>,
    line: Option<usize>,
    col: Option<usize>,
) -> PyErr {
    let made = py
        .import("nekosim._errors")
        .and_then(|m| m.getattr("ScenarioError"))
        .and_then(|class| class.call1((message.clone(), file, line, col)));
    match made {
        Ok(e) => PyErr::from_value(e),
        Err(e) => e,
    }
}

#[pymodule]
fn _nekosim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<scenario::Scenario>()?;
    m.add_class::<run::RunCore>()?;
    m.add_class::<sweep::SweepCore>()?;
    m.add_class::<check::CheckCore>()?;
    m.add_class::<columns::ArrowBatch>()?;
    m.add_function(wrap_pyfunction!(check::check_core, m)?)?;
    m.add_class::<algorithm::View>()?;
    m.add_class::<algorithm::Seen>()?;
    m.add_class::<algorithm::Decision>()?;
    m.add_class::<robot::RobotHandle>()?;
    m.add_class::<robot::MotionResult>()?;
    m.add("RunEnded", m.py().get_type::<robot::RunEnded>())?;
    Ok(())
}
