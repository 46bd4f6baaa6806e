//! A user's failure detector is assumed eventually accurate exactly when it says whom it
//! suspects (`Microprotocol::suspicions`), as `Heartbeat` does. The detector here is a test
//! layer written as a user would (`Flaw::Flawless`: it beats and checks as `Heartbeat` does).
//! `Omega` over it keeps a stable leader as it does over `Heartbeat` (a known answer), and
//! without the declaration the verdict is the one `Omega` over `Heartbeat` gets when judged
//! without the assumption.

use nekosim_models::config::UNLIMITED_TIMERS;
use nekosim_models::liveness::Verdict;
use nekosim_models::temporal::{accurate, assumes_accuracy, StackFairness};
use nekosim_models::{build, CheckModel, Family, Options, Target};
use nekosim_protocols::LayerSpec;

use super::detector_liveness::{Flaw, Flawed};
use super::liveness::{liveness, verdict};

/// `Omega` over `Heartbeat`, or over the user's detector in its place, on 2 processes with
/// unlimited timers.
fn omega(crashes: u32, user: Option<bool>) -> CheckModel {
    let target = Target {
        stack: vec![
            LayerSpec::new("fd", "Heartbeat(period: 1.0, timeout: 2.0)", "net", &[]),
            LayerSpec::new("omega", "Omega", "net", &["fd"]),
        ],
        entry: "omega".into(),
        family: Family::Leader,
        timer_fed: vec!["fd".into()],
    };
    let opts = Options {
        processes: 2,
        crashes,
        timer_budget: UNLIMITED_TIMERS,
        ..Options::default()
    };
    build(&target, &opts, |_, s| {
        if let Some(says) = user {
            s.layers[0] = Flawed::layer_saying(Flaw::Flawless, says);
        }
    })
    .expect("valid model")
}

fn stable(m: &CheckModel) -> (usize, bool) {
    let (states, _, d) = liveness(m, StackFairness::Weak);
    (
        states,
        matches!(verdict(&d, "stable leader"), Verdict::Holds),
    )
}

#[test]
fn a_users_detector_that_says_whom_it_suspects_is_assumed_accurate() {
    for crashes in [0, 1] {
        let (heartbeat, declared, silent) = (
            omega(crashes, None),
            omega(crashes, Some(true)),
            omega(crashes, Some(false)),
        );
        assert!(assumes_accuracy(&heartbeat) && assumes_accuracy(&declared));
        assert!(!assumes_accuracy(&silent));
        // The same graph and the same verdict as over `Heartbeat`.
        let (states, holds) = stable(&heartbeat);
        assert!(holds, "{crashes} crashes");
        assert_eq!(stable(&declared), (states, true), "{crashes} crashes");
        // Nothing assumed: the survivors' detectors may suspect and trust each other for
        // ever, and the leader follows them.
        if crashes == 0 {
            assert_eq!(stable(&silent), (states, false));
        }
    }
    // The assumption reads the user's layer: it suspects nobody at the start.
    let m = omega(0, Some(true));
    let init = stateright::Model::init_states(&m).remove(0);
    assert!(accurate(&m, &init));
}
