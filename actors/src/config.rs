//! The vocabulary an algorithm's configuration is written in (seed ch. 5, 6.2): what a
//! configurable algorithm is ([`Configured`]), what its configuration is checked against
//! ([`Setting`]) and the checks of a number field ([`positive`], [`finite`]). The registry
//! ([`crate::registry`]) and every algorithm, built-in or a user's, share it.

use nekosim_protocols::{FieldError, Service};
use serde::de::DeserializeOwned;

use crate::robot::Algorithm;
pub use crate::world::geometry::{MAX_COORDINATE, MAX_SPEED, MIN_RADIUS};

/// What an algorithm's configuration is checked against: the stack its robot runs on.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Setting {
    /// The stack's layers: id and the service each provides.
    pub layers: Vec<(String, Service)>,
    /// The scenario's Look-Compute-Move settings ([`crate::lcm`]).
    pub lcm: std::sync::Arc<crate::lcm::LcmSettings>,
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
