//! Shards (`--shard I/N`): a shard writes its rows with a manifest ([`Manifest`]), and
//! [`merge`] puts shards back together into the very files the whole sweep writes, refusing
//! shards that do not fit together.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::execution::Outcome;
use super::outputs::{finish, read_runs, runs_csv, write};
use super::{fnv1a, Plan, Row, SweepError};

/// A shard's manifest (`shard.json`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Manifest {
    pub plan: Plan,
    /// The binary that ran the shard ([`binary`]).
    pub binary: String,
    pub shard: usize,
    pub of: usize,
    /// Rows the shard holds.
    pub rows: usize,
}

/// What identifies this binary: its version, and its executable's size with a hash of 64
/// chunks of 64 KiB spread over it (a different build differs there; reading the whole
/// executable, hundreds of MB in a debug build, would cost each shard seconds).
pub fn binary() -> String {
    fn sample(path: &Path) -> std::io::Result<String> {
        use std::io::{Read, Seek, SeekFrom};
        let mut f = std::fs::File::open(path)?;
        let len = f.metadata()?.len();
        const CHUNK: u64 = 64 * 1024;
        let mut buf = vec![0u8; CHUNK as usize];
        let mut h = fnv1a(&[&len.to_le_bytes()]);
        for k in 0..64u64 {
            let at = (len.saturating_sub(CHUNK)) * k / 63;
            f.seek(SeekFrom::Start(at))?;
            let n = f.read(&mut buf)?;
            h ^= fnv1a(&[&buf[..n]]).rotate_left(k as u32);
        }
        Ok(format!("{len} bytes, {h:016x}"))
    }
    let exe = std::env::current_exe()
        .and_then(|p| sample(&p))
        .unwrap_or_else(|_| "unknown executable".into());
    format!("nekosim {} ({exe})", env!("CARGO_PKG_VERSION"))
}

/// Writes a shard's rows and manifest into `out`.
pub fn finish_shard(
    plan: &Plan,
    rows: &[Row],
    (shard, of): (usize, usize),
    out: &Path,
) -> Result<(), SweepError> {
    let checks = plan.parsed_checks();
    write(&out.join("runs.csv"), &runs_csv(plan, rows, &checks))?;
    let m = Manifest {
        plan: plan.clone(),
        binary: binary(),
        shard,
        of,
        rows: rows.len(),
    };
    let json = serde_json::to_string_pretty(&m).map_err(|e| SweepError::Write {
        path: out.join("shard.json").display().to_string(),
        error: std::io::Error::other(e),
    })?;
    write(&out.join("shard.json"), format!("{json}\n").as_bytes())
}

/// Merges shard directories into the whole sweep's files in `out`, refusing missing,
/// duplicated, incomplete or mismatched shards (other sweep file, scenario or binary).
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<Outcome, SweepError> {
    let input = SweepError::Input;
    let mut manifests: Vec<(Manifest, &PathBuf)> = Vec::new();
    for d in dirs {
        let path = d.join("shard.json");
        let text = std::fs::read_to_string(&path).map_err(|e| {
            input(format!(
                "{}: not a shard ({e}); expected the output of `nekosim sweep --shard I/N`",
                path.display()
            ))
        })?;
        let m: Manifest =
            serde_json::from_str(&text).map_err(|e| input(format!("{}: {e}", path.display())))?;
        manifests.push((m, d));
    }
    let Some((first, first_dir)) = manifests.first().cloned() else {
        return Err(input("no shard directories given".into()));
    };
    let mut seen: Vec<Option<&PathBuf>> = vec![None; first.of];
    for (m, d) in &manifests {
        if m.plan != first.plan {
            return Err(input(format!(
                "{}: a shard of another sweep (file or scenario differ from {})",
                d.display(),
                first_dir.display()
            )));
        }
        if m.binary != first.binary {
            return Err(input(format!(
                "{}: run by another binary ({}) than {} ({})",
                d.display(),
                m.binary,
                first_dir.display(),
                first.binary
            )));
        }
        if m.of != first.of || m.shard >= m.of {
            return Err(input(format!(
                "{}: shard {}/{} does not fit shards of {}",
                d.display(),
                m.shard,
                m.of,
                first.of
            )));
        }
        if let Some(other) = seen[m.shard] {
            return Err(input(format!(
                "shard {}/{} given twice: {} and {}",
                m.shard,
                m.of,
                other.display(),
                d.display()
            )));
        }
        seen[m.shard] = Some(d);
    }
    if let Some(missing) = seen.iter().position(Option::is_none) {
        return Err(input(format!("shard {missing}/{} is missing", first.of)));
    }
    let plan = &first.plan;
    let mut rows = Vec::new();
    for (m, d) in &manifests {
        let shard_rows = read_runs(plan, &d.join("runs.csv"))?;
        let expected = (0..plan.runs()).filter(|r| r % m.of == m.shard).count();
        if shard_rows.len() != m.rows
            || shard_rows.len() != expected
            || shard_rows
                .iter()
                .any(|r| r.run % m.of != m.shard || r.run >= plan.runs())
        {
            return Err(input(format!(
                "{}: shard {}/{} is incomplete or altered ({} rows, {} expected)",
                d.display(),
                m.shard,
                m.of,
                shard_rows.len(),
                expected
            )));
        }
        rows.extend(shard_rows);
    }
    rows.sort_by_key(|r| r.run);
    finish(plan, &rows, out)?;
    let checks = plan.parsed_checks();
    Ok(Outcome {
        failing: rows.iter().filter(|r| !r.ok(plan, &checks)).count(),
        errors: rows.iter().filter(|r| r.error.is_some()).count(),
        rows,
        interrupted: false,
    })
}
