//! A scenario from Python: the file's text, checked as `nekosim validate` reads it, edited by
//! path as `nekosim run --set PATH=VALUE` edits it (`nekosim::scenario::edit`), and run.

use std::path::PathBuf;

use nekosim::scenario::{edit, read_file, Overrides, Source};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt, PyString};

use crate::run::{execute, RunCore};

/// A scenario file's text and its name in errors.
#[derive(Debug)]
#[pyclass(module = "nekosim._nekosim")]
pub struct Scenario {
    /// The file's name in errors.
    #[pyo3(get)]
    file: String,
    /// The scenario's RON text, with every `set` applied.
    #[pyo3(get)]
    text: String,
    source: Source,
}

impl Scenario {
    fn parse(py: Python<'_>, file: String, text: String) -> PyResult<Self> {
        let source = Source::parse(&file, &text).map_err(|e| crate::scenario_error(py, &e))?;
        Ok(Self { file, text, source })
    }
}

/// A Python value as RON text: numbers and booleans as RON writes them, `None` as `None`, a
/// string as the RON text it holds (as on the command line: `"Infinite"`, `"(3.0, 13.0)"`).
fn ron_text(value: &Bound<'_, PyAny>) -> PyResult<String> {
    if value.is_none() {
        Ok("None".into())
    } else if value.is_instance_of::<PyBool>() {
        Ok(if value.extract::<bool>()? {
            "true"
        } else {
            "false"
        }
        .into())
    } else if value.is_instance_of::<PyInt>() {
        Ok(value.str()?.to_string())
    } else if value.is_instance_of::<PyFloat>() {
        let f: f64 = value.extract()?;
        // Debug prints the shortest text that reads back to the same f64, always with a point
        // or an exponent, which RON reads as a float.
        Ok(format!("{f:?}"))
    } else if value.is_instance_of::<PyString>() {
        Ok(value.extract::<String>()?)
    } else {
        Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "cannot set a value of type {}: give a number, a bool, None or RON text",
            value.get_type().name()?
        )))
    }
}

#[pymethods]
impl Scenario {
    /// Reads and checks the scenario file at `path`.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let (file, text) =
            read_file(&path, "scenario").map_err(|e| crate::scenario_error(py, &e))?;
        Self::parse(py, file, text)
    }

    /// Reads and checks scenario text; `name` names it in errors.
    #[staticmethod]
    #[pyo3(signature = (text, name = "<string>".to_string()))]
    fn from_ron(py: Python<'_>, text: String, name: String) -> PyResult<Self> {
        Self::parse(py, name, text)
    }

    /// Sets the value at `path` (as `--set PATH=VALUE`), and checks the scenario again.
    fn set(&mut self, py: Python<'_>, path: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let value = ron_text(value)?;
        let text = edit::set(&self.text, path, &value).map_err(|e| {
            crate::error(
                py,
                format!("{}: set {path}={value}: {e}", self.file),
                Some(self.file.clone()),
                None,
                None,
            )
        })?;
        *self = Self::parse(py, self.file.clone(), text)?;
        Ok(())
    }

    /// The scenario's name (its `name`, else the file's stem).
    #[getter]
    fn name(&self) -> String {
        self.source.scenario.name.clone().unwrap_or_else(|| {
            std::path::Path::new(&self.file)
                .file_stem()
                .map_or_else(|| self.file.clone(), |s| s.to_string_lossy().into_owned())
        })
    }

    /// The scenario's seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.source.scenario.seed
    }

    /// Runs the scenario; `seed` and `until` override the file's, `algorithms` names the
    /// Python Look-Compute-Move algorithms it uses, `rrd` saves a Rerun recording.
    #[pyo3(signature = (seed = None, until = None, algorithms = Vec::new(), rrd = None))]
    fn run_core(
        &self,
        py: Python<'_>,
        seed: Option<u64>,
        until: Option<f64>,
        algorithms: Vec<(String, Py<PyAny>)>,
        rrd: Option<PathBuf>,
    ) -> PyResult<RunCore> {
        execute(
            py,
            self.file.clone(),
            self.text.clone(),
            Overrides { seed, until },
            algorithms,
            rrd,
        )
    }

    fn __repr__(&self) -> String {
        format!("Scenario({:?}, file={:?})", self.name(), self.file)
    }
}
