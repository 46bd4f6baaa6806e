//! Robots (seed 3.1 and 4.1): the robot actor and the algorithm API.
//!
//! A robot's algorithm is sequential async code, like the seed's `doMotion` loops:
//!
//! ```text
//! loop {
//!     let all = robot.gps().all_positions(0.0).await;
//!     let end = robot.move_to(centroid(&all), 4.0, 30.0).await;
//! }
//! ```
//!
//! The robot actor polls the algorithm's future itself, inside the handler of the event that
//! woke it, until the future is pending; every request the algorithm makes meanwhile goes into
//! the handler's reply. No executor, timer or thread is involved, so the algorithm runs at a
//! single instant of virtual time and deterministically.

use std::cell::{RefCell, RefMut};
use std::collections::VecDeque;
use std::fmt;
use std::future::Future;
use std::pin::Pin;
use std::rc::Rc;
use std::task::{Context as TaskContext, Poll};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::world::event::{FutureEvent, Notice};
use crate::world::geometry::Point;
use crate::world::motion::{Kinematics, Motion};
use crate::world::observation::Observation;
use crate::world::sensor::builtins::{
    self as sensors, ContactQuery, Fix, GpsQuery, ProximityQuery, PushProximityQuery, Seen,
    ViewQuery,
};
use crate::world::sensor::{SensorModel, SensorQuery, SensorValue};
use crate::world::virtual_world::WorldSize;
use crate::world::{MotionOutcome, RobotId};
use nekosim_protocols::{
    app_decode, app_payload, AppMsg, Content, Indication, LayerIx, Payload as MsgPayload,
    Request as ProtoRequest, APP, NET,
};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// A running algorithm.
pub type AlgorithmFuture = Pin<Box<dyn Future<Output = ()>>>;

/// A robot algorithm (seed 4.1, chapter 5): given the robot's handle, the sequential code the
/// robot runs. Implementations are plain data (their settings); `run` builds the future.
pub trait Algorithm: fmt::Debug + Send {
    /// Name for logs.
    fn name(&self) -> &str;
    /// The algorithm's code.
    fn run(&self, robot: Robot) -> AlgorithmFuture;
    /// For a Look-Compute-Move robot, the roster of the run's such robots, which the run
    /// fills before it starts (the adversary of a round picks among them). Default: none.
    fn roster(&self) -> Option<&crate::lcm::settings::Roster> {
        None
    }
    /// For a Look-Compute-Move robot, its algorithm's pure `compute` (what a checker or a
    /// search hosts on its own). Default: none.
    fn look_compute_move(&self) -> Option<std::sync::Arc<dyn crate::lcm::LookComputeMove>> {
        None
    }
}

/// How a motion call ended.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionEnd {
    pub outcome: MotionOutcome,
    /// The robot's state when the motion ended.
    pub state: Kinematics,
}

/// Identifies a motion started with [`Robot::start_motion`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MotionTicket(pub u64);

/// What the algorithm asked for during one poll.
#[derive(Debug)]
enum Request {
    Motion {
        ticket: u64,
        motion: Motion,
        at: f64,
        note: Option<Observation>,
    },
    Sensor {
        ticket: u64,
        query: SensorQuery,
        at: f64,
    },
    Timer {
        ticket: u64,
        at: f64,
    },
    ListEvents {
        of: RobotId,
        ticket: u64,
    },
    Log(String),
    Record(Observation),
    Light(crate::lcm::LightState),
    Net {
        to: Vec<RobotId>,
        msg: MsgPayload,
    },
    Layer {
        ix: LayerIx,
        req: ProtoRequest,
    },
}

#[derive(Debug)]
struct RobotIo {
    now: f64,
    next_ticket: u64,
    inbox: VecDeque<Notice>,
    outbox: Vec<Request>,
    rng: Stream,
}

/// A robot's random stream (stream number: the robot's id), small between handlings: at rest
/// it is the run's seed and the words drawn so far (24 bytes with the empty slot of the live
/// generator, where a `ChaCha8Rng` carries a 256-byte block buffer, hundreds of megabytes
/// at a million robots). The generator is rebuilt at the first draw of a handling
/// ([`Stream::live`]) and folded back when the handling ends ([`Stream::rest`]);
/// `set_word_pos` resumes the very same stream.
#[derive(Debug)]
struct Stream {
    seed: u64,
    /// Words drawn so far (a robot draws far fewer than 2^64).
    pos: u64,
    live: Option<Box<ChaCha8Rng>>,
}

impl Stream {
    fn new(seed: u64) -> Self {
        Self {
            seed,
            pos: 0,
            live: None,
        }
    }

    /// The generator of stream `stream`, rebuilt at the position reached if it is at rest.
    fn live(&mut self, stream: u64) -> &mut ChaCha8Rng {
        let (seed, pos) = (self.seed, self.pos);
        self.live.get_or_insert_with(|| {
            let (spare, key) = SPARE.with_borrow_mut(|s| (s.rng.take(), s.key(seed)));
            let mut rng = match spare {
                Some(mut spare) => {
                    *spare = ChaCha8Rng::from_seed(key);
                    spare
                }
                None => Box::new(ChaCha8Rng::from_seed(key)),
            };
            rng.set_stream(stream);
            rng.set_word_pos(u128::from(pos));
            rng
        })
    }

    /// Folds the generator back into its position.
    fn rest(&mut self) {
        if let Some(rng) = self.live.take() {
            self.pos = u64::try_from(rng.get_word_pos()).expect("fewer than 2^64 words drawn");
            SPARE.with_borrow_mut(|s| s.rng = Some(rng));
        }
    }
}

/// The buffers a robot's handling uses and leaves empty: its inbox, its outbox and its live
/// generator. A robot keeps none of them between handlings (a million robots' buffers would
/// take hundreds of megabytes), so each handling borrows them from its thread's spares and
/// gives them back, empty, when it ends: no allocation in a robot's handling (an inbox, an
/// outbox and a generator of its own would be three allocations and three frees a notice).
#[derive(Default)]
struct Spare {
    inbox: VecDeque<Notice>,
    outbox: Vec<Request>,
    rng: Option<Box<ChaCha8Rng>>,
    /// The last seed a generator was built from and its 32-byte key: every robot's stream
    /// has the run's seed, so the key is expanded once, not at each handling's first draw.
    key: Option<(u64, [u8; 32])>,
}

thread_local! {
    static SPARE: RefCell<Spare> = RefCell::new(Spare::default());
}

impl Spare {
    /// The key `ChaCha8Rng::seed_from_u64(seed)` is built from.
    fn key(&mut self, seed: u64) -> [u8; 32] {
        match self.key {
            Some((s, key)) if s == seed => key,
            _ => {
                let key = ChaCha8Rng::seed_from_u64(seed).get_seed();
                self.key = Some((seed, key));
                key
            }
        }
    }

    /// Lends the thread's empty buffers to `io` where it has none.
    fn lend(io: &mut RobotIo) {
        SPARE.with_borrow_mut(|s| {
            if io.inbox.capacity() == 0 {
                std::mem::swap(&mut io.inbox, &mut s.inbox);
            }
            if io.outbox.capacity() == 0 {
                std::mem::swap(&mut io.outbox, &mut s.outbox);
            }
        });
    }

    /// Takes back an inbox left empty (or frees it, when the thread has one spare already: a
    /// robot keeps no buffer it does not need) and an outbox emptied.
    fn take_back(inbox: &mut VecDeque<Notice>, outbox: Vec<Request>) {
        debug_assert!(outbox.is_empty());
        SPARE.with_borrow_mut(|s| {
            if inbox.is_empty() {
                if s.inbox.capacity() == 0 {
                    std::mem::swap(inbox, &mut s.inbox);
                } else {
                    *inbox = VecDeque::new();
                }
            }
            if s.outbox.capacity() == 0 {
                s.outbox = outbox;
            }
        });
    }
}

/// What a robot knows about its setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobotInfo {
    pub id: RobotId,
    /// Number of robots in the run.
    pub count: usize,
    /// Radius [units].
    pub radius: f64,
    pub world: WorldSize,
    /// Whether anything reads the run's step records ([`Robot::records_steps`]).
    pub steps: bool,
}

/// A message or indication that reached the algorithm.
#[derive(Clone, Debug, PartialEq)]
pub struct Received {
    /// `"net"` for a direct message, else the id of the layer that indicated it.
    pub layer: String,
    pub ind: Indication,
}

impl Received {
    /// `ind` from `layer`.
    pub fn new(layer: String, ind: Indication) -> Self {
        Self { layer, ind }
    }

    /// The application payload carried (a message, a delivered broadcast, a decided value).
    pub fn payload(&self) -> Option<&MsgPayload> {
        match &self.ind {
            Indication::Deliver { msg, .. } | Indication::BDeliver { msg, .. } => Some(msg),
            Indication::Decide { value, .. } => Some(value),
            _ => None,
        }
    }

    /// The algorithm's own message carried, if there is one and it reads as an `M` (sent with
    /// [`Robot::send`] or a [`LayerHandle`] method).
    pub fn msg<M: DeserializeOwned>(&self) -> Option<M> {
        self.payload().and_then(app_decode)
    }

    /// The dynamic application message carried, if any: `(kind, content)`.
    pub fn app(&self) -> Option<(String, Content)> {
        self.payload()
            .and_then(AppMsg::of)
            .map(|m| (m.kind, m.content))
    }

    /// Who sent it (direct messages) or broadcast it (broadcast deliveries).
    pub fn sender(&self) -> Option<RobotId> {
        match &self.ind {
            Indication::Deliver { from, .. } => Some(*from),
            Indication::BDeliver { id, .. } => Some(id.origin),
            _ => None,
        }
    }
}

/// The future of a wait for a notice: the robot's handle and the test that picks the notice,
/// polled by hand (an `async fn` would keep both twice, and a robot's algorithm future holds
/// a wait).
struct Take<'a, F> {
    robot: &'a Robot,
    pick: F,
}

impl<T, F: Fn(&Notice) -> Option<T> + Unpin> Future for Take<'_, F> {
    type Output = T;

    fn poll(self: Pin<&mut Self>, _: &mut TaskContext<'_>) -> Poll<T> {
        let this = self.get_mut();
        let mut io = this.robot.shared.io.borrow_mut();
        match io
            .inbox
            .iter()
            .enumerate()
            .find_map(|(i, n)| (this.pick)(n).map(|v| (i, v)))
        {
            Some((i, v)) => {
                io.inbox.remove(i);
                Poll::Ready(v)
            }
            None => Poll::Pending,
        }
    }
}

/// The handle an algorithm uses to move, sense and wait (the seed's interface layer). One
/// pointer, shared by the robot's actor and its algorithm's future (a whole handle in each
/// would take 160 bytes a robot and put the actor's task in a larger size class).
#[derive(Clone)]
pub struct Robot {
    shared: Rc<Shared>,
}

struct Shared {
    info: RobotInfo,
    /// Ids of the protocol stack's layers, by index.
    layers: std::sync::Arc<Vec<String>>,
    io: RefCell<RobotIo>,
}

impl fmt::Debug for Robot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Robot")
            .field("info", &self.shared.info)
            .finish()
    }
}

impl Robot {
    /// The robot's id.
    pub fn id(&self) -> RobotId {
        self.shared.info.id
    }

    /// The robot's settings.
    pub fn info(&self) -> RobotInfo {
        self.shared.info
    }

    /// Current virtual time [s].
    pub fn now(&self) -> f64 {
        self.shared.io.borrow().now
    }

    /// The run's seed, for hosts of algorithms that derive further named streams from it
    /// ([`crate::random::rng`]), as the Look-Compute-Move adversary does.
    pub fn run_seed(&self) -> u64 {
        self.shared.io.borrow().rng.seed
    }

    /// Writes a typed record to the trace and the log, at this instant, in the order of the
    /// robot's other requests.
    pub fn record(&self, observation: Observation) {
        self.push(Request::Record(observation));
    }

    /// Whether anything reads the run's step records ([`Observation::is_step`]: the log, the
    /// trace, a recording, an observer): when nothing does, a step record given to
    /// [`Robot::record`] goes nowhere, and an algorithm may leave it out.
    pub fn records_steps(&self) -> bool {
        self.shared.info.steps
    }

    /// Shows `light` to the other robots from now on ([`crate::lcm`]).
    pub fn set_light(&self, light: crate::lcm::LightState) {
        self.push(Request::Light(light));
    }

    /// The robot's own random stream, derived from the run's seed and the robot's id.
    pub fn rng(&self) -> RefMut<'_, ChaCha8Rng> {
        let stream = crate::random::Stream::Robot(self.shared.info.id).number();
        RefMut::map(self.shared.io.borrow_mut(), |io| io.rng.live(stream))
    }

    fn ticket(&self) -> u64 {
        let mut io = self.shared.io.borrow_mut();
        io.next_ticket += 1;
        io.next_ticket
    }

    fn push(&self, r: Request) {
        self.shared.io.borrow_mut().outbox.push(r);
    }

    /// Waits for the first notice `pick` accepts and removes it from the inbox; the future is
    /// the handle and `pick` alone (see [`Take`]).
    fn take<T, F: Fn(&Notice) -> Option<T> + Unpin>(&self, pick: F) -> Take<'_, F> {
        Take { robot: self, pick }
    }

    /// Starts a motion, replacing the current one, without waiting for it to end.
    pub fn start_motion(&self, motion: Motion) -> MotionTicket {
        self.start_motion_at(self.now(), motion, None)
    }

    /// Starts `motion` at virtual time `at` (at once if it has come), replacing the motion
    /// the robot has then, without waiting for it to end: the same as sleeping until `at` and
    /// then [`Robot::start_motion`], one event fewer (the robot is not woken at `at` to ask
    /// for it). `note`, if any, is written to the trace and the log as the motion starts, as
    /// [`Robot::record`] would have written it then. A robot that crashes before `at` neither
    /// moves nor writes it.
    pub fn start_motion_at(
        &self,
        at: f64,
        motion: Motion,
        note: Option<Observation>,
    ) -> MotionTicket {
        let ticket = self.ticket();
        self.push(Request::Motion {
            ticket,
            motion,
            at,
            note,
        });
        MotionTicket(ticket)
    }

    /// Waits until the motion `t` ends.
    pub fn wait_motion(&self, t: MotionTicket) -> impl Future<Output = MotionEnd> + '_ {
        self.take(move |n| match n {
            Notice::MotionEnded {
                ticket,
                outcome,
                state,
            } if *ticket == t.0 => Some(MotionEnd {
                outcome: outcome.clone(),
                state: *state,
            }),
            _ => None,
        })
    }

    /// Performs a motion and waits for its end.
    pub async fn motion(&self, motion: Motion) -> MotionEnd {
        let t = self.start_motion(motion);
        self.wait_motion(t).await
    }

    // `move_to`, `forward` and `turn` are [`Robot::motion`]'s future itself, not a future that
    // awaits it: it starts the motion when first polled all the same, and an algorithm's
    // future holds the motion once instead of twice (48 bytes a robot).

    /// MOVETO: turn the shortest way towards `dest`, then move there (seed 6.3.1).
    pub fn move_to(
        &self,
        dest: Point,
        move_speed: f64,
        turn_speed: f64,
    ) -> impl Future<Output = MotionEnd> + '_ {
        self.motion(Motion::MoveTo {
            dest,
            move_speed,
            turn_speed,
        })
    }

    /// FORWARD: move `distance` along the heading.
    pub fn forward(&self, distance: f64, move_speed: f64) -> impl Future<Output = MotionEnd> + '_ {
        self.motion(Motion::Forward {
            distance,
            move_speed,
        })
    }

    /// TURN: turn by a signed `angle` [deg] (positive is anticlockwise).
    pub fn turn(&self, angle: f64, turn_speed: f64) -> impl Future<Output = MotionEnd> + '_ {
        self.motion(Motion::Turn { angle, turn_speed })
    }

    /// Waits `duration` [s] of virtual time.
    pub async fn sleep(&self, duration: f64) {
        let ticket = self.ticket();
        let at = self.now() + duration.max(0.0);
        self.push(Request::Timer { ticket, at });
        self.take(|n| matches!(n, Notice::Timer { ticket: t } if *t == ticket).then_some(()))
            .await;
    }

    /// Sends a sensor request and waits for the reply.
    pub async fn sense(&self, query: SensorQuery) -> SensorValue {
        self.sense_at(self.now(), query).await
    }

    /// Sends a sensor request that reaches the sensor manager at virtual time `at` (at once if
    /// it has come) and waits for the reply: a read at `at` that does not wake the robot
    /// before it.
    async fn sense_at(&self, at: f64, query: SensorQuery) -> SensorValue {
        let ticket = self.ticket();
        self.push(Request::Sensor { ticket, query, at });
        let v = self
            .take(|n| match n {
                Notice::SensorReply { ticket: t, value } if *t == ticket => Some(value.clone()),
                _ => None,
            })
            .await;
        v
    }

    /// Reads the pull sensor registered as `name` ([`crate::world::sensor::SensorModel`]):
    /// its reply to `query`, or why the request was refused.
    pub async fn read<S: SensorModel>(
        &self,
        name: &str,
        query: &S::Query,
    ) -> Result<S::Reply, String> {
        self.sense(SensorQuery::new::<S>(name, query.clone()))
            .await
            .decode()
    }

    /// Reads the pull sensor registered as `name` at virtual time `at`: the same reply as
    /// sleeping until `at` and then [`Robot::read`], one event fewer (the robot is not woken
    /// at `at` to send the request).
    pub async fn read_at<S: SensorModel>(
        &self,
        at: f64,
        name: &str,
        query: &S::Query,
    ) -> Result<S::Reply, String> {
        self.sense_at(at, SensorQuery::new::<S>(name, query.clone()))
            .await
            .decode()
    }

    /// Activates the push sensor registered as `name` with `query`: from now on it senses
    /// as its trigger says and interrupts the robot ([`Robot::next_notice`]) when its
    /// condition holds; the interrupt's value decodes as its reply ([`SensorValue::decode`]).
    pub async fn activate<S: SensorModel>(
        &self,
        name: &str,
        query: &S::Query,
    ) -> Result<(), String> {
        match self.sense(SensorQuery::new::<S>(name, query.clone())).await {
            SensorValue::Done => Ok(()),
            SensorValue::Rejected(e) => Err(e),
            other => Err(format!("{name} is a pull sensor (it answered {other:?})")),
        }
    }

    /// Deactivates the push sensor registered as `name`.
    pub async fn deactivate(&self, name: &str) {
        self.sense(SensorQuery::off(name)).await;
    }

    /// Waits for the next push-sensor interrupt, end of a motion started with
    /// [`Robot::start_motion`], or incoming message, whichever comes first.
    pub async fn next_notice(&self) -> Notice {
        self.take(|n| {
            matches!(
                n,
                Notice::Interrupt { .. } | Notice::MotionEnded { .. } | Notice::Incoming { .. }
            )
            .then(|| n.clone())
        })
        .await
    }

    /// The robot's pending events, as the event manager lists them now (seed 4.2.3): for
    /// instance to see a predicted collision before acting.
    pub async fn future_events(&self) -> Vec<FutureEvent> {
        self.future_events_of(self.shared.info.id).await
    }

    /// The pending events of robot `of` (any robot, as the seed's event manager lists them),
    /// now.
    pub async fn future_events_of(&self, of: RobotId) -> Vec<FutureEvent> {
        let ticket = self.ticket();
        self.push(Request::ListEvents { of, ticket });
        let v = self
            .take(|n| match n {
                Notice::FutureEvents { ticket: t, events } if *t == ticket => Some(events.clone()),
                _ => None,
            })
            .await;
        v
    }

    /// Writes `text` to the run's log as this robot, now (seed 5.3's `logger.info(..)`): a
    /// line of the Neko log, a `log` record of the trace and an entry of a recording's log.
    pub fn log(&self, text: impl Into<String>) {
        self.push(Request::Log(text.into()));
    }

    /// Sends the algorithm's own message `msg` (any serde type) to robots `to` directly over
    /// the network (multicast). The log and trace show it as compact RON (`GOTO(60.2, 31.7)`).
    pub fn send<M: Serialize>(&self, to: Vec<RobotId>, msg: &M) {
        self.push(Request::Net {
            to,
            msg: app_payload(msg),
        });
    }

    /// Waits for the next message or indication that carries an `M` (other notices stay
    /// queued for other waits).
    pub async fn receive_msg<M: DeserializeOwned>(&self) -> (Received, M) {
        let r = self
            .take(|n| match n {
                Notice::Incoming { layer, ind } => {
                    let r = Received::new(self.layer_id(*layer), ind.clone());
                    r.msg::<M>().map(|m| (r, m))
                }
                _ => None,
            })
            .await;
        r
    }

    /// A layer of the robot's protocol stack, by id (as in the scenario's `stack`).
    pub fn layer(&self, id: &str) -> Option<LayerHandle<'_>> {
        self.shared
            .layers
            .iter()
            .position(|l| l == id)
            .map(|ix| LayerHandle {
                robot: self,
                ix: ix as LayerIx,
            })
    }

    /// Waits for the next direct message or layer indication (Neko's active receive).
    pub async fn receive(&self) -> Received {
        let r = self
            .take(|n| match n {
                Notice::Incoming { layer, ind } => {
                    Some(Received::new(self.layer_id(*layer), ind.clone()))
                }
                _ => None,
            })
            .await;
        r
    }

    fn layer_id(&self, ix: LayerIx) -> String {
        match ix {
            NET => "net".into(),
            APP => "app".into(),
            i => self
                .shared
                .layers
                .get(i as usize)
                .cloned()
                .unwrap_or_default(),
        }
    }

    /// The GPS sensor.
    pub fn gps(&self) -> Gps<'_> {
        Gps(self)
    }

    /// Positions of the other robots whose centres are within `range` (view sensor).
    pub async fn robots_in_view(&self, range: f64) -> Vec<(RobotId, Point)> {
        let seen = self
            .read::<sensors::View>(
                "view",
                &ViewQuery {
                    range,
                    line_of_sight: None,
                },
            )
            .await;
        seen.unwrap_or_default()
            .into_iter()
            .map(|s| (s.robot, s.pos))
            .collect()
    }

    /// Free distances (border to border) to the other robots within `range` (proximity
    /// sensor, pull).
    pub async fn proximity(&self, range: f64) -> Vec<(RobotId, f64)> {
        let gaps = self
            .read::<sensors::Proximity>(
                "proximity",
                &ProximityQuery {
                    range,
                    line_of_sight: None,
                },
            )
            .await;
        gaps.unwrap_or_default()
            .into_iter()
            .map(|g| (g.robot, g.distance))
            .collect()
    }

    /// Activates the push proximity sensor; interrupts (their value a list of [`Gap`]s)
    /// arrive through [`Robot::next_notice`].
    pub async fn activate_proximity(&self, range: f64, interval: f64) -> SensorValue {
        let q = PushProximityQuery::ActivateProximity { range, interval };
        self.sense(SensorQuery::new::<sensors::PushProximity>(
            "push_proximity",
            q,
        ))
        .await
    }

    /// Deactivates the push proximity sensor.
    pub async fn deactivate_proximity(&self) {
        let q = PushProximityQuery::DeactivateProximity;
        self.sense(SensorQuery::new::<sensors::PushProximity>(
            "push_proximity",
            q,
        ))
        .await;
    }

    /// Activates the contact sensor; interrupts (their value a
    /// [`crate::world::sensor::builtins::Touch`]) arrive through [`Robot::next_notice`].
    pub async fn activate_contact(&self) {
        let q = ContactQuery::ActivateContact;
        self.sense(SensorQuery::new::<sensors::Contact>("contact", q))
            .await;
    }

    /// Deactivates the contact sensor.
    pub async fn deactivate_contact(&self) {
        let q = ContactQuery::DeactivateContact;
        self.sense(SensorQuery::new::<sensors::Contact>("contact", q))
            .await;
    }
}

/// A layer of a robot's stack, for requests from the algorithm.
#[derive(Debug)]
pub struct LayerHandle<'a> {
    robot: &'a Robot,
    ix: LayerIx,
}

impl LayerHandle<'_> {
    /// Broadcasts the algorithm's own message through the layer (broadcast layers).
    pub fn broadcast<M: Serialize>(&self, msg: &M) {
        self.robot.push(Request::Layer {
            ix: self.ix,
            req: ProtoRequest::Broadcast {
                msg: app_payload(msg),
            },
        });
    }

    /// Proposes the algorithm's own value to instance `k` (consensus layers).
    pub fn propose<M: Serialize>(&self, k: u64, value: &M) {
        self.robot.push(Request::Layer {
            ix: self.ix,
            req: ProtoRequest::Propose {
                k,
                value: app_payload(value),
            },
        });
    }

    /// Sends the algorithm's own message through the layer (point-to-point layers such as
    /// Fifo).
    pub fn send<M: Serialize>(&self, to: Vec<RobotId>, msg: &M) {
        self.robot.push(Request::Layer {
            ix: self.ix,
            req: ProtoRequest::Send {
                to,
                msg: app_payload(msg),
            },
        });
    }
}

/// The GPS sensor of a robot (seed 6.3.2).
#[derive(Debug)]
pub struct Gps<'a>(&'a Robot);

impl Gps<'_> {
    /// The robot's own position, each coordinate perturbed by `error` × N(0, 1).
    pub async fn self_position(&self, error: f64) -> Point {
        let q = GpsQuery::SelfPosition { error };
        match self.0.read::<sensors::Gps>("gps", &q).await {
            Ok(Fix::Position(p)) => p,
            _ => Point::new(f64::NAN, f64::NAN),
        }
    }

    /// All robots' positions by id, perturbed as above.
    pub async fn all_positions(&self, error: f64) -> Vec<(RobotId, Point)> {
        let q = GpsQuery::AllPositions { error };
        match self.0.read::<sensors::Gps>("gps", &q).await {
            Ok(Fix::Positions(v)) => v.into_iter().map(|s: Seen| (s.robot, s.pos)).collect(),
            _ => Vec::new(),
        }
    }
}

mod actor;
pub use actor::RobotActor;

#[cfg(test)]
mod tests;
