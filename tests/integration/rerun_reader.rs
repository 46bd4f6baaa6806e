//! Recordings checked by a reader nobody here wrote: `nekosim run --rrd` on example scenarios,
//! then tests/rerun/verify_rrd.py with the official rerun-sdk 0.36.3 (in a virtual environment
//! under target/, created on first use) checks the file against the JSONL trace of the same
//! run. A missing Python or a failed install fails the test: it is never skipped.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::run_command as run;

const RERUN_SDK: &str = "rerun-sdk==0.36.3";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The virtual environment's Python, with rerun-sdk installed (`NEKOSIM_PYTHON` picks the
/// interpreter that creates it; default `python3`).
fn python() -> PathBuf {
    // The tests of this binary run in threads: one of them installs, the others wait.
    static PYTHON: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    PYTHON.get_or_init(install).clone()
}

fn install() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target"));
    let venv = target.join("rerun-venv");
    let py = venv.join("bin").join("python");
    let ready = py.exists()
        && Command::new(&py)
            .args([
                "-c",
                "import rerun, sys; sys.exit(rerun.__version__ != '0.36.3')",
            ])
            .status()
            .is_ok_and(|s| s.success());
    if !ready {
        let base = std::env::var("NEKOSIM_PYTHON").unwrap_or_else(|_| "python3".into());
        run(Command::new(base).args(["-m", "venv"]).arg(&venv));
        run(Command::new(&py).args(["-m", "pip", "install", "--quiet", RERUN_SDK]));
    }
    py
}

/// `verify_rrd.py RRD TRACE FRAMERATE` with the pinned SDK: its summary line.
fn verify_rrd(py: &Path, rrd: &Path, trace: &Path, framerate: u32) -> String {
    run(Command::new(py)
        .arg(root().join("tests/rerun/verify_rrd.py"))
        .arg(rrd)
        .arg(trace)
        .arg(framerate.to_string()))
}

fn record(scenario: &str, extra: &[&str], dir: &Path) -> (PathBuf, PathBuf) {
    let name = Path::new(scenario).file_stem().unwrap().to_string_lossy();
    let rrd = dir.join(format!("{name}.rrd"));
    let trace = dir.join(format!("{name}.jsonl"));
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_nekosim"));
    cmd.arg("run")
        .arg(root().join(scenario))
        .arg("--rrd")
        .arg(&rrd)
        .arg("--trace")
        .arg(&trace)
        .arg("--quiet")
        .args(extra);
    run(&mut cmd);
    (rrd, trace)
}

#[test]
fn recordings_read_back_with_the_official_reader_match_the_trace() {
    let py = python();
    let dir = tempfile::tempdir().unwrap();
    // A collision; messages over a random network; many robots colliding; total-order
    // broadcast (many messages, robots at rest); consensus with a crashed robot.
    for (scenario, extra) in [
        ("examples/scenarios/collision.ron", &[][..]),
        (
            "examples/scenarios/ask_for_help.ron",
            &["--until", "60"][..],
        ),
        (
            "examples/scenarios/random_movement.ron",
            &["--until", "20"][..],
        ),
        (
            "examples/scenarios/abcast_lamport.ron",
            &["--until", "30"][..],
        ),
    ] {
        let (rrd, trace) = record(scenario, extra, dir.path());
        let trace_text = std::fs::read_to_string(&trace).unwrap();
        let out = verify_rrd(&py, &rrd, &trace, 25);
        assert!(out.contains("verify_rrd: ok"), "{scenario}: {out}");
        // Names up to 20 robots (random movement has 100); message plots only where robots
        // can send.
        let crowd = scenario.contains("random_movement");
        assert_eq!(name_strokes(&out) == 0, crowd, "{scenario}: {out}");
        assert_eq!(
            out.contains("messages_in_flight"),
            !scenario.contains("collision") && !crowd,
            "{scenario}: {out}"
        );
        // Deliveries only where a stack can deliver (ask_for_help sends without one).
        assert_eq!(
            out.contains("deliveries"),
            scenario.contains("abcast"),
            "{scenario}: {out}"
        );
        if out.contains("messages_in_flight") {
            assert!(!out.contains(" 0 space-time arrows"), "{scenario}: {out}");
        }
        // The checks had something to check.
        if trace_text.contains("\"kind\":\"collision\"") {
            assert!(!out.contains(" 0 collision markers"), "{scenario}: {out}");
        }
        if trace_text.contains("\"kind\":\"send\"") {
            assert!(!out.contains(" 0 sends with arrows"), "{scenario}: {out}");
        }
        eprintln!("{scenario}: {}", out.trim());
    }
}

/// Beyond 20 robots a name per robot would cover the world: robots are drawn without names,
/// and the recording still matches the trace.
#[test]
fn a_crowd_is_drawn_without_labels() {
    let py = python();
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("crowd.ron");
    // The seed's density (100 robots of radius 5 per 800 x 800), 200 robots.
    std::fs::write(
        &scenario,
        "Scenario(name: \"crowd\", seed: 7, until: 8.0,
           world: (size: Bounded(width: 1131.0, height: 1131.0), origin: (0.0, 0.0)),
           robots: [Group(count: 200, radius: 5.0, born: Random, algorithm: RandomMovement())])",
    )
    .unwrap();
    let (rrd, trace) = record(scenario.to_str().unwrap(), &[], dir.path());
    let out = verify_rrd(&py, &rrd, &trace, 25);
    assert!(out.contains("verify_rrd: ok"), "{out}");
    assert_eq!(name_strokes(&out), 0, "{out}");
}

/// Obstacles are drawn as static outlines, and every contact point of a collision with one
/// lies on its outline (verify_rrd.py).
#[test]
fn obstacles_are_drawn_where_robots_touch_them() {
    let py = python();
    let dir = tempfile::tempdir().unwrap();
    let (rrd, trace) = record(
        "examples/scenarios/obstacles.ron",
        &["--until", "60"],
        dir.path(),
    );
    let out = verify_rrd(&py, &rrd, &trace, 25);
    assert!(out.contains("verify_rrd: ok"), "{out}");
    let hits = out
        .split(", ")
        .find(|p| p.starts_with("4 obstacles with "))
        .unwrap_or_else(|| panic!("4 obstacles drawn: {out}"));
    let n: usize = hits["4 obstacles with ".len()..]
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(n >= 3, "{out}");
}

/// The number of robot-name strokes verify_rrd.py checked, from its summary line.
fn name_strokes(summary: &str) -> usize {
    count_of(summary, " name strokes")
}

/// The count verify_rrd.py's summary line gives right before `what`.
fn count_of(summary: &str, what: &str) -> usize {
    let end = summary
        .find(what)
        .unwrap_or_else(|| panic!("a count of{what}: {summary}"));
    let start = summary[..end].rfind(' ').map_or(0, |i| i + 1);
    summary[start..end].parse().expect("a count")
}

/// Copies the network drops never count as in flight, and a copy nobody receives (its
/// receiver crashed) leaves at its arrival: verify_rrd.py counts the copies in flight from
/// the trace's sends, receives and losses at every sample and compares the figure, each
/// layer's arrows and the lost marks, over a lossy network, a partition and a crash.
#[test]
fn messages_in_flight_match_the_trace_over_losses_partitions_and_crashes() {
    let py = python();
    let dir = tempfile::tempdir().unwrap();
    for (scenario, extra) in [
        ("examples/scenarios/lossy_abcast.ron", &[][..]),
        (
            "examples/scenarios/partition_consensus.ron",
            &["--until", "60"][..],
        ),
        (
            "examples/scenarios/meeting_point.ron",
            &["--until", "40"][..],
        ),
    ] {
        let (rrd, trace) = record(scenario, extra, dir.path());
        let out = verify_rrd(&py, &rrd, &trace, 25);
        assert!(out.contains("verify_rrd: ok"), "{scenario}: {out}");
        assert!(
            count_of(&out, " in-flight samples") > 500,
            "{scenario}: {out}"
        );
        // The lossy links and the cut drop copies; the crash drops none.
        assert_eq!(
            count_of(&out, " lost copies") > 0,
            !scenario.contains("meeting_point"),
            "{scenario}: {out}"
        );
        eprintln!("{scenario}: {}", out.trim());
    }
}

#[test]
fn a_recording_is_complete_and_in_place_even_when_the_run_fails() {
    let py = python();
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("out.rrd");
    // The log's target is a non-empty directory: the run itself succeeds, then publishing the
    // log fails, an internal error (exit 1) after the run started.
    let blocked = dir.path().join("blocked.log");
    std::fs::create_dir(&blocked).unwrap();
    std::fs::write(blocked.join("keep"), "").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .args([
            "run",
            "examples/scenarios/collision.ron",
            "--quiet",
            "--rrd",
        ])
        .arg(&rrd)
        .arg("--log")
        .arg(&blocked)
        .current_dir(root())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    // The recording is in place, and nothing is left half-written beside it.
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["blocked.log", "out.rrd"]);
    let rerun = py.parent().unwrap().join("rerun");
    let out = run(Command::new(rerun)
        .args(["rrd", "verify"])
        .arg(&rrd)
        .env("CI", "1"));
    assert!(out.contains("verified without error"), "{out}");
}

/// `nekosim check --rrd`: the counterexample's recording, read back by the official reader,
/// shows what the JSONL trace of the same path says; the copies the path drops are drawn as
/// lost from their send and never count as in flight, as in a run's recording.
#[test]
fn counterexample_recordings_read_back_with_the_official_reader() {
    let py = python();
    let dir = tempfile::tempdir().unwrap();
    for (i, (model, args, property)) in [
        (
            "reliable-broadcast",
            &["--network", "lossy"][..],
            "agreement",
        ),
        (
            "lamport-abcast",
            // Breadth-first, validity fails first; exploring on settles uniform agreement,
            // the first property in the report's order, whose path is recorded.
            &["--crashes", "1", "--keep-going"][..],
            "uniform agreement",
        ),
        (
            // Depth-first: a longer path, on which some copies arrive and others are lost.
            "reliable-broadcast",
            &["--network", "lossy", "--strategy", "dfs"][..],
            "agreement",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let (rrd, trace) = (
            dir.path().join(format!("{model}-{i}.rrd")),
            dir.path().join(format!("{model}-{i}.jsonl")),
        );
        let o = Command::new(env!("CARGO_BIN_EXE_nekosim"))
            .args(["check", model])
            .args(args)
            .arg("--trace")
            .arg(&trace)
            .arg("--rrd")
            .arg(&rrd)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(1), "{model}: a counterexample");
        let out = run(Command::new(&py)
            .arg(root().join("tests/rerun/verify_check_rrd.py"))
            .arg(&rrd)
            .arg(&trace)
            .arg(property)
            .arg("3"));
        assert!(out.contains("verify_check_rrd: ok"), "{model}: {out}");
        if model == "lamport-abcast" {
            assert!(!out.contains(" 0 crashes grey"), "{model}: {out}");
        }
        // The lossy network's paths drop copies; the other loses none.
        let lossy = args.contains(&"lossy");
        assert_eq!(count_of(&out, " lost copies") > 0, lossy, "{model}: {out}");
        assert!(count_of(&out, " in-flight samples") > 0, "{model}: {out}");
        if i == 2 {
            // Copies lost and copies received on one path.
            assert!(count_of(&out, " space-time arrows") > 0, "{model}: {out}");
        }
        eprintln!("{model}: {}", out.trim());
    }
}

/// A protocol stack's livelock: retransmission over a network that may lose every copy, under
/// weak fairness only. Its recording holds the path of the lasso (stem, then the cycle once),
/// and its verdict document states the temporal property, where the cycle begins and why it
/// fails, as the trace's last record says.
#[test]
fn a_stack_lasso_recording_reads_back_with_its_cycle() {
    let py = python();
    let dir = tempfile::tempdir().unwrap();
    let (rrd, trace) = (dir.path().join("lasso.rrd"), dir.path().join("lasso.jsonl"));
    let o = Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .current_dir(root())
        .args([
            "check",
            "tests/check/retransmit_lossy.ron",
            "--timers",
            "unlimited",
        ])
        .args(["--fairness", "weak", "--trace"])
        .arg(&trace)
        .arg("--rrd")
        .arg(&rrd)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let text = std::fs::read_to_string(&trace).unwrap();
    assert!(
        text.lines().last().unwrap().contains("\"kind\":\"lasso\""),
        "{text}"
    );
    let out = run(Command::new(&py)
        .arg(root().join("tests/rerun/verify_check_rrd.py"))
        .arg(&rrd)
        .arg(&trace)
        .arg("reliable delivery")
        .arg("2"));
    assert!(out.contains("verify_check_rrd: ok"), "{out}");
    assert_eq!(count_of(&out, " lost copies"), 1, "{out}");
}

/// Switches its push proximity sensor on, drives, looks around (view, proximity), switches
/// it off, and drives on.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Sentry {
    range: f64,
}

impl nekosim::registry::Configured for Sentry {
    type Config = Sentry;
    fn configure(
        config: Sentry,
        _: &nekosim::registry::Setting,
    ) -> Result<Self, nekosim_protocols::FieldError> {
        Ok(config)
    }
}

impl nekosim::Algorithm for Sentry {
    fn name(&self) -> &str {
        "sentry"
    }

    fn run(&self, robot: nekosim::Robot) -> nekosim::AlgorithmFuture {
        let range = self.range;
        Box::pin(async move {
            let start = robot.gps().self_position(0.0).await;
            robot.activate_proximity(range, 1.0).await;
            let leg = nekosim::world::geometry::Point::new(start.x + 30.0, start.y);
            robot.move_to(leg, 5.0, 90.0).await;
            // Pull queries: drawn from request to reply.
            robot.robots_in_view(40.0).await;
            robot.proximity(7.0).await;
            robot.deactivate_proximity().await;
            let back = nekosim::world::geometry::Point::new(start.x, start.y + 20.0);
            robot.move_to(back, 5.0, 90.0).await;
        })
    }
}

#[test]
fn push_sensor_circles_follow_their_robots_while_active() {
    use nekosim::recording::Target;
    use nekosim::runner::{self, RunOptions};
    use nekosim::scenario::{Overrides, Registry, Source};

    let py = python();
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("sentries.ron");
    std::fs::write(
        &scenario,
        r#"Scenario(name: "sentries", seed: 1, until: 30.0,
            world: (size: Bounded(width: 200.0, height: 200.0), origin: (0.0, 0.0)),
            robots: [
                Robot(id: 0, radius: 2.0, at: (20.0, 20.0), algorithm: Sentry(range: 6.0)),
                Robot(id: 1, radius: 3.0, at: (20.0, 100.0), algorithm: Idle),
                Robot(id: 2, radius: 2.5, at: (100.0, 20.0), algorithm: Sentry(range: 9.0)),
            ],
            animation: (framerate: 10.0))"#,
    )
    .unwrap();
    let mut registry = Registry::new();
    registry.algorithm::<Sentry>("Sentry");
    let built = Source::load(&scenario)
        .unwrap()
        .build(Overrides::default(), &registry)
        .unwrap();
    let (rrd, trace) = (dir.path().join("s.rrd"), dir.path().join("s.jsonl"));
    runner::run(
        built,
        RunOptions {
            trace: Some(trace.clone()),
            recording: Target {
                rrd: Some(rrd.clone()),
                connect: None,
            },
            ..RunOptions::default()
        },
    )
    .unwrap();
    let out = verify_rrd(&py, &rrd, &trace, 10);
    // Two sentries, each switching on and off, and circles checked at frames while they drive;
    // each makes a view and a proximity query.
    assert!(out.contains(" 4 sensor switches"), "{out}");
    assert!(out.contains(" 4 queries"), "{out}");
    assert!(!out.contains(" 0 sensor frames"), "{out}");
    eprintln!("{}", out.trim());
}

/// The bytes of an .rrd stream before its footer: Rerun's framing is a 12-byte stream header,
/// then messages of a 16-byte header (kind, length: little-endian u64) and a payload; the
/// end-of-stream message (kind 0) carries the footer.
fn before_footer(rrd: &[u8]) -> &[u8] {
    let mut at = 12;
    while at + 16 <= rrd.len() {
        let kind = u64::from_le_bytes(rrd[at..at + 8].try_into().unwrap());
        let len = u64::from_le_bytes(rrd[at + 8..at + 16].try_into().unwrap()) as usize;
        if kind == 0 {
            return &rrd[..at];
        }
        at += 16 + len;
    }
    panic!("no end-of-stream message in {} bytes", rrd.len());
}

#[test]
fn the_same_run_gives_the_same_recording_bytes() {
    let dir = tempfile::tempdir().unwrap();
    for (scenario, extra) in [
        ("examples/scenarios/collision.ron", &[][..]),
        (
            "examples/scenarios/random_movement.ron",
            &["--until", "5"][..],
        ),
    ] {
        let mut files = Vec::new();
        for i in 0..2 {
            let sub = dir.path().join(format!("{i}"));
            std::fs::create_dir_all(&sub).unwrap();
            let (rrd, _) = record(scenario, extra, &sub);
            files.push(std::fs::read(rrd).unwrap());
        }
        let (a, b) = (before_footer(&files[0]), before_footer(&files[1]));
        assert!(a.len() > 10_000, "{scenario}: {} bytes", a.len());
        assert!(a == b, "{scenario}: recordings differ before the footer");
    }
}

/// A local TCP port nobody listens on (as far as the kernel knows right now).
fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    l.local_addr().unwrap().port()
}

/// `nekosim run SCENARIO --connect` to a local port, also saving to `rrd`.
fn connected(scenario: &Path, port: u16, rrd: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_nekosim"));
    cmd.arg("run")
        .arg(scenario)
        .args(["--quiet", "--connect"])
        .arg(format!("rerun+http://127.0.0.1:{port}/proxy"))
        .arg("--rrd")
        .arg(rrd)
        .env_remove("RUST_LOG");
    cmd
}

/// Ctrl-C ends a run at the virtual time reached: exit 130, and the recording, the trace and
/// the log are complete for the run up to there (the recording matches the trace), with no
/// temporary file left.
#[cfg(unix)]
#[test]
fn an_interrupted_run_keeps_complete_outputs() {
    let py = python();
    let dir = tempfile::tempdir().unwrap();
    let (rrd, trace, log) = (
        dir.path().join("long.rrd"),
        dir.path().join("long.jsonl"),
        dir.path().join("long.log"),
    );
    let child = Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .arg("run")
        .arg(root().join("examples/scenarios/random_movement.ron"))
        .args(["--until", "1000000"])
        .arg("--rrd")
        .arg(&rrd)
        .arg("--trace")
        .arg(&trace)
        .arg("--log")
        .arg(&log)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Interrupt once the run is under way: its recording has been created.
    let started = std::time::Instant::now();
    while std::fs::read_dir(dir.path()).unwrap().count() == 0 {
        assert!(started.elapsed().as_secs() < 60, "the run never started");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(500));
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted at simulated time"), "{err}");
    // The summary names the recording and how to open it.
    let summary = String::from_utf8_lossy(&out.stdout);
    let shown = format!("recording: {} (", rrd.display());
    assert!(summary.contains(&shown), "{summary}");
    assert!(
        summary.contains(&format!("view it with `rerun {}`", rrd.display())),
        "{summary}"
    );
    let mut left: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["long.jsonl", "long.log", "long.rrd"]);
    let records: Vec<serde_json::Value> = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(!records.is_empty());
    assert_eq!(
        std::fs::read_to_string(&log).unwrap().lines().count(),
        records.len() - crate::common::silent_arrivals(&records)
    );
    let verified = verify_rrd(&py, &rrd, &trace, 25);
    assert!(verified.contains("verify_rrd: ok"), "{verified}");
}

/// `--rrd` naming a directory is refused before the run: exit 2, one line, nothing written.
#[test]
fn a_directory_is_not_a_recording_target() {
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .arg("run")
        .arg(root().join("examples/scenarios/collision.ron"))
        .arg("--rrd")
        .arg(dir.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("cannot create the recording: is a directory"),
        "{err}"
    );
    assert!(
        o.stdout.is_empty(),
        "the run started: {}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn connect_streams_to_a_running_viewer_and_refuses_a_missing_one() {
    let py = python();
    let dir = tempfile::tempdir().unwrap();
    let scenario = root().join("examples/scenarios/collision.ron");

    // Nobody at the URL: one line, exit 2, before the run, and no file.
    let rrd = dir.path().join("nobody.rrd");
    let out = connected(&scenario, free_port(), &rrd).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("cannot stream to the Rerun viewer"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);

    // Rerun's own gRPC server (the viewer's, headless) from rerun-sdk 0.36.3. The package's
    // `rerun` script runs the binary as a child process, which killing the script would leave
    // running: the binary is started directly, with nothing attached.
    let port = free_port();
    let binary = run(Command::new(&py).args([
        "-c",
        "import os, rerun_cli; print(os.path.join(os.path.dirname(rerun_cli.__file__), 'rerun'))",
    ]));
    let mut server = Command::new(binary.trim())
        .args(["--serve-grpc", "--port", &port.to_string()])
        .env("CI", "1")
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let up = (0..200).any(|_| {
        std::thread::sleep(std::time::Duration::from_millis(50));
        std::net::TcpStream::connect(("127.0.0.1", port)).is_ok()
    });
    let rrd = dir.path().join("live.rrd");
    let trace = dir.path().join("live.jsonl");
    let out = connected(&scenario, port, &rrd)
        .arg("--trace")
        .arg(&trace)
        .output()
        .unwrap();
    let _ = server.kill();
    let _ = server.wait();
    assert!(up, "rerun --serve-grpc did not listen on {port}");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The file written beside the stream is a complete recording.
    let out = verify_rrd(&py, &rrd, &trace, 25);
    assert!(out.contains("verify_rrd: ok"), "{out}");
}

/// Look-Compute-Move robots read back: each shows its light as its colour from each light
/// record on (the mean of the old and the new light while it computes), and its snapshot from
/// each Look to the end of its cycle (verify_rrd.py's `check_lcm`).
#[test]
fn lcm_lights_and_snapshots_read_back() {
    let py = python();
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("lcm.ron");
    std::fs::write(
        &scenario,
        "Scenario(name: \"lcm\", seed: 3, until: 12.0,
           world: (size: Infinite, ghost_mode: true),
           lcm: (synchrony: Async, movement: NonRigid(delta: 2.0)),
           robots: [Group(count: 2, radius: 0.5, born: Points([(0.0, 0.0), (30.0, 40.0)]),
             algorithm: RuleTable(lights: [\"black\", \"white\", \"red\"], rules: [
               (me: \"black\", move: ToHalf, light: \"white\"),
               (me: \"white\", light: \"red\"),
               (me: \"red\", move: ToOther, light: \"black\"),
             ]))])",
    )
    .unwrap();
    let (rrd, trace) = record(scenario.to_str().unwrap(), &[], dir.path());
    let out = verify_rrd(&py, &rrd, &trace, 25);
    assert!(out.contains("verify_rrd: ok"), "{out}");
    assert!(count_of(&out, " lights") >= 20, "{out}");
    assert!(count_of(&out, " looks") >= 10, "{out}");
}

/// A lasso replayed in the simulator is recorded with a document beside the drawings that
/// marks where its stem ends and where each repetition of its cycle begins and ends, and with
/// a log line at each of those instants (`log/milestones`), so they are on the viewer's
/// timeline; both read back with the official reader.
#[test]
fn a_replayed_lasso_recording_marks_its_cycle() {
    let py = python();
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("lasso.rrd");
    let out = Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .current_dir(root())
        .args([
            "check",
            "examples/lcm/to_half.ron",
            "--synchrony",
            "ssync",
            "--rrd",
        ])
        .arg(&rrd)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let doc = run(Command::new(&py)
        .arg("-c")
        .arg(
            "import sys; sys.path.insert(0, sys.argv[1]); import verify_rrd as v; \
             from pathlib import Path; \
             print(v.Rows(Path(sys.argv[2])).static['/verdict']['TextDocument:text'][0])",
        )
        .arg(root().join("tests/rerun"))
        .arg(&rrd));
    assert!(
        doc.contains("A lasso of the two-robot model, replayed"),
        "{doc}"
    );
    assert!(
        doc.contains("The stem runs from t = 0 to 2; the cycle, which the adversary can repeat forever, from t = 2 to 4, and again from 4 to 6"),
        "{doc}"
    );
    // The milestones: one log row at each mark, on sim_time, as `sim_ns<TAB>level<TAB>text`.
    let rows = run(Command::new(&py)
        .arg("-c")
        .arg(
            "import sys; sys.path.insert(0, sys.argv[1]); import verify_rrd as v; \
             from pathlib import Path; \
             rows = v.Rows(Path(sys.argv[2])).by_entity['/log/milestones']; \
             [print(f\"{t}\\t{c['TextLog:level'][0]}\\t{c['TextLog:text'][0]}\") for t, _, _, c in sorted(rows, key=lambda r: r[0])]",
        )
        .arg(root().join("tests/rerun"))
        .arg(&rrd));
    let rows: Vec<(i64, &str, &str)> = rows
        .lines()
        .map(|l| {
            let mut f = l.splitn(3, '\t');
            let t = f.next().unwrap().parse().unwrap();
            (t, f.next().unwrap(), f.next().unwrap())
        })
        .collect();
    let at: Vec<i64> = rows.iter().map(|r| r.0).collect();
    assert_eq!(
        at,
        [2_000_000_000, 4_000_000_000, 6_000_000_000],
        "{rows:?}"
    );
    assert!(rows.iter().all(|r| r.1 == "INFO"), "{rows:?}");
    assert!(
        rows[0]
            .2
            .contains("the stem ends and the cycle begins (repetition 1 of 2, to t = 4)")
            && rows[1]
                .2
                .contains("begins again (repetition 2 of 2, to t = 6)")
            && rows[2].2.contains("the adversary can repeat it forever"),
        "{rows:?}"
    );
}
