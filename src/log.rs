//! The Neko-style text log (seed 4.5.1, fig. 4.12, 5.2, 5.4): one line per observation, three
//! decimals. See docs/log.md for every line type.

use std::collections::HashMap;

use nekosim_actors::world::geometry::Point;
use nekosim_actors::world::motion::StepKind;
use nekosim_actors::world::observation::{Observation, Record};
use nekosim_actors::world::obstacle::Shape;
use nekosim_actors::world::sensor::SensorQuery;
use nekosim_actors::world::{MotionOutcome, RobotId};
use nekosim_protocols::codec::type_word;
use nekosim_protocols::Payload;

pub use nekosim_actors::world::observation::num;
use nekosim_actors::world::observation::{obstacle_text as obstacle, point_text as pt};

/// The seed's name of a motion pattern in conditions (`MoveTo`, `Turn`, `Forward`).
fn pattern(name: &str) -> String {
    match name {
        "move_to" => "MoveTo".into(),
        "turn" => "Turn".into(),
        "forward" => "Forward".into(),
        other => other.to_string(),
    }
}

/// The query, as its sensor writes it in the seed's log.
pub fn query_text(q: &SensorQuery) -> String {
    match &q.query {
        Some(d) => d
            .own_text()
            .unwrap_or_else(|| format!("{} {}", q.sensor, d.ron())),
        None => format!("Deactivate {}", q.sensor),
    }
}

/// of the run's stack).
pub fn wire_text(p: &Payload) -> String {
    p.to_string()
}

/// A message split for Neko's `messages` lines: its type (the rendering's first word) and the
/// rest of the rendering (`-` when there is none), with its numbers rounded as the seed's log
/// writes positions ([`round_numbers`]; the trace keeps every digit).
pub fn type_and_rest(p: &Payload) -> (String, String) {
    let text = p.to_string();
    let ty = type_word(&text).to_string();
    let rest = text[ty.len()..].trim();
    let rest = if rest.is_empty() { "-" } else { rest };
    (ty, round_numbers(rest))
}

/// `text` with every decimal number of more than three decimals rounded to three
/// (`GOTO(613.475885753758, 4.5)` becomes `GOTO(613.476, 4.5)`); integers, identifiers and
/// shorter decimals are left as they are.
pub fn round_numbers(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < bytes.len() {
        let starts_number = bytes[i].is_ascii_digit()
            && (i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_'));
        if !starts_number {
            let c = text[i..].chars().next().expect("in bounds");
            out.push(c);
            i += c.len_utf8();
            continue;
        }
        let start = i;
        while i < bytes.len() && bytes[i].is_ascii_digit() {
            i += 1;
        }
        let mut decimals = 0;
        if i + 1 < bytes.len() && bytes[i] == b'.' && bytes[i + 1].is_ascii_digit() {
            i += 1;
            while i < bytes.len() && bytes[i].is_ascii_digit() {
                i += 1;
                decimals += 1;
            }
        }
        // An exponent belongs to the number.
        if decimals > 0 && i < bytes.len() && (bytes[i] == b'e' || bytes[i] == b'E') {
            let mut j = i + 1;
            if j < bytes.len() && (bytes[j] == b'-' || bytes[j] == b'+') {
                j += 1;
            }
            if j < bytes.len() && bytes[j].is_ascii_digit() {
                while j < bytes.len() && bytes[j].is_ascii_digit() {
                    j += 1;
                }
                i = j;
                decimals = usize::MAX;
            }
        }
        let number = &text[start..i];
        match number.parse::<f64>() {
            Ok(v) if decimals > 3 => out.push_str(&format!("{v:.3}")),
            _ => out.push_str(number),
        }
    }
    out
}

/// The lines a log starts with in a world with obstacles (nekosim's; the seed had none): one
/// per obstacle, `0.000 Obstacle: K | Rect | [x,y] [x,y]` with its shape's points (a circle's
/// centre and radius).
pub fn obstacle_lines(shapes: &[Shape]) -> Vec<String> {
    let p = |v: &(f64, f64)| pt(Point::new(v.0, v.1));
    shapes
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let (kind, what) = match s {
                Shape::Segment { from, to } => ("Segment", format!("{} {}", p(from), p(to))),
                Shape::Rect { min, max } => ("Rect", format!("{} {}", p(min), p(max))),
                Shape::Polygon(points) => (
                    "Polygon",
                    points.iter().map(p).collect::<Vec<_>>().join(" "),
                ),
                Shape::Circle { center, radius } => {
                    ("Circle", format!("{} radius {}", p(center), num(*radius)))
                }
            };
            format!("{} Obstacle: {k} | {kind} | {what}", num(0.0))
        })
        .collect()
}

/// Turns observations into log lines; remembers each robot's current motion pattern, where its
/// current motion ends, and whether its last line closed a motion.
#[derive(Debug, Default)]
pub struct NekoLog {
    motions: HashMap<RobotId, String>,
    /// The destination of each robot's motion in progress (a `CollisionEvent` shows it).
    moving: HashMap<RobotId, Point>,
    /// Robots whose latest line was a finishing step (`Finish_MoveTo`, `Finish_Turn`): the
    /// arrival that follows it has no line of its own, as in the seed.
    finished: HashMap<RobotId, f64>,
}

impl NekoLog {
    /// A log writer.
    pub fn new() -> Self {
        Self::default()
    }

    /// The log line of an observation, or `None` for the one observation the seed's log has
    /// no line for: a motion's arrival right after the step that finished it (the seed writes
    /// `Finish_MoveTo` and nothing more; the trace has both).
    pub fn line(&mut self, r: &Record) -> Option<String> {
        let robot = r.obs.robot();
        let finished = self.finished.remove(&robot);
        if let Observation::MotionFinish {
            outcome: MotionOutcome::Arrived,
            ..
        } = &r.obs
        {
            self.moving.remove(&robot);
            if finished == Some(r.t) {
                return None;
            }
        }
        Some(self.text(r))
    }

    fn text(&mut self, r: &Record) -> String {
        let t = num(r.t);
        match &r.obs {
            Observation::Light {
                robot,
                light,
                pending,
            } => match pending {
                Some(p) => format!("{t} p{robot} Light: {light} | computing {p}"),
                None => format!("{t} p{robot} Light: {light}"),
            },
            Observation::Lcm(rec) => format!("{t} p{} {}", rec.robot(), rec.log_text()),
            Observation::Spawn {
                robot,
                pos,
                angle,
                radius,
            } => {
                format!(
                    "{t} p{robot} Born: ROBOT# {robot} | {} | {} | radius {}",
                    pt(*pos),
                    num(*angle),
                    num(*radius)
                )
            }
            Observation::MotionRequest {
                robot,
                ticket,
                motion,
            } => {
                let params = motion.params();
                let motion = motion.name();
                self.motions.insert(*robot, motion.to_string());
                let get = |k: &str| params.iter().find(|(n, _)| n == k).map_or(0.0, |(_, v)| *v);
                let what = match motion {
                    "move_to" => format!(
                        "MoveTo: ( {} , {} ) with turnSpeed = {} moveSpeed = {}",
                        num(get("x")),
                        num(get("y")),
                        num(get("turn_speed")),
                        num(get("move_speed"))
                    ),
                    "turn" => format!(
                        "Turn: angle = {} with turnSpeed = {}",
                        num(get("angle")),
                        num(get("turn_speed"))
                    ),
                    "forward" => format!(
                        "Forward: distance = {} with moveSpeed = {}",
                        num(get("distance")),
                        num(get("move_speed"))
                    ),
                    other => {
                        let ps: Vec<String> = params
                            .iter()
                            .map(|(k, v)| format!("{k} = {}", num(*v)))
                            .collect();
                        format!("{other}: {}", ps.join(" "))
                    }
                };
                // The seed's Task ID is the request's place in the robot's queue of motion tasks:
                // a robot runs one motion at a time, so every request is task 1 (as in every
                // MotionRequest line of the seed's logs); the trace's `ticket` counts them.
                let _ = ticket;
                format!(
                    "{t} p{robot} MotionRequest: TIME: {t} | ROBOT# {robot} Task ID = 1 | {what}"
                )
            }
            Observation::MotionStep {
                robot,
                step,
                state,
                progress,
            } => {
                let name = pattern(self.motions.get(robot).map_or("motion", String::as_str));
                let seq = if name == "MoveTo" {
                    "MoveTo_Sequence".to_string()
                } else {
                    name.clone()
                };
                // As in the seed, each line shows the phase it starts: during a turn the
                // destination is the robot's own position and only the turn is counted.
                self.moving.insert(*robot, progress.dest);
                if matches!(step, StepKind::FinishTurn | StepKind::FinishForward) {
                    self.finished.insert(*robot, r.t);
                }
                let (dest, turn, dist, ts, ms, cond) = match step {
                    StepKind::StartTurn => (
                        state.pos,
                        progress.turn_left,
                        0.0,
                        progress.turn_speed,
                        0.0,
                        format!("Do_{seq}"),
                    ),
                    StepKind::FinishTurn => {
                        (state.pos, 0.0, 0.0, 0.0, 0.0, format!("Finish_{seq}"))
                    }
                    StepKind::StartForward => (
                        progress.dest,
                        0.0,
                        progress.distance_left,
                        0.0,
                        progress.move_speed,
                        format!("Do_{seq}"),
                    ),
                    StepKind::FinishForward => {
                        (state.pos, 0.0, 0.0, 0.0, 0.0, format!("Finish_{name}"))
                    }
                    StepKind::Custom(s) => (
                        progress.dest,
                        progress.turn_left,
                        progress.distance_left,
                        progress.turn_speed,
                        progress.move_speed,
                        format!("{name}_{s}"),
                    ),
                };
                format!(
                    "{t} p{robot} Event: | {t} | {robot} | {} | {} | {} | {} | {} | {} | {} | {cond}",
                    pt(state.pos),
                    pt(dest),
                    num(state.angle),
                    num(turn),
                    num(dist),
                    num(ts),
                    num(ms)
                )
            }
            Observation::MotionFinish {
                robot,
                state,
                outcome,
            } => {
                self.moving.remove(robot);
                let name = pattern(self.motions.get(robot).map_or("motion", String::as_str));
                let cond = match outcome {
                    MotionOutcome::Arrived => format!("Arrived_{name}"),
                    MotionOutcome::Collided { with } => {
                        format!("Collided_{name}({})", obstacle(*with))
                    }
                    MotionOutcome::Replaced => format!("Replaced_{name}"),
                    MotionOutcome::Rejected(m) => format!("Rejected_{name}({m})"),
                    MotionOutcome::Crashed => format!("Crashed_{name}"),
                };
                format!(
                    "{t} p{robot} Event: | {t} | {robot} | {} | {} | {} | 0.000 | 0.000 | 0.000 | 0.000 | {cond}",
                    pt(state.pos),
                    pt(state.pos),
                    num(state.angle)
                )
            }
            // The seed's shape: the fourth column is where the robot was going, the condition
            // the phase the collision interrupted. A robot at rest, hit by another, shows its
            // own position and `Collision`; who hit whom is in the moving robot's
            // `Collided_...(pM)` line that follows, and in the trace.
            Observation::Collision {
                robot, pos, angle, ..
            } => {
                let (dest, cond) = match self.moving.get(robot) {
                    Some(dest) => {
                        let name =
                            pattern(self.motions.get(robot).map_or("motion", String::as_str));
                        let seq = if name == "MoveTo" {
                            "MoveTo_Sequence".to_string()
                        } else {
                            name
                        };
                        (*dest, format!("Do_{seq}(Collision)"))
                    }
                    None => (*pos, "Collision".to_string()),
                };
                format!(
                    "{t} p{robot} CollisionEvent: | {t} | {robot} | {} | {} | {} | 0.000 | 0.000 | 0.000 | 0.000 | {cond}",
                    pt(*pos),
                    pt(dest),
                    num(*angle)
                )
            }
            Observation::SensorRequest { robot, query, .. } => {
                format!(
                    "{t} p{robot} SensorRequest: ROBOT# {robot} | {}",
                    query_text(query)
                )
            }
            Observation::Log { robot, text } => format!("{t} p{robot} Info: {text}"),
            Observation::Request {
                robot,
                layer,
                op,
                msg,
            } => {
                format!(
                    "{t} p{robot} Request: layer {layer} | {op} | {}",
                    wire_text(msg)
                )
            }
            Observation::Send {
                robot,
                to,
                layer,
                msg,
                ..
            } => {
                let dests: Vec<String> = to.iter().map(|d| format!("p{d}")).collect();
                let (ty, rest) = type_and_rest(msg);
                format!(
                    "{t} p{robot} messages e s p{robot} {} {ty} {rest} [{layer}]",
                    dests.join(",")
                )
            }
            Observation::Receive {
                robot,
                from,
                layer,
                msg,
            } => {
                let (ty, rest) = type_and_rest(msg);
                format!("{t} p{robot} messages e r p{from} p{robot} {ty} {rest} [{layer}]")
            }
            Observation::Deliver {
                robot,
                layer,
                id,
                msg,
            } => {
                format!(
                    "{t} p{robot} Deliver: layer {layer} | {id} | {}",
                    wire_text(msg)
                )
            }
            Observation::Decide {
                robot,
                layer,
                k,
                value,
            } => {
                format!(
                    "{t} p{robot} Decide: layer {layer} | instance {k} | {}",
                    wire_text(value)
                )
            }
            Observation::Suspect {
                robot,
                layer,
                process,
            } => format!("{t} p{robot} Suspect: layer {layer} | p{process}"),
            Observation::Trust {
                robot,
                layer,
                process,
            } => format!("{t} p{robot} Trust: layer {layer} | p{process}"),
            Observation::Leader {
                robot,
                layer,
                process,
            } => format!("{t} p{robot} Leader: layer {layer} | p{process}"),
            Observation::Crash { robot, state } => {
                format!(
                    "{t} p{robot} Crash: ROBOT# {robot} | {} | {}",
                    pt(state.pos),
                    num(state.angle)
                )
            }
            Observation::SensorReply {
                robot,
                sensor,
                value,
                interrupt,
            } => format!(
                "{t} p{robot} {}: ROBOT# {robot} | {} | {}",
                if *interrupt {
                    "SensorInterrupt"
                } else {
                    "SensorReply"
                },
                sensor.name(),
                value.text()
            ),
        }
    }
}

#[cfg(test)]
mod num_tests {
    use super::num;
    use proptest::prelude::*;

    /// The standard formatter, the oracle.
    fn std_num(v: f64) -> String {
        let s = format!("{v:.3}");
        if s == "-0.000" {
            "0.000".into()
        } else {
            s
        }
    }

    #[test]
    fn ties_and_edges_match_the_standard_formatter() {
        // i / 16 are exact ties at three decimals (x.xxx5); i / 2^k for larger k are near
        // ties on either side.
        for i in -100_000i64..100_000 {
            for d in [16.0, 32.0, 64.0, 1024.0, 8.0, 2000.0, 1000.0] {
                let v = i as f64 / d;
                assert_eq!(num(v), std_num(v), "{v:e}");
            }
        }
        for v in [
            0.0,
            -0.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            5e-324,
            0.0005,
            -0.0005,
            0.0004999999999999999,
            1e15,
            1.2345678e17,
            1.152921504606847e18,
            1.152921504606847e19,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ] {
            assert_eq!(num(v), std_num(v), "{v:e}");
        }
    }

    proptest! {
        #[test]
        fn random_values_match_the_standard_formatter(bits in any::<u64>()) {
            let v = f64::from_bits(bits);
            prop_assert_eq!(num(v), std_num(v));
        }

        #[test]
        fn everyday_values_match_the_standard_formatter(v in -1e7f64..1e7) {
            prop_assert_eq!(num(v), std_num(v));
        }
    }
}

#[cfg(test)]
mod round_tests {
    use super::round_numbers;

    #[test]
    fn long_decimals_are_rounded_to_three_places_and_nothing_else_changes() {
        assert_eq!(
            round_numbers("(613.475885753758, 477.918603071893)"),
            "(613.476, 477.919)"
        );
        assert_eq!(
            round_numbers("[-0.12345, 4.5, 7, 1.000]"),
            "[-0.123, 4.5, 7, 1.000]"
        );
        assert_eq!(round_numbers("ts 1, 1:0, M 12"), "ts 1, 1:0, M 12");
        assert_eq!(round_numbers("p10 x2.123456 1.5e-7"), "p10 x2.123456 0.000");
        assert_eq!(round_numbers("é 3.14159 ü"), "é 3.142 ü");
        assert_eq!(round_numbers(""), "");
    }
}
