//! The liveness part of a stack check: the model's whole graph, explored without partial-order
//! or symmetry reduction (forgetting spent messages, as the search does) under the memory
//! budget and Ctrl-C, each family's temporal properties decided on it under
//! the fairness the family needs ([`nekosim_models::temporal`]), and a livelock printed as a
//! lasso (the stem, then the cycle that repeats for ever, then the reason in the property's
//! terms) and written with `--trace` and `--rrd` as counterexamples are.

use std::io::Write;
use std::time::Instant;

use nekosim_models::explain::{describe, explain};
use nekosim_models::liveness::{Exceeded, Verdict};
use nekosim_models::temporal::{
    assumes_accuracy, decide, explore_stack, lasso_path, reason, temporal_properties, Decision,
    StackFairness,
};
use nekosim_models::{CheckModel, NetworkKind, Outcome};
use stateright::Expectation;

use super::lcm::{Halt, Watch};
use super::Conclusion;

/// How the liveness part ended.
#[derive(Debug)]
pub(super) struct Live {
    pub conclusion: Conclusion,
    /// The first lasso, as a one-verdict outcome the trace and recording writers take, with
    /// the step where its cycle begins and its reason.
    pub lasso: Option<(Outcome, usize, String)>,
}

/// Explores the whole graph of `model` and decides its temporal properties under
/// `fairness`, printing the verdicts and every lasso on `out`.
pub(super) fn check(
    out: &mut dyn Write,
    model: &CheckModel,
    network: NetworkKind,
    fairness: StackFairness,
    max_states: Option<usize>,
    watch: &Watch,
) -> Live {
    let w = |out: &mut dyn Write, s: String| {
        let _ = writeln!(out, "{s}");
    };
    let holds = Live {
        conclusion: Conclusion::Holds,
        lasso: None,
    };
    if temporal_properties(model).is_empty() {
        return holds;
    }
    let assumption = if assumes_accuracy(model) {
        ", assuming eventual accuracy (from some point on no live process suspects a live one)"
    } else {
        ""
    };
    // The graph forgets spent messages exactly where the search does.
    let forgetting = if model.cfg.reduction && !matches!(network, NetworkKind::Ordered) {
        " forgetting spent messages"
    } else {
        ""
    };
    w(
        out,
        format!(
            "liveness: the whole graph{forgetting}, without partial-order or symmetry reduction; fairness: {}{assumption}",
            fairness.text(network)
        ),
    );
    let _ = out.flush();
    let start = Instant::now();
    let halted = std::cell::Cell::new(None);
    let halt = || {
        let h = watch.halt();
        if h.is_some() {
            halted.set(h);
        }
        h.is_some()
    };
    let (explored, stopped_after, _) = explore_stack(model, max_states, &halt);
    let stop = match (&explored, halted.get().zip(stopped_after)) {
        (_, Some((halt, states))) => Some((
            match halt {
                Halt::Interrupted => Conclusion::Interrupted,
                Halt::Memory { .. } => Conclusion::Unsettled,
            },
            format!("{} after {states} states explored", halt.text()),
        )),
        (Err(Exceeded::States { limit }), None) => Some((
            Conclusion::Unsettled,
            format!("the state budget ({limit} states)"),
        )),
        (Err(Exceeded::Memory { limit, .. }), None) => Some((
            Conclusion::Unsettled,
            format!("the memory budget ({})", super::size_text(*limit)),
        )),
        (Ok(_), None) => None,
    };
    if let Some((conclusion, what)) = stop {
        w(
            out,
            format!("liveness: stopped by {what} before the graph was whole; every temporal property is open"),
        );
        for p in temporal_properties(model) {
            w(
                out,
                format!(
                    "  open   {} {} ({})",
                    p.name,
                    p.kind.formula("P").trim_end_matches(" P"),
                    p.predicate
                ),
            );
        }
        return Live {
            conclusion,
            lasso: None,
        };
    }
    let graph = explored.expect("not stopped");
    let decisions = decide(model, &graph, fairness);
    w(
        out,
        format!(
            "liveness graph: {} states, {} steps, {} cut short by a bound, seconds: {:.3}",
            graph.len(),
            graph.edge_count(),
            graph.cut_states(),
            start.elapsed().as_secs_f64()
        ),
    );
    for d in &decisions {
        let shape = d.property.kind.formula("P");
        let shape = shape.trim_end_matches(" P");
        let detail = match &d.verdict {
            Verdict::Holds => String::new(),
            Verdict::Fails(l) if l.cycle.is_empty() => {
                format!(": the run ends after {} steps and stays", l.stem.len())
            }
            Verdict::Fails(l) => format!(
                ": a stem of {} steps, then a cycle of {} steps",
                l.stem.len(),
                l.cycle.len()
            ),
        };
        let mark = match d.verdict {
            Verdict::Holds => "holds ",
            Verdict::Fails(_) => "FAILS ",
        };
        w(
            out,
            format!(
                "  {mark} {} {shape} ({}){detail}",
                d.property.name, d.property.predicate
            ),
        );
    }
    let mut live = holds;
    for d in &decisions {
        let Verdict::Fails(lasso) = &d.verdict else {
            continue;
        };
        live.conclusion = Conclusion::Fails;
        let Some(path) = lasso_path(model, lasso) else {
            continue;
        };
        let why = reason(model, d, lasso, fairness);
        print_lasso(out, model, d, &path, lasso.stem.len());
        w(out, format!("  so {:?} fails: {why}", d.property.name));
        if live.lasso.is_none() {
            live.lasso = Some((as_outcome(d, path), lasso.stem.len(), why));
        }
    }
    live
}

/// Prints a lasso's path step by step: the stem, then the cycle.
fn print_lasso(
    out: &mut dyn Write,
    model: &CheckModel,
    d: &Decision,
    path: &stateright::Path<nekosim_models::State, nekosim_models::config::Action>,
    stem: usize,
) {
    let _ = writeln!(out, "lasso of {:?}:", d.property.name);
    for step in explain(model, path) {
        if step.index == stem + 1 {
            let _ = writeln!(
                out,
                "  cycle (from step {stem}, repeats for ever back to the state after step {stem}):"
            );
        }
        for (i, e) in step.events.iter().enumerate() {
            let head = if i == 0 {
                format!("step {:>3}:", step.index)
            } else {
                " ".repeat(9)
            };
            let _ = writeln!(out, "  {head} {}", describe(model, e));
        }
    }
}

/// A lasso as the one-verdict outcome the trace and recording writers take.
fn as_outcome(
    d: &Decision,
    path: stateright::Path<nekosim_models::State, nekosim_models::config::Action>,
) -> Outcome {
    Outcome {
        states: 0,
        unique_states: 0,
        max_depth: 0,
        verdicts: vec![nekosim_models::Verdict {
            name: d.property.name,
            expectation: Expectation::Eventually,
            holds: false,
            path: Some(path),
        }],
        stopped: None,
    }
}
