//! The reductions of a stack check (docs/model-checking.md): which one takes effect for a
//! model and a search, and, when asked, the same search again without it to show what it
//! saves.

use std::io::Write;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::time::Instant;

use nekosim_models::spill::Spill;
use nekosim_models::{
    build_in, run_watched, Exploration, NetworkKind, Options, Strategy, Target, Watch,
};

use super::budgets::fresh_spill_dir;
use super::{CheckArgs, CheckError, Live};

/// The reduction a check applies (docs/model-checking.md), by network: on an ordered one,
/// or one that reorders into layers that hold early arrivals back (each link is then
/// explored in send order), partial-order reduction; on one that reorders or loses messages
/// otherwise, where no smaller set of steps is enough (any process's step may send a message
/// that another takes first), forgetting spent messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reduction {
    PartialOrder,
    /// Links in send order, then partial-order reduction.
    PartialOrderInSendOrder,
    /// Links in send order alone (a strategy or depth bound without the persistent sets).
    InSendOrder,
    SpentMessages,
}

impl Reduction {
    /// Its name in the report.
    pub fn label(self) -> &'static str {
        match self {
            Reduction::PartialOrder => "partial-order reduction",
            Reduction::PartialOrderInSendOrder => {
                "partial-order reduction with links in send order"
            }
            Reduction::InSendOrder => "links in send order",
            Reduction::SpentMessages => "forgetting spent messages",
        }
    }
}

/// The reduction that takes effect in a check, or why none does: both need the
/// breadth-first search, and partial-order reduction no depth bound. Links in send order
/// (`in_send_order`, decided when the model is built) hold for every search.
pub fn reduction_in_effect(
    opts: &Options,
    args: &CheckArgs,
    in_send_order: bool,
) -> Result<Reduction, &'static str> {
    let bfs = args.strategy == Strategy::Bfs;
    if !opts.reduction {
        Err("turned off")
    } else if in_send_order && bfs && args.depth.is_none() {
        Ok(Reduction::PartialOrderInSendOrder)
    } else if in_send_order {
        Ok(Reduction::InSendOrder)
    } else if !bfs {
        Err("bfs only")
    } else if opts.network != NetworkKind::Ordered {
        Ok(Reduction::SpentMessages)
    } else if args.depth.is_some() {
        Err("not with a depth bound")
    } else {
        Ok(Reduction::PartialOrder)
    }
}

/// Searches the model again without its reduction and prints both counts, or why no
/// reduction took effect.
pub(super) fn compare_reduction(
    out: &mut dyn Write,
    protocols: &nekosim_protocols::Protocols,
    (target, opts, args): (&Target, &Options, &CheckArgs),
    (how, live): (Exploration, &Live),
    (with, with_model_in_send_order): (&nekosim_models::Outcome, bool),
) -> Result<(), CheckError> {
    /// Ctrl-C stops the second search as it stops the first.
    struct Interrupt<'a>(&'a Live);
    impl Watch for Interrupt<'_> {
        fn interrupted(&self) -> bool {
            self.0
                .interrupt
                .as_ref()
                .is_some_and(|i| i.load(Ordering::Relaxed))
        }
    }
    let reduction = match reduction_in_effect(opts, args, with_model_in_send_order) {
        Ok(r) => r.label(),
        Err(why) => {
            let _ = writeln!(out, "reduction: not in effect ({why})");
            return Ok(());
        }
    };
    let plain = Options {
        reduction: false,
        ..opts.clone()
    };
    let start = Instant::now();
    let model = build_in(protocols, target, &plain, |_, _| {})?;
    let how = Exploration {
        spill: how.spill.map(|s| Spill {
            dir: fresh_spill_dir(s.dir.parent().unwrap_or(Path::new("."))),
            ..s
        }),
        ..how
    };
    let without = run_watched(model, how, &mut Interrupt(live));
    let settled = |o: &nekosim_models::Outcome| {
        if o.stopped.is_some() {
            ", stopped by its budget"
        } else {
            ""
        }
    };
    let _ = writeln!(
        out,
        "without {reduction}: states: {}, unique states: {}, depth: {}, seconds: {:.3}{}",
        without.states,
        without.unique_states,
        without.max_depth,
        start.elapsed().as_secs_f64(),
        settled(&without),
    );
    let _ = writeln!(
        out,
        "{reduction}: {} unique states instead of {} ({:.2}x fewer){}",
        with.unique_states,
        without.unique_states,
        without.unique_states as f64 / with.unique_states.max(1) as f64,
        settled(with),
    );
    Ok(())
}
