//! `nekosim check`: the model list, exit codes 0/1/2, and the counterexample trace.

use std::process::{Command, Output};

use serde_json::Value;

fn nekosim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .args(args)
        .output()
        .expect("run nekosim")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn list_prints_the_model_names_only() {
    let o = nekosim(&["check", "--list"]);
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(
        stdout(&o),
        "lamport-abcast\nsequencer-abcast\nconsensus-abcast\nct-consensus\nreliable-broadcast\n"
    );
}

#[test]
fn a_correct_model_exits_0_with_figures_and_verdicts() {
    let o = nekosim(&[
        "check",
        "sequencer-abcast",
        "--processes",
        "3",
        "--requests",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
    let out = stdout(&o);
    assert!(
        out.contains("states: 93, unique states: 46, depth: 8"),
        "{out}"
    );
    assert!(out.contains("states/s: "));
    for p in ["total order", "integrity", "uniform agreement", "validity"] {
        assert!(out.contains(&format!("holds  {p} (always)")), "{p}: {out}");
    }
}

#[test]
fn a_counterexample_exits_1_and_is_traced_step_by_step() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("cx.jsonl");
    let o = nekosim(&[
        "check",
        "reliable-broadcast",
        "--requests",
        "1",
        "--network",
        "lossy",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    let out = stdout(&o);
    assert!(
        out.contains("FAILS  agreement (always): counterexample in 4 steps"),
        "{out}"
    );
    assert!(
        out.contains("the network loses RB(0:0, M 0) from p0 to p2"),
        "{out}"
    );
    let text = std::fs::read_to_string(&trace).unwrap();
    let records: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let kinds: Vec<&str> = records
        .iter()
        .map(|r| r["kind"].as_str().unwrap())
        .collect();
    for k in ["request", "send", "deliver", "drop", "receive"] {
        assert!(kinds.contains(&k), "{k} in {kinds:?}");
    }
    let seqs: Vec<u64> = records.iter().map(|r| r["seq"].as_u64().unwrap()).collect();
    assert!(
        seqs.windows(2).all(|w| w[0] <= w[1]),
        "seq is the step number"
    );
    assert_eq!(
        *seqs.last().unwrap(),
        4,
        "the last step of a 4-step counterexample"
    );
    // Exactly one process delivered (the broadcaster and the relay): p2 did not.
    let delivered: Vec<u64> = records
        .iter()
        .filter(|r| r["kind"] == "deliver")
        .map(|r| r["robot"].as_u64().unwrap())
        .collect();
    assert!(!delivered.contains(&2), "{delivered:?}");
}

#[test]
fn bad_arguments_exit_2_with_one_line() {
    for args in [
        &["check", "no-such-model"][..],
        &["check", "ct-consensus", "--requests", "1"],
        &["check", "lamport-abcast", "--processes", "1"],
        &["check", "lamport-abcast", "--crashes", "3"],
        &["check", "lamport-abcast", "--network", "carrier-pigeon"],
    ] {
        let o = nekosim(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(o.stdout.is_empty(), "{args:?}");
    }
    let o = nekosim(&["check", "no-such-model"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("expected one of lamport-abcast"), "{err}");
    // An output naming a directory is refused before the search: no report, one line.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    for (flag, says) in [
        ("--trace", "cannot write the trace"),
        ("--rrd", "cannot create the recording"),
    ] {
        let o = nekosim(&["check", "reliable-broadcast", "--network", "lossy", flag, d]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{flag}: {err}");
        assert!(o.stdout.is_empty(), "{flag}: the search ran");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.contains(says) && err.contains("is a directory"),
            "{err}"
        );
    }
}
