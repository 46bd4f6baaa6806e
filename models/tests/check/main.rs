//! Model-checking tests, one binary; modules are named by behaviour.

mod broken_variants_are_caught;
mod compact_search;
mod correct_models_hold;
mod detector_history;
mod detector_liveness;
mod early_arrivals;
mod liveness;
mod reduction;
mod rounds;
mod services;
mod spent;
mod spilling;
mod state_counts;
mod symmetry;
mod user_detector;

use nekosim_models::{build, find, run, Exploration, Options, Outcome};
use nekosim_protocols::{Pid, Stack};

/// Checks the registered model `name` with `opts`, after `tweak` on each initial stack.
pub fn check_with(
    name: &str,
    opts: &Options,
    tweak: impl Fn(Pid, &mut Stack),
    first_counterexample: bool,
) -> Outcome {
    let def = find(name).expect("registered model");
    let model = build(&def.target(), opts, tweak).expect("valid model");
    run(
        model,
        Exploration {
            first_counterexample,
            ..Exploration::default()
        },
    )
}

/// Checks the registered model `name` exhaustively.
pub fn check(name: &str, opts: &Options) -> Outcome {
    check_with(name, opts, |_, _| {}, false)
}

/// Options for `n` processes and `k` requests, the rest default.
pub fn opts(n: u32, k: u32) -> Options {
    Options {
        processes: n,
        requests: k,
        ..Options::default()
    }
}

/// Asserts every property holds, naming those that do not.
pub fn assert_all_hold(name: &str, o: &Outcome) {
    let failed: Vec<&str> = o
        .verdicts
        .iter()
        .filter(|v| !v.holds)
        .map(|v| v.name)
        .collect();
    assert!(failed.is_empty(), "{name}: {failed:?} do not hold");
}
