//! Algorithms by name (seed ch. 5, 6.2): a scenario names each robot's algorithm with its
//! configuration, `algorithm: RandomMovement(move_speed: (3.0, 13.0))`, and an [`Algorithms`]
//! registry reads the configuration into the algorithm's own type (serde) and builds it. The
//! built-in algorithms are registered exactly as a user's are ([`Algorithms::with_builtins`],
//! [`Algorithms::algorithm`]).

use nekosim_protocols::registry::Named;
use nekosim_protocols::{Spec, SpecError};

pub use crate::config::{
    finite, positive, speed, Configured, Setting, MAX_COORDINATE, MAX_SPEED, MIN_RADIUS,
};
use crate::robot::Algorithm;

/// Reads a spec's configuration once and builds the algorithm for `n` robots.
type BuildFn = fn(&Spec, &Setting, usize) -> Result<Vec<Box<dyn Algorithm>>, SpecError>;

fn build_entry<A: Configured>(
    spec: &Spec,
    setting: &Setting,
    n: usize,
) -> Result<Vec<Box<dyn Algorithm>>, SpecError> {
    let a = spec.configure(|c| A::configure(c, setting))?;
    Ok((0..n)
        .map(|_| Box::new(a.clone()) as Box<dyn Algorithm>)
        .collect())
}

/// Algorithms by the name scenarios use for them. A new (or default) registry holds the
/// built-in algorithms; [`Algorithms::empty`] holds none.
#[derive(Clone, Debug)]
pub struct Algorithms {
    entries: Named<BuildFn>,
}

impl Algorithms {
    /// A registry without any algorithm.
    pub fn empty() -> Self {
        Self {
            entries: Named::new("algorithm"),
        }
    }

    /// Registers the algorithm `A` under `name` (replacing an earlier registration).
    pub fn algorithm<A: Configured>(&mut self, name: &str) -> &mut Self {
        self.entries.insert(name, build_entry::<A>);
        self
    }

    /// Registered names, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.names()
    }

    /// Reads `spec`'s configuration and builds the algorithm for a robot of `setting`.
    /// Positions in the error are in `spec`'s text.
    pub fn build(&self, spec: &Spec, setting: &Setting) -> Result<Box<dyn Algorithm>, SpecError> {
        Ok(self
            .build_many(spec, setting, 1)?
            .pop()
            .expect("one algorithm built"))
    }

    /// `n` copies of `spec`'s algorithm for robots of a setting (a group sharing one spec):
    /// the configuration is read and checked once.
    pub fn build_many(
        &self,
        spec: &Spec,
        setting: &Setting,
        n: usize,
    ) -> Result<Vec<Box<dyn Algorithm>>, SpecError> {
        (self.entries.get(spec)?)(spec, setting, n)
    }
}
