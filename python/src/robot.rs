//! Seed-style robot algorithms written in Python (docs/python.md; seed chapter 5 and section
//! 6.3): a Python function `algorithm(robot, **config)`, or a class whose `run(self, robot)`
//! does the work, that calls the robot's motions, sensors and messages and blocks on their
//! results, as the seed's Java algorithms do.
//!
//! Each such robot's Python code runs on a thread of its own and hands control back and forth
//! with the robot's future in the engine at every call: the Python thread asks and waits, the
//! future performs the call through the very [`Robot`] API a Rust algorithm uses and answers
//! when the call's result is there, and the future waits for the next call while Python runs.
//! Exactly one of the two runs at any time, so Python code runs in the engine's order of
//! events and a run is as deterministic as its Python code. When the run ends, a thread still
//! waiting gets [`RunEnded`], an exception outside `Exception` so that a `try` in the
//! algorithm does not catch it by accident.

use std::sync::atomic::Ordering;
use std::sync::mpsc::{channel, Sender};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

use nekosim::algorithm::destination_area;
use nekosim::config::Configured;
use nekosim::protocols::FieldError;
use nekosim::rand::Rng;
use nekosim::registry::Setting;
use nekosim::robot::{Algorithm, AlgorithmFuture, Robot};
use nekosim::world::geometry::Point;
use nekosim::world::virtual_world::WorldSize;
use pyo3::prelude::*;
use pyo3::types::PyType;

use crate::algorithm::{kwargs, HostConfig, Hosted};

pyo3::create_exception!(
    nekosim,
    RunEnded,
    pyo3::exceptions::PyBaseException,
    "The run ended while the robot's algorithm waited for a call's result."
);

/// How often a waiting Python thread looks whether the run has ended.
const ENDED_POLL: Duration = Duration::from_millis(50);

/// A call of the Python algorithm to its robot.
#[derive(Debug)]
enum Call {
    Now,
    MoveTo {
        to: Point,
        move_speed: f64,
        turn_speed: f64,
    },
    Forward {
        distance: f64,
        move_speed: f64,
    },
    Turn {
        angle: f64,
        turn_speed: f64,
    },
    Sleep(f64),
    Position(f64),
    Positions(f64),
    InView(f64),
    Proximity(f64),
    Send {
        to: Vec<u32>,
        msg: serde_json::Value,
    },
    Receive,
    Log(String),
    Random,
    /// The algorithm returned or raised.
    Done,
}

/// The robot's answer to a [`Call`].
#[derive(Debug)]
enum Answer {
    Nothing,
    Number(f64),
    Motion {
        outcome: String,
        at: (f64, f64),
        angle: f64,
    },
    Point((f64, f64)),
    Robots(Vec<(u32, (f64, f64))>),
    Gaps(Vec<(u32, f64)>),
    Message {
        from: Option<u32>,
        msg: String,
    },
}

/// Where the robot's answers wait for its Python thread.
#[derive(Debug, Default)]
struct Answers {
    state: Mutex<Slot>,
    ready: Condvar,
}

#[derive(Debug, Default)]
enum Slot {
    #[default]
    Empty,
    Full(Answer),
    /// The robot's future is gone: no answer comes any more.
    Closed,
}

impl Answers {
    fn put(&self, slot: Slot) {
        if let Ok(mut s) = self.state.lock() {
            *s = slot;
        }
        self.ready.notify_one();
    }

    /// The next answer, or `None` once no answer can come (the robot's future is gone, or
    /// the run has ended).
    fn take(&self, ended: &std::sync::atomic::AtomicBool) -> Option<Answer> {
        let mut s = self.state.lock().ok()?;
        loop {
            match std::mem::take(&mut *s) {
                Slot::Full(a) => return Some(a),
                Slot::Closed => return None,
                Slot::Empty if ended.load(Ordering::Relaxed) => return None,
                Slot::Empty => s = self.ready.wait_timeout(s, ENDED_POLL).ok()?.0,
            }
        }
    }
}

/// Closes the answers when the robot's future is dropped.
#[derive(Debug)]
struct CloseOnDrop(Arc<Answers>);

impl Drop for CloseOnDrop {
    fn drop(&mut self) {
        self.0.put(Slot::Closed);
    }
}

/// A Python robot algorithm, as the engine's [`Algorithm`].
#[derive(Debug)]
pub struct PyRobot {
    name: String,
    object: Py<PyAny>,
    /// The scenario's configuration, as keyword arguments of a function.
    config: ron::Value,
    hosted: Hosted,
}

impl Clone for PyRobot {
    fn clone(&self) -> Self {
        Python::attach(|py| Self {
            name: self.name.clone(),
            object: self.object.clone_ref(py),
            config: self.config.clone(),
            hosted: self.hosted.clone(),
        })
    }
}

impl Configured for PyRobot {
    type Config = HostConfig;

    fn configure(config: HostConfig, _: &Setting) -> Result<Self, FieldError> {
        let (hosted, name, object) = Hosted::slot(config.slot)?;
        Python::attach(|py| {
            let failed =
                |e: PyErr| FieldError::new("", format!("{name}: {e}"), "what its class accepts");
            let bound = object.bind(py);
            // A class is built once from the configuration; a function takes it at each call.
            let (object, config) = if bound.is_instance_of::<PyType>() {
                let args = kwargs(py, &config.config)?;
                let made = bound.call((), Some(&args)).map_err(failed)?;
                if !made.hasattr("run").map_err(failed)? {
                    return Err(FieldError::new(
                        "",
                        format!("{name} has neither `compute` nor `run`"),
                        "a class with `compute(self, view)` or `run(self, robot)`",
                    ));
                }
                (made.unbind(), ron::Value::Unit)
            } else if bound.is_callable() {
                // The configuration must fit the function's parameters after the robot.
                let args = kwargs(py, &config.config)?;
                py.import("inspect")
                    .and_then(|i| i.call_method1("signature", (bound,)))
                    .and_then(|sig| sig.call_method("bind", (py.None(),), Some(&args)))
                    .map_err(failed)?;
                (object.clone_ref(py), config.config)
            } else {
                if !matches!(config.config, ron::Value::Unit) {
                    return Err(FieldError::new(
                        "",
                        format!("{name} is an object, configured in Python"),
                        "`()`, or register its class or function to configure it from the scenario",
                    ));
                }
                (object.clone_ref(py), ron::Value::Unit)
            };
            Ok(PyRobot {
                name,
                object,
                config,
                hosted,
            })
        })
    }
}

impl Algorithm for PyRobot {
    fn name(&self) -> &str {
        &self.name
    }

    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let me = self.clone();
        Box::pin(async move { me.drive(robot).await })
    }
}

impl PyRobot {
    /// Starts the Python code on its thread, then performs its calls one by one until it
    /// returns (or the run ends).
    async fn drive(self, robot: Robot) {
        let (calls, asked) = channel::<Call>();
        let done = calls.clone();
        let answers = Arc::new(Answers::default());
        let closing = CloseOnDrop(answers.clone());
        let handle = RobotHandle {
            id: robot.id(),
            count: robot.info().count,
            world: match robot.info().world {
                WorldSize::Bounded { min, max } => Some(((min.x, min.y), (max.x, max.y))),
                WorldSize::Infinite => None,
            },
            area: {
                let (lo, hi) = destination_area(robot.info().world);
                ((lo.x, lo.y), (hi.x, hi.y))
            },
            calls: Mutex::new(calls),
            answers,
            hosted: self.hosted.clone(),
        };
        let hosted = self.hosted.clone();
        let spawned = std::thread::Builder::new()
            .name(format!("nekosim robot {}", robot.id()))
            .spawn(move || {
                self.call_algorithm(handle);
                // The handle may outlive the call (an exception's traceback holds it).
                let _ = done.send(Call::Done);
            });
        match spawned {
            Ok(thread) => hosted.keep_thread(thread),
            Err(e) => {
                hosted.fail(pyo3::exceptions::PyRuntimeError::new_err(format!(
                    "cannot start the thread of robot {}: {e}",
                    robot.id()
                )));
                return;
            }
        }
        // The Python thread runs until it calls; the future waits for it, so that the two
        // never run at once.
        while let Ok(call) = asked.recv() {
            if let Call::Done = call {
                return;
            }
            let answer = perform(&robot, call).await;
            closing.0.put(Slot::Full(answer));
        }
    }

    /// The Python side: the algorithm called with the robot's handle, on the robot's thread.
    fn call_algorithm(self, handle: RobotHandle) {
        Python::attach(|py| {
            let outcome = Py::new(py, handle).and_then(|h| {
                let object = self.object.bind(py);
                if object.is_instance_of::<PyType>() || !object.is_callable() {
                    object.call_method1("run", (h,)).map(drop)
                } else {
                    let args = kwargs(py, &self.config)
                        .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
                    object.call((h,), Some(&args)).map(drop)
                }
            });
            if let Err(e) = outcome {
                if !e.is_instance_of::<RunEnded>(py) {
                    self.hosted.fail(e);
                }
            }
        });
    }
}

/// Performs `call` for the robot.
async fn perform(robot: &Robot, call: Call) -> Answer {
    let point = |p: Point| (p.x, p.y);
    match call {
        Call::Now => Answer::Number(robot.now()),
        Call::MoveTo {
            to,
            move_speed,
            turn_speed,
        } => motion(robot.move_to(to, move_speed, turn_speed).await),
        Call::Forward {
            distance,
            move_speed,
        } => motion(robot.forward(distance, move_speed).await),
        Call::Turn { angle, turn_speed } => motion(robot.turn(angle, turn_speed).await),
        Call::Sleep(d) => {
            robot.sleep(d).await;
            Answer::Nothing
        }
        Call::Position(error) => Answer::Point(point(robot.gps().self_position(error).await)),
        Call::Positions(error) => Answer::Robots(
            robot
                .gps()
                .all_positions(error)
                .await
                .into_iter()
                .map(|(id, p)| (id, point(p)))
                .collect(),
        ),
        Call::InView(range) => Answer::Robots(
            robot
                .robots_in_view(range)
                .await
                .into_iter()
                .map(|(id, p)| (id, point(p)))
                .collect(),
        ),
        Call::Proximity(range) => Answer::Gaps(robot.proximity(range).await),
        Call::Send { to, msg } => {
            robot.send(to, &msg);
            Answer::Nothing
        }
        Call::Receive => {
            let (received, msg) = robot.receive_msg::<serde_json::Value>().await;
            Answer::Message {
                from: received.sender(),
                msg: msg.to_string(),
            }
        }
        Call::Log(text) => {
            robot.log(text);
            Answer::Nothing
        }
        Call::Random => Answer::Number(robot.rng().gen::<f64>()),
        Call::Done => Answer::Nothing,
    }
}

fn motion(end: nekosim::robot::MotionEnd) -> Answer {
    Answer::Motion {
        outcome: end.outcome.name().to_string(),
        at: (end.state.pos.x, end.state.pos.y),
        angle: end.state.angle,
    }
}

/// The robot as its Python algorithm sees it: every call blocks until its result is there,
/// in virtual time.
#[derive(Debug)]
#[pyclass(module = "nekosim._nekosim", frozen)]
pub struct RobotHandle {
    /// The robot's id.
    #[pyo3(get)]
    id: u32,
    /// How many robots the run has.
    #[pyo3(get)]
    count: usize,
    /// The world's rectangle `((min_x, min_y), (max_x, max_y))`, `None` if infinite.
    #[pyo3(get)]
    world: Option<((f64, f64), (f64, f64))>,
    /// Where the seed's random movement draws destinations: the world, or the 800 x 800
    /// square centred on the origin in an infinite world.
    #[pyo3(get)]
    area: ((f64, f64), (f64, f64)),
    calls: Mutex<Sender<Call>>,
    answers: Arc<Answers>,
    hosted: Hosted,
}

impl RobotHandle {
    /// Hands `call` to the robot and waits, without the Python lock, for its answer.
    fn call(&self, py: Python<'_>, call: Call) -> PyResult<Answer> {
        let ended = || RunEnded::new_err("the run ended");
        self.calls
            .lock()
            .map_err(|_| ended())?
            .send(call)
            .map_err(|_| ended())?;
        let (answers, ended_flag) = (&self.answers, &self.hosted.ended);
        py.detach(|| answers.take(ended_flag)).ok_or_else(ended)
    }

    fn motion(&self, py: Python<'_>, call: Call) -> PyResult<MotionResult> {
        match self.call(py, call)? {
            Answer::Motion { outcome, at, angle } => Ok(MotionResult { outcome, at, angle }),
            other => Err(unexpected(other)),
        }
    }
}

fn unexpected(a: Answer) -> PyErr {
    pyo3::exceptions::PyRuntimeError::new_err(format!("unexpected answer {a:?}"))
}

fn positive(what: &str, v: f64) -> PyResult<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(pyo3::exceptions::PyValueError::new_err(format!(
            "{what} must be a finite number > 0, got {v}"
        )))
    }
}

#[pymethods]
impl RobotHandle {
    /// The current virtual time [s].
    fn now(&self, py: Python<'_>) -> PyResult<f64> {
        match self.call(py, Call::Now)? {
            Answer::Number(t) => Ok(t),
            other => Err(unexpected(other)),
        }
    }

    /// MOVETO (seed 6.3.1): turns the shortest way towards `to` = `(x, y)`, then moves there;
    /// returns when the motion ends, how it ended.
    fn move_to(
        &self,
        py: Python<'_>,
        to: (f64, f64),
        move_speed: f64,
        turn_speed: f64,
    ) -> PyResult<MotionResult> {
        positive("move_speed", move_speed)?;
        positive("turn_speed", turn_speed)?;
        self.motion(
            py,
            Call::MoveTo {
                to: Point::new(to.0, to.1),
                move_speed,
                turn_speed,
            },
        )
    }

    /// FORWARD: moves `distance` along the heading.
    fn forward(&self, py: Python<'_>, distance: f64, move_speed: f64) -> PyResult<MotionResult> {
        positive("move_speed", move_speed)?;
        self.motion(
            py,
            Call::Forward {
                distance,
                move_speed,
            },
        )
    }

    /// TURN: turns by a signed `angle` [deg] (positive is anticlockwise).
    fn turn(&self, py: Python<'_>, angle: f64, turn_speed: f64) -> PyResult<MotionResult> {
        positive("turn_speed", turn_speed)?;
        self.motion(py, Call::Turn { angle, turn_speed })
    }

    /// Waits `duration` [s] of virtual time.
    fn sleep(&self, py: Python<'_>, duration: f64) -> PyResult<()> {
        if !(duration.is_finite() && duration >= 0.0) {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "a sleep must last a finite number >= 0 of seconds, got {duration}"
            )));
        }
        self.call(py, Call::Sleep(duration)).map(drop)
    }

    /// The robot's own position from its GPS, each coordinate perturbed by `error` x N(0, 1).
    #[pyo3(signature = (error=0.0))]
    fn position(&self, py: Python<'_>, error: f64) -> PyResult<(f64, f64)> {
        match self.call(py, Call::Position(error))? {
            Answer::Point(p) => Ok(p),
            other => Err(unexpected(other)),
        }
    }

    /// Every robot's position from the GPS, `{id: (x, y)}`, perturbed as `position`.
    #[pyo3(signature = (error=0.0))]
    fn all_positions(&self, py: Python<'_>, error: f64) -> PyResult<Vec<(u32, (f64, f64))>> {
        match self.call(py, Call::Positions(error))? {
            Answer::Robots(r) => Ok(r),
            other => Err(unexpected(other)),
        }
    }

    /// The other robots whose centres are within `range`: a list of `(id, (x, y))`.
    fn robots_in_view(&self, py: Python<'_>, range: f64) -> PyResult<Vec<(u32, (f64, f64))>> {
        match self.call(py, Call::InView(range))? {
            Answer::Robots(r) => Ok(r),
            other => Err(unexpected(other)),
        }
    }

    /// Free distances (border to border) to the other robots within `range`: a list of
    /// `(id, distance)`.
    fn proximity(&self, py: Python<'_>, range: f64) -> PyResult<Vec<(u32, f64)>> {
        match self.call(py, Call::Proximity(range))? {
            Answer::Gaps(g) => Ok(g),
            other => Err(unexpected(other)),
        }
    }

    /// Sends `msg`, any value `json.dumps` accepts, to the robots `to` (a list of ids) over
    /// the scenario's network.
    fn send(&self, py: Python<'_>, to: Vec<u32>, msg: &Bound<'_, PyAny>) -> PyResult<()> {
        let text: String = py
            .import("json")?
            .call_method1("dumps", (msg,))?
            .extract()?;
        let msg: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
            pyo3::exceptions::PyValueError::new_err(format!("a message that is not JSON: {e}"))
        })?;
        self.call(py, Call::Send { to, msg }).map(drop)
    }

    /// Waits for the next message: `(sender, message)`, the message as `json.loads` reads
    /// it (`sender` is `None` when the network does not say).
    fn receive<'py>(&self, py: Python<'py>) -> PyResult<(Option<u32>, Bound<'py, PyAny>)> {
        match self.call(py, Call::Receive)? {
            Answer::Message { from, msg } => {
                Ok((from, py.import("json")?.call_method1("loads", (msg,))?))
            }
            other => Err(unexpected(other)),
        }
    }

    /// Writes `text` to the Neko log and the trace, at this instant.
    fn log(&self, py: Python<'_>, text: String) -> PyResult<()> {
        self.call(py, Call::Log(text)).map(drop)
    }

    /// A number uniform in `[0, 1)` from the robot's own seeded random stream (the stream
    /// the built-in algorithms draw from).
    fn random(&self, py: Python<'_>) -> PyResult<f64> {
        match self.call(py, Call::Random)? {
            Answer::Number(u) => Ok(u),
            other => Err(unexpected(other)),
        }
    }

    fn __repr__(&self) -> String {
        format!("Robot(id={}, count={})", self.id, self.count)
    }
}

/// How a motion ended.
#[derive(Debug)]
#[pyclass(module = "nekosim._nekosim", frozen)]
pub struct MotionResult {
    /// `"arrived"`, `"collided"`, `"replaced"`, `"rejected"` or `"crashed"` (docs/trace.md's
    /// `motion_finish`).
    #[pyo3(get)]
    outcome: String,
    /// Where the robot stands.
    #[pyo3(get)]
    at: (f64, f64),
    /// Its heading [deg].
    #[pyo3(get)]
    angle: f64,
}

#[pymethods]
impl MotionResult {
    /// Whether the robot arrived where it was sent.
    #[getter]
    fn arrived(&self) -> bool {
        self.outcome == "arrived"
    }

    fn __repr__(&self) -> String {
        format!(
            "MotionResult(outcome={:?}, at={:?}, angle={})",
            self.outcome, self.at, self.angle
        )
    }
}
