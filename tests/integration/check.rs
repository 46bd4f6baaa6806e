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
    // The unique counts are the models crate's own pins with spent messages forgotten
    // (models/tests/check/reduction.rs), reached here through the scenario files.
    for (name, file, unique) in [
        ("lamport-abcast", "examples/check/lamport_abcast.ron", 1_597),
        (
            "sequencer-abcast",
            "examples/check/sequencer_abcast.ron",
            46,
        ),
        (
            "consensus-abcast",
            "examples/check/consensus_abcast.ron",
            94,
        ),
        (
            "reliable-broadcast",
            "examples/check/reliable_broadcast.ron",
            49,
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

/// Every line but the figures' timing.
fn untimed(out: &str) -> Vec<&str> {
    out.lines()
        .map(|l| l.split(", seconds").next().unwrap_or(l))
        .collect()
}

#[test]
fn partial_order_reduction_is_reported_compared_and_can_be_turned_off() {
    // On an ordered network it takes effect: fewer states, the same verdicts; the counts are
    // the models crate's pins (models/tests/check/reduction.rs).
    let on = nekosim(&[
        "check",
        "lamport-abcast",
        "--network",
        "ordered",
        "--compare-reduction",
    ]);
    let out = stdout(&on);
    assert_eq!(on.status.code(), Some(0), "{out}");
    assert!(
        out.contains("search: bfs with partial-order reduction, 1 thread"),
        "{out}"
    );
    assert!(figures(&out).contains("unique states: 1597,"), "{out}");
    assert!(
        out.contains("without partial-order reduction: states: 7377, unique states: 2754, depth: 15, seconds: "),
        "{out}"
    );
    assert!(
        out.contains("partial-order reduction: 1597 unique states instead of 2754 (1.72x fewer)"),
        "{out}"
    );
    let off = nekosim(&[
        "check",
        "lamport-abcast",
        "--network",
        "ordered",
        "--no-reduction",
    ]);
    let plain = stdout(&off);
    assert_eq!(off.status.code(), Some(0), "{plain}");
    assert!(plain.contains("search: bfs, 1 thread"), "{plain}");
    assert!(figures(&plain).contains("unique states: 2754,"), "{plain}");
    let verdicts = |o: &str| -> Vec<String> {
        o.lines()
            .filter(|l| l.starts_with("  holds") || l.starts_with("  FAILS"))
            .map(String::from)
            .collect()
    };
    assert_eq!(verdicts(&out), verdicts(&plain));
    // On a network that reorders messages, the search forgets spent messages instead. The
    // fixed sequencer has none: the same states and report as with it off, but for the
    // search line.
    let unordered = stdout(&nekosim(&["check", "sequencer-abcast"]));
    let turned_off = stdout(&nekosim(&["check", "sequencer-abcast", "--no-reduction"]));
    assert!(
        unordered.contains("search: bfs forgetting spent messages, 1 thread"),
        "{unordered}"
    );
    let plain = unordered.replace(" forgetting spent messages", "");
    assert_eq!(untimed(&plain), untimed(&turned_off));
    // Lamport sits on Fifo, which holds early arrivals back: on a network that reorders, its
    // links are explored in send order, the states of the ordered network, and partial-order
    // reduction applies; without reductions every order of arrival is explored.
    let in_order = nekosim(&["check", "lamport-abcast", "--compare-reduction"]);
    let out = stdout(&in_order);
    assert_eq!(in_order.status.code(), Some(0), "{out}");
    assert!(
        out.contains("search: bfs with partial-order reduction, links in send order, 1 thread"),
        "{out}"
    );
    assert!(
        out.contains("without partial-order reduction with links in send order: states: 14131, unique states: 4439, depth: 15, seconds: "),
        "{out}"
    );
    assert!(
        out.contains("partial-order reduction with links in send order: 1597 unique states instead of 4439 (2.78x fewer)"),
        "{out}"
    );
    let every_order = stdout(&nekosim(&["check", "lamport-abcast", "--no-reduction"]));
    assert!(figures(&every_order).contains("unique states: 4439,"));
    assert_eq!(verdicts(&out), verdicts(&every_order));
    let compared = stdout(&nekosim(&[
        "check",
        "reliable-broadcast",
        "--compare-reduction",
    ]));
    assert!(
        compared.contains("without forgetting spent messages: states: 195, unique states: 129, depth: 7, seconds: "),
        "{compared}"
    );
    assert!(
        compared
            .contains("forgetting spent messages: 49 unique states instead of 129 (2.63x fewer)"),
        "{compared}"
    );
    let compared = stdout(&nekosim(&[
        "check",
        "sequencer-abcast",
        "--strategy",
        "dfs",
        "--compare-reduction",
    ]));
    assert!(
        compared.contains("reduction: not in effect (bfs only)"),
        "{compared}"
    );
    // Links in send order hold for every strategy.
    let compared = stdout(&nekosim(&[
        "check",
        "lamport-abcast",
        "--strategy",
        "dfs",
        "--compare-reduction",
    ]));
    assert!(
        compared.contains("links in send order: 2754 unique states instead of 4439 (1.61x fewer)"),
        "{compared}"
    );
    // A counterexample found with it is one of the same property, ending at rest.
    let args = [
        "check",
        "lamport-abcast",
        "--network",
        "ordered",
        "--crashes",
        "1",
    ];
    let with = stdout(&nekosim(&args));
    let without = stdout(&nekosim(&[&args[..], &["--no-reduction"]].concat()));
    assert!(
        with.contains("FAILS  validity (always): counterexample in 8 steps"),
        "{with}"
    );
    assert_eq!(reason(&with, "validity"), reason(&without, "validity"));
    assert!(
        nekosim(&[
            "check",
            "lamport-abcast",
            "--no-reduction",
            "--compare-reduction"
        ])
        .status
        .code()
            == Some(2)
    );
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
    // The exhaustive search has 84,924 unique states (the models crate pins it).
    let unique: usize = line
        .split(": ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!((1_000..84_924).contains(&unique), "{line}");
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
        "--no-reduction",
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
    // Depth-first search is exhaustive, like breadth-first (without its reduction), with the
    // same unique states.
    let bfs = nekosim(&[
        "check",
        "reliable-broadcast",
        "--requests",
        "3",
        "--no-reduction",
    ]);
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

/// The records of a JSONL trace.
fn records(trace: &std::path::Path) -> Vec<Value> {
    std::fs::read_to_string(trace)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// The `so "PROPERTY" fails: ...` line ending a counterexample.
fn reason<'a>(out: &'a str, property: &str) -> &'a str {
    let head = format!("  so {property:?} fails: ");
    out.lines()
        .find_map(|l| l.strip_prefix(&head))
        .unwrap_or_else(|| panic!("no reason for {property:?} in {out}"))
}

/// `(robot, seq, msg, content)` of each deliver record.
fn deliveries(records: &[Value]) -> Vec<(u64, u64, String, String)> {
    records
        .iter()
        .filter(|r| r["kind"] == "deliver")
        .map(|r| {
            (
                r["robot"].as_u64().unwrap(),
                r["seq"].as_u64().unwrap(),
                r["msg"].as_str().unwrap().to_string(),
                r["content"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

#[test]
fn a_counterexample_ends_with_the_reason_read_from_its_last_state() {
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
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}");
    // The oracle is the trace of the same path: who delivered what, at which step, and the
    // first process that never did.
    let delivered = deliveries(&records(&trace));
    let [(by, step, id, content)] = &delivered[..] else {
        panic!("{delivered:?}")
    };
    let missing = (0..3).find(|p| p != by).unwrap();
    assert_eq!(
        reason(&out, "agreement"),
        format!("p{missing} never delivered {id} ({content}), which p{by} delivered at step {step}; nothing is left to happen")
    );
    // The reason is the counterexample's last line.
    assert!(
        out.trim_end()
            .lines()
            .last()
            .unwrap()
            .starts_with("  so \"agreement\" fails: "),
        "{out}"
    );
}

#[test]
fn the_first_counterexample_ends_the_search_and_keep_going_settles_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("cx.jsonl");
    // Lamport assumes no crash: with one, the survivors stop delivering. Breadth-first, the
    // shortest violation is of validity (8 steps), before uniform agreement's (10).
    let o = nekosim(&["check", "lamport-abcast", "--crashes", "1"]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert!(out.contains("found: \"validity\" fails, after "), "{out}");
    assert!(!out.contains("found: \"uniform agreement\""), "{out}");
    assert!(
        out.contains("  FAILS  validity (always): counterexample in 8 steps"),
        "{out}"
    );
    assert!(
        out.contains("  open   uniform agreement (always): not settled (the search stopped at the first counterexample; --keep-going explores on)"),
        "{out}"
    );
    // It is reported when found, before the figures of the search that found it.
    assert!(
        out.find("found: \"validity\"").unwrap() < out.find("states: ").unwrap(),
        "{out}"
    );
    assert!(
        !out.contains("counterexample of \"uniform agreement\""),
        "{out}"
    );
    let stopped_at: usize = figures(&out)
        .split("unique states: ")
        .nth(1)
        .and_then(|s| s.split(',').next())
        .and_then(|n| n.parse().ok())
        .unwrap();
    // The whole space with one crash has 66,744 unique states (stateright's count before
    // this command stopped early; the exhaustive run below finds it again).
    assert!(stopped_at < 66_744, "{stopped_at}");

    let o = nekosim(&[
        "check",
        "lamport-abcast",
        "--crashes",
        "1",
        "--keep-going",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}");
    // 66,744 in every order of arrival (--no-reduction); each link in send order, with
    // partial-order reduction where no crash is left to happen, 50,016.
    assert!(figures(&out).contains("unique states: 50016,"), "{out}");
    for p in ["uniform agreement", "validity"] {
        assert!(
            out.contains(&format!("found: {p:?} fails, after ")),
            "{p}: {out}"
        );
        assert!(
            out.contains(&format!("  FAILS  {p} (always)")),
            "{p}: {out}"
        );
    }
    for p in ["total order", "integrity"] {
        assert!(
            out.contains(&format!("  holds  {p} (always)\n")),
            "{p}: {out}"
        );
    }
    // The trace is uniform agreement's path (the first property failing): a process delivers
    // and crashes; the live ones never deliver.
    let records = records(&trace);
    let delivered = deliveries(&records);
    let [(by, step, id, content)] = &delivered[..] else {
        panic!("{delivered:?}")
    };
    let crashed: Vec<u64> = records
        .iter()
        .filter(|r| r["kind"] == "crash")
        .map(|r| r["robot"].as_u64().unwrap())
        .collect();
    assert_eq!(crashed, [*by]);
    let missing = (0..3).find(|p| p != by).unwrap();
    assert_eq!(
        reason(&out, "uniform agreement"),
        format!("p{missing} never delivered {id} ({content}), which p{by} (crashed) delivered at step {step}; nothing is left to happen")
    );
    // Validity's path: p0 broadcasts at step 1 and never delivers its own message.
    assert_eq!(
        reason(&out, "validity"),
        "p0 never delivered its own 0:0, broadcast at step 1; nothing is left to happen"
    );
}

/// A flooding broadcast with a seeded bug: it relays each message once but delivers it on
/// every copy, so a process that hears it from two others delivers it twice.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct Flood {
    count: u64,
    relayed: std::collections::BTreeSet<nekosim::protocols::MsgId>,
}

#[derive(Clone, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
struct Flooded {
    id: nekosim::protocols::MsgId,
    msg: nekosim::protocols::Payload,
}

impl nekosim::protocols::Microprotocol for Flood {
    type Msg = Flooded;
    type Timer = ();
    type Config = nekosim::protocols::NoConfig;
    const NAME: &'static str = "Flood";

    fn shape(_: &Self::Config) -> nekosim::protocols::Shape {
        nekosim::protocols::Shape::on_links(nekosim::protocols::Service::BROADCAST)
    }

    fn new(_: Self::Config) -> Result<Self, nekosim::protocols::FieldError> {
        Ok(Self::default())
    }

    fn on_request(
        &mut self,
        ctx: &nekosim::protocols::Ctx,
        _from: nekosim::protocols::LayerIx,
        req: nekosim::protocols::Request,
        out: &mut nekosim::protocols::Out<Self>,
    ) {
        use nekosim::protocols::{Indication, MsgId, Request};
        if let Request::Broadcast { msg } = req {
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            self.relayed.insert(id);
            out.send(
                ctx.others(),
                Flooded {
                    id,
                    msg: msg.clone(),
                },
            );
            out.up(Indication::BDeliver { id, msg });
        }
    }

    fn on_message(
        &mut self,
        ctx: &nekosim::protocols::Ctx,
        from: nekosim::protocols::Pid,
        m: Flooded,
        out: &mut nekosim::protocols::Out<Self>,
    ) {
        if self.relayed.insert(m.id) {
            let to = ctx.others().into_iter().filter(|&q| q != from).collect();
            out.send(to, m.clone());
        }
        // The seeded bug: no check that it was delivered already.
        out.up(nekosim::protocols::Indication::BDeliver {
            id: m.id,
            msg: m.msg,
        });
    }
}

#[test]
fn a_users_seeded_bug_is_reported_in_the_terms_of_the_broken_property() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("flood.ron");
    std::fs::write(
        &file,
        r#"Scenario(
    world: (size: Infinite),
    network: RandomDelay(lambda: 1.0),
    stack: [Layer(id: "flood", protocol: Flood, below: "net")],
    robots: [Group(count: 3, radius: 1.0)],
)"#,
    )
    .unwrap();
    let trace = dir.path().join("cx.jsonl");
    let mut registry = nekosim::scenario::Registry::with_builtins();
    registry.protocol::<Flood>("Flood");
    let args = nekosim::check::CheckArgs {
        model: file.to_str().unwrap().to_string(),
        requests: Some(1),
        threads: 1,
        trace: Some(trace.clone()),
        ..Default::default()
    };
    let mut out = Vec::new();
    let c = nekosim::check::check(&args, &registry, &mut out).unwrap();
    let out = String::from_utf8(out).unwrap();
    assert_eq!(c, nekosim::check::Conclusion::Fails, "{out}");
    assert!(out.contains("found: \"integrity\" fails, after "), "{out}");
    // The broadcast, a relay, and the two copies reaching the same process.
    assert!(
        out.contains("  FAILS  integrity (always): counterexample in 4 steps"),
        "{out}"
    );
    // The oracle: the trace's process with two deliveries of one message.
    let delivered = deliveries(&records(&trace));
    let twice: Vec<&(u64, u64, String, String)> = delivered
        .iter()
        .filter(|d| {
            delivered
                .iter()
                .filter(|e| (e.0, &e.2) == (d.0, &d.2))
                .count()
                == 2
        })
        .collect();
    let (p, _, id, content) = twice.first().unwrap_or_else(|| panic!("{delivered:?}"));
    assert_eq!(
        reason(&out, "integrity"),
        format!("p{p} delivered {id} ({content}) twice")
    );
}

#[test]
fn ctrl_c_reports_what_was_found_writes_the_trace_and_exits_130() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("cx.jsonl");
    // Three broadcasts and a crash: a counterexample within a second, and a space that takes
    // far longer than this test waits to explore whole.
    let mut child = Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .args([
            "check",
            "lamport-abcast",
            "--requests",
            "3",
            "--crashes",
            "1",
            "--keep-going",
            "--trace",
        ])
        .arg(&trace)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let mut out = String::new();
    // Reported as soon as it is found, while the search goes on.
    for line in lines.by_ref() {
        let line = line.unwrap();
        out.push_str(&line);
        out.push('\n');
        if line.starts_with("found: ") {
            break;
        }
    }
    assert!(out.contains("found: "), "{out}");
    let found = out.lines().last().unwrap().to_string();
    assert!(!trace.exists(), "written before the search ends");
    // What a terminal's Ctrl-C sends.
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    for line in lines {
        out.push_str(&line.unwrap());
        out.push('\n');
    }
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "{out}");
    assert!(
        out.contains("stopped by Ctrl-C before the search was exhaustive: "),
        "{out}"
    );
    // What was found is reported, explained with its reason and written; what was not
    // settled is open.
    let property = found
        .strip_prefix("found: \"")
        .and_then(|s| s.split('"').next())
        .unwrap();
    let verdict = format!("  FAILS  {property} (always): counterexample in ");
    let steps: u64 = out
        .lines()
        .find_map(|l| l.strip_prefix(&verdict))
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{out}"));
    reason(&out, property);
    assert!(steps > 0, "{out}");
    assert!(out.contains("  open   "), "{out}");
    // The trace is the path of the first property failing, in the report's order.
    let first: u64 = out
        .lines()
        .find_map(|l| l.strip_prefix("  FAILS  "))
        .and_then(|l| l.rsplit("counterexample in ").next())
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{out}"));
    let records = records(&trace);
    assert_eq!(
        records.last().unwrap()["seq"].as_u64(),
        Some(first),
        "{out}"
    );
}

#[test]
fn no_progress_is_drawn_when_stderr_is_not_a_terminal() {
    let o = nekosim(&["check", "lamport-abcast"]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
    assert!(
        o.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // What a terminal shows: states, depth, rate, memory against its budget.
    let line = nekosim::check::progress_text(
        &nekosim_models::Progress {
            states: 1000,
            unique_states: 400,
            max_depth: 7,
            memory: Some(3 << 20),
        },
        2.0,
        Some(4 << 30),
    );
    assert_eq!(
        line,
        "checking: 1000 states, 400 unique, depth 7, 500 states/s, memory 3.0 MiB of 4.0 GiB"
    );
}

/// The fenced block of docs/extending.md whose first line is `first`.
fn docs_block(page: &str, first: &str) -> String {
    let mut lines = page.lines();
    while let Some(l) = lines.next() {
        if l.starts_with("```") && lines.clone().next() == Some(first) {
            return lines
                .take_while(|l| !l.starts_with("```"))
                .map(|l| format!("{l}\n"))
                .collect();
        }
    }
    panic!("no block starting {first:?} in docs/extending.md")
}

/// docs/extending.md's user crate, built from the page's own text against this workspace:
/// offline (no network), with this workspace's target directory so the dependencies already
/// built are reused.
#[test]
fn a_users_crate_builds_from_the_docs_text() {
    let root = env!("CARGO_MANIFEST_DIR");
    let page = std::fs::read_to_string(format!("{root}/docs/extending.md")).unwrap();
    let manifest = docs_block(&page, "# Cargo.toml");
    for line in [
        "[profile.dev.package.stateright]",
        "[profile.dev.package.nekosim-protocols]",
        "[profile.dev.package.nekosim-models]",
    ] {
        assert!(manifest.contains(line), "{line}");
    }
    let at = r#"nekosim = { path = "../nekosim" }"#;
    assert!(manifest.contains(at), "{manifest}");
    let manifest = manifest.replace(at, &format!("nekosim = {{ path = {root:?} }}"));
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("src")).unwrap();
    std::fs::write(dir.path().join("Cargo.toml"), manifest).unwrap();
    std::fs::write(
        dir.path().join("src/main.rs"),
        docs_block(&page, "// src/main.rs"),
    )
    .unwrap();
    // The workspace's versions, so that what is built is reused and nothing is fetched.
    std::fs::copy(format!("{root}/Cargo.lock"), dir.path().join("Cargo.lock")).unwrap();
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| format!("{root}/target").into());
    let o = Command::new(std::env::var_os("CARGO").unwrap_or("cargo".into()))
        .args(["check", "--offline", "--quiet"])
        .current_dir(dir.path())
        .env("CARGO_TARGET_DIR", target)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn the_docs_check_section_is_read_as_it_says() {
    // docs/model-checking.md's `check` section, in a scenario, sets each parameter.
    let root = env!("CARGO_MANIFEST_DIR");
    let page = std::fs::read_to_string(format!("{root}/docs/model-checking.md")).unwrap();
    let section = page
        .split("```ron\n")
        .nth(1)
        .and_then(|s| s.split("```").next())
        .unwrap()
        .trim();
    assert!(section.starts_with("check: ("), "{section}");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("s.ron");
    std::fs::write(
        &file,
        format!(
            "Scenario(\n    world: (size: Infinite),\n    stack: [Layer(id: \"fifo\", protocol: Fifo, below: \"net\"), Layer(id: \"abcast\", protocol: LamportAbcast, below: \"fifo\")],\n    robots: [Group(count: 4, radius: 1.0)],\n    {section}\n)\n"
        ),
    )
    .unwrap();
    let args = nekosim::check::CheckArgs {
        model: file.to_str().unwrap().to_string(),
        threads: 1,
        ..Default::default()
    };
    let r = nekosim::check::resolve(&args, &nekosim::scenario::Registry::with_builtins()).unwrap();
    assert_eq!(r.target.entry, "abcast");
    let o = &r.options;
    assert_eq!(
        (
            o.processes,
            o.requests,
            o.crashes,
            o.network,
            o.timer_budget,
            o.max_round
        ),
        (3, 1, 0, nekosim_models::NetworkKind::Unordered, 0, 1)
    );
}

#[test]
fn a_livelock_is_reported_as_a_lasso_printed_and_traced() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("lasso.jsonl");
    let file = format!(
        "{}/tests/check/retransmit_lossy.ron",
        env!("CARGO_MANIFEST_DIR")
    );
    // Under fair loss, retransmission gets every message through.
    let o = nekosim(&["check", &file, "--timers", "unlimited"]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(out.contains("fairness: fair loss"), "{out}");
    assert!(out.contains("holds  reliable delivery <>[]"), "{out}");
    // With every copy allowed to be lost, it resends and loses for ever: a lasso.
    let args = [
        "check",
        &file,
        "--timers",
        "unlimited",
        "--fairness",
        "weak",
    ];
    let o = nekosim(&[&args[..], &["--trace", trace.to_str().unwrap()]].concat());
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert!(out.contains("FAILS  reliable delivery <>[]"), "{out}");
    assert!(out.contains("lasso of \"reliable delivery\":"), "{out}");
    assert!(out.contains("cycle (from step 1"), "{out}");
    assert!(out.contains("the network loses RT_DATA#0(M 0)"), "{out}");
    assert!(
        out.contains("so \"reliable delivery\" fails: p1 never gets M 0 from p0"),
        "{out}"
    );
    let text = std::fs::read_to_string(&trace).unwrap();
    let last = text.lines().last().unwrap();
    assert!(last.contains("\"kind\":\"lasso\""), "{text}");
    assert!(last.contains("\"cycle_from\":1"), "{text}");
    assert!(
        text.lines().any(|l| l.contains("\"kind\":\"drop\"")),
        "{text}"
    );
    // Without fairness too; and `--no-liveness` decides nothing temporal.
    let o = nekosim(&[
        "check",
        &file,
        "--timers",
        "unlimited",
        "--fairness",
        "none",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    let o = nekosim(&[&args[..], &["--no-liveness"]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
    assert!(!stdout(&o).contains("liveness"), "{}", stdout(&o));
    // Bounded fairness is the robots'.
    let o = nekosim(&["check", &file, "--fairness", "bounded"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn the_shipped_models_state_their_liveness_and_keep_their_verdicts() {
    for name in [
        "lamport-abcast",
        "sequencer-abcast",
        "consensus-abcast",
        "reliable-broadcast",
    ] {
        let o = nekosim(&["check", name]);
        let out = stdout(&o);
        assert_eq!(o.status.code(), Some(0), "{name}: {out}");
        let unique_of = |out: &str| {
            figures(out)
                .split(", ")
                .find(|f| f.starts_with("unique states: "))
                .unwrap()
                .trim_start_matches("unique states: ")
                .to_string()
        };
        // The liveness graph is the very state space the search covered, but in every order
        // of arrival: Lamport's search, over Fifo, takes each link in send order.
        let unique = if name == "lamport-abcast" {
            unique_of(&stdout(&nekosim(&["check", name, "--no-reduction"])))
        } else {
            unique_of(&out)
        };
        assert!(
            out.contains(&format!("liveness graph: {unique} states,")),
            "{name}: {out}"
        );
        assert!(out.contains("holds  validity <>[]"), "{name}: {out}");
        assert!(!out.contains("FAILS"), "{name}: {out}");
    }
}

#[test]
fn a_leader_election_over_heartbeat_keeps_a_stable_leader_after_a_crash() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("omega.ron");
    std::fs::write(
        &file,
        r#"Scenario(
    world: (size: Infinite),
    network: RandomDelay(lambda: 10.0),
    stack: [
        Layer(id: "fd", protocol: Heartbeat(period: 1.0, timeout: 2.0), below: "net"),
        Layer(id: "omega", protocol: Omega, below: "net", uses: ["fd"]),
    ],
    robots: [
        Group(count: 2, radius: 1.0, born: Points([(0.0, 0.0), (20.0, 0.0)])),
    ],
)"#,
    )
    .unwrap();
    let file = file.to_str().unwrap();
    let args = ["check", file, "--timers", "unlimited", "--crashes", "1"];
    // Under fair timers the survivor suspects the crashed process and leads itself.
    let o = nekosim(&args);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(out.contains("assuming eventual accuracy"), "{out}");
    assert!(out.contains("liveness graph: 512 states,"), "{out}");
    assert!(out.contains("holds  stable leader <>[]"), "{out}");
    // Without them it may beat for ever and never check: it keeps the crashed leader.
    let o = nekosim(&[&args[..], &["--fairness", "none"]].concat());
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert!(out.contains("FAILS  stable leader <>[]"), "{out}");
    assert!(out.contains("step   1: p0 crashes"), "{out}");
    assert!(
        out.contains("never settle on one live leader (p1 trusts p0)"),
        "{out}"
    );
}

/// What a spill directory holds (nothing, once a check has ended).
fn left_in(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect()
}

/// Every line but the figures' timing, the search line (which names where it spills), what
/// was spilled, and when a failure was seen (the unique states when the search's supervisor
/// looked, which its timing decides).
fn unspilled(out: &str) -> Vec<&str> {
    untimed(out)
        .into_iter()
        .filter(|l| !l.starts_with("search: ") && !l.starts_with("spilled to disk: "))
        .map(|l| l.split(", after ").next().unwrap_or(l))
        .collect()
}

#[test]
fn a_spilled_check_reports_and_traces_what_the_check_in_memory_does() {
    let dir = tempfile::tempdir().unwrap();
    let spill = dir.path().join("spill");
    std::fs::create_dir(&spill).unwrap();
    let (a, b) = (dir.path().join("a.jsonl"), dir.path().join("b.jsonl"));
    // A counterexample on a lossy network, with every property settled; and a correct model
    // whose partial-order reduction looks in the spilled states for its cycle proviso.
    for (args, traces) in [
        (
            &[
                "reliable-broadcast",
                "--network",
                "lossy",
                "--requests",
                "3",
            ][..],
            true,
        ),
        (&["lamport-abcast", "--network", "ordered"][..], false),
    ] {
        let mut memory = vec!["check", "--keep-going", "--no-spill"];
        memory.extend(args);
        let mut disk = vec![
            "check",
            "--keep-going",
            "--spill-after",
            "50",
            "--spill-dir",
        ];
        disk.push(spill.to_str().unwrap());
        disk.extend(args);
        if traces {
            memory.extend(["--trace", a.to_str().unwrap()]);
            disk.extend(["--trace", b.to_str().unwrap()]);
        }
        let (m, d) = (nekosim(&memory), nekosim(&disk));
        let (mo, dout) = (stdout(&m), stdout(&d));
        assert_eq!(m.status.code(), d.status.code(), "{dout}");
        assert_eq!(unspilled(&mo), unspilled(&dout), "{args:?}");
        let search = dout.lines().find(|l| l.starts_with("search: ")).unwrap();
        assert!(
            search.ends_with(&format!(", spilling to {}", spill.display())),
            "{search}"
        );
        let said = dout
            .lines()
            .find(|l| l.starts_with("spilled to disk: "))
            .unwrap_or_else(|| panic!("{dout}"));
        let times: usize = said["spilled to disk: ".len()..]
            .split(' ')
            .next()
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{said}"));
        assert!(times > 1, "{said}");
        let err = String::from_utf8_lossy(&d.stderr);
        assert!(
            err.starts_with(&format!(
                "spilling to disk in {}/nekosim-spill-",
                spill.display()
            )),
            "{err}"
        );
        assert!(left_in(&spill).is_empty(), "{:?}", left_in(&spill));
        if traces {
            assert_eq!(m.status.code(), Some(1), "{mo}");
            assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
        }
    }
}

#[test]
fn a_disk_budget_too_small_stops_the_check_with_exit_3_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let o = nekosim(&[
        "check",
        "lamport-abcast",
        "--requests",
        "3",
        "--spill-after",
        "1000",
        "--spill-dir",
        d,
        "--max-disk",
        "4KiB",
    ]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(3), "{out}");
    let search = out.lines().find(|l| l.starts_with("search: ")).unwrap();
    assert!(
        search.ends_with(&format!(", spilling to {d} (at most 4.0 KiB)")),
        "{search}"
    );
    assert!(
        out.contains("stopped by the disk budget (4.0 KiB of spill files) before the search was exhaustive: "),
        "{out}"
    );
    assert!(
        out.contains("  open   total order (always): no counterexample in what was explored"),
        "{out}"
    );
    assert!(left_in(dir.path()).is_empty(), "{:?}", left_in(dir.path()));
    // Without spilling the budget is meaningless, and refused.
    let o = nekosim(&[
        "check",
        "lamport-abcast",
        "--no-spill",
        "--max-disk",
        "4KiB",
    ]);
    assert_eq!(o.status.code(), Some(2));
    // A spill directory that is not one is refused before the search, in one line.
    let file = dir.path().join("file");
    std::fs::write(&file, "").unwrap();
    let o = nekosim(&[
        "check",
        "lamport-abcast",
        "--spill-dir",
        file.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(o.stdout.is_empty());
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("cannot spill to ") && err.contains("not a directory"),
        "{err}"
    );
}

#[test]
fn a_time_budget_stops_the_check_with_exit_3() {
    let o = nekosim(&[
        "check",
        "lamport-abcast",
        "--requests",
        "3",
        "--max-time",
        "1s",
    ]);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(3), "{out}");
    assert!(
        out.lines()
            .next()
            .is_some_and(|_| out.contains(", 1s time\n")),
        "{out}"
    );
    let seconds: f64 = figures_seconds(&out);
    assert!((1.0..30.0).contains(&seconds), "{out}");
    assert!(
        out.contains("stopped by the time budget (1s) before the search was exhaustive: "),
        "{out}"
    );
    for bad in ["soon", "0s", "-3m", "5 parsecs"] {
        let o = nekosim(&["check", "lamport-abcast", &format!("--max-time={bad}")]);
        assert_eq!(o.status.code(), Some(2), "{bad}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("expected e.g. 90s, 10m or 2h"), "{bad}: {err}");
    }
}

/// The seconds of a report's figures.
fn figures_seconds(out: &str) -> f64 {
    out.lines()
        .find(|l| l.starts_with("states: "))
        .and_then(|l| l.split("seconds: ").nth(1))
        .and_then(|s| s.split(',').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no seconds in {out}"))
}

#[test]
fn ctrl_c_while_spilled_leaves_no_spill_file() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let dir = tempfile::tempdir().unwrap();
    for interrupts in [1, 2] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_nekosim"))
            .args(["check", "lamport-abcast", "--requests", "3"])
            .args(["--spill-after", "2000", "--spill-dir"])
            .arg(dir.path())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut err = BufReader::new(child.stderr.take().unwrap()).lines();
        let said = err.next().unwrap().unwrap();
        assert!(said.starts_with("spilling to disk in "), "{said}");
        assert_eq!(left_in(dir.path()).len(), 1, "the search's own directory");
        for _ in 0..interrupts {
            let status = Command::new("kill")
                .args(["-INT", &child.id().to_string()])
                .status()
                .unwrap();
            assert!(status.success());
        }
        let o = child.wait_with_output().unwrap();
        assert_eq!(o.status.code(), Some(130), "{}", stdout(&o));
        assert!(
            left_in(dir.path()).is_empty(),
            "{interrupts}: {:?}",
            left_in(dir.path())
        );
    }
}

#[test]
fn a_check_of_robots_refuses_the_budgets_only_a_stack_s_search_keeps() {
    let file = format!("{}/examples/lcm/optimal_2.ron", env!("CARGO_MANIFEST_DIR"));
    for flag in ["--max-time=1s", "--max-disk=1MiB", "--spill-dir=."] {
        let o = nekosim(&["check", &file, flag]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{flag}: {err}");
        assert!(o.stdout.is_empty(), "{flag}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains("apply to a stack's check"), "{err}");
    }
}

#[test]
fn a_heartbeat_detector_with_unlimited_timers_is_checked_exhaustively() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("fd.ron");
    std::fs::write(
        &file,
        r#"Scenario(
    world: (size: Infinite),
    network: RandomDelay(lambda: 10.0),
    stack: [ Layer(id: "fd", protocol: Heartbeat(period: 1.0, timeout: 2.0), below: "net") ],
    robots: [ Group(count: 2, radius: 1.0, born: Points([(0.0, 0.0), (20.0, 0.0)])) ],
)"#,
    )
    .unwrap();
    let file = file.to_str().unwrap();
    let verdicts = |out: &str| -> Vec<String> {
        out.lines()
            .filter(|l| {
                ["  holds ", "  FAILS ", "  open "]
                    .iter()
                    .any(|v| l.starts_with(v))
            })
            .map(String::from)
            .collect()
    };
    // A detector may suspect and trust again for ever; what its process heard is kept as a
    // summary (what it suspects now, whom it ever trusted, whether an indication was
    // ill-formed), so the space is finite and the search ends.
    for (crashes, unique) in [("0", 256), ("1", 2048)] {
        let bounded = nekosim(&["check", file, "--timers", "1", "--crashes", crashes]);
        assert_eq!(bounded.status.code(), Some(0), "{}", stdout(&bounded));
        let start = std::time::Instant::now();
        let o = nekosim(&["check", file, "--timers", "unlimited", "--crashes", crashes]);
        let took = start.elapsed();
        let out = stdout(&o);
        assert_eq!(o.status.code(), Some(0), "{crashes}: {out}");
        assert!(
            took < std::time::Duration::from_secs(20),
            "{crashes}: {took:?}"
        );
        assert!(
            out.contains(&format!("unique states: {unique},")),
            "{crashes}: {out}"
        );
        assert!(!out.contains("stopped"), "{crashes}: {out}");
        let now = verdicts(&out);
        // What the search settled with one timer firing it settles the same way.
        for line in verdicts(&stdout(&bounded)) {
            assert!(
                now.contains(&line),
                "{crashes}: {line:?} missing from {out}"
            );
        }
        assert!(
            out.contains("holds  false suspicion revoked (sometimes)"),
            "{crashes}: {out}"
        );
        assert!(
            out.contains("holds  eventual trust []<>"),
            "{crashes}: {out}"
        );
        assert!(!out.contains("FAILS"), "{crashes}: {out}");
    }
}
