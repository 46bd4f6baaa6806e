//! The run's random streams, named in one place.
//!
//! Every random number of a run comes from the run's seed and one named [`Stream`]: each
//! robot's algorithm, each sensor's noise, the network's losses and delays, the placement of
//! robots born at random. Two consumers never share a sequence by accident, because each
//! stream maps to its own ChaCha stream number and the mapping is one-to-one for every robot
//! id and sensor kind ([`Stream::number`]; a test checks it at the boundaries and at random).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::world::RobotId;

/// Who draws from a random stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stream {
    /// A robot's algorithm ([`crate::Robot::rng`]).
    Robot(RobotId),
    /// The noise of one sensor of a robot: the sensor kind's number, below 256
    /// ([`crate::world::sensor::SensorKind::stream`]).
    Sensor(RobotId, u8),
    /// The network's losses and delays.
    Network,
    /// The placement of robots born at random.
    Placement,
    /// A Look-Compute-Move robot's adversary: its local frames, phase durations and stop
    /// points ([`crate::lcm::adversary`]).
    Adversary(RobotId),
    /// The Look-Compute-Move adversary's choices for a whole round: which robots it
    /// activates ([`crate::lcm::adversary`]).
    Rounds,
}

/// Where each kind of stream starts among ChaCha's stream numbers: robots take
/// `[0, 2^32)`, sensors `[2^40, 2^41)` (a robot's id above its sensor kind's 8 bits), the
/// run-wide streams come after both, and the robots' adversaries take `[2^42, 2^42 + 2^32)`.
const SENSORS: u64 = 1 << 40;
const NETWORK: u64 = 1 << 41;
const PLACEMENT: u64 = NETWORK + 1;
const ROUNDS: u64 = NETWORK + 2;
const ADVERSARY: u64 = 1 << 42;

impl Stream {
    /// The ChaCha stream number: distinct for distinct streams.
    pub fn number(self) -> u64 {
        match self {
            Stream::Robot(r) => u64::from(r),
            Stream::Sensor(r, kind) => SENSORS + (u64::from(r) << 8 | u64::from(kind)),
            Stream::Network => NETWORK,
            Stream::Placement => PLACEMENT,
            Stream::Rounds => ROUNDS,
            Stream::Adversary(r) => ADVERSARY + u64::from(r),
        }
    }

    /// The stream whose number is `n`, if any: [`Stream::number`]'s inverse.
    pub fn of_number(n: u64) -> Option<Stream> {
        match n {
            _ if n < 1 << 32 => Some(Stream::Robot(n as RobotId)),
            _ if (SENSORS..NETWORK).contains(&n) => {
                let k = n - SENSORS;
                Some(Stream::Sensor((k >> 8) as RobotId, (k & 0xFF) as u8))
            }
            NETWORK => Some(Stream::Network),
            PLACEMENT => Some(Stream::Placement),
            ROUNDS => Some(Stream::Rounds),
            _ if (ADVERSARY..ADVERSARY + (1 << 32)).contains(&n) => {
                Some(Stream::Adversary((n - ADVERSARY) as RobotId))
            }
            _ => None,
        }
    }
}

/// The generator of `stream` in the run seeded with `seed`, at its start.
pub fn rng(seed: u64, stream: Stream) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream.number());
    rng
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::RngCore;

    fn any_stream() -> impl Strategy<Value = Stream> {
        prop_oneof![
            any::<u32>().prop_map(Stream::Robot),
            (any::<u32>(), any::<u8>()).prop_map(|(r, k)| Stream::Sensor(r, k)),
            Just(Stream::Network),
            Just(Stream::Placement),
            Just(Stream::Rounds),
            any::<u32>().prop_map(Stream::Adversary),
        ]
    }

    /// The extremes of every kind: the first and last robot, the first and last sensor of
    /// each, and the run-wide streams.
    fn extremes() -> Vec<Stream> {
        let mut all = vec![Stream::Network, Stream::Placement, Stream::Rounds];
        for r in [0, 1, 0xB0B0, 0x004E_4554, u32::MAX - 1, u32::MAX] {
            all.push(Stream::Robot(r));
            all.push(Stream::Adversary(r));
            for k in [0, 1, 254, 255] {
                all.push(Stream::Sensor(r, k));
            }
        }
        all
    }

    /// Every stream of the extremes has a number of its own, and its number names it back.
    #[test]
    fn streams_at_the_extremes_are_disjoint() {
        let all = extremes();
        let numbers: std::collections::HashSet<u64> = all.iter().map(|s| s.number()).collect();
        assert_eq!(numbers.len(), all.len());
        for s in all {
            assert_eq!(Stream::of_number(s.number()), Some(s));
        }
    }

    /// No robot's stream, for any robot count up to 2^32, is the placement's, the network's
    /// or any sensor's: robot 45,232 (0xB0B0) draws other numbers than the placement.
    #[test]
    fn no_robot_draws_the_placements_or_the_networks_numbers() {
        for r in [0xB0B0, 0x004E_4554, u32::MAX] {
            let robot = rng(7, Stream::Robot(r)).next_u64();
            assert_ne!(robot, rng(7, Stream::Placement).next_u64(), "robot {r}");
            assert_ne!(robot, rng(7, Stream::Network).next_u64(), "robot {r}");
        }
    }

    proptest! {
        /// Two streams share a number only if they are the same stream, which its number
        /// names back.
        #[test]
        fn a_streams_number_names_it(a in any_stream(), b in any_stream()) {
            prop_assert_eq!(Stream::of_number(a.number()), Some(a));
            prop_assert_eq!(a.number() == b.number(), a == b);
        }
    }
}
