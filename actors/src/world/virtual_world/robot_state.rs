//! A robot's state in the virtual world (seed 4.2.4): its motion or rest pose, radius, armed
//! push sensors, the events predicted with its partners and its own conditional events.

use smallvec::SmallVec;

use crate::world::event::Handle;
use crate::world::grid::{Cell, Span};
use crate::world::motion::{Path, Pose};
use crate::world::sensor::SensorKind;
use crate::world::RobotId;

/// A robot's state in the world.
#[derive(Debug)]
pub(super) struct RobotState {
    /// The motion in progress; its step events are asked of it (`events`) when needed
    /// rather than kept beside it, which would take 128 bytes a robot.
    pub(super) motion: Option<Path>,
    /// Radius [units].
    pub(super) radius: f64,
    /// Pose when there is no motion in progress.
    pub(super) rest: Pose,
    /// What the world shows of the robot's armed push sensors, once it arms one.
    pub(super) listening: Option<Box<Listening>>,
    /// Partner -> pair events predicted under the current motions of both.
    pub(super) pairs: Pairs,
    /// Own conditional events: motion steps, cell crossings, boundary contact.
    pub(super) own: OwnEvents,
    /// The first cell the robot is registered in: its cell when it was registered.
    pub(super) cell: Cell,
    pub(super) ticket: u64,
    /// Index of the next step event of the current motion.
    pub(super) next_step: u32,
    /// The cells after `cell` it is registered in, along its path.
    pub(super) span: Span,
    /// The first obstacle contact predicted against the obstacles around the robot's cell
    /// (predicted again whenever it changes cell).
    pub(super) obstacle: Option<Handle>,
    pub(super) crashed: bool,
    /// Stopped at this instant and not predicted for at rest yet ([`VirtualWorld::settle_all`]).
    pub(super) unsettled: bool,
}

/// What the world shows of a robot's armed push sensors (the sensor manager owns the rest),
/// kept apart from the robot's state: most robots never arm one, and each would pay 48 bytes.
#[derive(Debug, Default)]
pub(super) struct Listening {
    /// The free distance at which another robot's entry triggers each entry sensor, so that
    /// entries are predicted and invalidated with the other pair events,
    pub(super) entry: Vec<(SensorKind, f64)>,
    /// and the sensors a contact triggers.
    pub(super) contact: Vec<SensorKind>,
}

impl RobotState {
    /// The robot's entry-triggered push sensors and their ranges.
    pub(super) fn entry(&self) -> &[(SensorKind, f64)] {
        self.listening.as_deref().map_or(&[], |l| &l.entry)
    }

    /// The robot's contact-triggered push sensors.
    pub(super) fn contact(&self) -> &[SensorKind] {
        self.listening.as_deref().map_or(&[], |l| &l.contact)
    }

    pub(super) fn listening_mut(&mut self) -> &mut Listening {
        self.listening.get_or_insert_with(Default::default)
    }
}

/// A robot's partners (the robots it has pair events predicted with, under the current paths
/// of both: a pair predicted without any is not kept) and those events, sorted by partner, so
/// they are visited in partner order as a `BTreeMap` would: a robot has a handful of
/// partners, and a B-tree's first node alone takes about 280 bytes. The first three are
/// inline, in the robot's state, which the look-ahead brings into cache before the robot's
/// events: most robots have few partners, and a table of their own is a cache miss of its own
/// at a million robots and an allocation when it grows (docs/performance.md lists the gain).
#[derive(Debug, Default)]
pub(super) struct Pairs(pub(super) SmallVec<[(RobotId, PairEvents); INLINE_PARTNERS]>);

/// Partners kept inline in a robot's state ([`Pairs`]).
const INLINE_PARTNERS: usize = 3;

/// A robot's own conditional events, inline up to six (a motion's four steps, a wall contact,
/// a cell crossing): a firing step looks its handle up without a second cache miss.
pub(super) type OwnEvents = smallvec::SmallVec<[Handle; 6]>;

/// The events predicted for a pair of robots: mostly none or one collision, kept inline (a
/// vector was an allocation per prediction, in each of the two robots' tables).
pub(super) type PairEvents = smallvec::SmallVec<[Handle; 1]>;

impl Pairs {
    pub(super) fn find(&self, partner: RobotId) -> Result<usize, usize> {
        self.0.binary_search_by_key(&partner, |(p, _)| *p)
    }

    pub(super) fn contains_key(&self, partner: &RobotId) -> bool {
        self.find(*partner).is_ok()
    }

    /// Sets the pair events with `partner`, replacing any.
    pub(super) fn insert(&mut self, partner: RobotId, ids: PairEvents) {
        match self.find(partner) {
            Ok(i) => self.0[i].1 = ids,
            Err(i) => self.0.insert(i, (partner, ids)),
        }
    }

    /// Takes the pair events with `partner` out. A table that fits inline again goes back
    /// inline: kept on the heap, it is a cache miss of its own at every look at a million
    /// robots, and more robots' tables spill the longer a run goes.
    pub(super) fn remove(&mut self, partner: &RobotId) -> Option<PairEvents> {
        let i = self.find(*partner).ok()?;
        let ids = self.0.remove(i).1;
        if self.0.spilled() && self.0.len() <= self.0.inline_size() {
            self.0.shrink_to_fit();
        }
        Some(ids)
    }

    /// Takes every partner's events out, in partner order, keeping the table's room: a robot
    /// whose path changes soon has as many partners again, and freeing the table and growing
    /// it anew would be an allocation or more per change of path.
    pub(super) fn drain(
        &mut self,
    ) -> smallvec::Drain<'_, [(RobotId, PairEvents); INLINE_PARTNERS]> {
        self.0.drain(..)
    }

    /// The pair events with `partner`, made empty if there were none.
    pub(super) fn events_mut(&mut self, partner: RobotId) -> &mut PairEvents {
        let i = self.find(partner).unwrap_or_else(|i| {
            self.0.insert(i, (partner, PairEvents::new()));
            i
        });
        &mut self.0[i].1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::event::EventId;

    /// A robot's partner table that spilled to the heap goes back inline once it fits again,
    /// its partners still in order with their events.
    #[test]
    fn a_spilled_partner_table_goes_back_inline_when_it_fits() {
        let h = |k: RobotId| Handle {
            id: EventId {
                cause: u64::from(k),
                index: 0,
            },
            slot: k,
        };
        let mut pairs = Pairs::default();
        for partner in [7, 3, 9, 5, 11] {
            pairs.insert(partner, smallvec::smallvec![h(partner)]);
        }
        assert!(pairs.0.spilled());
        let listed = |p: &Pairs| -> Vec<(RobotId, u32)> {
            p.0.iter().map(|(r, ids)| (*r, ids[0].slot)).collect()
        };
        assert_eq!(listed(&pairs), [(3, 3), (5, 5), (7, 7), (9, 9), (11, 11)]);
        assert_eq!(pairs.remove(&3).map(|ids| ids[0].slot), Some(3));
        assert!(pairs.0.spilled(), "four do not fit inline");
        assert!(pairs.remove(&4).is_none());
        assert_eq!(pairs.remove(&9).map(|ids| ids[0].slot), Some(9));
        assert!(!pairs.0.spilled(), "three fit inline");
        assert_eq!(listed(&pairs), [(5, 5), (7, 7), (11, 11)]);
        pairs.insert(6, smallvec::smallvec![h(6)]);
        assert_eq!(listed(&pairs), [(5, 5), (6, 6), (7, 7), (11, 11)]);
    }
}
