//! The `nekosim` command end to end: example scenarios, byte-identical outputs, the trace
//! agreeing with the log, and every kind of bad input giving exit 2 with FILE:LINE:COL.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

fn nekosim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .args(args)
        .output()
        .expect("nekosim runs")
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn files(dir: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(root().join(dir))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    v.sort();
    v
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Every file in a folder, hidden ones included.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn every_bad_input_exits_2_with_file_line_col_and_leaves_no_output() {
    let bad = files("tests/bad");
    assert!(bad.len() >= 20);
    for f in bad {
        let text = std::fs::read_to_string(&f).unwrap();
        // `// expect: ` gives the start of the message, `// expect-all: ` all of it.
        let header = text.lines().next().unwrap();
        let (expect, whole) = match header.strip_prefix("// expect-all: ") {
            Some(all) => (all.to_string(), true),
            None => (
                header
                    .strip_prefix("// expect: ")
                    .expect("expect header")
                    .to_string(),
                false,
            ),
        };
        let path = f.to_str().unwrap();
        let out = tempfile::tempdir().unwrap();
        let old_log = out.path().join("kept.log");
        std::fs::write(&old_log, "an earlier, complete log\n").unwrap();
        let trace = out.path().join("t.jsonl");
        for args in [
            vec!["validate", path],
            vec![
                "run",
                path,
                "--log",
                old_log.to_str().unwrap(),
                "--trace",
                trace.to_str().unwrap(),
            ],
        ] {
            let o = nekosim(&args);
            let err = stderr(&o);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
            assert_eq!(err.lines().count(), 1, "one line: {err}");
            let want = format!("{path}:{expect}");
            assert!(
                err.starts_with(&want) && (!whole || err.trim_end() == want),
                "{args:?}\n got: {err}\nwant: {want}"
            );
            assert!(!err.contains("panicked"));
        }
        // Nothing lost, nothing half-written.
        assert_eq!(
            std::fs::read_to_string(&old_log).unwrap(),
            "an earlier, complete log\n"
        );
        assert_eq!(listing(out.path()), vec!["kept.log".to_string()]);
    }
}

#[test]
fn unreadable_scenarios_exit_2() {
    for p in ["/nonexistent/scenario.ron", env!("CARGO_MANIFEST_DIR")] {
        for cmd in ["validate", "run"] {
            let o = nekosim(&[cmd, p]);
            assert_eq!(o.status.code(), Some(2));
            let err = stderr(&o);
            assert!(
                err.starts_with(&format!("{p}: cannot read the scenario file")),
                "{err}"
            );
        }
    }
    // Bad command-line values are input errors too.
    let o = nekosim(&["run", "examples/scenarios/collision.ron", "--until", "-3"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = nekosim(&["run"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn example_scenarios_validate_and_run_with_byte_identical_outputs() {
    let examples = files("examples/scenarios");
    assert!(examples.len() >= 4);
    for f in examples {
        let path = f.to_str().unwrap();
        let v = nekosim(&["validate", path]);
        assert_eq!(v.status.code(), Some(0), "{path}: {}", stderr(&v));
        let dir = tempfile::tempdir().unwrap();
        let mut outputs = Vec::new();
        for k in 0..2 {
            let log = dir.path().join(format!("{k}.log"));
            let trace = dir.path().join(format!("{k}.jsonl"));
            let o = nekosim(&[
                "run",
                path,
                "--until",
                "40",
                "--log",
                log.to_str().unwrap(),
                "--trace",
                trace.to_str().unwrap(),
            ]);
            assert_eq!(o.status.code(), Some(0), "{path}: {}", stderr(&o));
            let summary = String::from_utf8_lossy(&o.stdout);
            assert!(
                summary.contains("events:") && summary.contains("collisions:"),
                "{summary}"
            );
            outputs.push((std::fs::read(&log).unwrap(), std::fs::read(&trace).unwrap()));
        }
        assert!(!outputs[0].0.is_empty() && !outputs[0].1.is_empty());
        assert!(
            outputs[0] == outputs[1],
            "{path}: outputs differ between two runs"
        );
    }
}

#[test]
fn seed_and_until_override_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let run = |seed: &str, until: &str| {
        let trace = dir.path().join(format!("{seed}-{until}.jsonl"));
        let o = nekosim(&[
            "run",
            "examples/scenarios/random_movement.ron",
            "--seed",
            seed,
            "--until",
            until,
            "--quiet",
            "--trace",
            trace.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert!(o.stdout.is_empty(), "--quiet prints nothing");
        std::fs::read_to_string(trace).unwrap()
    };
    let a = run("5", "10");
    assert_ne!(a, run("6", "10"));
    let last: Value = serde_json::from_str(a.lines().last().unwrap()).unwrap();
    assert!(last["t"].as_f64().unwrap() <= 10.0);
    assert!(run("5", "20").len() > a.len());
}

/// A rebuilt straight piece: from time `.0`, position `.1` + velocity `.2` × elapsed.
type Piece = (f64, [f64; 2], [f64; 2]);

/// Numbers of a log field like `[1.000,-2.500]`.
fn log_point(s: &str) -> (f64, f64) {
    let inner = s.trim().trim_start_matches('[').trim_end_matches(']');
    let (x, y) = inner.split_once(',').unwrap();
    (x.parse().unwrap(), y.parse().unwrap())
}

#[test]
fn the_trace_rebuilds_trajectories_that_agree_with_the_log() {
    let dir = tempfile::tempdir().unwrap();
    let (log, trace) = (dir.path().join("r.log"), dir.path().join("r.jsonl"));
    let o = nekosim(&[
        "run",
        "examples/scenarios/random_movement.ron",
        "--until",
        "60",
        "--log",
        log.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let log = std::fs::read_to_string(log).unwrap();
    let trace: Vec<Value> = std::fs::read_to_string(trace)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(
        log.lines().count(),
        trace.len() - crate::common::silent_arrivals(&trace),
        "one log line per trace object but arrivals after a finishing step"
    );
    // Rebuild each robot's kinematic state from the trace alone: (t, pos, vel) pieces.
    let mut pieces: Vec<Vec<Piece>> = Vec::new();
    let mut seq = -1i64;
    for v in &trace {
        let s = v["seq"].as_i64().unwrap();
        assert!(s > seq);
        seq = s;
        let p = |k: &str| [v[k][0].as_f64().unwrap(), v[k][1].as_f64().unwrap()];
        match v["kind"].as_str().unwrap() {
            "spawn" => pieces.push(vec![(0.0, p("pos"), [0.0, 0.0])]),
            "start_turn" | "finish_turn" | "start_forward" | "finish_forward" => pieces
                [v["robot"].as_u64().unwrap() as usize]
                .push((v["t"].as_f64().unwrap(), p("pos"), p("vel"))),
            "motion_finish" => pieces[v["robot"].as_u64().unwrap() as usize].push((
                v["t"].as_f64().unwrap(),
                p("pos"),
                [0.0, 0.0],
            )),
            _ => {}
        }
    }
    let at = |robot: usize, t: f64| {
        let ps = &pieces[robot];
        let i = ps.partition_point(|x| x.0 <= t).saturating_sub(1);
        let (t0, p, v) = ps[i];
        (p[0] + v[0] * (t - t0), p[1] + v[1] * (t - t0))
    };
    // Every position the log prints (events and collisions) matches the rebuilt trajectory
    // at the log's time, to the log's three decimals.
    let mut checked = 0;
    for line in log.lines() {
        let fields: Vec<&str> = line.split('|').collect();
        if !(line.contains(" Event: ") || line.contains(" CollisionEvent: ")) {
            continue;
        }
        let t: f64 = fields[1].trim().parse().unwrap();
        let robot: usize = fields[2].trim().parse().unwrap();
        let (x, y) = log_point(fields[3]);
        // The log's time has three decimals too: compare at the trace's exact time.
        let exact = trace
            .iter()
            .find(|v| {
                v["robot"].as_u64() == Some(robot as u64)
                    && (v["t"].as_f64().unwrap() - t).abs() <= 0.0005
                    && v["pos"].is_array()
            })
            .map(|v| v["t"].as_f64().unwrap())
            .unwrap();
        let (rx, ry) = at(robot, exact);
        assert!(
            (rx - x).abs() <= 0.0015 && (ry - y).abs() <= 0.0015,
            "{line}\nrebuilt ({rx}, {ry})"
        );
        checked += 1;
    }
    assert!(checked > 500, "{checked}");
}

/// The number after `key: ` in the run summary.
fn summary_count(stdout: &[u8], key: &str) -> u64 {
    let s = String::from_utf8_lossy(stdout);
    let at = s
        .find(&format!("{key}: "))
        .unwrap_or_else(|| panic!("no {key} in {s}"))
        + key.len()
        + 2;
    s[at..]
        .split(|c: char| !c.is_ascii_digit())
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn the_collision_examples_show_a_collision_and_a_cancelled_one() {
    let o = nekosim(&["run", "examples/scenarios/collision.ron"]);
    assert_eq!(summary_count(&o.stdout, "collisions"), 1);
    let o = nekosim(&["run", "examples/scenarios/cancelled_collision.ron"]);
    assert_eq!(summary_count(&o.stdout, "collisions"), 0);
    assert!(summary_count(&o.stdout, "cancelled events") >= 1);
    // Without robot 1 moving away, the same course ends in the predicted collision at 22.5 s.
    let text =
        std::fs::read_to_string(root().join("examples/scenarios/cancelled_collision.ron")).unwrap();
    let stay = text.replace("Wait(5.0),", "Wait(100.0),");
    let dir = tempfile::tempdir().unwrap();
    let (file, trace) = (dir.path().join("stay.ron"), dir.path().join("stay.jsonl"));
    std::fs::write(&file, stay).unwrap();
    let o = nekosim(&[
        "run",
        file.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(summary_count(&o.stdout, "collisions"), 1, "{}", stderr(&o));
    let collision: Value = std::fs::read_to_string(trace)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .find(|v| v["kind"] == "collision")
        .unwrap();
    assert_eq!(collision["t"].as_f64(), Some(22.5));
}

#[test]
fn communication_examples_deliver_in_one_order_from_the_trace() {
    for (file, correct, per_robot) in [
        (
            "examples/scenarios/abcast_lamport.ron",
            vec![0u64, 1, 2, 3],
            20usize,
        ),
        ("examples/scenarios/consensus_abcast.ron", vec![0, 1, 2], 10),
        ("examples/scenarios/lossy_abcast.ron", vec![0, 1, 2, 3], 10),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let trace = dir.path().join("t.jsonl");
        let o = nekosim(&["run", file, "--trace", trace.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let mut seqs: std::collections::BTreeMap<u64, Vec<String>> = Default::default();
        let mut crashed = Vec::new();
        for line in std::fs::read_to_string(trace).unwrap().lines() {
            let v: Value = serde_json::from_str(line).unwrap();
            match v["kind"].as_str().unwrap() {
                "deliver" if v["layer"] == "abcast" => seqs
                    .entry(v["robot"].as_u64().unwrap())
                    .or_default()
                    .push(v["msg"].as_str().unwrap().to_string()),
                "crash" => crashed.push(v["robot"].as_u64().unwrap()),
                _ => {}
            }
        }
        let first = &seqs[&correct[0]];
        for p in &correct {
            assert!(!crashed.contains(p));
            let s = &seqs[p];
            assert_eq!(s, first, "{file}: p{p} delivers a different sequence");
            // Validity: every correct robot's messages are all there, once.
            for q in &correct {
                let mine = s.iter().filter(|m| m.starts_with(&format!("{q}:"))).count();
                assert_eq!(mine, per_robot, "{file}: p{p} has {mine} messages of p{q}");
            }
        }
    }
}

/// Runs an example scenario with `--trace` and returns the trace's objects.
fn example_trace(file: &str) -> Vec<Value> {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.jsonl");
    let o = nekosim(&["run", file, "--trace", trace.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    std::fs::read_to_string(trace)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// Each robot's decision (time, value; at most one) and arrival point, from a trace.
type Decisions = std::collections::BTreeMap<u64, (f64, String)>;
fn decisions_and_arrivals(
    trace: &[Value],
) -> (Decisions, std::collections::BTreeMap<u64, (f64, f64)>) {
    let mut decided = Decisions::new();
    let mut arrived = std::collections::BTreeMap::new();
    for v in trace {
        let robot = v["robot"].as_u64();
        match v["kind"].as_str().unwrap() {
            "decide" => assert!(
                decided
                    .insert(
                        robot.unwrap(),
                        (
                            v["t"].as_f64().unwrap(),
                            v["value"].as_str().unwrap().to_string()
                        )
                    )
                    .is_none(),
                "decided twice"
            ),
            "motion_finish" if v["outcome"] == "arrived" => {
                arrived.insert(
                    robot.unwrap(),
                    (v["pos"][0].as_f64().unwrap(), v["pos"][1].as_f64().unwrap()),
                );
            }
            _ => {}
        }
    }
    (decided, arrived)
}

fn same_point(a: (f64, f64), b: (f64, f64)) -> bool {
    (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9
}

#[test]
fn lossy_example_loses_copies_that_retransmit_recovers() {
    let trace = example_trace("examples/scenarios/lossy_abcast.ron");
    let (mut copies, mut received) = (0usize, 0usize);
    for v in &trace {
        match v["kind"].as_str().unwrap() {
            "send" => copies += v["to"].as_array().unwrap().len(),
            "receive" => received += 1,
            _ => {}
        }
    }
    // p = 0.2: about a fifth of the copies are lost (binomial, thousands of copies).
    let lost = 1.0 - received as f64 / copies as f64;
    assert!(
        (0.15..0.25).contains(&lost),
        "{received} of {copies} copies arrived"
    );
}

#[test]
fn partition_blocks_the_minority_until_it_heals_then_everybody_agrees() {
    let trace = example_trace("examples/scenarios/partition_consensus.ron");
    let side = |r: u64| r < 2;
    // Nothing crosses the cut while it lasts.
    let crossing = trace
        .iter()
        .filter(|v| {
            v["kind"] == "receive"
                && v["t"].as_f64().unwrap() < 30.0
                && side(v["robot"].as_u64().unwrap()) != side(v["from"].as_u64().unwrap())
        })
        .count();
    assert_eq!(crossing, 0, "messages crossed the partition");
    let (decided, arrived) = decisions_and_arrivals(&trace);
    assert_eq!(decided.len(), 5, "everybody decides: {decided:?}");
    let value = &decided[&2].1;
    for (p, (t, v)) in &decided {
        assert_eq!(v, value, "agreement");
        if side(*p) {
            assert!(*t >= 30.0, "p{p} decided at {t}, inside the partition");
        } else {
            assert!(
                *t < 30.0,
                "the majority decides during the partition (p{p} at {t})"
            );
        }
        assert!(same_point(arrived[p], arrived[&2]), "p{p} meets the others");
    }
}

#[test]
fn every_correct_robot_meets_at_the_same_decided_point_despite_a_crash() {
    let trace = example_trace("examples/scenarios/meeting_point.ron");
    let (decided, arrived) = decisions_and_arrivals(&trace);
    let spawn: Vec<(f64, f64)> = trace
        .iter()
        .filter(|v| v["kind"] == "spawn")
        .map(|v| (v["pos"][0].as_f64().unwrap(), v["pos"][1].as_f64().unwrap()))
        .collect();
    assert!(
        !decided.contains_key(&0),
        "the crashed robot decides nothing"
    );
    let value = &decided[&1].1;
    for p in [1u64, 2, 3, 4] {
        assert_eq!(&decided[&p].1, value, "agreement");
        assert!(
            same_point(arrived[&p], arrived[&1]),
            "everybody at the same point"
        );
    }
    // Validity: the decided point (the trace shows the value as RON) is somebody's born
    // position, exactly.
    let nekosim::algorithm::Meet(x, y) = ron::from_str(value).expect("a MEET value");
    assert!(spawn.contains(&(x, y)), "{value} was never proposed");
}

#[test]
fn broadcast_load_summary_reports_latency_computed_from_the_trace() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.jsonl");
    let o = nekosim(&[
        "run",
        "examples/scenarios/abcast_lamport.ron",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Independent computation: broadcast k of robot o is message "o:k".
    let mut sent = std::collections::HashMap::new();
    let mut count = std::collections::HashMap::new();
    let mut lat = Vec::new();
    for line in std::fs::read_to_string(trace).unwrap().lines() {
        let v: Value = serde_json::from_str(line).unwrap();
        let t = v["t"].as_f64().unwrap();
        match v["kind"].as_str().unwrap() {
            "request" if v["op"] == "broadcast" => {
                let r = v["robot"].as_u64().unwrap();
                let k = count.entry(r).or_insert(0u64);
                sent.insert(format!("{r}:{k}"), t);
                *k += 1;
            }
            "deliver" => lat.push(t - sent[v["msg"].as_str().unwrap()]),
            _ => {}
        }
    }
    assert_eq!(lat.len(), 320);
    let mean = lat.iter().sum::<f64>() / lat.len() as f64;
    lat.sort_by(f64::total_cmp);
    let p50 = lat[159];
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("deliveries: 320,"), "{out}");
    assert!(
        out.contains(&format!("latency mean: {mean:.3} s, p50: {p50:.3} s")),
        "{out}\nmean {mean} p50 {p50}"
    );
}

#[test]
fn path_reservation_avoids_the_collisions_that_random_movement_has() {
    let text =
        std::fs::read_to_string(root().join("examples/scenarios/path_reservation.ron")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for seed in ["5", "6", "7"] {
        let trace = dir.path().join(format!("r{seed}.jsonl"));
        let o = nekosim(&[
            "run",
            "examples/scenarios/path_reservation.ron",
            "--until",
            "120",
            "--seed",
            seed,
            "--trace",
            trace.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert_eq!(summary_count(&o.stdout, "collisions"), 0, "seed {seed}");
        let arrivals = std::fs::read_to_string(trace)
            .unwrap()
            .lines()
            .filter(|l| l.contains("\"arrived\""))
            .count();
        assert!(
            arrivals >= 20,
            "seed {seed}: the robots did move ({arrivals} trips)"
        );
        // The same robots moving without reservations collide.
        let free = text.replace(
            "PathReservation(layer: \"abcast\", move_speed: 8.0)",
            "RandomMovement(move_speed: (8.0, 8.0))",
        );
        let file = dir.path().join(format!("free{seed}.ron"));
        std::fs::write(&file, free).unwrap();
        let o = nekosim(&[
            "run",
            file.to_str().unwrap(),
            "--until",
            "120",
            "--seed",
            seed,
        ]);
        assert!(
            summary_count(&o.stdout, "collisions") > 0,
            "seed {seed}: {}",
            String::from_utf8_lossy(&o.stdout)
        );
    }
}
