//! The vocabulary an algorithm's configuration is written in (seed ch. 5, 6.2): what a
//! configurable algorithm is ([`Configured`]), what its configuration is checked against
//! ([`Setting`]) and the checks of a number field ([`positive`], [`finite`]). The registry
//! ([`crate::registry`]) and every algorithm, built-in or a user's, share it.

use nekosim_protocols::{FieldError, Service};
use serde::de::DeserializeOwned;

use crate::robot::Algorithm;

/// What an algorithm's configuration is checked against: the stack its robot runs on.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Setting {
    /// The stack's layers: id and the service each provides.
    pub layers: Vec<(String, Service)>,
}

impl Setting {
    /// The service layer `id` provides, if the stack has it.
    pub fn layer(&self, id: &str) -> Option<Service> {
        self.layers.iter().find(|(l, _)| l == id).map(|(_, s)| *s)
    }
}

/// An algorithm a scenario can name: its configuration type and how it is built from it. It
/// is `Clone`: a group of robots sharing one configuration reads it once and clones the
/// algorithm for each robot (a sweep builds thousands of runs).
pub trait Configured: Algorithm + Clone + Sized + 'static {
    /// What `algorithm: Name(field: value, ...)` is read into (derive `Deserialize` with
    /// `#[serde(deny_unknown_fields)]`).
    type Config: DeserializeOwned;

    /// The algorithm, or why the configuration is refused (a [`FieldError::field`] is
    /// reported at that field in the scenario file; a field path starting with `[` is joined
    /// without a dot, as in `[0][2].angle` for a tuple's element).
    fn configure(config: Self::Config, setting: &Setting) -> Result<Self, FieldError>;
}

/// `field`'s value `v` must be a finite number > 0; `what` names it in the message.
pub fn positive(field: &str, what: &str, v: f64) -> Result<f64, FieldError> {
    if !v.is_finite() {
        return Err(FieldError::new(
            field,
            format!("{what} is {v}"),
            "a finite number",
        ));
    }
    if v > 0.0 {
        Ok(v)
    } else {
        Err(FieldError::new(
            field,
            format!("{what} is {v}"),
            "a number > 0",
        ))
    }
}

/// The largest coordinate and world extent a scenario may use [units]. f64 has 53 bits of
/// mantissa, so positions up to 1e9 (just under 2^30) are exact to 2^-23, about 1.2e-7 units:
/// well below any radius a scenario may give ([`MIN_RADIUS`]).
pub const MAX_COORDINATE: f64 = 1e9;

/// The smallest robot radius [units]: at least ten thousand times the position resolution at
/// [`MAX_COORDINATE`] (1.2e-7), so a contact is resolved to 1e-4 of a radius anywhere in the
/// world. The spatial index's cells are at least two radii wide, so a smaller radius would
/// also make a robot cross a cell every few nanoseconds of virtual time.
pub const MIN_RADIUS: f64 = 1e-3;

/// The largest speed an algorithm's configuration may give [units/s, or deg/s for turns]. A
/// position at time `t` is computed from a time rounded to `t * 2^-52`, so its error is
/// `v * t * 2^-52`; at 1e4 units/s that stays within the position resolution at
/// [`MAX_COORDINATE`] (2^-23) for `t` up to 2^29 / 1e4, about 15 hours of virtual time. Faster
/// robots also cross a world in microseconds, a run of events that never lets time advance.
pub const MAX_SPEED: f64 = 1e4;

/// `field`'s value `v` must be a speed: finite, > 0 and at most [`MAX_SPEED`].
pub fn speed(field: &str, what: &str, v: f64) -> Result<f64, FieldError> {
    positive(field, what, v)?;
    if v <= MAX_SPEED {
        Ok(v)
    } else {
        Err(FieldError::new(
            field,
            format!("{what} is {v:e}"),
            format!(
                "at most {MAX_SPEED:e} (faster, positions lose the precision exact motion needs)"
            ),
        ))
    }
}

/// `field`'s value `v` must be a finite number.
pub fn finite(field: &str, what: &str, v: f64) -> Result<f64, FieldError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(FieldError::new(
            field,
            format!("{what} is {v}"),
            "a finite number",
        ))
    }
}
