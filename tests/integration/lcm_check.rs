//! `nekosim check` on two-robot rule tables: the verdict of every shipped table under
//! spin-light's 12 scheduler variants, rigid and non-rigid; known answers (to-half under FSYNC
//! and SSYNC, the optimal two-colour algorithm under ASYNC, bounded fairness); the command's
//! report, trace and exit codes; and SPIN run on a sample, shipped tables, random tables and
//! one-rule mutants, whose verdicts must equal nekosim's.

use std::path::PathBuf;
use std::process::Command;
use std::sync::{Mutex, OnceLock};

use nekosim::check::lcm::{
    decide, replay, rule_table_of, Abstraction, RobotFairness, State, Step, Variant,
};
use nekosim::lcm::rule_table::{Move, RuleConfig, RuleTable, RuleTableConfig};
use nekosim::lcm::settings::Lights;
use nekosim::scenario::Source;
use nekosim_models::liveness::{Limits, Liveness, Verdict};

use crate::spin;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every shipped two-robot rule table, by file stem, in name order.
fn shipped() -> Vec<(String, RuleTable)> {
    let mut v: Vec<(String, RuleTable)> = std::fs::read_dir(root().join("examples/lcm"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .filter_map(|p| {
            let source = Source::load(&p).unwrap();
            let (table, _) = rule_table_of(&source)?.expect("a valid table");
            Some((p.file_stem().unwrap().to_string_lossy().into_owned(), table))
        })
        .collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v
}

fn table(name: &str) -> RuleTable {
    shipped()
        .into_iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("{name}"))
        .1
}

/// Gathering `<>[] (position == SAME)` under `fairness`: true when it holds.
fn gathers(t: &RuleTable, variant: Variant, rigid: bool, fairness: RobotFairness) -> bool {
    let d = decide(
        t,
        Lights::Full,
        variant,
        rigid,
        fairness,
        Liveness::EventuallyAlways,
        Limits::default(),
    )
    .expect("small");
    matches!(d.verdict, Verdict::Holds)
}

/// One shipped table under one variant and movement, decided under spin-light's fairness.
struct Case {
    name: String,
    source: Source,
    table: RuleTable,
    lights: Lights,
    variant: Variant,
    rigid: bool,
    verdict: Verdict<State, Step>,
}

/// Every shipped table under each of the 12 variants, rigid and non-rigid: decided once, on
/// two threads, for every test that reads them (the largest models take seconds each in a
/// debug build).
fn every_case() -> &'static [Case] {
    static CASES: OnceLock<Vec<Case>> = OnceLock::new();
    CASES.get_or_init(|| {
        let mut todo = Vec::new();
        for (name, _) in shipped() {
            let source = Source::load(&root().join(format!("examples/lcm/{name}.ron"))).unwrap();
            let (table, lights) = rule_table_of(&source).unwrap().unwrap();
            for variant in Variant::ALL {
                for rigid in [true, false] {
                    todo.push((
                        name.clone(),
                        source.clone(),
                        table.clone(),
                        lights,
                        variant,
                        rigid,
                    ));
                }
            }
        }
        let n = todo.len();
        let todo = Mutex::new(todo.into_iter().enumerate().collect::<Vec<_>>());
        let done = Mutex::new(Vec::with_capacity(n));
        std::thread::scope(|scope| {
            for _ in 0..2 {
                scope.spawn(|| loop {
                    let Some((i, (name, source, table, lights, variant, rigid))) =
                        todo.lock().unwrap().pop()
                    else {
                        break;
                    };
                    let verdict = decide(
                        &table,
                        lights,
                        variant,
                        rigid,
                        RobotFairness::SpinLight,
                        Liveness::EventuallyAlways,
                        Limits::default(),
                    )
                    .expect("small")
                    .verdict;
                    let case = Case {
                        name,
                        source,
                        table,
                        lights,
                        variant,
                        rigid,
                        verdict,
                    };
                    done.lock().unwrap().push((i, case));
                });
            }
        });
        let mut done = done.into_inner().unwrap();
        done.sort_by_key(|c| c.0);
        done.into_iter().map(|c| c.1).collect()
    })
}

/// The verdicts of `name`'s cases of one movement, in [`Variant::ALL`] order: `P` holds.
fn row(name: &str, rigid: bool) -> String {
    every_case()
        .iter()
        .filter(|c| c.name == name && c.rigid == rigid)
        .map(|c| match c.verdict {
            Verdict::Holds => 'P',
            Verdict::Fails(_) => '-',
        })
        .collect()
}

/// Gathering's verdict for every shipped table under spin-light's fairness, per variant in
/// [`Variant::ALL`] order (CENTRALIZED, FSYNC, SSYNC, ASYNC, ASYNC_REGULAR, ASYNC_SAFE,
/// ASYNC_MOVE_ATOMIC, ASYNC_MOVE_REGULAR, ASYNC_MOVE_SAFE, ASYNC_LC_ATOMIC, ASYNC_LC_STRICT,
/// ASYNC_CM_ATOMIC), `P` holds and `-` fails: rigid, then non-rigid. Computed by nekosim and
/// cross-checked against SPIN on spin-light's model where
/// `spin_agrees_on_a_sample_of_tables_and_variants` samples it (docs/model-checking.md).
const TABLE: [(&str, &str, &str); 15] = [
    ("ext3_non_qss", "P---------P-", "P---------P-"),
    ("flocchini_3ext", "PPP---------", "PPP---------"),
    ("flocchini_3ext_prime", "PP----------", "PP----------"),
    ("no_move", "------------", "------------"),
    ("optimal_2", "PPPP--P--PPP", "PPPP--P--PPP"),
    ("regular_4", "PPPPP-PP-PPP", "PPPPP-PP-PPP"),
    ("regular_5", "PPPPP-PP-PPP", "PPPPP-PP-PPP"),
    ("regular_6", "PPPPP-PP-PPP", "PPPPP-PP-PPP"),
    ("tixeuil_extra", "PP----------", "PP----------"),
    ("to_half", "-P----------", "-P----------"),
    ("to_other", "P-----------", "P-----------"),
    ("viglietta_2", "PPP------PP-", "PPP------PP-"),
    ("viglietta_3", "PPPP--P--PPP", "PPPP--P--PPP"),
    ("wada_4ext", "P---------P-", "P---------P-"),
    ("wada_5ext", "PPP------PP-", "PPP------PP-"),
];

#[test]
fn the_verdict_table_of_every_shipped_rule_table() {
    let tables = shipped();
    assert_eq!(
        tables.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(),
        TABLE.map(|r| r.0).to_vec()
    );
    for ((name, _), (_, rigid, non_rigid)) in tables.iter().zip(TABLE) {
        assert_eq!(row(name, true), rigid, "{name}, rigid");
        assert_eq!(row(name, false), non_rigid, "{name}, non-rigid");
    }
}

#[test]
fn to_half_gathers_under_fsync_and_not_under_ssync() {
    let t = table("to_half");
    for fairness in [
        RobotFairness::Weak,
        RobotFairness::Strong,
        RobotFairness::SpinLight,
    ] {
        assert!(gathers(&t, Variant::Fsync, true, fairness));
        assert!(gathers(&t, Variant::Fsync, false, fairness));
        let d = decide(
            &t,
            Lights::Full,
            Variant::Ssync,
            true,
            fairness,
            Liveness::EventuallyAlways,
            Limits::default(),
        )
        .unwrap();
        let Verdict::Fails(lasso) = d.verdict else {
            panic!("to-half gathers under SSYNC with {fairness:?}");
        };
        // The cycle keeps the robots apart throughout, and activates both robots.
        assert!(!lasso.cycle.is_empty());
        assert!(lasso
            .cycle
            .iter()
            .all(|(_, s)| s.position != nekosim::check::lcm::Position::Same));
        for r in 0..2 {
            assert!(
                lasso
                    .cycle
                    .iter()
                    .any(|(step, _)| step.phases.iter().any(|p| p.0 == r)),
                "{lasso:?}"
            );
        }
    }
}

#[test]
fn optimal_2_gathers_under_async_rigid_and_non_rigid() {
    let t = table("optimal_2");
    for rigid in [true, false] {
        for fairness in [
            RobotFairness::Weak,
            RobotFairness::Strong,
            RobotFairness::SpinLight,
        ] {
            assert!(
                gathers(&t, Variant::Async, rigid, fairness),
                "{rigid} {fairness:?}"
            );
        }
        // A safe register lets a Look read any colour mid-Compute, which defeats it.
        assert!(!gathers(
            &t,
            Variant::AsyncSafe,
            rigid,
            RobotFairness::SpinLight
        ));
    }
}

/// Under ASYNC with at most one step in a row per robot, the scheduler must alternate robots
/// phase by phase: both Look before either moves, and the second mover's pending `ToHalf`
/// becomes `ToOther` when the first lands on the midpoint, so to-half gathers; with two steps
/// in a row one robot can Look, compute and move before the other Looks, and the SSYNC
/// counterexample comes back.
#[test]
fn bounded_fairness_changes_a_verdict() {
    let t = table("to_half");
    for rigid in [true, false] {
        assert!(gathers(
            &t,
            Variant::Async,
            rigid,
            RobotFairness::Bounded(Some(1))
        ));
        assert!(!gathers(
            &t,
            Variant::Async,
            rigid,
            RobotFairness::Bounded(Some(2))
        ));
        assert!(!gathers(&t, Variant::Async, rigid, RobotFairness::Weak));
    }
}

fn nekosim_bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_nekosim"))
}

#[test]
fn the_command_reports_a_lasso_and_writes_it() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("cx.jsonl");
    let out = nekosim_bin()
        .args([
            "check",
            "examples/lcm/to_half.ron",
            "--synchrony",
            "ssync",
            "--trace",
        ])
        .arg(&trace)
        .current_dir(root())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(text.contains("fails ("), "{text}");
    assert!(
        text.contains("  stem:") && text.contains("  cycle (repeats forever"),
        "{text}"
    );
    assert!(text.contains("reason: the cycle repeats forever"), "{text}");
    let lines: Vec<serde_json::Value> = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(lines.iter().any(|l| l["part"] == "cycle"));
    assert!(lines.last().unwrap()["reason"].is_string());

    let out = nekosim_bin()
        .args(["check", "examples/lcm/optimal_2.ron"])
        .current_dir(root())
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let out = nekosim_bin()
        .args(["check", "examples/lcm/optimal_2.ron", "--max-states", "10"])
        .current_dir(root())
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    for bad in [
        ["--fairness", "bounded:0"],
        ["--synchrony", "sometimes"],
        ["--movement", "bouncy"],
    ] {
        let out = nekosim_bin()
            .args(["check", "examples/lcm/optimal_2.ron"])
            .args(bad)
            .current_dir(root())
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{bad:?}");
    }
    // A register the variant does not model is refused.
    let out = nekosim_bin()
        .args([
            "check",
            "examples/lcm/optimal_2.ron",
            "--synchrony",
            "fsync",
            "--register",
            "safe",
        ])
        .current_dir(root())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

/// A seeded xorshift: the sample needs no crate.
struct Rng(u64);

impl Rng {
    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0 % n
    }
}

fn full_table(colours: u8, pick: &mut dyn FnMut(u8, u8, bool) -> (Move, u8)) -> RuleTable {
    let names: Vec<String> = (0..colours).map(|c| format!("c{c}")).collect();
    let mut rules = Vec::new();
    for me in 0..colours {
        for other in 0..colours {
            for same in [false, true] {
                let (go, light) = pick(me, other, same);
                rules.push(RuleConfig {
                    me: Some(names[me as usize].clone()),
                    other: Some(names[other as usize].clone()),
                    same: Some(same),
                    go,
                    light: Some(names[light as usize].clone()),
                });
            }
        }
    }
    RuleTable::new(
        RuleTableConfig {
            lights: names,
            rules,
        },
        Lights::Full,
    )
    .unwrap()
}

/// `t` with the row for (me, other, same) replaced.
fn mutant(t: &RuleTable, me: u8, other: u8, same: bool, go: Move, light: u8) -> RuleTable {
    let n = t.lights.len() as u8;
    full_table(n, &mut |m, o, s| {
        if (m, o, s) == (me, other, same) {
            (go, light)
        } else {
            let r = t.rule(Some(m), Some(o), s).unwrap();
            (r.go, r.light.unwrap_or(m))
        }
    })
}

const MOVES: [Move; 3] = [Move::Stay, Move::ToHalf, Move::ToOther];

/// The sample SPIN checks: shipped tables under several variants, random tables, and one-rule
/// mutants of the algorithms that gather under ASYNC.
fn sample() -> Vec<(String, RuleTable, Variant, bool)> {
    use Variant::*;
    let mut v: Vec<(String, RuleTable, Variant, bool)> = [
        ("to_half", Fsync, true),
        ("to_half", Ssync, true),
        ("to_half", Async, false),
        ("no_move", Centralized, true),
        ("to_other", AsyncLcAtomic, true),
        ("optimal_2", Async, false),
        ("optimal_2", AsyncSafe, true),
        ("optimal_2", AsyncMoveRegular, true),
        ("viglietta_2", AsyncRegular, true),
        ("viglietta_2", AsyncLcStrict, false),
        ("flocchini_3ext", Ssync, false),
        ("flocchini_3ext", AsyncCmAtomic, true),
        ("wada_4ext", AsyncLcAtomic, true),
        ("ext3_non_qss", Fsync, true),
        ("tixeuil_extra", Fsync, false),
        ("regular_4", AsyncMoveAtomic, true),
        ("regular_4", AsyncMoveSafe, true),
    ]
    .into_iter()
    .map(|(n, var, rigid)| (n.to_string(), table(n), var, rigid))
    .collect();
    let mut rng = Rng(0x5EED_2023);
    for i in 0..6 {
        let colours = 1 + rng.below(3) as u8;
        let t = full_table(colours, &mut |_, _, _| {
            (
                MOVES[rng.below(3) as usize],
                rng.below(u64::from(colours)) as u8,
            )
        });
        let var = Variant::ALL[rng.below(12) as usize];
        v.push((format!("random {i}"), t, var, rng.below(2) == 0));
    }
    for (base, var) in [
        ("optimal_2", Async),
        ("optimal_2", AsyncLcAtomic),
        ("viglietta_3", Ssync),
        ("regular_4", AsyncCmAtomic),
    ] {
        let t = table(base);
        let n = t.lights.len() as u64;
        let (me, other, same) = (rng.below(n) as u8, rng.below(n) as u8, rng.below(2) == 0);
        let m = mutant(
            &t,
            me,
            other,
            same,
            MOVES[rng.below(3) as usize],
            rng.below(n) as u8,
        );
        v.push((
            format!("{base} with ({me}, {other}, {same}) changed"),
            m,
            var,
            rng.below(2) == 0,
        ));
    }
    v
}

#[test]
fn spin_agrees_on_a_sample_of_tables_and_variants() {
    if !spin::available() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but spin (or cc) is missing: .ci/run installs it"
        );
        eprintln!("\n\n*** SKIPPED spin_agrees_on_a_sample_of_tables_and_variants: `spin` or `cc` is not installed (apt-get install spin) ***\n");
        return;
    }
    let cases = sample();
    let todo = std::sync::Mutex::new(cases.iter().enumerate().collect::<Vec<_>>());
    let results = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..2 {
            scope.spawn(|| {
                let dir = tempfile::tempdir().unwrap();
                loop {
                    let Some((i, (name, t, var, rigid))) = todo.lock().unwrap().pop() else {
                        break;
                    };
                    let theirs = spin::verdict(dir.path(), t, var.spin_name(), *rigid);
                    let ours = gathers(t, *var, *rigid, RobotFairness::SpinLight);
                    results
                        .lock()
                        .unwrap()
                        .push((i, name.clone(), *var, *rigid, ours, theirs));
                }
            });
        }
    });
    let mut results = results.into_inner().unwrap();
    results.sort_by_key(|r| r.0);
    let mut holds = 0;
    for (_, name, var, rigid, ours, theirs) in &results {
        assert_eq!(
            Some(*ours),
            *theirs,
            "{name} under {var:?}, rigid {rigid}: nekosim {ours}, SPIN {theirs:?}"
        );
        holds += usize::from(*ours);
    }
    eprintln!(
        "SPIN agrees with nekosim on {} cases ({holds} hold)",
        results.len()
    );
    // The sample has both verdicts.
    assert_eq!(results.len(), 27);
    assert!(
        holds >= 4 && holds + 4 <= results.len(),
        "{holds} of {}",
        results.len()
    );
}

/// A lasso replays in the simulator: to-half under SSYNC, the stem once and the cycle twice
/// through the scripted adversary, follows the lasso step by step with the robots apart in
/// each repetition; under ASYNC too (one phase a step, each a second), for Viglietta's two
/// colours; and the replay is recorded with `--rrd`.
#[test]
fn a_lasso_replays_in_the_simulator() {
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("lasso.rrd");
    for (example, synchrony, record) in [
        ("to_half", "ssync", true),
        ("viglietta_2", "async", false),
        ("to_other", "async-lc-atomic", false),
    ] {
        let mut cmd = nekosim_bin();
        cmd.args([
            "check",
            &format!("examples/lcm/{example}.ron"),
            "--synchrony",
            synchrony,
        ]);
        if record && cfg!(feature = "rerun") {
            cmd.arg("--rrd").arg(&rrd);
        }
        let out = cmd.current_dir(root()).output().expect("runs");
        let text = String::from_utf8_lossy(&out.stdout);
        assert_eq!(out.status.code(), Some(1), "{example}: {text}");
        assert!(
            text.contains("it follows the lasso step by step")
                && text.contains("and the robots are apart after"),
            "{example} under {synchrony}: {text}"
        );
        if record && cfg!(feature = "rerun") {
            assert!(std::fs::metadata(&rrd).map(|m| m.len()).unwrap_or(0) > 1_000);
        }
    }
}

/// Every lasso of every shipped table, under each of the 12 variants, rigid and non-rigid,
/// replays in the simulator and shows its violation: after each step of the stem and of the
/// cycle's two repetitions the simulated run has the model's lights, and its robots share a
/// point exactly when the model's do, and in each repetition the robots are apart.
#[test]
fn every_lasso_of_the_shipped_tables_replays_its_violation() {
    let mut replayed = 0;
    let mut failing = Vec::new();
    for c in every_case() {
        let Verdict::Fails(lasso) = &c.verdict else {
            continue;
        };
        let case = format!("{} under {:?}, rigid {}", c.name, c.variant, c.rigid);
        let model = Abstraction {
            table: &c.table,
            lights: c.lights,
            variant: c.variant,
            rigid: c.rigid,
            bound: None,
        };
        let plan = replay::replay(&model, lasso)
            .unwrap_or_else(|| panic!("{case}: the lasso has a cycle"));
        let records = replay::simulate(&c.source, &model, &plan).expect("the replay runs");
        match replay::shows(&plan, &records) {
            Ok(s) if s.apart.iter().all(|&n| n > 0) => {}
            other => failing.push((case, other)),
        }
        replayed += 1;
    }
    assert!(
        failing.is_empty(),
        "{} of {replayed} replays do not show their violation: {failing:#?}",
        failing.len()
    );
    // Every `-` of the verdict table is a lasso replayed here.
    let fails: usize = TABLE
        .iter()
        .map(|(_, r, n)| r.matches('-').count() + n.matches('-').count())
        .sum();
    assert_eq!(replayed, fails);
    eprintln!("{replayed} lassos replayed, each showing its violation");
}

/// Runs `nekosim check ARGS` in the crate's root, sends it what a terminal's Ctrl-C sends
/// once its report's first line (`first`) is out and `wait` has passed, and returns its exit
/// code and report.
pub(crate) fn interrupted(
    args: &[&str],
    first: &str,
    wait: std::time::Duration,
) -> (Option<i32>, String) {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let mut child = nekosim_bin()
        .arg("check")
        .args(args)
        .current_dir(root())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let mut out = String::new();
    for line in lines.by_ref() {
        let line = line.unwrap();
        out.push_str(&line);
        out.push('\n');
        if line.starts_with(first) {
            break;
        }
    }
    assert!(out.contains(first), "{out}");
    std::thread::sleep(wait);
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    for line in lines {
        out.push_str(&line.unwrap());
        out.push('\n');
    }
    (child.wait().unwrap().code(), out)
}

/// The exhaustive check honours its budgets as a stack check does: a memory budget the
/// process is already above stops it before its first state (exit 3, saying what stopped it
/// and how far it went), and Ctrl-C during a long exploration (six colours under a safe
/// register, up to 255 steps in a row) stops it too (exit 130), with what it covered. A
/// budget of 1 GiB keeps a lost signal from running the test out of memory: it would end in
/// exit 3, not 130.
#[test]
fn the_exhaustive_check_stops_at_its_memory_budget_and_at_ctrl_c() {
    let out = nekosim_bin()
        .args([
            "check",
            "examples/lcm/optimal_2.ron",
            "--max-memory",
            "1KiB",
        ])
        .current_dir(root())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(3), "{text}");
    assert!(
        text.contains("open (stopped by the memory budget (resident ")
            && text.contains(
                " of 1.0 KiB) after 0 states explored, before the search was exhaustive)"
            ),
        "{text}"
    );
    let (code, text) = interrupted(
        &[
            "examples/lcm/regular_6.ron",
            "--synchrony",
            "async",
            "--register",
            "safe",
            "--movement",
            "non-rigid",
            "--fairness",
            "bounded:255",
            "--max-memory",
            "1GiB",
        ],
        "model: ",
        std::time::Duration::from_millis(500),
    );
    assert_eq!(code, Some(130), "{text}");
    let explored: u64 = text
        .split("open (stopped by Ctrl-C after ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{text}"));
    assert!(explored > 0, "{text}");
}
