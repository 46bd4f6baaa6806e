//! `nekosim sweep` end to end: bad sweep files refused at FILE:LINE:COL before any run, output
//! bytes independent of `--jobs` and of sharding, merges that refuse shards that do not fit,
//! every row equal to the single run that replays it, and the summary's statistics
//! recomputed from the rows.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn nekosim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("nekosim runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Every file under `dir`, by relative path, with its bytes.
fn tree(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().display().to_string();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

fn sweep(out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "sweep",
        "tests/sweeps/tiny.ron",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    nekosim(&args)
}

#[test]
fn bad_sweep_files_are_refused_at_their_place_before_any_run() {
    let dir = tempfile::tempdir().unwrap();
    let mut files: Vec<PathBuf> = std::fs::read_dir(root().join("tests/sweeps/bad"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert!(files.len() >= 10);
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        let expect = text
            .lines()
            .next()
            .and_then(|l| l.strip_prefix("// expect: "))
            .expect("an expect line");
        let rel = f.strip_prefix(root()).unwrap().display().to_string();
        let out = dir.path().join("out");
        let o = nekosim(&["sweep", &rel, "--out", out.to_str().unwrap()]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{rel}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{rel}: one line: {err}");
        assert!(
            err.starts_with(&format!("{rel}:{expect}")),
            "{rel}: expected `{rel}:{expect}...`, got {err}"
        );
        assert!(!out.exists(), "{rel}: nothing written");
    }
}

#[test]
fn outputs_do_not_depend_on_jobs_or_shards() {
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("one");
    let o = sweep(&one, &["--jobs", "1", "--quiet"]);
    // Some runs fail their checks (and some cannot be built): exit 1, the files complete.
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let reference = tree(&one);
    let names: Vec<&str> = reference.keys().map(String::as_str).collect();
    assert_eq!(
        names,
        [
            "failures.txt",
            "plots/collisions.svg",
            "plots/end_time.svg",
            "plots/events.svg",
            "runs.csv",
            "summary.csv"
        ]
    );
    let two = dir.path().join("two");
    assert_eq!(
        sweep(&two, &["--jobs", "2", "--quiet"]).status.code(),
        Some(1)
    );
    assert_eq!(
        tree(&two),
        reference,
        "--jobs 2 writes the bytes of --jobs 1"
    );

    let shards: Vec<PathBuf> = (0..3)
        .map(|i| {
            let d = dir.path().join(format!("shard{i}"));
            let o = sweep(
                &d,
                &["--shard", &format!("{i}/3"), "--jobs", "2", "--quiet"],
            );
            assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
            assert!(d.join("shard.json").exists() && !d.join("summary.csv").exists());
            d
        })
        .collect();
    let merged = dir.path().join("merged");
    // Shards in any order.
    let o = nekosim(&[
        "sweep",
        "merge",
        shards[2].to_str().unwrap(),
        shards[0].to_str().unwrap(),
        shards[1].to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(
        tree(&merged),
        reference,
        "merged shards write the bytes of the whole sweep"
    );
}

#[test]
fn merge_refuses_shards_that_do_not_fit() {
    let dir = tempfile::tempdir().unwrap();
    let shard = |name: &str, sweep_file: &str, s: &str| {
        let d = dir.path().join(name);
        let o = nekosim(&[
            "sweep",
            sweep_file,
            "--out",
            d.to_str().unwrap(),
            "--shard",
            s,
            "--quiet",
        ]);
        assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
        d.to_str().unwrap().to_string()
    };
    let a0 = shard("a0", "tests/sweeps/tiny.ron", "0/2");
    let a1 = shard("a1", "tests/sweeps/tiny.ron", "1/2");
    // The same sweep with other seeds is another sweep.
    let other = dir.path().join("other.ron");
    let text = std::fs::read_to_string(root().join("tests/sweeps/tiny.ron"))
        .unwrap()
        .replace("seeds: [3, 1, 2]", "seeds: [3, 1, 4]")
        .replace(
            "../../examples/scenarios/random_movement.ron",
            root()
                .join("examples/scenarios/random_movement.ron")
                .to_str()
                .unwrap(),
        );
    std::fs::write(&other, text).unwrap();
    let b1 = shard("b1", other.to_str().unwrap(), "1/2");
    let out = dir.path().join("out");
    let merge = |dirs: &[&str]| {
        let mut args = vec!["sweep", "merge"];
        args.extend_from_slice(dirs);
        args.extend_from_slice(&["--out", out.to_str().unwrap()]);
        let o = nekosim(&args);
        (o.status.code(), stderr(&o))
    };
    for (dirs, says) in [
        (vec![a0.as_str()], "shard 1/2 is missing"),
        (vec![a0.as_str(), a1.as_str(), a0.as_str()], "given twice"),
        (vec![a0.as_str(), b1.as_str()], "a shard of another sweep"),
        (
            vec![a0.as_str(), dir.path().to_str().unwrap()],
            "not a shard",
        ),
    ] {
        let (code, err) = merge(&dirs);
        assert_eq!(code, Some(2), "{dirs:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(says), "{dirs:?}: expected {says:?}: {err}");
        assert!(!out.exists(), "nothing merged");
    }
    // A shard whose rows were tampered with.
    let runs = Path::new(&a1).join("runs.csv");
    let text = std::fs::read_to_string(&runs).unwrap();
    let cut: Vec<&str> = text.lines().take(text.lines().count() - 1).collect();
    std::fs::write(&runs, cut.join("\n") + "\n").unwrap();
    let (code, err) = merge(&[a0.as_str(), a1.as_str()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("incomplete or altered"), "{err}");
}

/// `NAME: VALUE` out of a run's summary line.
fn summary_field(stdout: &str, name: &str) -> f64 {
    let at = stdout.find(&format!("{name}: ")).expect(name) + name.len() + 2;
    let rest = &stdout[at..];
    let end = rest.find([',', ' ', '\n']).unwrap_or(rest.len());
    rest[..end].parse().unwrap()
}

#[test]
fn each_row_is_the_run_its_replay_command_makes_and_the_summary_its_statistics() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    assert_eq!(sweep(&out, &["--quiet"]).status.code(), Some(1));
    let mut rows = csv::Reader::from_path(out.join("runs.csv")).unwrap();
    let header: Vec<String> = rows.headers().unwrap().iter().map(String::from).collect();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let rows: Vec<Vec<String>> = rows
        .records()
        .map(|r| r.unwrap().iter().map(String::from).collect())
        .collect();
    assert_eq!(rows.len(), 12);

    // failures.txt: exactly the rows that are not ok, each with a command that replays it.
    let failures = std::fs::read_to_string(out.join("failures.txt")).unwrap();
    let lines: Vec<&str> = failures.lines().collect();
    let mut replayed = 0;
    for r in &rows {
        let run = &r[col("run")];
        let listed = lines
            .iter()
            .position(|l| l.starts_with(&format!("run {run} (")));
        assert_eq!(
            listed.is_some(),
            r[col("ok")] == "false",
            "run {run}: {failures}"
        );
        // The replay command, or the same command for a passing run.
        let command = match listed {
            Some(i) => lines[i + 1].trim().to_string(),
            None => format!(
                "nekosim run examples/scenarios/random_movement.ron --seed {} --set 'robots[0].count={}' --set 'world.size={}' --set until=15.0 --rrd run-{run}.rrd",
                r[col("seed")],
                r[col("robots[0].count")],
                r[col("world.size")]
            ),
        };
        let rrd = dir.path().join(format!("run-{run}.rrd"));
        let mut command = command
            .replacen("nekosim", env!("CARGO_BIN_EXE_nekosim"), 1)
            .replace(&format!("run-{run}.rrd"), rrd.to_str().unwrap());
        if !cfg!(feature = "rerun") {
            command = command.replace(&format!(" --rrd {}", rrd.display()), "");
        }
        let o = Command::new("sh")
            .args(["-c", &command])
            .current_dir(root())
            .output()
            .unwrap();
        let error = &r[col("error")];
        if error.is_empty() {
            assert_eq!(o.status.code(), Some(0), "{command}: {}", stderr(&o));
            let stdout = String::from_utf8_lossy(&o.stdout);
            for (metric, printed) in [
                ("collisions", "collisions"),
                ("events", "events"),
                ("cancelled_events", "cancelled events"),
                ("end_time", "simulated time"),
            ] {
                let v: f64 = r[col(metric)].parse().unwrap();
                assert_eq!(
                    v,
                    summary_field(&stdout, printed),
                    "run {run} {metric}: {stdout}"
                );
            }
            if cfg!(feature = "rerun") {
                assert!(rrd.exists(), "{command} writes its recording");
            }
        } else {
            // A point that cannot be built: the replay says the same, exit 2.
            assert_eq!(o.status.code(), Some(2), "{command}");
            assert_eq!(stderr(&o).trim_end(), error, "run {run}");
        }
        replayed += 1;
    }
    assert_eq!(replayed, 12);

    // summary.csv: per point, mean, sample sd and the t interval of each metric's values.
    let mut summary = csv::Reader::from_path(out.join("summary.csv")).unwrap();
    let sh: Vec<String> = summary
        .headers()
        .unwrap()
        .iter()
        .map(String::from)
        .collect();
    let scol = |name: &str| sh.iter().position(|h| h == name).unwrap();
    let points: Vec<Vec<String>> = summary
        .records()
        .map(|r| r.unwrap().iter().map(String::from).collect())
        .collect();
    assert_eq!(points.len(), 4);
    // t(0.975, 2), in closed form for 2 degrees of freedom.
    let t2 = 0.95 / (2.0f64 * 0.975 * 0.025).sqrt();
    for p in &points {
        let of_point: Vec<&Vec<String>> = rows
            .iter()
            .filter(|r| r[col("point")] == p[scol("point")])
            .collect();
        assert_eq!(p[scol("runs")], of_point.len().to_string());
        let failing = of_point.iter().filter(|r| r[col("ok")] == "false").count();
        assert_eq!(p[scol("failing")], failing.to_string());
        for metric in ["collisions", "events", "end_time", "cancelled_events"] {
            let v: Vec<f64> = of_point
                .iter()
                .filter(|r| !r[col(metric)].is_empty())
                .map(|r| r[col(metric)].parse().unwrap())
                .collect();
            let got = |s: &str| p[scol(&format!("{metric}_{s}"))].clone();
            assert_eq!(got("n"), v.len().to_string());
            if v.is_empty() {
                assert_eq!(got("mean"), "");
                continue;
            }
            assert_eq!(v.len(), 3);
            let mean = (v[0] + v[1] + v[2]) / 3.0;
            let sd = (((v[0] - mean).powi(2) + (v[1] - mean).powi(2) + (v[2] - mean).powi(2))
                / 2.0)
                .sqrt();
            let half = t2 * sd / 3f64.sqrt();
            let close = |a: &str, b: f64| {
                let a: f64 = a.parse().unwrap();
                assert!(
                    (a - b).abs() <= 1e-9 * b.abs().max(1.0),
                    "{metric}: {a} vs {b}"
                );
            };
            close(&got("mean"), mean);
            close(&got("sd"), sd);
            close(&got("ci95_low"), mean - half);
            close(&got("ci95_high"), mean + half);
        }
    }
}

#[test]
fn set_replaces_and_adds_scenario_values_and_refuses_bad_paths() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.jsonl");
    let o = nekosim(&[
        "run",
        "examples/scenarios/random_movement.ron",
        "--set",
        "robots[0].count=7",
        "--set",
        "robots[0].angle=45.0",
        "--set",
        "until=3.0",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("robots: 7,"), "{stdout}");
    assert_eq!(summary_field(&stdout, "simulated time"), 3.0);
    // The added field took effect: every robot is born heading 45 degrees.
    let spawns: Vec<serde_json::Value> = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .filter(|r: &serde_json::Value| r["kind"] == "spawn")
        .collect();
    assert_eq!(spawns.len(), 7);
    assert!(spawns.iter().all(|s| s["angle"] == 45.0), "{spawns:?}");
    for (set, says) in [
        ("robots[3].count=1", "no value at `robots[3].count`"),
        ("robots[0].count=many", "random_movement.ron:"),
        ("robots[0].count", "expected PATH=VALUE"),
    ] {
        let o = nekosim(&[
            "run",
            "examples/scenarios/random_movement.ron",
            "--set",
            set,
        ]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{set}: {err}");
        assert!(err.contains(says), "{set}: expected {says:?} in {err}");
    }
}
