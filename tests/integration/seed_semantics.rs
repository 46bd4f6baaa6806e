//! The seed's own semantics where nekosim's defaults differ (issue 16): MOVETO turning always
//! anticlockwise (seed eq. 4.1) as a world setting, walls separate from ghost mode, and inputs
//! refused at once that used to run into long searches or lost precision.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Runs `scenario` with `--set` pairs; the trace's records.
fn trace(dir: &Path, scenario: &str, sets: &[&str]) -> Vec<Value> {
    let file = dir.join("s.ron");
    std::fs::write(&file, scenario).unwrap();
    let t = dir.join("t.jsonl");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_nekosim"));
    cmd.arg("run")
        .arg(&file)
        .arg("--quiet")
        .arg("--trace")
        .arg(&t);
    for s in sets {
        cmd.args(["--set", s]);
    }
    let o = cmd.current_dir(root()).output().unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::read_to_string(t)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn finish(records: &[Value]) -> &Value {
    records
        .iter()
        .find(|r| r["kind"] == "motion_finish")
        .expect("a motion_finish")
}

#[test]
fn moveto_turns_the_shortest_way_by_default_and_anticlockwise_as_the_seed_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    // Facing 90 degrees, to a destination at heading 45: the shortest turn is -45 degrees
    // (1 s at 45 deg/s), the seed's anticlockwise turn +315 degrees (7 s); then sqrt(200) at 1/s.
    let scenario = "Scenario(until: 60.0, world: (size: Infinite), robots: [Robot(id: 0, radius: 1.0, at: (0.0, 0.0), angle: 90.0, algorithm: Script([MoveTo(x: 10.0, y: 10.0, move_speed: 1.0, turn_speed: 45.0)]))])";
    let leg = 200f64.sqrt();
    for (sets, turn_time) in [(vec![], 1.0), (vec!["world.turn=Anticlockwise"], 7.0)] {
        let rs = trace(dir.path(), scenario, &sets);
        let f = finish(&rs);
        assert_eq!(f["outcome"], "arrived", "{f}");
        let t = f["t"].as_f64().unwrap();
        assert!(
            (t - (turn_time + leg)).abs() < 1e-9,
            "{sets:?}: arrived at {t}, expected {}",
            turn_time + leg
        );
        assert!((f["angle"].as_f64().unwrap() - 45.0).abs() < 1e-9, "{f}");
        // Half-way through the turn the heading is 90 -/+ half the turn.
        let half = turn_time / 2.0;
        let turning = rs
            .iter()
            .find(|r| {
                r["robot"] == 0 && r.get("omega").is_some() && r["omega"].as_f64().unwrap() != 0.0
            })
            .expect("a turning record");
        let omega = turning["omega"].as_f64().unwrap();
        let expected = if sets.is_empty() { -45.0 } else { 45.0 };
        assert!((omega - expected).abs() < 1e-9, "{sets:?}: omega {omega}");
        let heading =
            turning["angle"].as_f64().unwrap() + omega * (half - turning["t"].as_f64().unwrap());
        let want = if sets.is_empty() {
            90.0 - 22.5
        } else {
            90.0 + 157.5
        };
        assert!(
            (heading - want).abs() < 1e-9,
            "{sets:?}: heading {heading} at {half}"
        );
    }
}

#[test]
fn walls_are_their_own_setting_and_ghost_mode_without_walls_is_the_seeds() {
    let dir = tempfile::tempdir().unwrap();
    // Centred 100 x 100: heading east from the middle, a robot of radius 5 meets the wall at
    // x = 45 after 4.5 s; without walls it drives on to x = 200.
    let scenario = "Scenario(until: 60.0, world: (size: Bounded(width: 100.0, height: 100.0), ghost_mode: true), robots: [Robot(id: 0, radius: 5.0, at: (0.0, 0.0), angle: 0.0, algorithm: Script([Forward(distance: 200.0, move_speed: 10.0)]))])";
    let rs = trace(dir.path(), scenario, &[]);
    let f = finish(&rs);
    assert_eq!(f["outcome"], "collided", "{f}");
    assert_eq!(f["other"], "boundary", "{f}");
    assert!(
        (f["t"].as_f64().unwrap() - 4.5).abs() < 1e-9
            && (f["pos"][0].as_f64().unwrap() - 45.0).abs() < 1e-9,
        "{f}"
    );
    let rs = trace(dir.path(), scenario, &["world.walls=false"]);
    let f = finish(&rs);
    assert_eq!(f["outcome"], "arrived", "{f}");
    assert!(
        (f["t"].as_f64().unwrap() - 20.0).abs() < 1e-9
            && (f["pos"][0].as_f64().unwrap() - 200.0).abs() < 1e-9,
        "{f}"
    );
    assert!(
        rs.iter().all(|r| r["kind"] != "collision"),
        "no collision at all"
    );
}

#[test]
fn a_crowd_that_cannot_fit_is_refused_by_the_packing_bound_not_a_random_search() {
    let o = Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .args(["validate", "tests/bad/million_robots.ron"])
        .current_dir(root())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2));
    // The bound (pi r^2 per robot against pi / (2 sqrt 3) of the area) answers, not the
    // placement's random tries ("could not place ...").
    let covered = 1e6 * std::f64::consts::PI * 25.0;
    assert!(
        err.contains(&format!("would cover {covered:.0} square units")),
        "{err}"
    );
    assert!(!err.contains("could not place"), "{err}");
}
