//! Simulated networks (seed 3.4, fig. 3.8; Neko's simulated networks): when, and whether, a
//! message sent at some instant reaches each destination.
//!
//! A network model implements [`NetworkModel`] and is registered by name in [`Networks`],
//! the built-ins exactly as a user's model:
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
use std::fmt;

use nekosim_protocols::registry::Named;
use nekosim_protocols::{FieldError, Spec, SpecError};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::de::DeserializeOwned;
use serde::Deserialize;

use super::geometry::Point;
use super::RobotId;

/// What a network model sees of one send: when, who to whom, where every robot is.
#[allow(missing_debug_implementations)] // holds a position function
pub struct Send<'a> {
    /// The send instant [s].
    pub now: f64,
    pub from: RobotId,
    pub to: &'a [RobotId],
    /// Exact positions of the robots at `now` (the motion formulas, seed 3.1).
    pub pos: &'a dyn Fn(RobotId) -> Point,
    /// Whether the straight line between two points crosses an obstacle of the world.
    pub blocked: &'a dyn Fn(Point, Point) -> bool,
}

/// A network model: decides the arrival time of each copy of a message, or its loss.
pub trait NetworkModel: fmt::Debug + std::marker::Send {
    /// Arrival time of the copy to each destination of `send` (`None`: lost), in `send.to`'s
    /// order. Random draws come from `rng`, the run's seeded network stream.
    fn transmit(&mut self, send: &Send<'_>, rng: &mut ChaCha8Rng) -> Vec<(RobotId, Option<f64>)>;
}

/// A network model a scenario can name: `network: Name(field: value, ...)`.
pub trait ConfiguredNetwork: NetworkModel + Sized + 'static {
    /// What the scenario's configuration is read into (serde, from RON).
    type Config: DeserializeOwned;

    /// The model, or why the configuration is refused; `networks` builds the models a
    /// configuration names in turn (`Lossy(p: 0.1, over: RandomDelay(lambda: 1.0))`).
    fn configure(config: Self::Config, networks: &Networks) -> Result<Self, FieldError>;
}

type BuildFn = fn(&Spec, &Networks) -> Result<Box<dyn NetworkModel>, SpecError>;

fn build_entry<N: ConfiguredNetwork>(
    spec: &Spec,
    networks: &Networks,
) -> Result<Box<dyn NetworkModel>, SpecError> {
    spec.configure(|c| N::configure(c, networks))
        .map(|n| Box::new(n) as Box<dyn NetworkModel>)
}

/// Network models by the name scenarios use for them. A new (or default) registry holds the
/// built-in models; [`Networks::empty`] holds none.
#[derive(Clone, Debug)]
pub struct Networks {
    entries: Named<BuildFn>,
}

impl PartialEq for Networks {
    fn eq(&self, other: &Self) -> bool {
        self.entries.names().eq(other.entries.names())
    }
}

impl Default for Networks {
    /// [`Networks::with_builtins`].
    fn default() -> Self {
        Self::with_builtins()
    }
}

impl Networks {
    /// A registry without any model.
    pub fn empty() -> Self {
        Self {
            entries: Named::new("network"),
        }
    }

    /// The built-in models, under their names.
    pub fn with_builtins() -> Self {
        let mut r = Self::empty();
        r.network::<Reliable>("Reliable")
            .network::<RandomDelay>("RandomDelay")
            .network::<Metric>("Metric")
            .network::<Lossy>("Lossy")
            .network::<Radio>("Radio");
        r
    }

    /// Registers the model `N` under `name` (replacing an earlier registration).
    pub fn network<N: ConfiguredNetwork>(&mut self, name: &str) -> &mut Self {
        self.entries.insert(name, build_entry::<N>);
        self
    }

    /// Registered names, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.names()
    }

    /// Reads `spec`'s configuration and builds the model. Positions in the error are in
    /// `spec`'s text; an error inside a nested model names the field holding it.
    pub fn build(&self, spec: &Spec) -> Result<Box<dyn NetworkModel>, SpecError> {
        (self.entries.get(spec)?)(spec, self)
    }

    /// Builds the model `spec` held in field `field` of another model's configuration: an
    /// error is reported at that field.
    pub fn build_in(&self, field: &str, spec: &Spec) -> Result<Box<dyn NetworkModel>, FieldError> {
        // An error inside the nested model's text is reported at the field holding it.
        self.build(spec).map_err(|e| {
            FieldError::new(e.field.as_deref().unwrap_or(""), e.message, "").inside(field)
        })
    }
}

/// `field`'s value must be a finite number >= 0.
fn nonneg(field: &str, v: f64) -> Result<f64, FieldError> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(FieldError::new(
            field,
            format!("{field} is {v}"),
            "a finite number >= 0",
        ))
    }
}

/// `Reliable(delay: D)`: every copy arrives after `delay` seconds.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Reliable {
    pub delay: f64,
}

impl NetworkModel for Reliable {
    fn transmit(&mut self, s: &Send<'_>, _: &mut ChaCha8Rng) -> Vec<(RobotId, Option<f64>)> {
        s.to.iter()
            .map(|&d| (d, Some(s.now + self.delay)))
            .collect()
    }
}

impl ConfiguredNetwork for Reliable {
    type Config = Reliable;
    fn configure(c: Reliable, _: &Networks) -> Result<Self, FieldError> {
        nonneg("delay", c.delay)?;
        Ok(c)
    }
}

/// `RandomDelay(lambda: L)`: exponential delays of mean `lambda` (Neko's RandomNetwork).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomDelay {
    pub lambda: f64,
}

impl NetworkModel for RandomDelay {
    fn transmit(&mut self, s: &Send<'_>, rng: &mut ChaCha8Rng) -> Vec<(RobotId, Option<f64>)> {
        s.to.iter()
            .map(|&d| {
                let u: f64 = rng.gen();
                (d, Some(s.now - self.lambda * (1.0 - u).ln()))
            })
            .collect()
    }
}

impl ConfiguredNetwork for RandomDelay {
    type Config = RandomDelay;
    fn configure(c: RandomDelay, _: &Networks) -> Result<Self, FieldError> {
        nonneg("lambda", c.lambda)?;
        Ok(c)
    }
}

/// `Metric(lambda: L)`: contention on the sender's CPU, the shared medium and the receivers'
/// CPUs (Neko's MetricNetwork).
#[derive(Clone, Debug, PartialEq)]
pub struct Metric {
    lambda: f64,
    send_cpu: BTreeMap<RobotId, f64>,
    medium: f64,
    recv_cpu: BTreeMap<RobotId, f64>,
}

/// `Metric(lambda: L)`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetricConfig {
    pub lambda: f64,
}

impl NetworkModel for Metric {
    fn transmit(&mut self, s: &Send<'_>, _: &mut ChaCha8Rng) -> Vec<(RobotId, Option<f64>)> {
        let cpu = self.send_cpu.entry(s.from).or_insert(0.0);
        let sent = cpu.max(s.now) + 1.0;
        *cpu = sent;
        let on_wire = self.medium.max(sent) + self.lambda;
        self.medium = on_wire;
        s.to.iter()
            .map(|&d| {
                let rc = self.recv_cpu.entry(d).or_insert(0.0);
                let arrived = rc.max(on_wire) + 1.0;
                *rc = arrived;
                (d, Some(arrived))
            })
            .collect()
    }
}

impl ConfiguredNetwork for Metric {
    type Config = MetricConfig;
    fn configure(c: MetricConfig, _: &Networks) -> Result<Self, FieldError> {
        Ok(Self {
            lambda: nonneg("lambda", c.lambda)?,
            send_cpu: BTreeMap::new(),
            medium: 0.0,
            recv_cpu: BTreeMap::new(),
        })
    }
}

/// `Lossy(p: P, over: NET)`: `over`, then each copy is dropped with probability `p`.
#[derive(Debug)]
pub struct Lossy {
    p: f64,
    over: Box<dyn NetworkModel>,
}

/// `Lossy(p: P, over: NET)`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LossyConfig {
    pub p: f64,
    pub over: Spec,
}

impl NetworkModel for Lossy {
    fn transmit(&mut self, s: &Send<'_>, rng: &mut ChaCha8Rng) -> Vec<(RobotId, Option<f64>)> {
        let mut v = self.over.transmit(s, rng);
        for (_, t) in v.iter_mut() {
            let u: f64 = rng.gen();
            if u < self.p {
                *t = None;
            }
        }
        v
    }
}

impl ConfiguredNetwork for Lossy {
    type Config = LossyConfig;
    fn configure(c: LossyConfig, networks: &Networks) -> Result<Self, FieldError> {
        if !(c.p.is_finite() && (0.0..=1.0).contains(&c.p)) {
            return Err(FieldError::new(
                "p",
                format!("p is {}", c.p),
                "a probability in [0, 1]",
            ));
        }
        Ok(Self {
            p: c.p,
            over: networks.build_in("over", &c.over)?,
        })
    }
}

/// `Radio(range: R, over: NET, line_of_sight: B)`: `over`, but only destinations within
/// `range` of the sender at the send instant receive; with `line_of_sight: true`, only those
/// whose straight line from the sender crosses no obstacle (seed 7.2: "communication ranges
/// tied to obstacles").
#[derive(Debug)]
pub struct Radio {
    range: f64,
    over: Box<dyn NetworkModel>,
    line_of_sight: bool,
}

/// `Radio(range: R, over: NET, line_of_sight: false)`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadioConfig {
    pub range: f64,
    pub over: Spec,
    /// Drop copies whose straight line crosses an obstacle; default false.
    #[serde(default)]
    pub line_of_sight: bool,
}

impl NetworkModel for Radio {
    fn transmit(&mut self, s: &Send<'_>, rng: &mut ChaCha8Rng) -> Vec<(RobotId, Option<f64>)> {
        let me = (s.pos)(s.from);
        let mut v = self.over.transmit(s, rng);
        for (d, t) in v.iter_mut() {
            let there = (s.pos)(*d);
            if (there - me).norm() > self.range || (self.line_of_sight && (s.blocked)(me, there)) {
                *t = None;
            }
        }
        v
    }
}

impl ConfiguredNetwork for Radio {
    type Config = RadioConfig;
    fn configure(c: RadioConfig, networks: &Networks) -> Result<Self, FieldError> {
        Ok(Self {
            range: nonneg("range", c.range)?,
            over: networks.build_in("over", &c.over)?,
            line_of_sight: c.line_of_sight,
        })
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

/// A run's network: its model, random stream and partitions.
#[derive(Debug)]
pub struct Network {
    model: Box<dyn NetworkModel>,
    rng: ChaCha8Rng,
    partitions: Vec<Partition>,
}

impl Network {
    /// A network following `model`, drawing from `rng`.
    pub fn new(model: Box<dyn NetworkModel>, rng: ChaCha8Rng, partitions: Vec<Partition>) -> Self {
        Self {
            model,
            rng,
            partitions,
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
        self.transmit_among(now, from, to, pos, &|_, _| false)
    }

    /// [`Network::transmit`] in a world with obstacles: `blocked` says whether the straight
    /// line between two points crosses one.
    pub fn transmit_among(
        &mut self,
        now: f64,
        from: RobotId,
        to: &[RobotId],
        pos: &dyn Fn(RobotId) -> Point,
        blocked: &dyn Fn(Point, Point) -> bool,
    ) -> Vec<(RobotId, Option<f64>)> {
        let send = Send {
            now,
            from,
            to,
            pos,
            blocked,
        };
        let mut out = self.model.transmit(&send, &mut self.rng);
        for (d, t) in out.iter_mut() {
            if self.partitions.iter().any(|p| p.separates(from, *d, now)) {
                *t = None;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn model(spec: &str) -> Box<dyn NetworkModel> {
        Networks::with_builtins()
            .build(&Spec::new(spec))
            .expect("valid")
    }

    fn net(spec: &str) -> Network {
        Network::new(model(spec), ChaCha8Rng::seed_from_u64(1), Vec::new())
    }

    fn origin(_: RobotId) -> Point {
        Point::new(0.0, 0.0)
    }

    #[test]
    fn random_delays_are_exponential_with_the_given_mean() {
        let mut n = net("RandomDelay(lambda: 10.0)");
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
        let mut n = net("Metric(lambda: 2.0)");
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
        let mut n = net("Lossy(p: 0.25, over: Reliable(delay: 1.0))");
        let lost = (0..10_000)
            .filter(|_| n.transmit(0.0, 0, &[1], &origin)[0].1.is_none())
            .count();
        assert!((lost as f64 / 10_000.0 - 0.25).abs() < 0.02, "{lost}");
        let mut r = net("Radio(range: 10.0, over: Reliable(delay: 1.0))");
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
            model("Reliable(delay: 1.0)"),
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
        let nets = Networks::with_builtins();
        let e = nets
            .build(&Spec::new("Lossy(p: 1.5, over: Reliable(delay: 1.0))"))
            .unwrap_err();
        assert_eq!(e.field.as_deref(), Some("p"));
        assert_eq!(
            e.message,
            "Lossy: p is 1.5; expected a probability in [0, 1]"
        );
        let e = nets
            .build(&Spec::new(
                "Radio(range: 3.0, over: RandomDelay(lambda: -1.0))",
            ))
            .unwrap_err();
        assert_eq!(e.field.as_deref(), Some("over.lambda"));
        assert_eq!(
            e.message,
            "Radio: RandomDelay: lambda is -1; expected a finite number >= 0"
        );
        let e = nets.build(&Spec::new("Reliable(dealy: 1.0)")).unwrap_err();
        assert_eq!((e.field, e.at), (None, Some((1, 10))));
        let e = nets.build(&Spec::new("Wormhole")).unwrap_err();
        assert!(e
            .message
            .starts_with("unknown network \"Wormhole\"; expected one of Lossy"));
    }
}
