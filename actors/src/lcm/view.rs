//! What a Look-Compute-Move robot sees and decides (Flocchini, Prencipe and Santoro 2019,
//! section 1.1): a snapshot of the others in the robot's local frame, with itself at the
//! origin, and a destination in that frame plus a light.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::world::geometry::{Point, Vector};

/// A light's colour: its index in the algorithm's palette (0 is the first colour).
pub type Light = u8;

/// What a robot's light shows: the colour the others see, and while the robot computes a new
/// one, that new colour (the register's write in progress: a Look then reads either under a
/// regular register, anything under a safe one, the shown colour under an atomic one).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LightState {
    pub shown: Light,
    pub pending: Option<Light>,
}

impl LightState {
    /// A light showing `l`, not being written.
    pub fn steady(l: Light) -> Self {
        Self {
            shown: l,
            pending: None,
        }
    }
}

/// How many robots a robot sees at one point, as its multiplicity detection allows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Multiplicity {
    /// No detection: a point with robots is just a point.
    Unknown,
    /// Weak detection: one robot, or more than one.
    One,
    Many,
    /// Strong detection: the exact number.
    Exactly(u32),
}

/// One point of the snapshot where the robot sees robots (robots at one point that show the
/// same light, or whose lights it cannot see, are one entry).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Seen {
    /// In the robot's local frame.
    pub at: Point,
    /// The light seen there, when lights are visible to others.
    pub light: Option<Light>,
    /// How many robots (not counting the robot itself) stand there, as detection allows.
    pub multiplicity: Multiplicity,
}

impl Seen {
    /// Whether this entry is at the robot's own point.
    pub fn is_here(&self) -> bool {
        self.at == Point::origin()
    }
}

/// A snapshot in the robot's local frame, the robot itself at the origin.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct View {
    /// The robot's own light, when its lights are visible to itself.
    pub light: Option<Light>,
    /// The other robots it sees, by point (and light), in a fixed order: by distance from the
    /// robot, then by coordinates, then by light.
    pub others: Vec<Seen>,
    /// How far the robot sees, in its own unit of length (`None`: everything).
    pub visibility: Option<f64>,
}

impl View {
    /// Whether some other robot stands at the robot's own point.
    pub fn shares_its_point(&self) -> bool {
        self.others.iter().any(Seen::is_here)
    }

    /// How many robots stand at the robot's own point, itself included, as detection allows
    /// (`None` without detection).
    pub fn here(&self) -> Option<u32> {
        let mut n = 1;
        for s in self.others.iter().filter(|s| s.is_here()) {
            match s.multiplicity {
                Multiplicity::Unknown => return None,
                Multiplicity::One => n += 1,
                Multiplicity::Many => n += 2,
                Multiplicity::Exactly(k) => n += k,
            }
        }
        Some(n)
    }

    /// Every point where the robot sees robots, its own first (the origin), once each.
    pub fn points(&self) -> Vec<Point> {
        let mut pts = vec![Point::origin()];
        for s in &self.others {
            if !pts.contains(&s.at) {
                pts.push(s.at);
            }
        }
        pts
    }

    /// The centre of gravity of the robot and the points it sees, each point counted once
    /// per robot where multiplicity is known (else once).
    pub fn centre_of_gravity(&self) -> Point {
        let (mut sum, mut n) = (Vector::zeros(), 1.0);
        for s in &self.others {
            let k = match s.multiplicity {
                Multiplicity::Exactly(k) => f64::from(k),
                _ => 1.0,
            };
            sum += s.at.coords * k;
            n += k;
        }
        Point::from(sum / n)
    }
}

/// What a robot decided: a destination in its local frame (or stay), and its new light
/// (or keep the one it has).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Decision {
    pub to: Option<Point>,
    pub light: Option<Light>,
}

impl Decision {
    /// Stay, keeping the light.
    pub fn stay() -> Self {
        Self::default()
    }

    /// Move to `p` (local frame), keeping the light.
    pub fn to(p: Point) -> Self {
        Self {
            to: Some(p),
            light: None,
        }
    }

    /// The same decision with the new light `l`.
    pub fn with_light(mut self, l: Light) -> Self {
        self.light = Some(l);
        self
    }
}

/// A Look-Compute-Move algorithm: the pure function from a snapshot to a decision. Nothing
/// else survives between cycles; an implementation is its settings only.
pub trait LookComputeMove: fmt::Debug + Send + Sync + 'static {
    /// The decision for `view`.
    fn compute(&self, view: &View) -> Decision;

    /// How many colours its lights take (1: a robot without lights).
    fn colours(&self) -> u8 {
        1
    }

    /// The name of colour `l`, for logs and records.
    fn colour_name(&self, l: Light) -> String {
        l.to_string()
    }
}

/// The one tolerance every Look-Compute-Move predicate uses: two points are the same when
/// they are within this much of each other, relative to the snapshot's scale (the largest
/// distance it holds, at least 1). Local frames rotate and scale by floating-point products,
/// so a destination mapped back to the world can land a few ulps off the point it names;
/// [`snap`] puts it back on that point, so that "gathered" means equal coordinates.
pub const SAME_POINT: f64 = 1e-9;

/// `p` put onto the nearest of `candidates` when one is within [`SAME_POINT`] times `scale`
/// of it; else `p` itself.
pub fn snap(p: Point, candidates: impl IntoIterator<Item = Point>, scale: f64) -> Point {
    let tolerance = SAME_POINT * scale.max(1.0);
    let mut best: Option<(f64, Point)> = None;
    for c in candidates {
        let d = (c - p).norm();
        if d <= tolerance && best.is_none_or(|(b, _)| d < b) {
            best = Some((d, c));
        }
    }
    best.map_or(p, |(_, c)| c)
}
