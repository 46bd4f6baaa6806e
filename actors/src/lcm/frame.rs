//! Local frames (Flocchini, Prencipe and Santoro 2019, section 1.1.2): each robot sees the
//! world in its own coordinate system, centred on itself, whose orientation, handedness
//! (chirality) and unit of length the adversary chooses, and may change at every activation.

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::world::geometry::Vector;

/// A robot's local frame: its x axis at `rotation` degrees (anticlockwise) from the world's,
/// its y axis mirrored when `mirrored` (the other chirality), and `unit` world units to its
/// unit of length.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    pub rotation: f64,
    pub mirrored: bool,
    pub unit: f64,
}

impl Default for Frame {
    fn default() -> Self {
        Self {
            rotation: 0.0,
            mirrored: false,
            unit: 1.0,
        }
    }
}

impl Frame {
    /// A world displacement in this frame.
    pub fn to_local(&self, v: Vector) -> Vector {
        let (s, c) = self.rotation.to_radians().sin_cos();
        let x = c * v.x + s * v.y;
        let y = -s * v.x + c * v.y;
        let y = if self.mirrored { -y } else { y };
        Vector::new(x / self.unit, y / self.unit)
    }

    /// A displacement in this frame, in the world's.
    pub fn to_world(&self, v: Vector) -> Vector {
        let (x, y) = (v.x * self.unit, v.y * self.unit);
        let y = if self.mirrored { -y } else { y };
        let (s, c) = self.rotation.to_radians().sin_cos();
        Vector::new(c * x - s * y, s * x + c * y)
    }
}

/// Whether every robot shares a setting of its frame with the world, or the adversary picks
/// it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Agreement {
    /// Every robot agrees with the world.
    Common,
    /// The adversary picks it for each robot.
    #[default]
    Any,
}

/// When the adversary picks the frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Changes {
    /// Once per robot, for the whole run.
    Fixed,
    /// Anew at every activation.
    #[default]
    EveryActivation,
}

/// The assumptions on local frames, as a scenario states them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Frames {
    #[serde(default)]
    pub orientation: Agreement,
    #[serde(default)]
    pub chirality: Agreement,
    #[serde(default)]
    pub unit: Agreement,
    #[serde(default)]
    pub changes: Changes,
}

impl Frames {
    /// A frame drawn from `rng` under these assumptions: any rotation, either handedness, a
    /// unit between a half and two world units, where the setting is the adversary's.
    pub fn draw(&self, rng: &mut impl Rng) -> Frame {
        let rotation = rng.gen_range(0.0..360.0);
        let mirrored = rng.gen_bool(0.5);
        let unit = 2f64.powf(rng.gen_range(-1.0..1.0));
        Frame {
            rotation: if self.orientation == Agreement::Any {
                rotation
            } else {
                0.0
            },
            mirrored: self.chirality == Agreement::Any && mirrored,
            unit: if self.unit == Agreement::Any {
                unit
            } else {
                1.0
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// A displacement taken to a frame and back is the same to within rounding.
        #[test]
        fn to_world_undoes_to_local(rot in 0.0..360.0f64, m: bool, unit in 0.5..2.0f64,
                                    x in -1e3..1e3f64, y in -1e3..1e3f64) {
            let f = Frame { rotation: rot, mirrored: m, unit };
            let v = Vector::new(x, y);
            let back = f.to_world(f.to_local(v));
            prop_assert!((back - v).norm() <= 1e-12 * (1.0 + v.norm()));
            // Lengths scale by the unit, and angles keep their size.
            prop_assert!((f.to_local(v).norm() * unit - v.norm()).abs() <= 1e-9 * (1.0 + v.norm()));
        }
    }

    /// A mirrored frame turns an anticlockwise quarter turn into a clockwise one.
    #[test]
    fn a_mirrored_frame_has_the_other_chirality() {
        let f = Frame {
            rotation: 0.0,
            mirrored: true,
            unit: 1.0,
        };
        let l = f.to_local(Vector::new(0.0, 1.0));
        assert_eq!(l, Vector::new(0.0, -1.0));
    }
}
