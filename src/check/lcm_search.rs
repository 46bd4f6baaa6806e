//! `nekosim check` on a Look-Compute-Move scenario that exhaustive checking does not cover
//! (three or more robots, or algorithms on exact positions): the bounded or randomised search
//! of [`nekosim_actors::lcm::search`] over the scenario's own robots and algorithms, its
//! coverage stated exactly, and a violation replayed in the simulator through the scripted
//! adversary (`--trace`, `--rrd`).

use std::cell::Cell;
use std::io::Write;
use std::sync::Arc;

use nekosim_actors::lcm::search::{self, Goal, Limits, Outcome, Problem, Violation};
use nekosim_actors::lcm::settings::AdversaryKind;
use nekosim_actors::lcm::{LcmSettings, Movement};

use super::lcm::{Halt, Watch};
use super::{CheckArgs, CheckError, Conclusion, Registry};
use crate::scenario::{Overrides, Source};
use nekosim_models::model::Strategy;

/// The stop fractions a search's adversary picks from, for non-rigid moves: half the way, or
/// all of it (never short of the movement's δ).
pub const MENU: [f64; 2] = [0.5, 1.0];

/// Rounds deep a bounded search goes unless `--depth` says.
pub const DEPTH: usize = 4;

/// Random runs unless `--max-states` says.
pub const RUNS: u64 = 1_000;

/// Reads a `--goal`: `collision-free`, `diameter-never-grows`, `gathered-within:K` or
/// `converged-within:EPSILON:K`.
pub fn parse_goal(text: &str) -> Result<Goal, String> {
    let parts: Vec<&str> = text.split(':').collect();
    let number = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite() && *v > 0.0);
    let cycles = |s: &str| s.parse::<u32>().ok();
    match parts.as_slice() {
        ["collision-free"] => Ok(Goal::CollisionFree),
        ["diameter-never-grows"] => Ok(Goal::DiameterNeverGrows),
        ["gathered-within", k] => cycles(k)
            .map(|cycles| Goal::GatheredWithin { cycles })
            .ok_or_else(|| format!("{k:?} is not a number of cycles")),
        ["converged-within", e, k] => match (number(e), cycles(k)) {
            (Some(epsilon), Some(cycles)) => Ok(Goal::ConvergedWithin { epsilon, cycles }),
            _ => Err(format!("{text:?}: expected converged-within:EPSILON:CYCLES")),
        },
        _ => Err(format!(
            "{text:?}: expected collision-free, diameter-never-grows, gathered-within:K or converged-within:EPSILON:K"
        )),
    }
}

/// The search's problem: the scenario's robots and algorithms, its settings with the command
/// line's overrides.
fn problem(source: &Source, registry: &Registry, args: &CheckArgs) -> Result<Problem, CheckError> {
    let built = source.build(Overrides::default(), registry)?;
    let mut settings: LcmSettings = source.scenario.lcm.clone().unwrap_or_default();
    if let Some(s) = args.lcm.synchrony {
        settings.synchrony = s;
    }
    match args.lcm.rigid {
        Some(true) => settings.movement = Movement::Rigid,
        Some(false) if settings.movement == Movement::Rigid => {
            settings.movement = Movement::NonRigid { delta: 1.0 }
        }
        _ => {}
    }
    let mut algorithms = Vec::new();
    let mut start = Vec::new();
    for (i, (spec, algorithm)) in built.robots.iter().enumerate() {
        let Some(a) = algorithm.look_compute_move() else {
            return Err(CheckError::Lcm(format!(
                "robot {i} is not a Look-Compute-Move robot; the search covers scenarios of such robots only"
            )));
        };
        algorithms.push(a);
        start.push(spec.pose.pos);
    }
    if start.len() > 12 {
        return Err(CheckError::Lcm(format!(
            "{} robots; the search's rounds are every subset of the robots, for at most 12",
            start.len()
        )));
    }
    Ok(Problem {
        algorithms,
        settings: Arc::new(settings),
        seed: built.seed,
        start,
    })
}

/// Searches and reports; `watch` stops the search (the resident memory, Ctrl-C).
pub fn check(
    source: &Source,
    registry: &Registry,
    args: &CheckArgs,
    watch: &Watch,
    out: &mut dyn Write,
) -> Result<Conclusion, CheckError> {
    let p = problem(source, registry, args)?;
    let goals = if args.goals.is_empty() {
        vec![Goal::CollisionFree]
    } else {
        args.goals.clone()
    };
    let depth = args.depth.unwrap_or(DEPTH);
    let random = matches!(args.strategy, Strategy::Simulation { .. });
    let w = |out: &mut dyn Write, line: String| {
        let _ = writeln!(out, "{line}");
    };
    let names: Vec<String> = goals.iter().map(Goal::name).collect();
    // Said before the search, which may be long, so the person waiting knows what runs.
    w(
        out,
        format!(
            "searching {} robots for: {}",
            p.start.len(),
            names.join(", ")
        ),
    );
    let _ = out.flush();
    let halted: Cell<Option<Halt>> = Cell::new(None);
    let halt = || {
        let h = watch.halt();
        halted.set(h);
        h.is_some()
    };
    let outcome = if random {
        let seed = match args.strategy {
            Strategy::Simulation { seed } => seed,
            _ => 0,
        };
        let runs = args.max_states.map_or(RUNS, |n| n as u64);
        search::random(&p, &MENU, depth, runs, 3, seed, &goals, &halt)
    } else {
        let max_rounds = args.max_states.map_or(u64::MAX, |n| n as u64);
        search::bounded(
            &p,
            &MENU,
            depth,
            &goals,
            Limits {
                max_rounds,
                halt: &halt,
            },
        )
    };
    w(out, coverage_text(&outcome, random));
    if let Some(h) = halted.get() {
        w(
            out,
            format!("stopped by {} before the search was done", h.text()),
        );
    }
    let interrupted = halted.get() == Some(Halt::Interrupted);
    let Some(v) = outcome.violation else {
        if interrupted {
            w(
                out,
                "no violation found before Ctrl-C; nothing is claimed".into(),
            );
            return Ok(Conclusion::Interrupted);
        }
        return Ok(if !random && outcome.coverage.complete {
            w(
                out,
                format!(
                    "holds on every schedule searched (depth {}); nothing is claimed beyond them",
                    outcome.coverage.depth
                ),
            );
            Conclusion::Holds
        } else {
            w(
                out,
                "no violation found; the search was not exhaustive, so nothing is claimed".into(),
            );
            Conclusion::Unsettled
        });
    };
    report(out, &v, p.settings.cycle);
    replay(source, registry, args, &v, p.settings.cycle, out)?;
    Ok(Conclusion::Fails)
}

fn coverage_text(o: &Outcome, random: bool) -> String {
    let c = &o.coverage;
    if random {
        format!(
            "searched: {} random runs of up to {} rounds (PCT-style priorities), {} rounds played, stops {:?}",
            c.runs, c.depth, c.rounds, c.stops
        )
    } else {
        format!(
            "searched: every schedule of non-empty subsets with stops {:?}, {} rounds deep{}, {} rounds played, {} configurations at the last depth",
            c.stops,
            c.depth,
            if c.complete { "" } else { " (stopped within the next depth)" },
            c.rounds,
            c.states
        )
    }
}

fn report(out: &mut dyn Write, v: &Violation, cycle: f64) {
    let _ = writeln!(out, "{}: fails", v.goal.name());
    for (k, round) in v.schedule.0.iter().enumerate() {
        let acts: Vec<String> = round
            .active
            .iter()
            .zip(&round.stops)
            .map(|(r, s)| format!("p{r} (stops at {s} of the way)"))
            .collect();
        let _ = writeln!(
            out,
            "  round {k} at t = {}: {}",
            k as f64 * cycle,
            acts.join(", ")
        );
    }
    let ends: Vec<String> = v
        .positions
        .iter()
        .map(|p| format!("({}, {})", p.x, p.y))
        .collect();
    let _ = writeln!(out, "  the robots end at {}", ends.join(", "));
    let _ = writeln!(out, "  {}", v.reason);
    let _ = writeln!(
        out,
        "  replay: lcm.adversary = {}",
        v.schedule.scripted(cycle)
    );
}

/// Runs the violation's schedule in the simulator as a scripted adversary, writing the trace
/// and recording asked for.
fn replay(
    source: &Source,
    registry: &Registry,
    args: &CheckArgs,
    v: &Violation,
    cycle: f64,
    out: &mut dyn Write,
) -> Result<(), CheckError> {
    if args.trace.is_none() && args.rrd.is_none() {
        return Ok(());
    }
    let mut replayed = source.clone();
    let lcm = replayed.scenario.lcm.get_or_insert_with(Default::default);
    lcm.adversary = AdversaryKind::Scripted(v.schedule.activations(cycle));
    replayed.scenario.until = v.schedule.0.len() as f64 * cycle;
    let built = replayed.build(Overrides::default(), registry)?;
    let options = crate::runner::RunOptions {
        note: Some(format!(
            "### {}: fails\n\n{}\n\nEach round is one simulated second.",
            v.goal.name(),
            v.reason
        )),
        trace: args.trace.clone(),
        recording: crate::recording::Target {
            rrd: args.rrd.clone(),
            connect: None,
        },
        ..Default::default()
    };
    crate::runner::run(built, options).map_err(|e| CheckError::Lcm(e.to_string()))?;
    let _ = writeln!(
        out,
        "  replayed in the simulator through the scripted adversary"
    );
    Ok(())
}
