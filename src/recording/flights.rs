//! The message copies a recording draws: those on their way, indexed so that a receive finds
//! its copy without searching a list, and those the network lost, drawn as lost for
//! [`LOST_SECONDS`] and then forgotten.
//!
//! A copy is in flight from its send until its receive. A copy whose send gave an arrival time
//! also leaves at that time when no receive comes: it reached a robot that had crashed, which
//! records nothing. A copy the network dropped (`arrive` null in the trace) is never in flight.
//! So `messages_in_flight` counts what the network carries at each instant, and the lists
//! here stay as long as the traffic is, however long the run.

use std::collections::{BTreeMap, VecDeque};

use nekosim_actors::world::geometry::Point;
use nekosim_actors::world::RobotId;
use nekosim_protocols::Payload;

use super::canvas::Flight;

/// How long a lost copy stays drawn after its send [simulated s]: long enough to see at play
/// speed, short enough that a lossy run's world does not fill with marks.
pub const LOST_SECONDS: f64 = 2.0;

/// A simulated instant, ordered by [`f64::total_cmp`] (the engine's times are finite).
#[derive(Clone, Copy, Debug)]
struct Instant(f64);

impl PartialEq for Instant {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == std::cmp::Ordering::Equal
    }
}

impl Eq for Instant {}

impl PartialOrd for Instant {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Instant {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// What a receive names of its copy: sender, receiver and message.
type Key = (RobotId, RobotId, Payload);

/// The copies of one layer.
#[derive(Debug, Default)]
struct Layer {
    /// In flight, by send number, so they are drawn in send order.
    flying: BTreeMap<u64, (Key, Flight)>,
    /// The send numbers of the copies in flight, per sender, receiver and message, oldest
    /// first: a receive looks up its key and picks among the few copies of that message.
    waiting: BTreeMap<Key, Vec<u64>>,
    /// Lost copies still drawn, in send order, so the oldest is the first to go.
    lost: VecDeque<Flight>,
}

/// The copies in flight and the copies lost recently, per layer.
#[derive(Debug, Default)]
pub struct Flights {
    /// By layer name: drawn in name order, whatever order the layers first sent in.
    layers: BTreeMap<String, Layer>,
    /// Copies in flight with an arrival time, by that time and send number, with their layer:
    /// one still here once its time has passed was received by no one.
    due: BTreeMap<(Instant, u64), String>,
    /// The next send number.
    next: u64,
    in_flight: u64,
}

impl Flights {
    /// Copies in flight, over every layer.
    pub fn in_flight(&self) -> u64 {
        self.in_flight
    }

    /// A copy of `msg` handed to the network on `layer`; `lost`: the network dropped it, so it
    /// is drawn as lost and never counts as in flight.
    pub fn send(&mut self, layer: &str, msg: &Payload, flight: Flight, lost: bool) {
        if !self.layers.contains_key(layer) {
            self.layers.insert(layer.to_string(), Layer::default());
        }
        let l = self.layers.get_mut(layer).expect("inserted");
        if lost {
            l.lost.push_back(flight);
            return;
        }
        let id = self.next;
        self.next += 1;
        let key = (flight.from, flight.to, msg.clone());
        if let Some(t) = flight.arrive {
            self.due.insert((Instant(t), id), layer.to_string());
        }
        l.waiting.entry(key.clone()).or_default().push(id);
        l.flying.insert(id, (key, flight));
        self.in_flight += 1;
    }

    /// The copy that a receive at `t` of `msg` from `from` at `to` on `layer` ends, no longer
    /// in flight: the copy of that message arriving at `t` (copies of one message may overtake
    /// each other), or else the oldest. `None`: no such copy is in flight.
    pub fn receive(
        &mut self,
        layer: &str,
        from: RobotId,
        to: RobotId,
        msg: &Payload,
        t: f64,
    ) -> Option<Flight> {
        let l = self.layers.get_mut(layer)?;
        let key = (from, to, msg.clone());
        let ids = l.waiting.get_mut(&key)?;
        let k = ids
            .iter()
            .position(|id| l.flying[id].1.arrive == Some(t))
            .unwrap_or(0);
        let id = ids.remove(k);
        if ids.is_empty() {
            l.waiting.remove(&key);
        }
        let (_, flight) = l.flying.remove(&id).expect("waiting copies fly");
        if let Some(a) = flight.arrive {
            self.due.remove(&(Instant(a), id));
        }
        self.in_flight -= 1;
        Some(flight)
    }

    /// The copies in flight on `layer`, in send order.
    pub fn flying(&self, layer: &str) -> impl Iterator<Item = &Flight> {
        self.layers
            .get(layer)
            .into_iter()
            .flat_map(|l| l.flying.values().map(|(_, f)| f))
    }

    /// The lost copies still drawn on `layer`, in send order.
    pub fn lost(&self, layer: &str) -> impl Iterator<Item = &Flight> {
        self.layers
            .get(layer)
            .into_iter()
            .flat_map(|l| l.lost.iter())
    }

    /// The layers with a copy in flight that has an arrival time (a packet moving along its
    /// arrow), in name order.
    pub fn moving_layers(&self) -> Vec<String> {
        self.layers
            .iter()
            .filter(|(_, l)| l.flying.values().any(|(_, f)| f.arrive.is_some()))
            .map(|(name, _)| name.clone())
            .collect()
    }

    /// Aims the copies on their way to `robot` at where it will be when they arrive (`at(t)`:
    /// its position at `t`, from its new motion). Returns the layers whose arrows moved.
    pub fn retarget(&mut self, robot: RobotId, at: impl Fn(f64) -> Point) -> Vec<String> {
        let mut moved = Vec::new();
        for (name, l) in &mut self.layers {
            let mut changed = false;
            for (_, f) in l.flying.values_mut().filter(|(_, f)| f.to == robot) {
                if let Some(t) = f.arrive {
                    let target = at(t);
                    changed |= target != f.target;
                    f.target = target;
                }
            }
            if changed {
                moved.push(name.clone());
            }
        }
        moved
    }

    /// The earliest arrival time among the copies in flight.
    pub fn next_due(&self) -> Option<f64> {
        self.due.keys().next().map(|(t, _)| t.0)
    }

    /// Ends the flights of the copies due at or before `t` that no receive ended: nobody
    /// received them. Returns the layers that changed, in name order.
    pub fn retire_due(&mut self, t: f64) -> Vec<String> {
        let mut changed = Vec::new();
        while let Some(entry) = self.due.first_entry() {
            if entry.key().0 .0 > t {
                break;
            }
            let ((_, id), layer) = entry.remove_entry();
            let l = self.layers.get_mut(&layer).expect("a due copy's layer");
            let (key, _) = l.flying.remove(&id).expect("due copies fly");
            let ids = l.waiting.get_mut(&key).expect("flying copies wait");
            ids.retain(|i| *i != id);
            if ids.is_empty() {
                l.waiting.remove(&key);
            }
            self.in_flight -= 1;
            changed.push(layer);
        }
        changed.sort();
        changed.dedup();
        changed
    }

    /// When the oldest lost copy stops being drawn.
    pub fn next_expiry(&self) -> Option<f64> {
        self.layers
            .values()
            .filter_map(|l| l.lost.front())
            .map(|f| f.sent + LOST_SECONDS)
            .min_by(f64::total_cmp)
    }

    /// Forgets the lost copies drawn for [`LOST_SECONDS`] at `t`. Returns the layers that
    /// changed, in name order.
    pub fn expire_lost(&mut self, t: f64) -> Vec<String> {
        let mut changed = Vec::new();
        for (name, l) in &mut self.layers {
            let before = l.lost.len();
            while l.lost.front().is_some_and(|f| f.sent + LOST_SECONDS <= t) {
                l.lost.pop_front();
            }
            if l.lost.len() != before {
                changed.push(name.clone());
            }
        }
        changed
    }
}
