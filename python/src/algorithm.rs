//! Look-Compute-Move algorithms written in Python (docs/python.md): a Python object with
//! `compute(self, view) -> Decision` is hosted by the engine as a [`LookComputeMove`], so the
//! cycle, the frames, the adversary and the records are the engine's, exactly as for an
//! algorithm written in Rust. `compute` is called in the engine's order of events, so a
//! deterministic Python `compute` gives the same run for the same seed.
//!
//! A scenario names the algorithm as any other (`algorithm: PyCog()`); before the scenario is
//! built, each robot entry naming a Python algorithm is rewritten to the one registered host,
//! `PythonAlgorithm(slot: K, config: (...))`, and the host finds its Python object by slot in
//! the table of the build in progress on this thread.

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

use nekosim::lcm::{Decision as RustDecision, LcmConfigured, LookComputeMove, Multiplicity};
use nekosim::protocols::{FieldError, Spec};
use nekosim::registry::Setting;
use nekosim::scenario::{RobotEntry, Source};
use nekosim::world::geometry::Point;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple, PyType};
use serde::Deserialize;

/// The name the host is registered under (never a name a user's scenario uses).
pub const HOST_NAME: &str = "PythonAlgorithm";

/// The name the host of seed-style robot algorithms is registered under (never a name a
/// user's scenario uses).
pub const ROBOT_HOST_NAME: &str = "PythonRobot";

/// The Python algorithms of one run, and what a failing `compute` leaves for the caller.
#[derive(Debug, Clone)]
pub struct Hosted {
    /// By the name scenarios use.
    pub algorithms: Arc<Vec<(String, Py<PyAny>)>>,
    /// The first exception a `compute` raised.
    pub error: Arc<Mutex<Option<PyErr>>>,
    /// Set when an algorithm raised: the run ends at the virtual time reached.
    pub stop: Arc<AtomicBool>,
    /// Set when the run has ended: the threads of seed-style algorithms still waiting for a
    /// call's result end ([`crate::robot`]).
    pub ended: Arc<AtomicBool>,
    /// The threads of the run's seed-style algorithms.
    threads: Arc<Mutex<Vec<JoinHandle<()>>>>,
}

thread_local! {
    /// The Python algorithms of the scenario being built on this thread.
    static BUILDING: RefCell<Option<Hosted>> = const { RefCell::new(None) };
}

impl Hosted {
    pub fn new(algorithms: Vec<(String, Py<PyAny>)>) -> Self {
        Self {
            algorithms: Arc::new(algorithms),
            error: Arc::default(),
            stop: Arc::default(),
            ended: Arc::default(),
            threads: Arc::default(),
        }
    }

    /// Keeps `e`, the first exception an algorithm raised, and stops the run.
    pub fn fail(&self, e: PyErr) {
        if let Ok(mut slot) = self.error.lock() {
            slot.get_or_insert(e);
        }
        self.stop.store(true, Ordering::Relaxed);
    }

    /// Keeps the thread of a seed-style algorithm, to be joined when the run ends.
    pub fn keep_thread(&self, thread: JoinHandle<()>) {
        if let Ok(mut threads) = self.threads.lock() {
            threads.push(thread);
        }
    }

    /// After the run: ends the threads of seed-style algorithms and waits for them (call it
    /// without the Python lock, which they take to unwind).
    pub fn end(&self) {
        self.ended.store(true, Ordering::Relaxed);
        let threads = self
            .threads
            .lock()
            .map(|mut t| std::mem::take(&mut *t))
            .unwrap_or_default();
        for t in threads {
            let _ = t.join();
        }
    }

    /// Points every robot entry that names one of the Python algorithms at its host: a
    /// Look-Compute-Move one (it has `compute`) or a seed-style one ([`crate::robot`]).
    pub fn rewrite(&self, source: &mut Source) {
        for entry in &mut source.scenario.robots {
            let spec = match entry {
                RobotEntry::Robot { algorithm, .. } | RobotEntry::Group { algorithm, .. } => {
                    algorithm
                }
            };
            let Some(slot) = self.algorithms.iter().position(|(n, _)| n == spec.name()) else {
                continue;
            };
            let config = spec.config_text().unwrap_or("()").to_string();
            let lcm = Python::attach(|py| {
                self.algorithms[slot]
                    .1
                    .bind(py)
                    .hasattr("compute")
                    .unwrap_or(false)
            });
            let host = if lcm { HOST_NAME } else { ROBOT_HOST_NAME };
            *spec = Spec::new(&format!("{host}(slot: {slot}, config: {config})"));
        }
    }

    /// `f` (the scenario's build) with these algorithms visible to the host.
    pub fn building<R>(&self, f: impl FnOnce() -> R) -> R {
        BUILDING.with(|b| *b.borrow_mut() = Some(self.clone()));
        let out = f();
        BUILDING.with(|b| *b.borrow_mut() = None);
        out
    }

    /// The scenario's Python algorithm at `slot` in the build in progress on this thread:
    /// the run's algorithms, and its name and object.
    pub(crate) fn slot(slot: usize) -> Result<(Self, String, Py<PyAny>), FieldError> {
        let hosted = BUILDING.with(|b| b.borrow().clone()).ok_or_else(|| {
            FieldError::new("", "a Python algorithm outside a run from Python", "")
        })?;
        let (name, object) = hosted
            .algorithms
            .get(slot)
            .map(|(n, o)| (n.clone(), Python::attach(|py| o.clone_ref(py))))
            .ok_or_else(|| FieldError::new("slot", "no such Python algorithm", ""))?;
        Ok((hosted, name, object))
    }

    /// The exception a `compute` raised, if any.
    pub fn take_error(&self) -> Option<PyErr> {
        self.error.lock().ok().and_then(|mut e| e.take())
    }
}

/// `PythonAlgorithm(slot: K, config: (...))`: the Python algorithm at `slot`, with the
/// configuration the scenario gave it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HostConfig {
    pub(crate) slot: usize,
    #[serde(default = "unit")]
    pub(crate) config: ron::Value,
}

fn unit() -> ron::Value {
    ron::Value::Unit
}

/// A Python object's `compute`, as the engine's [`LookComputeMove`].
pub struct PyLcm {
    name: String,
    object: Py<PyAny>,
    colours: u8,
    names: Vec<String>,
    error: Arc<Mutex<Option<PyErr>>>,
    stop: Arc<AtomicBool>,
}

impl std::fmt::Debug for PyLcm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PyLcm")
            .field("name", &self.name)
            .field("colours", &self.colours)
            .finish_non_exhaustive()
    }
}

impl PyLcm {
    fn fail(&self, e: PyErr) {
        if let Ok(mut slot) = self.error.lock() {
            slot.get_or_insert(e);
        }
        self.stop.store(true, Ordering::Relaxed);
    }

    fn call(&self, py: Python<'_>, view: &nekosim::lcm::View) -> PyResult<RustDecision> {
        let v = Bound::new(py, View::from(view))?;
        let out = self.object.bind(py).call_method1("compute", (v,))?;
        if out.is_none() {
            return Ok(RustDecision::stay());
        }
        let d = out.cast::<Decision>().map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(format!(
                "{}.compute returned {}; expected a nekosim.Decision",
                self.name,
                out.get_type().name().map_or("?".into(), |n| n.to_string())
            ))
        })?;
        let d = d.get();
        Ok(RustDecision {
            to: d.to.map(|(x, y)| Point::new(x, y)),
            light: d.light,
        })
    }
}

impl LookComputeMove for PyLcm {
    fn compute(&self, view: &nekosim::lcm::View) -> RustDecision {
        if self.stop.load(Ordering::Relaxed) {
            return RustDecision::stay();
        }
        Python::attach(|py| {
            self.call(py, view).unwrap_or_else(|e| {
                self.fail(e);
                RustDecision::stay()
            })
        })
    }

    fn colours(&self) -> u8 {
        self.colours
    }

    fn colour_name(&self, l: nekosim::lcm::Light) -> String {
        self.names
            .get(usize::from(l))
            .cloned()
            .unwrap_or_else(|| l.to_string())
    }
}

impl LcmConfigured for PyLcm {
    type Config = HostConfig;

    fn configure(config: HostConfig, _: &Setting) -> Result<Self, FieldError> {
        let (hosted, name, object) = Hosted::slot(config.slot)?;
        Python::attach(|py| {
            let failed =
                |e: PyErr| FieldError::new("", format!("{name}: {e}"), "what its class accepts");
            let bound = object.bind(py);
            let object = if bound.is_instance_of::<PyType>() {
                let kwargs = kwargs(py, &config.config)?;
                bound.call((), Some(&kwargs)).map_err(failed)?.unbind()
            } else {
                if !matches!(config.config, ron::Value::Unit) {
                    return Err(FieldError::new(
                        "",
                        format!("{name} is an object, configured in Python"),
                        "`()`, or register its class to configure it from the scenario",
                    ));
                }
                object.clone_ref(py)
            };
            let b = object.bind(py);
            let colours: u8 = match b.getattr_opt("colours").map_err(failed)? {
                Some(c) => c.extract().map_err(|e: PyErr| failed(e))?,
                None => 1,
            };
            let mut names = Vec::new();
            if b.hasattr("colour_name").map_err(failed)? {
                for l in 0..colours {
                    let n = b.call_method1("colour_name", (l,)).map_err(failed)?;
                    names.push(n.str().map_err(failed)?.to_string());
                }
            }
            Ok(PyLcm {
                name,
                object,
                colours: colours.max(1),
                names,
                error: hosted.error.clone(),
                stop: hosted.stop.clone(),
            })
        })
    }
}

/// A scenario's configuration `Name(field: value, ...)` as keyword arguments.
pub(crate) fn kwargs<'py>(
    py: Python<'py>,
    config: &ron::Value,
) -> Result<Bound<'py, PyDict>, FieldError> {
    let failed = |e: PyErr| FieldError::new("", e.to_string(), "what the algorithm accepts");
    let kwargs = PyDict::new(py);
    match config {
        ron::Value::Unit => {}
        ron::Value::Map(m) => {
            for (k, v) in m.iter() {
                let ron::Value::String(k) = k else {
                    return Err(FieldError::new("", "a field without a name", ""));
                };
                kwargs
                    .set_item(k, to_python(py, v).map_err(failed)?)
                    .map_err(failed)?;
            }
        }
        other => {
            return Err(FieldError::new(
                "",
                format!("the configuration {other:?}"),
                "named fields, `Name(field: value, ...)`",
            ))
        }
    }
    Ok(kwargs)
}

/// A RON configuration value as a Python value.
fn to_python<'py>(py: Python<'py>, v: &ron::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        ron::Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        ron::Value::Char(c) => c.to_string().into_pyobject(py)?.into_any(),
        ron::Value::String(s) => s.into_pyobject(py)?.into_any(),
        ron::Value::Number(n) => match n {
            ron::Number::F32(f) => f.get().into_pyobject(py)?.into_any(),
            ron::Number::F64(f) => f.get().into_pyobject(py)?.into_any(),
            other => match other.into_f64() {
                f if f.fract() == 0.0 && f.abs() < 9.0e15 => {
                    (f as i64).into_pyobject(py)?.into_any()
                }
                f => f.into_pyobject(py)?.into_any(),
            },
        },
        ron::Value::Option(None) | ron::Value::Unit => py.None().into_bound(py),
        ron::Value::Option(Some(inner)) => to_python(py, inner)?,
        ron::Value::Bytes(b) => pyo3::types::PyBytes::new(py, b).into_any(),
        ron::Value::Seq(items) => {
            let l = PyList::empty(py);
            for i in items {
                l.append(to_python(py, i)?)?;
            }
            l.into_any()
        }
        ron::Value::Map(m) => {
            let d = PyDict::new(py);
            for (k, v) in m.iter() {
                d.set_item(to_python(py, k)?, to_python(py, v)?)?;
            }
            d.into_any()
        }
    })
}

/// What the robot sees, in its local frame with itself at the origin (the engine's `View`).
#[derive(Debug)]
#[pyclass(module = "nekosim._nekosim", frozen)]
pub struct View {
    /// The robot's own light, when visible to itself.
    #[pyo3(get)]
    light: Option<u8>,
    /// How far the robot sees, in its own unit (`None`: everything).
    #[pyo3(get)]
    visibility: Option<f64>,
    seen: Vec<(f64, f64, Option<u8>, Multiplicity)>,
}

impl From<&nekosim::lcm::View> for View {
    fn from(v: &nekosim::lcm::View) -> Self {
        Self {
            light: v.light,
            visibility: v.visibility,
            seen: v
                .others
                .iter()
                .map(|s| (s.at.x, s.at.y, s.light, s.multiplicity))
                .collect(),
        }
    }
}

fn multiplicity(py: Python<'_>, m: Multiplicity) -> PyResult<Py<PyAny>> {
    Ok(match m {
        Multiplicity::Unknown => py.None(),
        Multiplicity::One => "one".into_pyobject(py)?.into_any().unbind(),
        Multiplicity::Many => "many".into_pyobject(py)?.into_any().unbind(),
        Multiplicity::Exactly(k) => k.into_pyobject(py)?.into_any().unbind(),
    })
}

#[pymethods]
impl View {
    /// The other robots seen, one entry per point (and light), nearest first.
    #[getter]
    fn others(&self, py: Python<'_>) -> PyResult<Vec<Py<Seen>>> {
        self.seen
            .iter()
            .map(|&(x, y, light, m)| {
                Py::new(
                    py,
                    Seen {
                        at: (x, y),
                        light,
                        multiplicity: multiplicity(py, m)?,
                    },
                )
            })
            .collect()
    }

    /// The points of the others, nearest first: a list of `(x, y)`.
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        PyList::new(
            py,
            self.seen
                .iter()
                .map(|&(x, y, ..)| PyTuple::new(py, [x, y]))
                .collect::<PyResult<Vec<_>>>()?,
        )
    }

    fn __len__(&self) -> usize {
        self.seen.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "View(light={:?}, visibility={:?}, {} others)",
            self.light,
            self.visibility,
            self.seen.len()
        )
    }
}

/// One point where the robot sees robots.
#[derive(Debug)]
#[pyclass(module = "nekosim._nekosim", frozen)]
pub struct Seen {
    /// `(x, y)` in the robot's local frame.
    #[pyo3(get)]
    at: (f64, f64),
    /// The light seen there, when lights are visible.
    #[pyo3(get)]
    light: Option<u8>,
    /// `None` without multiplicity detection, `"one"` or `"many"` with weak detection, the
    /// number of robots there with strong detection.
    #[pyo3(get)]
    multiplicity: Py<PyAny>,
}

#[pymethods]
impl Seen {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Seen(at={:?}, light={:?}, multiplicity={})",
            self.at,
            self.light,
            self.multiplicity.bind(py)
        )
    }
}

/// What a robot decided: a destination `(x, y)` in its local frame (`None`: stay) and a new
/// light (`None`: keep its light).
#[derive(Debug)]
#[pyclass(module = "nekosim._nekosim", frozen)]
pub struct Decision {
    #[pyo3(get)]
    to: Option<(f64, f64)>,
    #[pyo3(get)]
    light: Option<u8>,
}

#[pymethods]
impl Decision {
    #[new]
    #[pyo3(signature = (to=None, light=None))]
    fn new(to: Option<(f64, f64)>, light: Option<u8>) -> Self {
        Self { to, light }
    }

    /// Stay, keeping the light.
    #[staticmethod]
    fn stay() -> Self {
        Self {
            to: None,
            light: None,
        }
    }

    fn __repr__(&self) -> String {
        format!("Decision(to={:?}, light={:?})", self.to, self.light)
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Decision>()
            .is_ok_and(|o| o.get().to == self.to && o.get().light == self.light)
    }
}
