//! Sensors (seed 3.1.2, 4.2.2 and 6.3.2): what a robot can ask, what comes back, and how a
//! sensor turns the world's exact data into a reply.
//!
//! Every sensor, built-in or a user's, is a [`SensorModel`] registered by name in [`Sensors`]:
//! [`SensorModel::sense`] gathers exact data from the world at the trigger instant (the seed's
//! `doSensor`, run by the sensor manager), [`SensorModel::reply`] computes the robot's reply on
//! the robot's sensor actor with that sensor's own seeded random stream (the seed's
//! `calReply`). A query either reads once (pull) or arms the sensor ([`Trigger`]): re-sensing
//! every interval, at the exact instant another robot comes within a range (push proximity),
//! or whenever the robot touches something (contact). The built-in GPS, view, proximity, push
//! proximity and contact sensors ([`builtins`]) are registered exactly as a user's sensor is.

use std::any::Any;
use std::fmt;
use std::sync::Arc;

use nekosim_protocols::app::compact_ron;
use nekosim_protocols::registry::{intern, Named};

use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::geometry::Point;
use super::{Obstacle, RobotId};

pub mod builtins;

/// Which sensor of a robot: the name it is registered under (serialized as that name).
///
/// A thin pointer to the interned name (8 bytes, where a `&str` takes 16): events that name
/// a sensor stay small. Compared, ordered and hashed by the name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SensorKind(&'static &'static str);

impl SensorKind {
    /// The built-in GPS sensor.
    pub const GPS: SensorKind = SensorKind(&"gps");
    /// The built-in view sensor.
    pub const VIEW: SensorKind = SensorKind(&"view");
    /// The built-in (pull) proximity sensor.
    pub const PROXIMITY: SensorKind = SensorKind(&"proximity");
    /// The built-in push proximity sensor.
    pub const PUSH_PROXIMITY: SensorKind = SensorKind(&"push_proximity");
    /// The built-in contact sensor.
    pub const CONTACT: SensorKind = SensorKind(&"contact");

    /// The sensor registered under `name`.
    pub fn named(name: &str) -> Self {
        static KINDS: std::sync::Mutex<
            std::collections::BTreeMap<&'static str, &'static &'static str>,
        > = std::sync::Mutex::new(std::collections::BTreeMap::new());
        let mut kinds = KINDS.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(&kind) = kinds.get(name) {
            return SensorKind(kind);
        }
        let name = intern(name);
        SensorKind(
            kinds
                .entry(name)
                .or_insert_with(|| Box::leak(Box::new(name))),
        )
    }

    /// Name used in traces and logs.
    pub fn name(self) -> &'static str {
        self.0
    }

    /// The number that derives the sensor's random stream from the run's seed: the built-ins
    /// keep 0 to 4, any other name gets a number from its FNV-1a hash, clear of them.
    pub fn stream(self) -> u64 {
        let builtins = [
            Self::GPS,
            Self::VIEW,
            Self::PROXIMITY,
            Self::PUSH_PROXIMITY,
            Self::CONTACT,
        ];
        if let Some(i) = builtins.iter().position(|&k| k == self) {
            return i as u64;
        }
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in self.0.bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
        16 + (h % 240)
    }
}

impl fmt::Display for SensorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
    }
}

impl Serialize for SensorKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.0)
    }
}

/// What a sensor's data is required to be: a serde type that can be compared and printed.
pub trait Data: Serialize + fmt::Debug + PartialEq + Send + Sync + 'static {}
impl<T: Serialize + fmt::Debug + PartialEq + Send + Sync + 'static> Data for T {}

/// How one type of [`Datum`] is shown and compared.
struct Ops {
    json: fn(&dyn Any) -> serde_json::Value,
    ron: fn(&dyn Any) -> String,
    text: fn(&dyn Any) -> Option<String>,
    debug: fn(&dyn Any, &mut fmt::Formatter<'_>) -> fmt::Result,
    eq: fn(&dyn Any, &dyn Any) -> bool,
}

fn cast<T: 'static>(v: &dyn Any) -> &T {
    v.downcast_ref::<T>()
        .expect("a datum's operations are those of its own type")
}

fn json_of<T: Data>(v: &dyn Any) -> serde_json::Value {
    serde_json::to_value(cast::<T>(v)).unwrap_or_else(|e| serde_json::json!(e.to_string()))
}

fn ron_of<T: Data>(v: &dyn Any) -> String {
    compact_ron(cast::<T>(v)).unwrap_or_else(|e| e.to_string())
}

fn debug_of<T: Data>(v: &dyn Any, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    fmt::Debug::fmt(cast::<T>(v), f)
}

fn eq_of<T: Data>(a: &dyn Any, b: &dyn Any) -> bool {
    b.downcast_ref::<T>().is_some_and(|b| cast::<T>(a) == b)
}

/// The operations of a sensor's query and of its reply, with the sensor's own log text.
struct OpsOf<S>(std::marker::PhantomData<S>);

impl<S: SensorModel> OpsOf<S> {
    const QUERY: Ops = Ops {
        json: json_of::<S::Query>,
        ron: ron_of::<S::Query>,
        text: |v| S::query_text(cast(v)),
        debug: debug_of::<S::Query>,
        eq: eq_of::<S::Query>,
    };
    const READING: Ops = Ops {
        json: json_of::<S::Reading>,
        ron: ron_of::<S::Reading>,
        text: |_| None,
        debug: debug_of::<S::Reading>,
        eq: eq_of::<S::Reading>,
    };
    const REPLY: Ops = Ops {
        json: json_of::<S::Reply>,
        ron: ron_of::<S::Reply>,
        text: |v| S::reply_text(cast(v)),
        debug: debug_of::<S::Reply>,
        eq: eq_of::<S::Reply>,
    };
}

/// A query, reading or reply of some sensor, its type erased: it travels in events and
/// records without being encoded, is shown in the trace by serde (JSON) and in the log by its
/// sensor's own text, and is taken back as its own type with [`Datum::get`].
#[derive(Clone)]
pub struct Datum {
    value: Arc<dyn Any + Send + Sync>,
    ops: &'static Ops,
}

impl Datum {
    /// `S`'s query `q`.
    pub fn query<S: SensorModel>(q: S::Query) -> Self {
        Self {
            value: Arc::new(q),
            ops: &OpsOf::<S>::QUERY,
        }
    }

    fn reading<S: SensorModel>(r: S::Reading) -> Self {
        Self {
            value: Arc::new(r),
            ops: &OpsOf::<S>::READING,
        }
    }

    fn reply<S: SensorModel>(r: S::Reply) -> Self {
        Self {
            value: Arc::new(r),
            ops: &OpsOf::<S>::REPLY,
        }
    }

    /// The value, when it is a `T`.
    pub fn get<T: 'static>(&self) -> Option<&T> {
        self.value.downcast_ref::<T>()
    }

    /// The value as JSON (the trace's form).
    pub fn json(&self) -> serde_json::Value {
        (self.ops.json)(&*self.value)
    }

    /// The value as compact RON.
    pub fn ron(&self) -> String {
        (self.ops.ron)(&*self.value)
    }

    /// The value as its sensor writes it in the Neko log, when the sensor says how
    /// ([`SensorModel::query_text`], [`SensorModel::reply_text`]).
    pub fn own_text(&self) -> Option<String> {
        (self.ops.text)(&*self.value)
    }

    /// The value as the Neko log writes it: its sensor's own text, or else its RON.
    pub fn text(&self) -> String {
        self.own_text().unwrap_or_else(|| self.ron())
    }
}

impl fmt::Debug for Datum {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        (self.ops.debug)(&*self.value, f)
    }
}

impl PartialEq for Datum {
    fn eq(&self, other: &Self) -> bool {
        (self.ops.eq)(&*self.value, &*other.value)
    }
}

impl Serialize for Datum {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.json().serialize(s)
    }
}

/// A sensor request: a query for the sensor registered as `sensor`, or (`query: None`) its
/// deactivation.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorQuery {
    pub sensor: SensorKind,
    pub query: Option<Datum>,
}

impl SensorQuery {
    /// `S`'s query `q` for the sensor registered as `name`.
    pub fn new<S: SensorModel>(name: &str, q: S::Query) -> Self {
        Self {
            sensor: SensorKind::named(name),
            query: Some(Datum::query::<S>(q)),
        }
    }

    /// Deactivates the push sensor registered as `name`.
    pub fn off(name: &str) -> Self {
        Self {
            sensor: SensorKind::named(name),
            query: None,
        }
    }
}

/// As the trace shows a request: `sensor` (its name) and `value` (the query, or
/// `{"query": "deactivate"}`).
impl Serialize for SensorQuery {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry("sensor", &self.sensor)?;
        match &self.query {
            Some(q) => m.serialize_entry("value", q)?,
            None => m.serialize_entry("value", &serde_json::json!({"query": "deactivate"}))?,
        }
        m.end()
    }
}

/// A sensor's answer to its robot.
#[derive(Clone, Debug, PartialEq)]
pub enum SensorValue {
    /// The sensor's reply (a pull reading, or a push sensor's interrupt).
    Reply(Datum),
    /// A push sensor was (de)activated.
    Done,
    /// The request was invalid (or named no registered sensor).
    Rejected(String),
}

impl SensorValue {
    /// The reply, when it is an `R` (the sensor's [`SensorModel::Reply`]).
    pub fn get<R: 'static>(&self) -> Option<&R> {
        match self {
            SensorValue::Reply(d) => d.get(),
            _ => None,
        }
    }

    /// The reply as an `R`, or why there is none.
    pub fn decode<R: Clone + 'static>(&self) -> Result<R, String> {
        match self {
            SensorValue::Reply(d) => d
                .get::<R>()
                .cloned()
                .ok_or_else(|| format!("the reply {d:?} is not a {}", std::any::type_name::<R>())),
            SensorValue::Rejected(e) => Err(e.clone()),
            SensorValue::Done => Err("the sensor answered `done`, not a reply".into()),
        }
    }

    /// The Neko log's text of the value.
    pub fn text(&self) -> String {
        match self {
            SensorValue::Reply(d) => d.text(),
            SensorValue::Done => "done".into(),
            SensorValue::Rejected(m) => format!("rejected: {m}"),
        }
    }
}

impl Serialize for SensorValue {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            SensorValue::Reply(d) => d.serialize(s),
            SensorValue::Done => s.serialize_str("done"),
            SensorValue::Rejected(m) => serde_json::json!({ "rejected": m }).serialize(s),
        }
    }
}

/// When a query makes its sensor sense ([`SensorModel::trigger`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Trigger {
    /// Once, now: a pull reading answered to the robot.
    Pull,
    /// Arms a push sensor that re-senses every `interval` [s] from its activation.
    Every(f64),
    /// Arms a push sensor that senses at the exact instant another robot's border comes
    /// within `range` of the robot's border (predicted from the motion formulas, cancelled
    /// when paths change); after an interrupt it stays quiet for `quiet` [s] and senses again
    /// at its end if an entry happened meanwhile.
    Entry { range: f64, quiet: f64 },
    /// Arms a push sensor that senses whenever the robot touches a robot or the boundary
    /// ([`WorldView::contact`]).
    Contact,
    /// Deactivates the sensor.
    Off,
}

/// How far a query looks, drawn around the robot in recordings ([`SensorModel::reach`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reach {
    /// Centre to centre [units].
    Centres(f64),
    /// Border to border (free distance) [units].
    Borders(f64),
}

/// What a sensor sees of the world at its trigger instant (the seed's `doSensor` runs on the
/// sensor manager, which alone reaches the world): exact positions from the motion formulas.
pub trait WorldView {
    /// The trigger instant [s].
    fn now(&self) -> f64;
    /// The robot whose sensor it is.
    fn robot(&self) -> RobotId;
    /// Number of robots.
    fn count(&self) -> usize;
    /// A robot's exact position now.
    fn position(&self, robot: RobotId) -> Point;
    /// A robot's radius.
    fn radius(&self, robot: RobotId) -> f64;
    /// The other robots whose centres are within `range` of this robot's centre, with their
    /// positions and centre distances, by id (found through the spatial index).
    fn within(&self, range: f64) -> Vec<(RobotId, Point, f64)>;
    /// The other robots whose borders are within `gap` of this robot's border (to within
    /// [`crate::world::collision::CONTACT_TOLERANCE`], the precision of predicted entries),
    /// with the free distance (border to border), by id (found through the spatial index).
    fn near(&self, gap: f64) -> Vec<(RobotId, f64)>;
    /// What the robot touches, when the sensing was triggered by a contact ([`Trigger::Contact`]).
    fn contact(&self) -> Option<Obstacle>;
    /// Whether the straight line from this robot's centre to `other`'s crosses no obstacle
    /// (seed 7.2). Default: always (a world without obstacles).
    fn in_sight(&self, _other: RobotId) -> bool {
        true
    }
    /// The light `robot` shows ([`crate::lcm`]), if it has set one. Default: none.
    fn light(&self, _robot: RobotId) -> Option<crate::lcm::LightState> {
        None
    }
}

/// A sensor written against the seed's split (4.2.2): [`SensorModel::sense`] gathers exact
/// data from the world at the trigger instant, [`SensorModel::reply`] computes the robot's
/// reply on the robot's sensor actor with that sensor's own seeded random stream (the seed's
/// `calReply`). A query's [`SensorModel::trigger`] says whether it reads once or arms the
/// sensor; an armed (push) sensor interrupts its robot whenever [`SensorModel::fires`] holds.
pub trait SensorModel: fmt::Debug + Send + Sync + 'static {
    /// What the robot asks (shown in the trace by serde).
    type Query: Data + Clone;
    /// The exact data gathered at the trigger.
    type Reading: Data + Clone;
    /// What the robot gets (shown in the trace by serde).
    type Reply: Data + Clone;

    /// Checks a query; `Err` says what is wrong (the robot gets it as a rejection).
    fn check(_query: &Self::Query) -> Result<(), String> {
        Ok(())
    }

    /// The exact data for `query` now.
    fn sense(query: &Self::Query, world: &dyn WorldView) -> Self::Reading;

    /// The reply from the exact data; `rng` is the sensor's own seeded stream.
    fn reply(query: &Self::Query, reading: Self::Reading, rng: &mut ChaCha8Rng) -> Self::Reply;

    /// When the query makes the sensor sense. Default: [`Trigger::Pull`].
    fn trigger(_query: &Self::Query) -> Trigger {
        Trigger::Pull
    }

    /// For a push sensor: whether a reading interrupts the robot. Default: always.
    fn fires(_query: &Self::Query, _reading: &Self::Reading) -> bool {
        true
    }

    /// The query as the Neko log writes it. Default (`None`): the sensor's name and the
    /// query's RON.
    fn query_text(_query: &Self::Query) -> Option<String> {
        None
    }

    /// The reply as the Neko log writes it. Default (`None`): its RON.
    fn reply_text(_reply: &Self::Reply) -> Option<String> {
        None
    }

    /// How far the query looks, drawn in recordings. Default: not drawn.
    fn reach(_query: &Self::Query) -> Option<Reach> {
        None
    }
}

/// What the sensor manager does with a checked query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    pub trigger: Trigger,
    pub reach: Option<Reach>,
}

/// One registered sensor, its types erased behind [`Datum`].
#[derive(Clone, Copy)]
struct SensorEntry {
    plan: fn(&Datum) -> Result<Plan, String>,
    sense: fn(&Datum, &dyn WorldView) -> Result<Datum, String>,
    fires: fn(&Datum, &Datum) -> bool,
    reply: fn(&Datum, Datum, &mut ChaCha8Rng) -> Result<Datum, String>,
}

fn query_of<S: SensorModel>(query: &Datum) -> Result<&S::Query, String> {
    query.get::<S::Query>().ok_or_else(|| {
        format!(
            "the query {query:?} is not a {}",
            std::any::type_name::<S::Query>()
        )
    })
}

fn plan_entry<S: SensorModel>(query: &Datum) -> Result<Plan, String> {
    let q = query_of::<S>(query)?;
    S::check(q)?;
    let trigger = S::trigger(q);
    let positive = |what: &str, v: f64, zero: bool| {
        if v.is_finite() && (v > 0.0 || zero && v == 0.0) {
            Ok(())
        } else {
            let bound = if zero { ">= 0" } else { "> 0" };
            Err(format!("{what} is {v}; expected a finite number {bound}"))
        }
    };
    match trigger {
        Trigger::Every(i) => positive("push interval", i, false)?,
        Trigger::Entry { range, quiet } => {
            positive("range", range, true)?;
            positive("quiet interval", quiet, true)?;
        }
        _ => {}
    }
    Ok(Plan {
        trigger,
        reach: S::reach(q),
    })
}

fn sense_entry<S: SensorModel>(query: &Datum, world: &dyn WorldView) -> Result<Datum, String> {
    Ok(Datum::reading::<S>(S::sense(query_of::<S>(query)?, world)))
}

fn fires_entry<S: SensorModel>(query: &Datum, reading: &Datum) -> bool {
    match (query.get::<S::Query>(), reading.get::<S::Reading>()) {
        (Some(q), Some(r)) => S::fires(q, r),
        _ => false,
    }
}

fn reply_entry<S: SensorModel>(
    query: &Datum,
    reading: Datum,
    rng: &mut ChaCha8Rng,
) -> Result<Datum, String> {
    let q = query_of::<S>(query)?;
    let r = reading.value.downcast::<S::Reading>().map_err(|_| {
        format!(
            "the reading is not a {}",
            std::any::type_name::<S::Reading>()
        )
    })?;
    // The reading travels alone to the sensor actor, so this takes it without a copy.
    let r = Arc::try_unwrap(r).unwrap_or_else(|shared| (*shared).clone());
    Ok(Datum::reply::<S>(S::reply(q, r, rng)))
}

/// Sensors by the name robots use for them. A new (or default) registry holds the built-in
/// GPS, view, proximity, push proximity and contact sensors; [`Sensors::empty`] holds none.
#[derive(Clone, Debug)]
pub struct Sensors {
    entries: Named<SensorEntry>,
}

impl Sensors {
    /// No sensor at all.
    pub fn empty() -> Self {
        Self {
            entries: Named::new("sensor"),
        }
    }

    /// Registers the sensor `S` under `name` (replacing an earlier one).
    pub fn sensor<S: SensorModel>(&mut self, name: &str) -> &mut Self {
        self.entries.insert(
            name,
            SensorEntry {
                plan: plan_entry::<S>,
                sense: sense_entry::<S>,
                fires: fires_entry::<S>,
                reply: reply_entry::<S>,
            },
        );
        self
    }

    /// Registered names, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.names()
    }

    fn entry(&self, kind: SensorKind) -> Result<&SensorEntry, String> {
        self.entries.by_name(kind.name())
    }

    /// Checks `query` for `kind` and says what it asks for.
    pub fn plan(&self, kind: SensorKind, query: &Datum) -> Result<Plan, String> {
        (self.entry(kind)?.plan)(query)
    }

    /// The exact reading of `kind` for `query`.
    pub fn sense(
        &self,
        kind: SensorKind,
        query: &Datum,
        world: &dyn WorldView,
    ) -> Result<Datum, String> {
        (self.entry(kind)?.sense)(query, world)
    }

    /// Whether a push reading interrupts.
    pub fn fires(&self, kind: SensorKind, query: &Datum, reading: &Datum) -> bool {
        self.entry(kind).is_ok_and(|e| (e.fires)(query, reading))
    }

    /// The reply of `kind` from a reading.
    pub fn reply(
        &self,
        kind: SensorKind,
        query: &Datum,
        reading: Datum,
        rng: &mut ChaCha8Rng,
    ) -> Result<Datum, String> {
        (self.entry(kind)?.reply)(query, reading, rng)
    }
}
