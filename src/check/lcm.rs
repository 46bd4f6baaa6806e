//! `nekosim check SCENARIO.ron` on a Look-Compute-Move scenario whose two robots run a rule
//! table: every behaviour of the adversary of its synchrony model is explored on the finite
//! model of [`abstraction`] (built from the scenario's own [`RuleTable`]), and liveness is
//! decided under fairness by [`nekosim_models::liveness`], with a lasso for a property that
//! fails. The synchrony model, movement, register and property come from the scenario's `lcm`
//! section; the command line overrides each. docs/model-checking.md, "Checking robot
//! algorithms".

use std::io::{self, Write};
use std::path::Path;
use std::time::Instant;

use nekosim_actors::lcm::predicate::Predicate;
use nekosim_actors::lcm::rule_table::{RuleTable, RuleTableConfig};
use nekosim_actors::lcm::settings::{Lights, Movement, Register, Synchrony};
use nekosim_models::liveness::{explore, Exceeded, Fairness, Lasso, Limits, Liveness, Verdict};
use serde_json::json;

use super::{CheckArgs, CheckError, Conclusion};
use crate::scenario::{RobotEntry, Source};

pub mod abstraction;
pub mod budget;
pub mod replay;

pub use abstraction::{Abstraction, Pending, Phase, Position, State, Step, Variant};
use budget::Watched;
pub use budget::{Budget, Halt, Open, Watch};

/// Which runs the check judges (docs/model-checking.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RobotFairness {
    /// Every run.
    None,
    /// Every robot that stays enabled is activated again: every robot is activated
    /// infinitely often until the robots gather.
    Weak,
    /// Every robot enabled infinitely often is activated infinitely often.
    Strong,
    /// No robot takes more than `k` scheduler steps in a row (spin-light's `FAIRNESS_LIMIT`
    /// counters); `None`: spin-light's own limit, `(1 + colours) * phases per cycle`.
    Bounded(Option<u32>),
    /// [`Self::Bounded`] at spin-light's limit, the setting whose verdicts are SPIN's.
    #[default]
    SpinLight,
}

impl RobotFairness {
    /// Reads `weak`, `strong`, `none`, `bounded` (spin-light's limit) or `bounded:K`.
    pub fn parse(text: &str) -> Result<Self, String> {
        match text {
            "weak" => Ok(Self::Weak),
            "strong" => Ok(Self::Strong),
            "none" => Ok(Self::None),
            "bounded" => Ok(Self::SpinLight),
            _ => match text.strip_prefix("bounded:").map(str::parse::<u32>) {
                Some(Ok(k)) if (1..=255).contains(&k) => Ok(Self::Bounded(Some(k))),
                _ => Err(format!(
                    "{text:?}: expected weak, strong, none, bounded or bounded:K with K from 1 to 255"
                )),
            },
        }
    }

    /// The scheduler's bound and the fairness of the cycle search.
    fn split(self, variant: Variant, colours: usize) -> (Option<u32>, Fairness) {
        match self {
            Self::None => (None, Fairness::None),
            Self::Weak => (None, Fairness::Weak),
            Self::Strong => (None, Fairness::Strong),
            Self::Bounded(Some(k)) => (Some(k), Fairness::None),
            Self::Bounded(None) | Self::SpinLight => {
                (Some(variant.fair_limit(colours)), Fairness::None)
            }
        }
    }

    fn describe(self, variant: Variant, colours: usize) -> String {
        match self {
            Self::None => "none".into(),
            Self::Weak => "weak".into(),
            Self::Strong => "strong".into(),
            Self::Bounded(Some(1)) => "bounded (at most 1 step in a row)".into(),
            Self::Bounded(Some(k)) => format!("bounded (at most {k} steps in a row)"),
            Self::Bounded(None) | Self::SpinLight => format!(
                "bounded (at most {} steps in a row, spin-light's limit)",
                variant.fair_limit(colours)
            ),
        }
    }
}

/// Reads a synchrony model's name: nekosim's (`AsyncMoveAtomic`) or in words
/// (`async-move-atomic`), any case.
pub fn parse_synchrony(text: &str) -> Result<Synchrony, String> {
    let key: String = text
        .chars()
        .filter(|c| c.is_alphanumeric())
        .collect::<String>()
        .to_lowercase();
    Ok(match key.as_str() {
        "centralized" => Synchrony::Centralized,
        "fsync" => Synchrony::Fsync,
        "ssync" => Synchrony::Ssync,
        "async" => Synchrony::Async,
        "asynclcatomic" => Synchrony::AsyncLcAtomic,
        "asynclcstrict" => Synchrony::AsyncLcStrict,
        "asynccmatomic" => Synchrony::AsyncCmAtomic,
        "asyncmoveatomic" => Synchrony::AsyncMoveAtomic,
        _ => {
            return Err(format!(
                "{text:?}: expected Centralized, Fsync, Ssync, Async, AsyncLcAtomic, AsyncLcStrict, AsyncCmAtomic or AsyncMoveAtomic"
            ))
        }
    })
}

/// Reads `eventually`, `eventually-always` or `always-eventually`.
pub fn parse_property(text: &str) -> Result<Liveness, String> {
    match text {
        "eventually" => Ok(Liveness::Eventually),
        "eventually-always" => Ok(Liveness::EventuallyAlways),
        "always-eventually" => Ok(Liveness::AlwaysEventually),
        _ => Err(format!(
            "{text:?}: expected eventually, eventually-always or always-eventually"
        )),
    }
}

/// The command line's overrides of a Look-Compute-Move scenario's settings.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LcmOverrides {
    pub synchrony: Option<Synchrony>,
    /// `Some(true)`: rigid.
    pub rigid: Option<bool>,
    pub register: Option<Register>,
    pub fairness: Option<RobotFairness>,
    /// The temporal shape of "the robots are on one point".
    pub property: Option<Liveness>,
}

impl LcmOverrides {
    pub fn any(&self) -> bool {
        *self != Self::default()
    }
}

/// One decided check: the graph's size and the verdict.
#[derive(Debug)]
pub struct Decided {
    pub states: usize,
    pub steps: usize,
    pub verdict: Verdict<State, Step>,
}

/// Checks `kind` over "the robots are on one point" for `table` under `variant`.
pub fn decide(
    table: &RuleTable,
    lights: Lights,
    variant: Variant,
    rigid: bool,
    fairness: RobotFairness,
    kind: Liveness,
    limits: Limits,
) -> Result<Decided, Exceeded> {
    let budget = Budget {
        limits,
        watch: Watch::default(),
    };
    decide_within(table, lights, variant, rigid, fairness, kind, &budget).map_err(|o| match o {
        Open::Exceeded(e) => e,
        Open::Halted { .. } => unreachable!("a watch of nothing never halts"),
    })
}

/// [`decide`] within `budget`, its watch polled as the model is explored.
pub fn decide_within(
    table: &RuleTable,
    lights: Lights,
    variant: Variant,
    rigid: bool,
    fairness: RobotFairness,
    kind: Liveness,
    budget: &Budget,
) -> Result<Decided, Open> {
    let (bound, fairness) = fairness.split(variant, table.lights.len());
    let model = Abstraction {
        table,
        lights,
        variant,
        rigid,
        bound,
    };
    let watched = Watched::new(&model, &budget.watch);
    let graph = explore(&watched, budget.limits).map_err(Open::Exceeded)?;
    if let Some((halt, states)) = watched.halted() {
        return Err(Open::Halted { halt, states });
    }
    let verdict = graph.check(kind, fairness, |s| s.position == Position::Same);
    Ok(Decided {
        states: graph.len(),
        steps: graph.edge_count(),
        verdict,
    })
}

/// The scenario's rule table when it is a Look-Compute-Move scenario of two robots that run
/// one: the check of this module applies.
pub fn rule_table_of(source: &Source) -> Option<Result<(RuleTable, Lights), CheckError>> {
    let s = &source.scenario;
    let lcm = s.lcm.as_ref()?;
    let specs: Vec<_> = s
        .robots
        .iter()
        .map(|r| match r {
            RobotEntry::Robot { algorithm, .. } | RobotEntry::Group { algorithm, .. } => algorithm,
        })
        .collect();
    if specs.is_empty() || specs.iter().any(|a| a.name() != "RuleTable") {
        return None;
    }
    let count: usize = s
        .robots
        .iter()
        .map(|r| match r {
            RobotEntry::Robot { .. } => 1,
            RobotEntry::Group { count, .. } => *count,
        })
        .sum();
    if count != 2 {
        return Some(Err(source
            .place(
                "robots",
                format!("{count} robots run a rule table; the exhaustive check is for two"),
            )
            .into()));
    }
    let read = |i: usize| -> Result<RuleTable, CheckError> {
        let at = format!("robots[{i}].algorithm");
        let config: RuleTableConfig = specs[i]
            .read_config()
            .map_err(|e| source.place(&at, e.message))?;
        RuleTable::new(config, lcm.lights).map_err(|e| source.place(&at, e.message()).into())
    };
    let table = match read(0) {
        Ok(t) => t,
        Err(e) => return Some(Err(e)),
    };
    for i in 1..specs.len() {
        match read(i) {
            Ok(t) if t == table => {}
            Ok(_) => {
                return Some(Err(source
                    .place(
                        &format!("robots[{i}].algorithm"),
                        "the two robots run different rule tables; the check expects one",
                    )
                    .into()))
            }
            Err(e) => return Some(Err(e)),
        }
    }
    Some(Ok((table, lcm.lights)))
}

/// A state in one line: `NEAR | A white (ToHalf, moving) next BeginMove | B ...`.
pub fn state_text(s: &State, table: &RuleTable) -> String {
    let robot = |r: usize| {
        let x = &s.robots[r];
        let name = |l: u8| {
            table
                .lights
                .get(usize::from(l))
                .cloned()
                .unwrap_or_default()
        };
        let mut flags = Vec::new();
        if x.pending != Pending::Stay {
            flags.push(format!("{:?}", x.pending));
        }
        if x.computing {
            flags.push(format!("computing {}", name(x.pending_light)));
        }
        if x.moving {
            flags.push("moving".into());
        }
        let flags = if flags.is_empty() {
            String::new()
        } else {
            format!(" ({})", flags.join(", "))
        };
        format!(
            "{} {}{flags}, next {:?}",
            ["A", "B"][r],
            name(x.light),
            s.phase[r]
        )
    };
    format!("{:?} | {} | {}", s.position, robot(0), robot(1))
}

fn step_text(step: &Step) -> String {
    let mut parts: Vec<String> = Vec::new();
    for &(r, p) in &step.phases {
        parts.push(format!("{} {:?}", ["A", "B"][r], p));
    }
    parts.join(", ")
}

/// Why a lasso violates the property, in the property's terms.
pub fn reason(lasso: &Lasso<State, Step>, kind: Liveness) -> String {
    let apart = |s: &State| s.position != Position::Same;
    if lasso.cycle.is_empty() {
        return format!(
            "the scheduler stops here (no step is possible) with the robots {:?}, so they are never on one point again",
            lasso.entry().position
        );
    }
    let positions: Vec<Position> = {
        let mut v: Vec<Position> = lasso.cycle.iter().map(|(_, s)| s.position).collect();
        v.sort();
        v.dedup();
        v
    };
    match kind {
        Liveness::Eventually => format!(
            "the robots are never on one point: not along the stem, and the cycle repeats forever through {positions:?}"
        ),
        Liveness::EventuallyAlways => {
            let n = lasso.cycle.iter().filter(|(_, s)| apart(s)).count();
            format!(
                "the cycle repeats forever and is apart ({positions:?}) in {n} of its {} states, so the robots never stay on one point",
                lasso.cycle.len()
            )
        }
        Liveness::AlwaysEventually => format!(
            "the cycle repeats forever with the robots apart in every state ({positions:?})"
        ),
    }
}

/// Runs the check of a rule-table scenario and prints its report on `out`; `watch` stops it
/// (the resident memory, Ctrl-C).
pub fn check(
    source: &Source,
    (table, lights): (RuleTable, Lights),
    args: &CheckArgs,
    watch: Watch,
    out: &mut dyn Write,
) -> Result<Conclusion, CheckError> {
    let settings = source.scenario.lcm.clone().unwrap_or_default();
    let o = args.lcm;
    let synchrony = o.synchrony.unwrap_or(settings.synchrony);
    let register = o.register.unwrap_or(settings.register);
    let rigid = o
        .rigid
        .unwrap_or(matches!(settings.movement, Movement::Rigid));
    let Some(variant) = Variant::of(synchrony, register) else {
        let what = format!(
            "a {register:?} register under {synchrony:?}: spin-light models regular and safe registers under Async and AsyncMoveAtomic only"
        );
        return Err(if o.synchrony.is_some() || o.register.is_some() {
            CheckError::Lcm(what)
        } else {
            source.place("lcm.register", what).into()
        });
    };
    let fairness = o.fairness.unwrap_or_default();
    let kinds: Vec<(String, Liveness)> = match o.property {
        Some(k) => vec![("gathering".into(), k)],
        None => {
            let mut v: Vec<(String, Liveness)> = settings
                .predicates
                .iter()
                .filter(|p| matches!(p, Predicate::Gathered | Predicate::Rendezvous))
                .map(|p| (p.name(), Liveness::EventuallyAlways))
                .collect();
            if v.is_empty() {
                v.push(("gathering".into(), Liveness::EventuallyAlways));
            }
            v
        }
    };
    if let Some(path) = args.trace.as_ref().filter(|p| p.is_dir()) {
        return Err(CheckError::Trace {
            path: path.clone(),
            source: io::Error::new(io::ErrorKind::InvalidInput, "is a directory"),
        });
    }
    let colours = table.lights.len();
    let w = |out: &mut dyn Write, text: String| {
        let _ = writeln!(out, "{text}");
    };
    w(
        out,
        format!(
            "model: {}: two robots under a rule table of {colours} colour{}, {} ({synchrony:?}, {register:?} register), {}, fairness {}",
            source.file,
            if colours == 1 { "" } else { "s" },
            variant.spin_name(),
            if rigid { "rigid" } else { "non-rigid" },
            fairness.describe(variant, colours)
        ),
    );
    let budget = Budget {
        limits: Limits {
            max_states: args.max_states,
            max_memory: watch.max_memory,
        },
        watch,
    };
    let mut conclusion = Conclusion::Holds;
    let mut first_lasso: Option<(Lasso<State, Step>, Liveness)> = None;
    for (name, kind) in kinds {
        let start = Instant::now();
        let formula = kind.formula("(position == SAME)");
        if conclusion == Conclusion::Interrupted {
            w(
                out,
                format!("property {name:?} {formula}: open (not checked: Ctrl-C)"),
            );
            continue;
        }
        match decide_within(&table, lights, variant, rigid, fairness, kind, &budget) {
            Err(e) => {
                let why = match e {
                    Open::Exceeded(Exceeded::States { limit }) => {
                        format!("the state budget ({limit} states)")
                    }
                    Open::Exceeded(Exceeded::Memory { limit, estimate }) => format!(
                        "the memory budget (a graph of {} of {})",
                        super::size_text(estimate),
                        super::size_text(limit)
                    ),
                    Open::Halted { halt, states } => {
                        format!("{} after {states} states explored,", halt.text())
                    }
                };
                w(out, format!("property {name:?} {formula}: open (stopped by {why} before the search was exhaustive)"));
                if let Open::Halted {
                    halt: Halt::Interrupted,
                    ..
                } = e
                {
                    conclusion = Conclusion::Interrupted;
                } else if conclusion == Conclusion::Holds {
                    conclusion = Conclusion::Unsettled;
                }
            }
            Ok(d) => {
                let seconds = start.elapsed().as_secs_f64();
                let counts = format!("{} states, {} steps, {seconds:.3} s", d.states, d.steps);
                match d.verdict {
                    Verdict::Holds => w(
                        out,
                        format!("property {name:?} {formula}: holds ({counts})"),
                    ),
                    Verdict::Fails(lasso) => {
                        w(
                            out,
                            format!("property {name:?} {formula}: fails ({counts})"),
                        );
                        print_lasso(out, &lasso, &table, kind);
                        conclusion = Conclusion::Fails;
                        first_lasso.get_or_insert((lasso, kind));
                    }
                }
            }
        }
    }
    if let Some((lasso, kind)) = &first_lasso {
        let model = Abstraction {
            table: &table,
            lights,
            variant,
            rigid,
            bound: None,
        };
        replay_lasso(source, &model, (lasso, *kind), args.rrd.as_deref(), out)?;
    }
    if let (Some(path), Some((lasso, kind))) = (&args.trace, &first_lasso) {
        write_lasso(path, lasso, &table, *kind).map_err(|source| CheckError::Trace {
            path: path.clone(),
            source,
        })?;
    }
    Ok(conclusion)
}

fn print_lasso(out: &mut dyn Write, lasso: &Lasso<State, Step>, table: &RuleTable, kind: Liveness) {
    let _ = writeln!(out, "counterexample (a lasso):");
    let _ = writeln!(out, "  stem:");
    let _ = writeln!(out, "    0. start: {}", state_text(&lasso.start, table));
    let steps = |out: &mut dyn Write, part: &[(Step, State)]| {
        for (i, (step, s)) in part.iter().enumerate() {
            let _ = writeln!(
                out,
                "    {}. {} -> {}",
                i + 1,
                step_text(step),
                state_text(s, table)
            );
        }
    };
    steps(out, &lasso.stem);
    if lasso.cycle.is_empty() {
        let _ = writeln!(
            out,
            "  cycle: none, the run ends here and stays in this state"
        );
    } else {
        let _ = writeln!(
            out,
            "  cycle (repeats forever from stem state {}):",
            lasso.stem.len()
        );
        steps(out, &lasso.cycle);
    }
    let _ = writeln!(out, "  reason: {}", reason(lasso, kind));
}

/// The lasso as JSONL: one record per state, `part` saying stem or cycle, `seq` the step.
pub fn lasso_lines(lasso: &Lasso<State, Step>, table: &RuleTable, kind: Liveness) -> Vec<String> {
    let mut lines = Vec::new();
    let record = |seq: usize, part: &str, step: Option<&Step>, s: &State| {
        json!({
            "seq": seq,
            "part": part,
            "step": step,
            "state": s,
            "lights": [table.lights[usize::from(s.robots[0].light)], table.lights[usize::from(s.robots[1].light)]],
        })
        .to_string()
    };
    lines.push(record(0, "start", None, &lasso.start));
    for (i, (step, s)) in lasso.stem.iter().enumerate() {
        lines.push(record(i + 1, "stem", Some(step), s));
    }
    for (i, (step, s)) in lasso.cycle.iter().enumerate() {
        lines.push(record(lasso.stem.len() + 1 + i, "cycle", Some(step), s));
    }
    lines.push(json!({ "reason": reason(lasso, kind) }).to_string());
    lines
}

fn write_lasso(
    path: &Path,
    lasso: &Lasso<State, Step>,
    table: &RuleTable,
    kind: Liveness,
) -> io::Result<()> {
    let mut text = lasso_lines(lasso, table, kind).join("\n");
    text.push('\n');
    std::fs::write(path, text)
}

/// Replays `lasso` in the simulator ([`replay`]), says whether the run shows the violation,
/// and records it to `rrd` if asked.
fn replay_lasso(
    source: &Source,
    model: &Abstraction,
    (lasso, kind): (&Lasso<State, Step>, Liveness),
    rrd: Option<&Path>,
    out: &mut dyn Write,
) -> Result<(), CheckError> {
    let Some(plan) = replay::replay(model, lasso) else {
        let _ = writeln!(out, "replay: the lasso has no cycle to repeat");
        return Ok(());
    };
    let records = replay::simulate(source, model, &plan)?;
    let [from, first, second] = plan.marks;
    let text = match replay::shows(&plan, &records) {
        Ok(s) => format!(
            "it follows the lasso step by step (the lights, and whether the robots share a point, after each of its {} steps), and the robots are apart after {} and {} of the cycle's {} steps in its two repetitions; they end at ({}, {}) and ({}, {})",
            s.steps,
            s.apart[0],
            s.apart[1],
            lasso.cycle.len(),
            s.end[0].x,
            s.end[0].y,
            s.end[1].x,
            s.end[1].y
        ),
        Err(d) => format!(
            "the simulated run does not show the violation: after step {} (t = {}) the lasso has lights {:?} and the robots {}, the run lights {:?} with the robots at ({}, {}) and ({}, {})",
            d.step,
            d.expected.at,
            d.expected.lights,
            if d.expected.together { "together" } else { "apart" },
            d.seen.1,
            d.seen.0[0].x,
            d.seen.0[0].y,
            d.seen.0[1].x,
            d.seen.0[1].y
        ),
    };
    let _ = writeln!(
        out,
        "replay in the simulator (the stem, then the cycle twice, from t = {from} to {first} and {second}): {text}"
    );
    if let Some(path) = rrd {
        let built = replay::build(&replay::scenario(source, model, &plan), &plan)?;
        crate::runner::run(
            built,
            crate::runner::RunOptions {
                recording: crate::recording::Target {
                    rrd: Some(path.to_path_buf()),
                    connect: None,
                },
                note: Some(format!(
                    "### A lasso of the two-robot model, replayed\n\nThe stem runs from t = 0 to {from}; the cycle, which the adversary can repeat forever, from t = {from} to {first}, and again from {first} to {second}. Each step of the lasso is one simulated second.\n\n{}",
                    reason(lasso, kind)
                )),
                milestones: vec![
                    (
                        from,
                        format!(
                            "lasso: the stem ends and the cycle begins (repetition 1 of 2, to t = {first})"
                        ),
                    ),
                    (
                        first,
                        format!(
                            "lasso: the cycle ends where it began at t = {from} and begins again (repetition 2 of 2, to t = {second})"
                        ),
                    ),
                    (
                        second,
                        format!(
                            "lasso: the cycle ends where it began at t = {first}; the adversary can repeat it forever"
                        ),
                    ),
                ],
                ..Default::default()
            },
        )
        .map_err(|e| CheckError::Lcm(format!("the replay's recording failed: {e}")))?;
        let _ = writeln!(out, "replay recorded: {}", path.display());
    }
    Ok(())
}
