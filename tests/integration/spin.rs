//! SPIN on spin-light's Promela model (tests/integration/spin_light/, MIT licence, from
//! github.com/xdefago/spin-light at 7a752849): MainGathering.pml, Robots.pml,
//! Schedulers.pml and Types.pml as they are, with an Algorithms.pml written from a rule table
//! (every case of my light, the light I see and "same point", so the Promela `if` is
//! deterministic), run as spin-light's verify.py runs it: `spin -a`, `cc -DMEMLIM=4096
//! -DXUSAFE -DNOREDUCE -O2`, `./pan -m100000 -a -f -E -n gathering`. A trail file means the
//! property `<>[] (position == SAME)` fails.

use std::path::Path;
use std::process::Command;

use nekosim::lcm::rule_table::{Move, RuleTable};

const FILES: [(&str, &str); 4] = [
    (
        "MainGathering.pml",
        include_str!("spin_light/MainGathering.pml"),
    ),
    ("Robots.pml", include_str!("spin_light/Robots.pml")),
    ("Schedulers.pml", include_str!("spin_light/Schedulers.pml")),
    ("Types.pml", include_str!("spin_light/Types.pml")),
];

/// Whether `spin` and a C compiler are on the path.
pub fn available() -> bool {
    let runs = |c: &str, a: &str| {
        Command::new(c)
            .arg(a)
            .output()
            .is_ok_and(|o| o.status.success())
    };
    runs("spin", "-V") && runs("cc", "--version")
}

/// The Algorithms.pml of a rule table, for robots that see both lights.
pub fn algorithm_pml(table: &RuleTable) -> String {
    let n = table.lights.len() as u8;
    let mut rows = String::new();
    for me in 0..n {
        for other in 0..n {
            for same in [false, true] {
                let known = |l: u8| Some(if n == 1 { 0 } else { l });
                let (go, light) = table
                    .rule(known(me), known(other), same)
                    .map_or((Move::Stay, me), |r| (r.go, r.light.unwrap_or(me)));
                let go = match go {
                    Move::Stay => "STAY",
                    Move::ToHalf => "TO_HALF",
                    Move::ToOther => "TO_OTHER",
                };
                rows.push_str(&format!(
                    "    :: (obs.color.me == {me} && obs.color.other == {other} && {}obs.same_position) -> command.move = {go}; command.new_color = {light}\n",
                    if same { "" } else { "!" }
                ));
            }
        }
    }
    format!(
        "#ifndef __ALGORITHMS_PML__\n#define __ALGORITHMS_PML__\n#define ALGO_NAME \"RULE_TABLE\"\n#define Algorithm(o,c) Alg_Table(o,c)\n#define MAX_COLOR ({})\ninline Alg_Table(obs, command)\n{{\n    if\n{rows}    fi\n}}\n#define NUM_COLORS  ((MAX_COLOR)-(BLACK)+1)\n#endif\n",
        n - 1
    )
}

/// SPIN's verdict on `table` under the scheduler `variant` (Schedulers.pml's name): `Some(true)`
/// when the property holds, `Some(false)` when pan writes a trail, `None` when its search
/// is incomplete. Works in `dir`.
pub fn verdict(dir: &Path, table: &RuleTable, variant: &str, rigid: bool) -> Option<bool> {
    for (name, text) in FILES {
        std::fs::write(dir.join(name), text).unwrap();
    }
    std::fs::write(dir.join("Algorithms.pml"), algorithm_pml(table)).unwrap();
    let run = |cmd: &mut Command| {
        let out = cmd.current_dir(dir).output().expect("runs");
        assert!(
            out.status.success() || cmd.get_program() == "./pan",
            "{cmd:?}: {}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let movement = if rigid { "RIGID" } else { "NON_RIGID" };
    run(Command::new("spin").args([
        "-a",
        "-DALGO=1",
        &format!("-DSCHEDULER={variant}"),
        &format!("-DMOVEMENT={movement}"),
        "MainGathering.pml",
    ]));
    run(Command::new("cc").args([
        "-DMEMLIM=4096",
        "-DXUSAFE",
        "-DNOREDUCE",
        "-O2",
        "-w",
        "-o",
        "pan",
        "pan.c",
    ]));
    let _ = std::fs::remove_file(dir.join("MainGathering.pml.trail"));
    let report = run(Command::new("./pan").args(["-m100000", "-a", "-f", "-E", "-n", "gathering"]));
    if dir.join("MainGathering.pml.trail").exists() {
        Some(false)
    } else if report.contains("Search not completed") || !report.contains("errors: 0") {
        None
    } else {
        Some(true)
    }
}
