//! Rule tables: a Look-Compute-Move algorithm for two robots whose view is only lights and
//! whether the other robot stands on the same point, written in RON with no Rust. This is the
//! form of the rendezvous algorithms of Viglietta ("Rendezvous of two robots with visible
//! bits", ALGOSENSORS 2013), Flocchini, Santoro, Viglietta and Yamashita ("Rendezvous with
//! constant memory", TCS 621, 2016), Heriban, Défago and Tixeuil ("Optimally gathering two
//! robots", ICDCN 2018) and spin-light's Algorithms.pml.
//!
//! ```text
//! algorithm: RuleTable(
//!     lights: ["black", "white"],
//!     rules: [
//!         (me: "black", other: "black", light: "white"),
//!         (me: "black", other: "white"),
//!         (me: "white", other: "black", move: ToOther),
//!         (me: "white", other: "white", move: ToHalf, light: "black"),
//!     ],
//! )
//! ```
//!
//! A row matches my light `me`, the other's light `other` and `same` (whether the other
//! stands on my point); an omitted field matches anything. The first row that matches
//! decides: `move` (`Stay` when omitted) and the new `light` (kept when omitted). Every case
//! the scenario's lights allow a robot to see must match some row.

use serde::{Deserialize, Serialize};

use super::runtime::LcmConfigured;
use super::settings::Lights;
use super::view::{Decision, Light, LookComputeMove, View};
use crate::config::Setting;
use crate::world::geometry::Point;
use nekosim_protocols::FieldError;

/// Where a rule sends the robot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Move {
    #[default]
    Stay,
    /// To the midpoint of the two robots.
    ToHalf,
    /// To the other robot's point.
    ToOther,
}

/// One row as a scenario writes it.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RuleConfig {
    #[serde(default)]
    pub me: Option<String>,
    #[serde(default)]
    pub other: Option<String>,
    #[serde(default)]
    pub same: Option<bool>,
    #[serde(default, rename = "move")]
    pub go: Move,
    #[serde(default)]
    pub light: Option<String>,
}

/// `RuleTable(lights: [...], rules: [...])`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RuleTableConfig {
    /// The palette, first colour first; at least one.
    pub lights: Vec<String>,
    pub rules: Vec<RuleConfig>,
}

/// One checked row.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Rule {
    pub me: Option<Light>,
    pub other: Option<Light>,
    pub same: Option<bool>,
    pub go: Move,
    pub light: Option<Light>,
}

impl Rule {
    fn matches(&self, me: Option<Light>, other: Option<Light>, same: bool) -> bool {
        self.me.is_none_or(|l| Some(l) == me)
            && self.other.is_none_or(|l| Some(l) == other)
            && self.same.is_none_or(|s| s == same)
    }
}

/// A checked rule table.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct RuleTable {
    pub lights: Vec<String>,
    pub rules: Vec<Rule>,
}

impl RuleTable {
    /// The first row for what a robot sees: its own light, the other's, and whether they
    /// share a point.
    pub fn rule(&self, me: Option<Light>, other: Option<Light>, same: bool) -> Option<&Rule> {
        self.rules.iter().find(|r| r.matches(me, other, same))
    }

    /// Checks a table under the scenario's `lights`: names known, and a row for every case.
    pub fn new(c: RuleTableConfig, lights: Lights) -> Result<Self, FieldError> {
        if c.lights.is_empty() {
            return Err(FieldError::new(
                "lights",
                "the palette is empty",
                "at least one colour",
            ));
        }
        if c.lights.len() > usize::from(Light::MAX) {
            return Err(FieldError::new(
                "lights",
                format!("{} colours", c.lights.len()),
                format!("at most {}", Light::MAX),
            ));
        }
        let names = c.lights.join(", ");
        let colour = |field: String, name: &Option<String>| -> Result<Option<Light>, FieldError> {
            match name {
                None => Ok(None),
                Some(n) => match c.lights.iter().position(|l| l == n) {
                    Some(i) => Ok(Some(i as Light)),
                    None => Err(FieldError::new(
                        &field,
                        format!("unknown light \"{n}\""),
                        format!("one of {names}"),
                    )),
                },
            }
        };
        let mut rules = Vec::with_capacity(c.rules.len());
        for (i, r) in c.rules.iter().enumerate() {
            rules.push(Rule {
                me: colour(format!("rules[{i}].me"), &r.me)?,
                other: colour(format!("rules[{i}].other"), &r.other)?,
                same: r.same,
                go: r.go,
                light: colour(format!("rules[{i}].light"), &r.light)?,
            });
        }
        let table = Self {
            lights: c.lights,
            rules,
        };
        let n = table.lights.len() as Light;
        // A one-colour palette's light is known to everyone ([`RuleTable::compute`]).
        let mine: Vec<Option<Light>> = if lights.own_visible() || n == 1 {
            (0..n).map(Some).collect()
        } else {
            vec![None]
        };
        let theirs: Vec<Option<Light>> = if lights.others_visible() || n == 1 {
            (0..n).map(Some).collect()
        } else {
            vec![None]
        };
        for &me in &mine {
            for &other in &theirs {
                for same in [false, true] {
                    if table.rule(me, other, same).is_none() {
                        let name = |l: Option<Light>| {
                            l.map_or("unseen".to_string(), |l| table.lights[l as usize].clone())
                        };
                        return Err(FieldError::new(
                            "rules",
                            format!(
                                "no rule for me {}, other {}, {}",
                                name(me),
                                name(other),
                                if same { "same point" } else { "apart" }
                            ),
                            "a rule for every case",
                        ));
                    }
                }
            }
        }
        Ok(table)
    }
}

impl LookComputeMove for RuleTable {
    /// The row for the nearest other robot (a rule table is for two robots); stay when the
    /// robot sees none. A view holds no lights when the palette has one colour, since there is
    /// nothing to tell apart; every light then shows that colour, and the rows that name it
    /// match.
    fn compute(&self, view: &View) -> Decision {
        let Some(other) = view.others.first() else {
            return Decision::stay();
        };
        let known = |l: Option<Light>| if self.lights.len() == 1 { Some(0) } else { l };
        let Some(rule) = self.rule(known(view.light), known(other.light), other.is_here()) else {
            return Decision::stay();
        };
        let to = match rule.go {
            Move::Stay => None,
            Move::ToHalf => Some(Point::from(other.at.coords / 2.0)),
            Move::ToOther => Some(other.at),
        };
        Decision {
            to,
            light: rule.light,
        }
    }

    fn colours(&self) -> u8 {
        self.lights.len() as u8
    }

    fn colour_name(&self, l: Light) -> String {
        self.lights
            .get(usize::from(l))
            .cloned()
            .unwrap_or_else(|| l.to_string())
    }
}

impl LcmConfigured for RuleTable {
    type Config = RuleTableConfig;

    fn configure(c: RuleTableConfig, setting: &Setting) -> Result<Self, FieldError> {
        RuleTable::new(c, setting.lcm.lights)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lcm::view::{Multiplicity, Seen};

    fn row(me: Option<&str>, other: Option<&str>, go: Move) -> RuleConfig {
        RuleConfig {
            me: me.map(str::to_string),
            other: other.map(str::to_string),
            same: None,
            go,
            light: None,
        }
    }

    /// A view of one other robot at `at`, with the lights the runtime shows.
    fn view(me: Option<Light>, at: Point, other: Option<Light>) -> View {
        View {
            light: me,
            others: vec![Seen {
                at,
                light: other,
                multiplicity: Multiplicity::Unknown,
            }],
            visibility: None,
        }
    }

    /// A one-colour table that names its colour decides as written: the runtime's view shows
    /// no light then, and the table reads it as the one colour, under every lights setting
    /// the check accepts it for.
    #[test]
    fn a_one_colour_table_that_names_its_colour_applies() {
        for lights in [Lights::Full, Lights::External, Lights::Internal] {
            let c = RuleTableConfig {
                lights: vec!["black".into()],
                rules: vec![row(Some("black"), Some("black"), Move::ToHalf)],
            };
            let t = RuleTable::new(c, lights).expect("complete");
            let d = t.compute(&view(None, Point::new(4.0, 2.0), None));
            assert_eq!(d.to, Some(Point::new(2.0, 1.0)), "{lights:?}");
        }
    }

    /// With more colours, an unseen light matches only rows that leave it open.
    #[test]
    fn an_unseen_light_matches_only_open_rows() {
        let c = RuleTableConfig {
            lights: vec!["black".into(), "white".into()],
            rules: vec![
                row(Some("black"), None, Move::ToOther),
                row(None, None, Move::ToHalf),
            ],
        };
        let t = RuleTable::new(c, Lights::External).expect("complete");
        let d = t.compute(&view(None, Point::new(4.0, 2.0), Some(0)));
        assert_eq!(d.to, Some(Point::new(2.0, 1.0)));
        let d = t.compute(&view(Some(0), Point::new(4.0, 2.0), Some(0)));
        assert_eq!(d.to, Some(Point::new(4.0, 2.0)));
    }
}
