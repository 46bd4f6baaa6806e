//! The whole verdict table of the shipped two-robot rule tables (every table × spin-light's 12
//! scheduler variants × rigid and non-rigid), checked by nekosim, and SPIN (spin -a, cc, pan,
//! as spin-light's verify.py runs them) on a documented subset of it, side by side in one
//! run: `cargo bench --bench lcm_check`. SPIN compiles a verifier per case, so its side runs
//! the rigid column of five tables (60 cases) unless `LCM_CHECK_SPIN=all` asks for all 360.
//! docs/performance.md records the figures.

use std::time::Instant;

use nekosim::check::lcm::{decide, rule_table_of, RobotFairness, Variant};
use nekosim::lcm::rule_table::RuleTable;
use nekosim::lcm::settings::Lights;
use nekosim::scenario::Source;
use nekosim_models::liveness::{Limits, Liveness, Verdict};

#[path = "../tests/integration/spin.rs"]
mod spin;

const SUBSET: [&str; 5] = [
    "to_half",
    "optimal_2",
    "viglietta_2",
    "flocchini_3ext",
    "regular_4",
];

fn shipped() -> Vec<(String, RuleTable)> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/lcm");
    let mut v: Vec<(String, RuleTable)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .filter_map(|p| {
            let (t, _) = rule_table_of(&Source::load(&p).unwrap())?.unwrap();
            Some((p.file_stem().unwrap().to_string_lossy().into_owned(), t))
        })
        .collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v
}

fn ours(t: &RuleTable, v: Variant, rigid: bool) -> (bool, usize) {
    let d = decide(
        t,
        Lights::Full,
        v,
        rigid,
        RobotFairness::SpinLight,
        Liveness::EventuallyAlways,
        Limits::default(),
    )
    .unwrap();
    (matches!(d.verdict, Verdict::Holds), d.states)
}

fn main() {
    let tables = shipped();
    let all_spin = std::env::var("LCM_CHECK_SPIN").is_ok_and(|v| v == "all");
    let start = Instant::now();
    let mut states = 0;
    let mut verdicts = Vec::new();
    for (name, t) in &tables {
        for v in Variant::ALL {
            for rigid in [true, false] {
                let (holds, n) = ours(t, v, rigid);
                states += n;
                verdicts.push((name.clone(), v, rigid, holds));
            }
        }
    }
    let whole = start.elapsed().as_secs_f64();
    println!(
        "nekosim: whole table, {} cases, {states} states, {whole:.3} s",
        verdicts.len()
    );
    let subset: Vec<&(String, Variant, bool, bool)> = verdicts
        .iter()
        .filter(|(n, _, rigid, _)| all_spin || (*rigid && SUBSET.contains(&n.as_str())))
        .collect();
    let start = Instant::now();
    for (name, v, rigid, _) in &subset {
        let t = &tables.iter().find(|(n, _)| n == name).unwrap().1;
        ours(t, *v, *rigid);
    }
    let ours_subset = start.elapsed().as_secs_f64();
    println!(
        "nekosim: SPIN's subset, {} cases, {ours_subset:.3} s",
        subset.len()
    );
    if !spin::available() {
        println!("spin: not installed, SPIN's side skipped");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let start = Instant::now();
    let mut agree = 0;
    for (name, v, rigid, holds) in &subset {
        let t = &tables.iter().find(|(n, _)| n == name).unwrap().1;
        let theirs = spin::verdict(dir.path(), t, v.spin_name(), *rigid);
        if theirs == Some(*holds) {
            agree += 1;
        } else {
            println!("DISAGREE: {name} {v:?} rigid {rigid}: nekosim {holds}, SPIN {theirs:?}");
        }
    }
    let theirs = start.elapsed().as_secs_f64();
    println!(
        "spin: {} cases (spin -a, cc, pan), {theirs:.1} s, {agree} verdicts equal nekosim's",
        subset.len()
    );
    println!(
        "speed-up on the same cases: {:.0}x",
        theirs / ours_subset.max(1e-9)
    );
}
