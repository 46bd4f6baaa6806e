//! The Python package (python/, docs/python.md) read by the tests nobody wrote in Rust:
//! python/tests with pytest, in a virtual environment under target/ with the pinned versions
//! of python/tests/requirements.txt (maturin, pytest, pandas, pyarrow, numpy, Dask, matplotlib), created on
//! first use, into which `pip install ./python` builds the package. The package is built as
//! a debug build in this target directory, so it reuses the workspace's compiled crates.
//!
//! Without a Python interpreter the test says so and passes, except under `CI=true`, where a
//! missing Python fails it; a failed install or a failed Python test always fails it.

use std::path::PathBuf;
use std::process::Command;

use crate::common::run_command as run;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn target() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target"))
}

/// The virtual environment's Python with the pinned packages and this repository's package
/// installed, or `None` when there is no Python to create it (outside CI).
fn python() -> Option<PathBuf> {
    let venv = target().join("python-venv");
    let bin = venv.join("bin");
    let py = bin.join("python");
    let requirements = root().join("python/tests/requirements.txt");
    let pinned = std::fs::read_to_string(&requirements).unwrap();
    let ready = py.exists()
        && Command::new(&py)
            .args(["-m", "pip", "freeze"])
            .output()
            .is_ok_and(|o| {
                let have = String::from_utf8_lossy(&o.stdout).to_lowercase();
                pinned
                    .lines()
                    .filter(|l| !l.trim().is_empty())
                    .all(|l| have.lines().any(|h| h == l.trim().to_lowercase()))
            });
    if !ready {
        let base = std::env::var("NEKOSIM_PYTHON").unwrap_or_else(|_| "python3".into());
        if Command::new(&base).arg("--version").output().is_err() {
            let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
            assert!(
                !ci,
                "no Python interpreter ({base}) under CI: the Python package is untested"
            );
            eprintln!(
                "python_package: no Python interpreter ({base}); the Python package is not tested"
            );
            return None;
        }
        run(Command::new(base).args(["-m", "venv"]).arg(&venv));
        run(Command::new(&py)
            .args(["-m", "pip", "install", "--quiet", "-r"])
            .arg(&requirements));
    }
    // The package is built from the sources every time (cargo rebuilds what changed), with
    // the pinned maturin, as a debug build in this target directory.
    let path = std::env::join_paths(std::iter::once(bin.clone()).chain(std::env::split_paths(
        &std::env::var_os("PATH").unwrap_or_default(),
    )))
    .unwrap();
    run(Command::new(&py)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-build-isolation",
            "--force-reinstall",
            "--no-deps",
        ])
        .arg(root().join("python"))
        .env("PATH", path)
        .env("CARGO_TARGET_DIR", target())
        .env("MATURIN_PEP517_ARGS", "--profile dev"));
    Some(py)
}

#[test]
fn the_python_package_matches_the_command_line() {
    let Some(py) = python() else {
        return;
    };
    let out = run(Command::new(&py)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(root().join("python/tests"))
        .env("NEKOSIM_BIN", env!("CARGO_BIN_EXE_nekosim"))
        .current_dir(root()));
    assert!(out.contains(" passed"), "{out}");
    assert!(!out.contains("skipped"), "{out}");
    eprintln!("{}", out.trim().lines().last().unwrap_or_default());
}
