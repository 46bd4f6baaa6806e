//! A behaviour tree as an algorithm's configuration (seed 7.2): `algorithm: Behaviour(B)` is
//! read into [`BehaviourConfig`], and every number of the tree is checked, each refusal
//! located at its field.

use serde::Deserialize;

use super::tree::{Behaviour, Condition, Count, Speed, Target};
use crate::config::{finite, positive, speed, Configured, Setting};
use nekosim_protocols::FieldError;

impl Speed {
    fn check(self, path: &str, what: &str) -> Result<(), FieldError> {
        match self {
            Speed::Fixed(v) => speed(path, what, v).map(drop),
            Speed::Range(lo, hi) => {
                speed(&format!("{path}[0]"), what, lo)?;
                speed(&format!("{path}[1]"), what, hi)?;
                if hi < lo {
                    return Err(FieldError::new(
                        path,
                        format!("{what} range ({lo}, {hi}) is reversed"),
                        "(min, max) with min <= max",
                    ));
                }
                Ok(())
            }
        }
    }
}

impl Behaviour {
    /// Checks every number of the tree; `path` is where this behaviour is in the scenario's
    /// configuration (fields `.name`, positional elements `[k]`).
    pub fn check(&self, path: &str) -> Result<(), FieldError> {
        let at = |f: &str| format!("{path}{f}");
        let nonneg = |p: &str, what: &str, v: f64| -> Result<(), FieldError> {
            finite(p, what, v)?;
            if v < 0.0 {
                return Err(FieldError::value(p, what, v, "a number >= 0"));
            }
            Ok(())
        };
        match self {
            Behaviour::GoTo {
                to,
                move_speed,
                turn_speed,
                error,
                retry,
            } => {
                if let Target::Point(x, y) = *to {
                    finite(&at(".to[0]"), "x", x)?;
                    finite(&at(".to[1]"), "y", y)?;
                }
                move_speed.check(&at(".move_speed"), "move speed")?;
                if let Some(t) = turn_speed {
                    t.check(&at(".turn_speed"), "turn speed")?;
                }
                nonneg(&at(".error"), "error factor", *error)?;
                positive(&at(".retry"), "retry", *retry)?;
            }
            Behaviour::Wander {
                area,
                move_speed,
                turn_speed,
                retry,
            } => {
                if let Some(((x0, y0), (x1, y1))) = *area {
                    for (k, v) in [x0, y0, x1, y1].into_iter().enumerate() {
                        finite(&at(&format!(".area[{}][{}]", k / 2, k % 2)), "corner", v)?;
                    }
                    if x1 < x0 || y1 < y0 {
                        return Err(FieldError::new(
                            &at(".area"),
                            format!("area (({x0}, {y0}), ({x1}, {y1})) is reversed"),
                            "((min x, min y), (max x, max y))",
                        ));
                    }
                }
                move_speed.check(&at(".move_speed"), "move speed")?;
                if let Some(t) = turn_speed {
                    t.check(&at(".turn_speed"), "turn speed")?;
                }
                positive(&at(".retry"), "retry", *retry)?;
            }
            Behaviour::Wait(t) => {
                positive(&at("[0]"), "wait", *t)?;
            }
            Behaviour::WaitFor(c) => c.check(&at("[0]"))?,
            Behaviour::Avoid {
                range,
                turn_speed,
                back_off,
                move_speed,
                retry,
            } => {
                nonneg(&at(".range"), "range", *range)?;
                speed(&at(".turn_speed"), "turn speed", *turn_speed)?;
                if let Some(d) = back_off {
                    nonneg(&at(".back_off"), "back-off distance", *d)?;
                }
                positive(&at(".move_speed"), "move speed", *move_speed)?;
                positive(&at(".retry"), "retry", *retry)?;
            }
            Behaviour::Follow {
                distance,
                move_speed,
                turn_speed,
                period,
                ..
            } => {
                nonneg(&at(".distance"), "distance", *distance)?;
                positive(&at(".move_speed"), "move speed", *move_speed)?;
                speed(&at(".turn_speed"), "turn speed", *turn_speed)?;
                positive(&at(".period"), "period", *period)?;
            }
            Behaviour::Sequence(v) | Behaviour::Race(v) => {
                if v.is_empty() {
                    return Err(FieldError::new(
                        &at("[0]"),
                        "an empty list",
                        "at least one behaviour",
                    ));
                }
                for (k, b) in v.iter().enumerate() {
                    b.check(&at(&format!("[0][{k}]")))?;
                }
            }
            Behaviour::Repeat(n, b) => {
                if *n == Count::Times(0) {
                    return Err(FieldError::new(
                        &at("[0][0]"),
                        "repeat count is 0",
                        "a count >= 1 or `Forever`",
                    ));
                }
                b.check(&at("[1]"))?;
            }
            Behaviour::Until(c, b) => {
                c.check(&at("[0]"))?;
                b.check(&at("[1]"))?;
            }
        }
        Ok(())
    }
}

impl Condition {
    fn check(&self, path: &str) -> Result<(), FieldError> {
        match *self {
            Condition::Time(t) => positive(&format!("{path}[0]"), "time", t).map(drop),
            Condition::Proximity(r) => {
                let p = format!("{path}[0]");
                finite(&p, "range", r)?;
                if r < 0.0 {
                    return Err(FieldError::value(&p, "range", r, "a number >= 0"));
                }
                Ok(())
            }
            Condition::Message | Condition::Contact => Ok(()),
        }
    }
}

/// `Behaviour(B)`: the configuration of the `Behaviour` algorithm, one behaviour tree.
#[derive(Debug, Deserialize)]
pub struct BehaviourConfig(pub Behaviour);

impl Configured for Behaviour {
    type Config = BehaviourConfig;
    fn configure(BehaviourConfig(b): BehaviourConfig, _: &Setting) -> Result<Self, FieldError> {
        b.check("[0]")?;
        Ok(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nekosim_protocols::{Spec, SpecError};
    use rand::Rng;

    /// Reads `Behaviour(..)` as a scenario's algorithm is read.
    fn read(text: &str) -> Result<Behaviour, SpecError> {
        Spec::new(text).configure(|c| Behaviour::configure(c, &Setting::default()))
    }

    fn err(text: &str) -> SpecError {
        read(text).expect_err(text)
    }

    #[test]
    fn the_seed_examples_read_as_short_compositions() {
        assert_eq!(
            read("Behaviour(Repeat(Forever, Wander()))").unwrap(),
            Behaviour::wander().forever()
        );
        assert_eq!(
            read("Behaviour(Repeat(Forever, GoTo(to: Centroid)))").unwrap(),
            Behaviour::go_to_centroid().forever()
        );
        // The registry knows the name.
        let spec = Spec::new("Behaviour(Repeat(Times(3), Wait(1.0)))");
        crate::registry::Algorithms::with_builtins()
            .build(&spec, &Setting::default())
            .unwrap();
    }

    #[test]
    fn every_behaviour_and_combinator_reads() {
        let b = read(
            "Behaviour(Sequence([
                GoTo(to: Point(1.0, 2.0), move_speed: 5, turn_speed: (10.0, 30.0)),
                Repeat(Times(3), Wait(1.5)),
                Until(Message, Follow(robot: 1, distance: 5.0, period: 0.5)),
                Race([Avoid(range: 3.0, back_off: 0.0), WaitFor(Time(2.0))]),
                Until(Proximity(2.0), Wander(area: ((0.0, 0.0), (10.0, 20.0)))),
                Until(Contact, Wait(1.0)),
            ]))",
        )
        .unwrap();
        let want = Behaviour::Sequence(vec![
            Behaviour::GoTo {
                to: Target::Point(1.0, 2.0),
                move_speed: Speed::Fixed(5.0),
                turn_speed: Some(Speed::Range(10.0, 30.0)),
                error: 0.0,
                retry: 1.0,
            },
            Behaviour::Wait(1.5).times(3),
            Behaviour::Follow {
                robot: 1,
                distance: 5.0,
                move_speed: 5.0,
                turn_speed: 90.0,
                period: 0.5,
            }
            .until(Condition::Message),
            Behaviour::Avoid {
                range: 3.0,
                turn_speed: 90.0,
                back_off: Some(0.0),
                move_speed: 5.0,
                retry: 1.0,
            }
            .race(Behaviour::WaitFor(Condition::Time(2.0))),
            Behaviour::Wander {
                area: Some(((0.0, 0.0), (10.0, 20.0))),
                move_speed: Speed::Range(3.0, 13.0),
                turn_speed: None,
                retry: 1.0,
            }
            .until(Condition::Proximity(2.0)),
            Behaviour::Wait(1.0).until(Condition::Contact),
        ]);
        assert_eq!(b, want);
    }

    #[test]
    fn refused_values_name_their_field() {
        let cases = [
            (
                "Behaviour(Repeat(Forever, Sequence([Wander(), Wait(-1.0)])))",
                "[0][1][0][1][0]",
                "Behaviour: wait is -1; expected a number > 0",
            ),
            (
                "Behaviour(Repeat(Times(0), Wander()))",
                "[0][0][0]",
                "Behaviour: repeat count is 0; expected a count >= 1 or `Forever`",
            ),
            (
                "Behaviour(Wander(move_speed: (13.0, 3.0)))",
                "[0].move_speed",
                "Behaviour: move speed range (13, 3) is reversed; expected (min, max) with min <= max",
            ),
            (
                "Behaviour(Race([GoTo(to: Point(1.0, 2.0), turn_speed: 0.0), Wait(1.0)]))",
                "[0][0][0].turn_speed",
                "Behaviour: turn speed is 0; expected a number > 0",
            ),
            (
                "Behaviour(Until(Time(0.0), Wait(1.0)))",
                "[0][0][0]",
                "Behaviour: time is 0; expected a number > 0",
            ),
            (
                "Behaviour(Sequence([]))",
                "[0][0]",
                "Behaviour: an empty list; expected at least one behaviour",
            ),
            (
                "Behaviour(Follow(robot: 2, distance: -1.0))",
                "[0].distance",
                "Behaviour: distance is -1; expected a number >= 0",
            ),
            (
                "Behaviour(Until(Proximity(inf), Wait(1.0)))",
                "[0][0][0]",
                "Behaviour: range is inf; expected a finite number",
            ),
        ];
        for (text, field, message) in cases {
            let e = err(text);
            assert_eq!(e.field.as_deref(), Some(field), "{text}: {e:?}");
            assert_eq!(e.message, message, "{text}");
        }
    }

    #[test]
    fn misspelt_names_are_errors_at_their_place() {
        let e = err("Behaviour(Repeat(Forever, Wander(speed: 3.0)))");
        assert!(e.message.contains("unknown field `speed`"), "{e:?}");
        assert_eq!(e.at.map(|(l, _)| l), Some(1), "{e:?}");
        let e = err("Behaviour(Repeat(Forevr, Wander()))");
        assert!(e.message.contains("Forevr"), "{e:?}");
        let e = err("Behaviour(Until(Mesage, Wait(1.0)))");
        assert!(e.message.contains("Mesage"), "{e:?}");
        let e = err("Behaviour(GoTo(to: Centroid, move_speed: \"fast\"))");
        assert!(e.message.contains("a speed (a number) or a range"), "{e:?}");
    }

    #[test]
    fn speeds_draw_as_the_built_ins() {
        use rand::SeedableRng;
        let mut a = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut b = a.clone();
        assert_eq!(Speed::Fixed(4.0).draw(&mut a), 4.0);
        // A fixed speed draws nothing.
        assert_eq!(a.gen::<f64>(), b.gen::<f64>());
        let r = Speed::Range(3.0, 13.0).draw(&mut a);
        assert_eq!(r, 3.0 + 10.0 * b.gen::<f64>());
    }
}
