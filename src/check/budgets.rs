//! The command line's side of a stack check's budgets: where a breadth-first search spills
//! ([`nekosim_models::spill`]; a directory of its own per search, and the cleanup for a
//! process that ends at once), and durations, sizes and timer firings as `--max-time`,
//! `--max-memory` and `--timers` read them.

use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use nekosim_models::spill::{Spill, Spilled};
use nekosim_models::Strategy;

use nekosim_models::config::UNLIMITED_TIMERS;

use super::{CheckArgs, CheckError};

/// How the search of `args` spills: `None` when it does not (`--no-spill`, or a search other
/// than breadth-first) and stops at the memory budget. A parent that is not a directory is
/// refused before the search.
pub(super) fn spill(args: &CheckArgs) -> Result<Option<Spill>, CheckError> {
    if args.no_spill || args.strategy != Strategy::Bfs {
        return Ok(None);
    }
    let parent = args.spill_dir.clone().unwrap_or_else(default_spill_parent);
    if !parent.is_dir() {
        return Err(CheckError::SpillDir {
            path: parent,
            source: io::Error::new(io::ErrorKind::NotFound, "not a directory"),
        });
    }
    Ok(Some(Spill {
        dir: fresh_spill_dir(&parent),
        after_states: args.spill_after,
        max_disk: args.max_disk,
    }))
}

/// Refuses the budgets a check of robots does not keep: only a stack's search spills and
/// keeps a time budget.
pub(super) fn stack_only(args: &CheckArgs) -> Result<(), CheckError> {
    if args.max_time.is_some() || args.max_disk.is_some() || args.spill_dir.is_some() {
        return Err(CheckError::Lcm(
            "--max-time, --max-disk and --spill-dir apply to a stack's check, not to robots'"
                .into(),
        ));
    }
    Ok(())
}

/// What the report's search line adds: where the search spills and at most how much, and
/// its time budget.
pub(super) fn search_text(args: &CheckArgs, spill: Option<&Spill>) -> String {
    let mut text = String::new();
    if let Some(parent) = spill.and_then(|s| s.dir.parent()) {
        text += &format!(", spilling to {}", parent.display());
        if let Some(d) = args.max_disk {
            text += &format!(" (at most {})", size_text(d));
        }
    }
    if let Some(t) = args.max_time {
        text += &format!(", {} time", duration_text(t));
    }
    text
}

/// The line on stderr that tells of the first spill, into `dir`.
pub(super) fn spilling_text(dir: Option<&Path>, so_far: &Spilled) -> String {
    format!(
        "spilling to disk in {}: {} visited states and {} frontier states moved out of memory",
        dir.unwrap_or(Path::new("?")).display(),
        so_far.states,
        so_far.frontier
    )
}

/// The report's line of what the search spilled.
pub(super) fn spilled_text(s: &Spilled) -> String {
    format!(
        "spilled to disk: {} time{}, at most {} of files ({} written), {} visited states on disk at the end",
        s.spills,
        if s.spills == 1 { "" } else { "s" },
        size_text(s.peak_bytes),
        size_text(s.written),
        s.states
    )
}

/// Parses a duration: a number of seconds, or numbers with units `ms`, `s`, `m`, `h`, e.g.
/// `90s`, `10m`, `1h30m` or `2.5h`.
pub fn parse_duration(text: &str) -> Result<Duration, String> {
    let bad = || format!("{text:?} is not a duration; expected e.g. 90s, 10m or 2h");
    let t = text.trim();
    if let Ok(seconds) = t.parse::<f64>() {
        return Duration::try_from_secs_f64(seconds)
            .ok()
            .filter(|d| !d.is_zero())
            .ok_or_else(bad);
    }
    let mut total = 0.0;
    let mut rest = t;
    while !rest.is_empty() {
        let split = rest
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .ok_or_else(bad)?;
        let (num, tail) = rest.split_at(split);
        let unit_end = tail
            .find(|c: char| c.is_ascii_digit() || c == '.')
            .unwrap_or(tail.len());
        let (unit, tail) = tail.split_at(unit_end);
        let factor = match unit {
            "ms" => 1e-3,
            "s" => 1.0,
            "m" | "min" => 60.0,
            "h" => 3600.0,
            _ => return Err(bad()),
        };
        total += num.parse::<f64>().map_err(|_| bad())? * factor;
        rest = tail;
    }
    Duration::try_from_secs_f64(total)
        .ok()
        .filter(|d| !d.is_zero())
        .ok_or_else(bad)
}

/// A duration as the report gives it: whole hours, minutes or seconds where it is one.
pub fn duration_text(d: Duration) -> String {
    let s = d.as_secs_f64();
    match d.as_secs() {
        n if d.subsec_nanos() == 0 && n >= 3600 && n % 3600 == 0 => format!("{}h", n / 3600),
        n if d.subsec_nanos() == 0 && n >= 60 && n % 60 == 0 => format!("{}m", n / 60),
        _ => format!("{s}s"),
    }
}

/// Where a breadth-first search spills by default: `$TMPDIR` when set, else `/var/tmp`
/// where it exists (a disk on systems whose `/tmp` is in memory), else the system's
/// temporary directory.
pub fn default_spill_parent() -> PathBuf {
    match std::env::var_os("TMPDIR") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ if Path::new("/var/tmp").is_dir() => PathBuf::from("/var/tmp"),
        _ => std::env::temp_dir(),
    }
}

/// The prefix of this process's spill directories ([`fresh_spill_dir`]).
fn spill_prefix() -> String {
    format!("nekosim-spill-{}-", std::process::id())
}

/// A spill directory in `parent` that no other search of this process (nor of another
/// process) names.
pub fn fresh_spill_dir(parent: &Path) -> PathBuf {
    static SEARCHES: AtomicUsize = AtomicUsize::new(0);
    let n = SEARCHES.fetch_add(1, Ordering::Relaxed);
    parent.join(format!("{}{n}", spill_prefix()))
}

/// Removes this process's spill directories in `parent`: a search removes its own when it
/// ends, and this is for a process that ends at once (a second Ctrl-C).
pub fn remove_spills(parent: &Path) {
    let prefix = spill_prefix();
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    for e in entries.flatten() {
        if e.file_name().to_string_lossy().starts_with(&prefix) {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// `bytes` in the largest binary unit that keeps it at least 1.
pub fn size_text(bytes: u64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < units.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} B")
    } else {
        format!("{v:.1} {}", units[u])
    }
}

/// Parses a timer budget: a number of firings per process, or `unlimited`.
pub fn parse_timers(text: &str) -> Result<u32, String> {
    match text.trim() {
        "unlimited" => Ok(UNLIMITED_TIMERS),
        t => t
            .parse::<u32>()
            .ok()
            .filter(|&n| n != UNLIMITED_TIMERS)
            .ok_or_else(|| {
                format!("{text:?} is not a timer budget; expected a number of firings or unlimited")
            }),
    }
}

/// Parses a memory size: a number of bytes with an optional unit, binary (`KiB`, `MiB`,
/// `GiB`, `TiB`) or decimal (`kB`, `MB`, `GB`, `TB`), e.g. `512MiB` or `4GiB`.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let factor: f64 = match unit.trim() {
        "" | "B" => 1.0,
        "KiB" => 1024.0,
        "MiB" => 1024.0 * 1024.0,
        "GiB" => 1024.0 * 1024.0 * 1024.0,
        "TiB" => 1024.0 * 1024.0 * 1024.0 * 1024.0,
        "kB" | "KB" => 1e3,
        "MB" => 1e6,
        "GB" => 1e9,
        "TB" => 1e12,
        other => {
            return Err(format!(
                "unknown unit {other:?} in {text:?}; expected e.g. 512MiB or 4GiB"
            ))
        }
    };
    let n: f64 = num
        .parse()
        .map_err(|_| format!("{text:?} is not a size; expected e.g. 512MiB or 4GiB"))?;
    let bytes = n * factor;
    if !(bytes >= 1.0 && bytes.is_finite()) {
        return Err(format!(
            "{text:?} is not a size; expected e.g. 512MiB or 4GiB"
        ));
    }
    Ok(bytes as u64)
}
