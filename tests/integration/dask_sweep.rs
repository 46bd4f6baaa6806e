//! Sweeps on Dask (docs/sweeps.md): `tests/sweep/test_dask.py`, in a virtual environment with
//! the pinned `dask[distributed]` (tests/sweep/requirements.txt), shards
//! examples/sweeps/smoke.ron 4 ways over a `LocalCluster` of 2 worker processes with the
//! shipped launcher, and checks the merged files byte for byte against `--jobs 1`, also when
//! one worker is killed during the sweep.

use std::path::PathBuf;
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The virtual environment's Python with the pinned dask (`NEKOSIM_PYTHON` picks the
/// interpreter that creates it; default `python3`).
fn python() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target"));
    let venv = target.join("dask-venv");
    let py = venv.join("bin").join("python");
    let requirements = root().join("tests/sweep/requirements.txt");
    let pinned = std::fs::read_to_string(&requirements).unwrap();
    let version = pinned
        .trim()
        .rsplit("==")
        .next()
        .expect("a pinned version")
        .to_string();
    let ready = py.exists()
        && Command::new(&py)
            .args([
                "-c",
                &format!(
                    "import dask, distributed, sys; sys.exit(dask.__version__ != {version:?})"
                ),
            ])
            .status()
            .is_ok_and(|s| s.success());
    if !ready {
        let base = std::env::var("NEKOSIM_PYTHON").unwrap_or_else(|_| "python3".into());
        let ok = Command::new(base)
            .args(["-m", "venv"])
            .arg(&venv)
            .status()
            .unwrap()
            .success();
        assert!(ok, "python3 -m venv {}", venv.display());
        let ok = Command::new(&py)
            .args(["-m", "pip", "install", "--quiet", "-r"])
            .arg(&requirements)
            .status()
            .unwrap()
            .success();
        assert!(ok, "pip install -r {}", requirements.display());
    }
    py
}

#[test]
fn a_sweep_sharded_on_a_dask_local_cluster_merges_into_the_local_files_even_when_a_worker_dies() {
    let py = python();
    let o = Command::new(&py)
        .arg(root().join("tests/sweep/test_dask.py"))
        .arg(env!("CARGO_BIN_EXE_nekosim"))
        .arg("examples/sweeps/smoke.ron")
        .current_dir(root())
        .output()
        .unwrap();
    let out = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "{out}");
    assert!(out.contains("test_dask: ok"), "{out}");
    eprintln!("{}", out.trim());
}
