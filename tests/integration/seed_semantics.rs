//! The seed's own semantics where nekosim's defaults differ: MOVETO turning always
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

fn built(text: &str) -> Result<nekosim::scenario::Built, String> {
    let source = nekosim::scenario::Source::parse("s.ron", text).map_err(|e| e.to_string())?;
    source
        .build(
            Default::default(),
            &nekosim::scenario::Registry::with_builtins(),
        )
        .map_err(|e| e.to_string())
}

#[test]
fn the_seeds_chapter_6_1_settings_robot_size_animation_and_panel() {
    // robot.size: every robot's radius unless its entry gives one.
    let b = built("Scenario(robot_size: 7.0, world: (size: Bounded(width: 400.0, height: 300.0)), robots: [Group(count: 3), Robot(id: 3, radius: 2.0, at: (0.0, 0.0))])").unwrap();
    let radii: Vec<f64> = b.robots.iter().map(|r| r.0.radius).collect();
    assert_eq!(radii, [7.0, 7.0, 7.0, 2.0]);
    let e = built("Scenario(world: (size: Infinite), robots: [Group(count: 3)])").unwrap_err();
    assert!(e.starts_with("s.ron:1:44: no radius"), "{e}");
    // Animation on by default at 25 frames per simulated second; off: event instants only.
    assert_eq!(b.framerate, 25.0);
    let off = built("Scenario(robot_size: 1.0, world: (size: Infinite), animation: (enabled: false), robots: [Group(count: 1)])").unwrap();
    assert_eq!(off.framerate, 0.0);
    // The panel: the 2D view from the world's lower-left corner; by default the world.
    use nekosim::world::geometry::Point;
    assert_eq!(
        b.view,
        Some((Point::new(-200.0, -150.0), Point::new(200.0, 150.0)))
    );
    let panel = built("Scenario(robot_size: 1.0, world: (size: Bounded(width: 400.0, height: 300.0), origin: (0.0, 0.0)), animation: (panel: (100.0, 50.0)), robots: [Group(count: 1)])").unwrap();
    assert_eq!(
        panel.view,
        Some((Point::new(0.0, 0.0), Point::new(100.0, 50.0)))
    );
    let e = built("Scenario(robot_size: 1.0, world: (size: Infinite), animation: (panel: (0.0, 50.0)), robots: [])").unwrap_err();
    assert!(e.contains("panel width is 0"), "{e}");
}

#[test]
fn a_scenarios_outputs_are_written_unless_the_command_line_says_otherwise() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("s.ron");
    std::fs::write(
        &file,
        "Scenario(until: 5.0, robot_size: 5.0, world: (size: Bounded(width: 200.0, height: 200.0)), outputs: (log: \"out/s.log\", trace: \"out/s.jsonl\"), robots: [Group(count: 3, algorithm: RandomMovement())])",
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_nekosim"))
            .arg("run")
            .arg(&file)
            .arg("--quiet")
            .args(extra)
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
    };
    run(&[]);
    let log = std::fs::read_to_string(dir.path().join("out/s.log")).unwrap();
    let trace = std::fs::read_to_string(dir.path().join("out/s.jsonl")).unwrap();
    assert_eq!(
        log.lines().count(),
        trace.lines().count(),
        "one log line per trace record"
    );
    assert!(log.lines().count() > 3);
    // --log wins over the file's log; the file's trace is still written.
    std::fs::remove_dir_all(dir.path().join("out")).unwrap();
    run(&["--log", "mine.log"]);
    assert!(dir.path().join("mine.log").exists());
    assert!(!dir.path().join("out/s.log").exists());
    assert!(dir.path().join("out/s.jsonl").exists());
}

/// The log's lines in the seed's shape (seed 4.5.1 fig. 4.12, 5.2): a `CollisionEvent` shows
/// where the robot was going and `Do_MoveTo_Sequence(Collision)`; an arrival has no line after
/// the `Finish_MoveTo` that ends it; every MotionRequest is `Task ID = 1`. Checked line by line
/// against the trace of the seed's random movement (100 robots, collisions included).
#[test]
fn log_lines_have_the_seeds_shape() {
    let dir = tempfile::tempdir().unwrap();
    let (log, trace) = (dir.path().join("l.log"), dir.path().join("t.jsonl"));
    let o = Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .args(["run", "examples/scenarios/random_movement.ron", "--quiet"])
        .args(["--until", "120", "--log"])
        .arg(&log)
        .arg("--trace")
        .arg(&trace)
        .current_dir(root())
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let log = std::fs::read_to_string(log).unwrap();
    let records: Vec<Value> = std::fs::read_to_string(trace)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();

    // Walk the trace: each robot's destination while a motion is in progress.
    let mut going: std::collections::HashMap<u64, (f64, f64)> = Default::default();
    let mut expected_collisions = Vec::new();
    for r in &records {
        let robot = r["robot"].as_u64().unwrap();
        match r["kind"].as_str().unwrap() {
            "motion_request" => {
                assert_eq!(r["motion"], "move_to");
                going.insert(robot, (r["x"].as_f64().unwrap(), r["y"].as_f64().unwrap()));
            }
            "collision" => {
                let pos = (r["pos"][0].as_f64().unwrap(), r["pos"][1].as_f64().unwrap());
                let (dest, cond) = match going.get(&robot) {
                    Some(d) => (*d, "Do_MoveTo_Sequence(Collision)"),
                    None => (pos, "Collision"),
                };
                expected_collisions.push((robot, dest, cond));
            }
            "motion_finish" => {
                going.remove(&robot);
            }
            _ => {}
        }
    }
    let silent = crate::common::silent_arrivals(&records);
    assert!(silent > 20, "{silent} arrivals");
    assert!(
        expected_collisions.len() >= 2,
        "{} collisions",
        expected_collisions.len()
    );
    let lines: Vec<&str> = log.lines().collect();
    assert_eq!(lines.len(), records.len() - silent);
    assert!(!log.contains("Arrived_MoveTo"));

    let num = |v: f64| format!("{v:.3}");
    let collisions: Vec<&str> = lines
        .iter()
        .copied()
        .filter(|l| l.contains(" CollisionEvent: "))
        .collect();
    assert_eq!(collisions.len(), expected_collisions.len());
    for (line, (robot, dest, cond)) in collisions.iter().zip(&expected_collisions) {
        let fields: Vec<&str> = line.split('|').map(str::trim).collect();
        assert_eq!(fields[2], robot.to_string(), "{line}");
        assert_eq!(
            fields[4],
            format!("[{},{}]", num(dest.0), num(dest.1)),
            "{line}"
        );
        assert_eq!(fields[10], *cond, "{line}");
    }
    let requests: Vec<&str> = lines
        .iter()
        .copied()
        .filter(|l| l.contains(" MotionRequest: "))
        .collect();
    assert_eq!(
        requests.len(),
        records
            .iter()
            .filter(|r| r["kind"] == "motion_request")
            .count()
    );
    assert!(requests.iter().all(|l| l.contains("Task ID = 1 |")));
}
