//! What a sweep measures of each run: the run summary's figures by name, with units, and the
//! checks (`collisions == 0`) that decide whether a run passed.

use crate::runner::Summary;

/// A metric: its name in sweep files and CSV columns, its unit, what it counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Metric {
    pub name: &'static str,
    pub unit: &'static str,
    pub what: &'static str,
}

const fn m(name: &'static str, unit: &'static str, what: &'static str) -> Metric {
    Metric { name, unit, what }
}

/// Every metric, in the order of the CSV columns. Wall-clock figures (wall time, events per
/// second) are left out: a sweep's files do not depend on the machine or its load.
pub const METRICS: &[Metric] = &[
    m("robots", "robots", "robots in the run"),
    m("events", "events", "events the scheduler fired"),
    m(
        "cancelled_events",
        "events",
        "conditional events cancelled before they fired (collisions predicted, then avoided)",
    ),
    m(
        "collisions",
        "collisions",
        "robot-robot and robot-wall collisions",
    ),
    m("end_time", "s", "simulated time at the end of the run"),
    m(
        "messages_sent",
        "copies",
        "message copies handed to the network (one per receiver), every layer",
    ),
    m("messages_lost", "copies", "copies the network lost"),
    m("messages_received", "copies", "copies received"),
    m(
        "deliveries",
        "deliveries",
        "deliveries of broadcast layers (one per message per delivering robot)",
    ),
    m(
        "deliver_latency_mean",
        "s",
        "mean time from a broadcast to its deliveries; empty without deliveries",
    ),
    m("deliver_latency_p50", "s", "median of the same"),
    m("deliver_latency_p99", "s", "99th percentile of the same"),
    m(
        "throughput",
        "deliveries/s",
        "deliveries per simulated second from the first broadcast to the last delivery",
    ),
    m(
        "decisions",
        "decisions",
        "decisions of consensus layers (one per instance per deciding robot)",
    ),
    m(
        "decided",
        "robots",
        "robots that decided at least once and did not crash",
    ),
    m(
        "suspicions",
        "suspicions",
        "suspicions raised by failure detectors",
    ),
    m("crashes", "robots", "robots that crashed"),
    m("live_robots", "robots", "robots that did not crash"),
];

/// The metric named `name`.
pub fn find(name: &str) -> Option<&'static Metric> {
    METRICS.iter().find(|m| m.name == name)
}

/// The value of metric `name` in `s` (`None`: the run has none, e.g. no deliveries).
pub fn value(name: &str, s: &Summary) -> Option<f64> {
    let c = &s.counts;
    let lat = s.latency.as_ref();
    Some(match name {
        "robots" => s.robots as f64,
        "events" => s.events as f64,
        "cancelled_events" => s.cancelled as f64,
        "collisions" => s.collisions as f64,
        "end_time" => s.end_time,
        "messages_sent" => c.sent as f64,
        "messages_lost" => c.lost as f64,
        "messages_received" => c.received as f64,
        "deliveries" => c.delivered as f64,
        "deliver_latency_mean" => lat?.mean,
        "deliver_latency_p50" => lat?.p50,
        "deliver_latency_p99" => lat?.p99,
        "throughput" => lat?.throughput,
        "decisions" => c.decisions as f64,
        "decided" => c.decided as f64,
        "suspicions" => c.suspicions as f64,
        "crashes" => c.crashes as f64,
        "live_robots" => s.robots.saturating_sub(c.crashes as usize) as f64,
        _ => return None,
    })
}

/// One side of a check: a metric or a number.
#[derive(Clone, Debug, PartialEq)]
pub enum Operand {
    Metric(&'static str),
    Number(f64),
}

/// A comparison between two operands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
}

impl Op {
    fn holds(self, a: f64, b: f64) -> bool {
        match self {
            Op::Eq => a == b,
            Op::Ne => a != b,
            Op::Lt => a < b,
            Op::Le => a <= b,
            Op::Gt => a > b,
            Op::Ge => a >= b,
        }
    }
}

/// A check: `OPERAND OP OPERAND`, e.g. `collisions == 0`, `decided == live_robots`,
/// `deliver_latency_p99 <= 2.5`. A metric a run has no value of fails the check.
#[derive(Clone, Debug, PartialEq)]
pub struct Check {
    pub text: String,
    pub left: Operand,
    pub op: Op,
    pub right: Operand,
}

/// Why a check does not parse: the message and the byte offset in its text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CheckError {
    pub offset: usize,
    pub message: String,
}

impl Check {
    /// Parses `text`.
    pub fn parse(text: &str) -> Result<Self, CheckError> {
        const OPS: [(&str, Op); 6] = [
            ("==", Op::Eq),
            ("!=", Op::Ne),
            ("<=", Op::Le),
            (">=", Op::Ge),
            ("<", Op::Lt),
            (">", Op::Gt),
        ];
        let found = OPS
            .iter()
            .filter_map(|(s, op)| text.find(s).map(|i| (i, *s, *op)))
            .min_by_key(|(i, s, _)| (*i, std::cmp::Reverse(s.len())));
        let Some((at, sym, op)) = found else {
            return Err(CheckError {
                offset: 0,
                message: format!(
                    "check `{text}` has no comparison; expected `METRIC OP VALUE` with OP one of == != < <= > >="
                ),
            });
        };
        let side = |start: usize, s: &str| -> Result<Operand, CheckError> {
            let lead = s.len() - s.trim_start().len();
            let t = s.trim();
            if t.is_empty() {
                return Err(CheckError {
                    offset: start,
                    message: format!("check `{text}`: a side of `{sym}` is empty"),
                });
            }
            if let Ok(v) = t.parse::<f64>() {
                return Ok(Operand::Number(v));
            }
            find(t)
                .map(|m| Operand::Metric(m.name))
                .ok_or_else(|| CheckError {
                    offset: start + lead,
                    message: format!(
                        "check `{text}`: unknown metric `{t}`; known: {}",
                        METRICS
                            .iter()
                            .map(|m| m.name)
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                })
        };
        Ok(Self {
            text: text.to_string(),
            left: side(0, &text[..at])?,
            op,
            right: side(at + sym.len(), &text[at + sym.len()..])?,
        })
    }

    /// Whether the check holds for a run whose metrics `value` gives.
    pub fn holds(&self, value: &dyn Fn(&str) -> Option<f64>) -> bool {
        let get = |o: &Operand| match o {
            Operand::Metric(m) => value(m),
            Operand::Number(v) => Some(*v),
        };
        match (get(&self.left), get(&self.right)) {
            (Some(a), Some(b)) => self.op.holds(a, b),
            _ => false,
        }
    }

    /// The metrics the check reads.
    pub fn metrics(&self) -> impl Iterator<Item = &'static str> + '_ {
        [&self.left, &self.right]
            .into_iter()
            .filter_map(|o| match o {
                Operand::Metric(m) => Some(*m),
                Operand::Number(_) => None,
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_parse_and_evaluate() {
        let c = Check::parse("collisions == 0").unwrap();
        assert_eq!(c.left, Operand::Metric("collisions"));
        assert_eq!(c.op, Op::Eq);
        assert_eq!(c.right, Operand::Number(0.0));
        let v = |m: &str| match m {
            "collisions" => Some(0.0),
            "decided" => Some(3.0),
            "live_robots" => Some(4.0),
            _ => None,
        };
        assert!(c.holds(&v));
        assert!(!Check::parse("decided == live_robots").unwrap().holds(&v));
        assert!(Check::parse("decided<=live_robots").unwrap().holds(&v));
        assert!(Check::parse("decided >= 3").unwrap().holds(&v));
        // No value: the check fails.
        assert!(!Check::parse("deliver_latency_p99 < 1e9").unwrap().holds(&v));
    }

    #[test]
    fn bad_checks_say_where() {
        let e = Check::parse("colisions == 0").unwrap_err();
        assert_eq!(e.offset, 0);
        assert!(
            e.message.contains("unknown metric `colisions`"),
            "{}",
            e.message
        );
        let e = Check::parse("collisions ==  x").unwrap_err();
        assert_eq!(e.offset, 15);
        assert!(Check::parse("collisions")
            .unwrap_err()
            .message
            .contains("no comparison"));
        assert!(Check::parse("== 3").unwrap_err().message.contains("empty"));
    }
}
