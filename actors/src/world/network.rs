//! Simulated networks (seed 3.4, fig. 3.8; Neko's simulated networks): when, and whether, a
//! message sent at some instant reaches each destination.
//!
//! - `Reliable(delay)`: every message arrives after a constant delay.
//! - `RandomDelay(lambda)`: exponential delays with mean `lambda` (Neko's RandomNetwork).
//! - `Metric(lambda)`: Neko's contention-aware model. A send occupies the sender's CPU for 1,
//!   then the shared network for `lambda` (one transmission per multicast), then each
//!   receiver's CPU for 1; each resource serves messages in FIFO order.
//! - `Lossy(p, over)`: `over`, then each copy is dropped with probability `p`.
//! - `Radio(range, over)`: `over`, but only destinations within `range` of the sender at send
//!   time receive (mobility and communication coupled).
//!
//! Partitions drop messages between processes in different groups at send time. All draws
//! come from the network's own seeded stream, in send order.

use std::collections::BTreeMap;

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::geometry::Point;
use super::RobotId;

/// A network model, as a scenario names it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum NetworkSpec {
    Reliable { delay: f64 },
    RandomDelay { lambda: f64 },
    Metric { lambda: f64 },
    Lossy { p: f64, over: Box<NetworkSpec> },
    Radio { range: f64, over: Box<NetworkSpec> },
}

impl Default for NetworkSpec {
    fn default() -> Self {
        NetworkSpec::Reliable { delay: 1.0 }
    }
}

impl NetworkSpec {
    /// Checks the parameters; `Err((field path suffix, message))`.
    pub fn check(&self) -> Result<(), (String, String)> {
        let nonneg = |f: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err((
                    f.to_string(),
                    format!("{f} is {v}; expected a finite number >= 0"),
                ))
            }
        };
        match self {
            NetworkSpec::Reliable { delay } => nonneg("delay", *delay),
            NetworkSpec::RandomDelay { lambda } | NetworkSpec::Metric { lambda } => {
                nonneg("lambda", *lambda)
            }
            NetworkSpec::Lossy { p, over } => {
                if !(p.is_finite() && (0.0..=1.0).contains(p)) {
                    return Err((
                        "p".into(),
                        format!("p is {p}; expected a probability in [0, 1]"),
                    ));
                }
                over.check().map_err(|(f, m)| (format!("over.{f}"), m))
            }
            NetworkSpec::Radio { range, over } => {
                nonneg("range", *range)?;
                over.check().map_err(|(f, m)| (format!("over.{f}"), m))
            }
        }
    }
}

/// A partition: messages between different groups are dropped during `[from, to)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Partition {
    pub groups: Vec<Vec<RobotId>>,
    pub from: f64,
    pub to: f64,
}

impl Partition {
    fn separates(&self, a: RobotId, b: RobotId, t: f64) -> bool {
        if t < self.from || t >= self.to {
            return false;
        }
        let group = |x| self.groups.iter().position(|g| g.contains(&x));
        group(a) != group(b)
    }
}

/// A network's state: its model, random stream and, for `Metric`, when each resource is free.
#[derive(Debug)]
pub struct Network {
    spec: NetworkSpec,
    rng: ChaCha8Rng,
    partitions: Vec<Partition>,
    send_cpu: BTreeMap<RobotId, f64>,
    medium: f64,
    recv_cpu: BTreeMap<RobotId, f64>,
}

impl Network {
    /// A network following `spec`, drawing from `rng`.
    pub fn new(spec: NetworkSpec, rng: ChaCha8Rng, partitions: Vec<Partition>) -> Self {
        Self {
            spec,
            rng,
            partitions,
            send_cpu: BTreeMap::new(),
            medium: 0.0,
            recv_cpu: BTreeMap::new(),
        }
    }

    /// Arrival time of the copy to each destination of a message `from` sends at `now`
    /// (`None`: lost). `pos` gives robots' positions at `now`.
    pub fn transmit(
        &mut self,
        now: f64,
        from: RobotId,
        to: &[RobotId],
        pos: &dyn Fn(RobotId) -> Point,
    ) -> Vec<(RobotId, Option<f64>)> {
        let spec = self.spec.clone();
        let mut out = self.model(&spec, now, from, to, pos);
        for (d, t) in out.iter_mut() {
            if self.partitions.iter().any(|p| p.separates(from, *d, now)) {
                *t = None;
            }
        }
        out
    }

    fn model(
        &mut self,
        spec: &NetworkSpec,
        now: f64,
        from: RobotId,
        to: &[RobotId],
        pos: &dyn Fn(RobotId) -> Point,
    ) -> Vec<(RobotId, Option<f64>)> {
        match spec {
            NetworkSpec::Reliable { delay } => to.iter().map(|&d| (d, Some(now + delay))).collect(),
            NetworkSpec::RandomDelay { lambda } => to
                .iter()
                .map(|&d| {
                    let u: f64 = self.rng.gen();
                    (d, Some(now - lambda * (1.0 - u).ln()))
                })
                .collect(),
            NetworkSpec::Metric { lambda } => {
                let cpu = self.send_cpu.entry(from).or_insert(0.0);
                let sent = cpu.max(now) + 1.0;
                *cpu = sent;
                let on_wire = self.medium.max(sent) + lambda;
                self.medium = on_wire;
                to.iter()
                    .map(|&d| {
                        let rc = self.recv_cpu.entry(d).or_insert(0.0);
                        let arrived = rc.max(on_wire) + 1.0;
                        *rc = arrived;
                        (d, Some(arrived))
                    })
                    .collect()
            }
            NetworkSpec::Lossy { p, over } => {
                let mut v = self.model(over, now, from, to, pos);
                for (_, t) in v.iter_mut() {
                    let u: f64 = self.rng.gen();
                    if u < *p {
                        *t = None;
                    }
                }
                v
            }
            NetworkSpec::Radio { range, over } => {
                let me = pos(from);
                let mut v = self.model(over, now, from, to, pos);
                for (d, t) in v.iter_mut() {
                    if (pos(*d) - me).norm() > *range {
                        *t = None;
                    }
                }
                v
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn net(spec: NetworkSpec) -> Network {
        Network::new(spec, ChaCha8Rng::seed_from_u64(1), Vec::new())
    }

    fn origin(_: RobotId) -> Point {
        Point::new(0.0, 0.0)
    }

    #[test]
    fn random_delays_are_exponential_with_the_given_mean() {
        let mut n = net(NetworkSpec::RandomDelay { lambda: 10.0 });
        let d: Vec<f64> = (0..20_000)
            .map(|_| n.transmit(5.0, 0, &[1], &origin)[0].1.unwrap() - 5.0)
            .collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        assert!((mean - 10.0).abs() < 0.3, "mean {mean}");
        // Exponential: P(X > mean) = 1/e.
        let above = d.iter().filter(|x| **x > 10.0).count() as f64 / d.len() as f64;
        assert!((above - (-1f64).exp()).abs() < 0.02, "{above}");
    }

    #[test]
    fn metric_queues_on_cpus_and_the_shared_medium() {
        let mut n = net(NetworkSpec::Metric { lambda: 2.0 });
        // Sender CPU 0->1, medium 1->3, receiver CPUs 3->4.
        assert_eq!(
            n.transmit(0.0, 0, &[1, 2], &origin),
            vec![(1, Some(4.0)), (2, Some(4.0))]
        );
        // A second message at once waits for the CPU (1->2), the medium (3->5), CPU 1 (5->6).
        assert_eq!(n.transmit(0.0, 0, &[1], &origin), vec![(1, Some(6.0))]);
        // Another sender: its CPU is free (0->1) but the medium is busy until 5 (5->7), then
        // receiver 1 is busy until 6 (7->8).
        assert_eq!(n.transmit(0.0, 3, &[1], &origin), vec![(1, Some(8.0))]);
    }

    #[test]
    fn lossy_drops_about_p_and_radio_only_reaches_within_range() {
        let mut n = net(NetworkSpec::Lossy {
            p: 0.25,
            over: Box::new(NetworkSpec::Reliable { delay: 1.0 }),
        });
        let lost = (0..10_000)
            .filter(|_| n.transmit(0.0, 0, &[1], &origin)[0].1.is_none())
            .count();
        assert!((lost as f64 / 10_000.0 - 0.25).abs() < 0.02, "{lost}");
        let mut r = net(NetworkSpec::Radio {
            range: 10.0,
            over: Box::new(NetworkSpec::Reliable { delay: 1.0 }),
        });
        let pos = |id: RobotId| Point::new(id as f64 * 6.0, 0.0);
        assert_eq!(
            r.transmit(0.0, 0, &[1, 2], &pos),
            vec![(1, Some(1.0)), (2, None)]
        );
    }

    #[test]
    fn partitions_drop_across_groups_while_they_last() {
        let p = Partition {
            groups: vec![vec![0, 1], vec![2]],
            from: 5.0,
            to: 10.0,
        };
        let mut n = Network::new(
            NetworkSpec::Reliable { delay: 1.0 },
            ChaCha8Rng::seed_from_u64(1),
            vec![p],
        );
        assert_eq!(
            n.transmit(6.0, 0, &[1, 2], &origin),
            vec![(1, Some(7.0)), (2, None)]
        );
        assert_eq!(n.transmit(10.0, 0, &[2], &origin), vec![(2, Some(11.0))]);
        assert_eq!(n.transmit(4.0, 2, &[0], &origin), vec![(0, Some(5.0))]);
    }

    #[test]
    fn bad_parameters_are_named() {
        let e = NetworkSpec::Lossy {
            p: 1.5,
            over: Box::new(NetworkSpec::Reliable { delay: 1.0 }),
        }
        .check()
        .unwrap_err();
        assert_eq!(e.0, "p");
        let e = NetworkSpec::Radio {
            range: 3.0,
            over: Box::new(NetworkSpec::RandomDelay { lambda: -1.0 }),
        }
        .check()
        .unwrap_err();
        assert_eq!(e.0, "over.lambda");
    }
}
