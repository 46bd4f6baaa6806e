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
        out.contains("FAILS  agreement (always): counterexample in 3 steps"),
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
    // The shortest violation: the broadcast, then both of its copies lost (after two steps a
    // copy is still in flight, so the system is not at rest).
    for k in ["request", "send", "deliver", "drop"] {
        assert!(kinds.contains(&k), "{k} in {kinds:?}");
    }
    let seqs: Vec<u64> = records.iter().map(|r| r["seq"].as_u64().unwrap()).collect();
    assert!(
        seqs.windows(2).all(|w| w[0] <= w[1]),
        "seq is the step number"
    );
    assert_eq!(
        *seqs.last().unwrap(),
        3,
        "the last step of a 3-step counterexample"
    );
    // Only the broadcaster delivered.
    let delivered: Vec<u64> = records
        .iter()
        .filter(|r| r["kind"] == "deliver")
        .map(|r| r["robot"].as_u64().unwrap())
        .collect();
    assert_eq!(delivered, [0], "{delivered:?}");
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
    assert!(
        err.contains("expected a scenario file (.ron) or one of lamport-abcast"),
        "{err}"
    );
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

/// The `states:` line of a report.
fn figures(out: &str) -> &str {
    out.lines()
        .find(|l| l.starts_with("states: "))
        .and_then(|l| l.split(", seconds").next())
        .unwrap_or_else(|| panic!("no figures in {out}"))
}

#[test]
fn each_shortcut_is_its_scenario_file_with_the_models_pinned_counts() {
    // The unique counts are the models crate's own pins (models/tests/check/state_counts.rs
    // and correct_models_hold.rs), reached here through the scenario files.
    for (name, file, unique) in [
        ("lamport-abcast", "examples/check/lamport_abcast.ron", 4_439),
        (
            "sequencer-abcast",
            "examples/check/sequencer_abcast.ron",
            46,
        ),
        (
            "consensus-abcast",
            "examples/check/consensus_abcast.ron",
            678,
        ),
        (
            "reliable-broadcast",
            "examples/check/reliable_broadcast.ron",
            129,
        ),
    ] {
        let by_name = nekosim(&["check", name]);
        let path = format!("{}/{file}", env!("CARGO_MANIFEST_DIR"));
        let by_file = nekosim(&["check", &path]);
        assert_eq!(by_name.status.code(), Some(0), "{}", stdout(&by_name));
        assert_eq!(by_file.status.code(), Some(0), "{}", stdout(&by_file));
        let (a, b) = (stdout(&by_name), stdout(&by_file));
        assert_eq!(figures(&a), figures(&b), "{name}");
        assert!(
            figures(&a).contains(&format!("unique states: {unique},")),
            "{name}: {a}"
        );
    }
}

#[test]
fn a_scenario_gives_processes_crashes_and_network_and_the_command_line_overrides_them() {
    let file = format!(
        "{}/examples/scenarios/consensus_abcast.ron",
        env!("CARGO_MANIFEST_DIR")
    );
    // 4 robots, one crash fault, RandomDelay: the model's parameters come from the file. A
    // state budget keeps the search short; it stops cleanly with exit 3.
    let o = nekosim(&["check", &file, "--max-states", "3000"]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(3), "{out}");
    assert!(
        out.contains(
            "stack [fd, rb, consensus, abcast], checking \"abcast\" (total-order broadcast): 4 processes, 2 requests, 1 crashes, unordered network"
        ),
        "{out}"
    );
    let o = nekosim(&[
        "check",
        &file,
        "--processes",
        "3",
        "--crashes",
        "0",
        "--network",
        "ordered",
        "--layer",
        "consensus",
        "--max-states",
        "3000",
    ]);
    let out = stdout(&o);
    assert!(
        out.contains("checking \"consensus\" (consensus): 3 processes, 2 requests, 0 crashes, ordered network"),
        "{out}"
    );
}

#[test]
fn a_budget_stops_the_search_cleanly_with_exit_3_and_no_partial_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.jsonl");
    let o = nekosim(&[
        "check",
        "lamport-abcast",
        "--requests",
        "3",
        "--max-states",
        "1000",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(3), "{out}");
    let line = out
        .lines()
        .find(|l| l.starts_with("stopped by the state budget (1000 states)"))
        .unwrap_or_else(|| panic!("{out}"));
    // The exhaustive search has 584,565 unique states (the models crate pins it).
    let unique: usize = line
        .split(": ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!((1_000..584_565).contains(&unique), "{line}");
    assert!(
        out.contains("  open   total order (always): no counterexample in what was explored"),
        "{out}"
    );
    // Every process delivering all 3 broadcasts takes at least 9 steps (3 requests and 6
    // receipts), deeper than a thousand states of breadth-first search reach: no witness, so
    // no trace file, not even an empty one.
    assert!(
        out.contains("  open   everything delivered (sometimes): not reached in what was explored"),
        "{out}"
    );
    assert!(!trace.exists(), "a witness-free stop wrote a trace");

    // The memory budget: the checker's own process stops at the resident size given.
    let o = nekosim(&[
        "check",
        "lamport-abcast",
        "--requests",
        "3",
        "--max-memory",
        "80MiB",
    ]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(3), "{out}");
    // It stops at 63/64 of the budget (78.75 MiB), so that the peak stays under it.
    let says = "stopped by the memory budget (80.0 MiB; resident ";
    let at = out.find(says).unwrap_or_else(|| panic!("{out}")) + says.len();
    let resident: f64 = out[at..]
        .split(' ')
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{out}"));
    assert!((78.7..90.0).contains(&resident), "{out}");
}

#[test]
fn simulation_explores_configurations_too_large_for_exhaustive_search() {
    let file = format!("{}/tests/check/five_robots.ron", env!("CARGO_MANIFEST_DIR"));
    let o = nekosim(&[
        "check",
        &file,
        "--strategy",
        "simulation",
        "--seed",
        "7",
        "--max-states",
        "20000",
    ]);
    let out = stdout(&o);
    // Random walks are never exhaustive: no property fails, so the answer is exit 3, with the
    // witness that every process delivered every broadcast found on some walk.
    assert_eq!(o.status.code(), Some(3), "{out}");
    assert!(out.contains("5 processes, 2 requests"), "{out}");
    assert!(
        out.contains("holds  everything delivered (sometimes): witness in"),
        "{out}"
    );
    assert!(
        out.contains("stopped by the state budget (20000 states)"),
        "{out}"
    );
    // Depth-first search is exhaustive, like breadth-first, with the same unique states.
    let bfs = nekosim(&["check", "reliable-broadcast", "--requests", "3"]);
    let dfs = nekosim(&[
        "check",
        "reliable-broadcast",
        "--requests",
        "3",
        "--strategy",
        "dfs",
    ]);
    assert_eq!(bfs.status.code(), Some(0));
    assert_eq!(dfs.status.code(), Some(0));
    let unique = |o: &Output| {
        figures(&stdout(o))
            .split(", ")
            .find(|f| f.starts_with("unique states"))
            .unwrap()
            .to_string()
    };
    assert_eq!(unique(&bfs), "unique states: 5756");
    assert_eq!(unique(&dfs), unique(&bfs));
}

#[test]
fn a_wrong_composition_in_a_scenario_is_caught_with_a_counterexample() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("cx.jsonl");
    let file = format!(
        "{}/tests/check/sequencer_on_lossy.ron",
        env!("CARGO_MANIFEST_DIR")
    );
    let o = nekosim(&["check", &file, "--trace", trace.to_str().unwrap()]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert!(out.contains("lossy network"), "{out}");
    assert!(out.contains("FAILS "), "{out}");
    assert!(out.contains("the network loses"), "{out}");
    let text = std::fs::read_to_string(&trace).unwrap();
    assert!(
        text.lines().any(|l| l.contains("\"kind\":\"drop\"")),
        "{text}"
    );
    // The same stack on the reliable links it assumes holds.
    let o = nekosim(&["check", &file, "--network", "unordered"]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
}

#[test]
fn scenario_problems_are_located_in_the_file_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let no_stack = write(
        "no_stack.ron",
        "Scenario(\n    world: (size: Infinite),\n    robots: [Group(count: 3, radius: 1.0)],\n)\n",
    );
    let two_tops = write(
        "two_tops.ron",
        "Scenario(\n    world: (size: Infinite),\n    stack: [\n        Layer(id: \"a\", protocol: ReliableBroadcast, below: \"net\"),\n        Layer(id: \"b\", protocol: FixedSequencer, below: \"net\"),\n    ],\n    robots: [Group(count: 3, radius: 1.0)],\n)\n",
    );
    let many = write(
        "many.ron",
        "Scenario(\n    world: (size: Infinite),\n    stack: [Layer(id: \"rb\", protocol: ReliableBroadcast, below: \"net\")],\n    robots: [Group(count: 12, radius: 1.0)],\n)\n",
    );
    let typo = write(
        "typo.ron",
        "Scenario(\n    world: (size: Infinite),\n    stack: [Layer(id: \"rb\", protocol: ReliableBroadcast, below: \"net\")],\n    robots: [Group(count: 3, radius: 1.0)],\n    check: (requestz: 2),\n)\n",
    );
    for (file, extra, says) in [
        (
            &no_stack,
            None,
            format!("{no_stack}:1:1: the scenario has no stack"),
        ),
        (&two_tops, None, "several top layers (a, b)".to_string()),
        (
            &two_tops,
            Some("c"),
            "no layer \"c\" in the stack".to_string(),
        ),
        (&many, None, format!("{many}:4:")),
        (&typo, None, format!("{typo}:5:")),
    ] {
        let mut args = vec!["check", file.as_str()];
        if let Some(l) = extra {
            args.extend(["--layer", l]);
        }
        let o = nekosim(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(o.stdout.is_empty(), "{args:?}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(&says), "{args:?}: {err}");
    }
    // With two top layers, --layer picks one.
    let o = nekosim(&["check", &two_tops, "--layer", "a"]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
}

#[test]
fn the_shipped_scenario_files_define_the_models_crates_targets() {
    // The models crate states each named model in Rust for its own tests and benches; the
    // command reads the scenario files. They must be the same stacks, entry layers, families
    // and timer-fed layers.
    use nekosim::check::{resolve, CheckArgs, SHORTCUTS};
    use nekosim::scenario::Registry;
    assert_eq!(
        SHORTCUTS.map(|(n, ..)| n).to_vec(),
        nekosim_models::MODELS.map(|m| m.name).to_vec()
    );
    for (name, ..) in SHORTCUTS {
        let args = CheckArgs {
            model: name.to_string(),
            threads: 1,
            ..Default::default()
        };
        let resolved = resolve(&args, &Registry::with_builtins()).expect(name);
        let ours = nekosim_models::find(name).unwrap().target();
        let text = |t: &nekosim_models::Target| {
            let stack: Vec<String> = t
                .stack
                .iter()
                .map(|l| format!("{} {} {} {:?}", l.id, l.protocol.text(), l.below, l.uses))
                .collect();
            format!("{stack:?} {} {:?} {:?}", t.entry, t.family, t.timer_fed)
        };
        assert_eq!(text(&resolved.target), text(&ours), "{name}");
        assert_eq!(resolved.options.processes, 3, "{name}");
    }
}
