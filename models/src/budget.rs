//! A search's budgets (states, memory; a spilling search's disk, and the watcher's time and
//! Ctrl-C), what ended a search that one of them stopped before it was exhaustive, and the
//! memory a memory budget is measured against (this process's, the machine's).

use std::time::Duration;

/// Resources a search may use. When one runs out, the search stops cleanly with what it has
/// settled ([`Outcome::stopped`](crate::Outcome::stopped)); it never grows past the memory
/// budget.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Budget {
    /// Unique states (states visited, for a simulation).
    pub max_states: Option<usize>,
    /// Resident memory of this process, in bytes (Linux: `VmRSS`); the search stops a little
    /// below it ([`MEMORY_HEADROOM`]), so the peak stays under it.
    pub max_memory: Option<u64>,
}

/// What ended a search before it was exhaustive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stopped {
    /// The state budget; the unique states (or simulated states) reached.
    States { limit: usize },
    /// The memory budget; the resident bytes seen when it ran out.
    Memory { limit: u64, seen: u64 },
    /// The watcher asked it to stop ([`Watch::interrupted`](crate::Watch::interrupted):
    /// Ctrl-C).
    Interrupted,
    /// The time budget the watcher keeps ([`Watch::out_of_time`](crate::Watch::out_of_time)).
    Time { limit: Duration },
    /// The disk budget of spilling ([`Spill::max_disk`](crate::spill::Spill::max_disk))
    /// \[bytes\].
    Disk { limit: u64 },
    /// A spill file could not be written or read ([`crate::spill`]).
    DiskError { kind: std::io::ErrorKind },
}

/// A memory budget stops the search at `1 - 1/MEMORY_HEADROOM` of its size (64 MiB below
/// 4 GiB), so that the peak stays under it.
pub const MEMORY_HEADROOM: u64 = 64;

/// This process's resident memory in bytes (`VmRSS` of /proc/self/status), where readable.
pub fn resident_memory() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    kib_field(&status, "VmRSS:")
}

/// The memory this process may use: the machine's (`MemTotal`), or the cgroup's limit when
/// lower (a container's `memory.max`).
pub fn available_memory() -> Option<u64> {
    let total = kib_field(&std::fs::read_to_string("/proc/meminfo").ok()?, "MemTotal:")?;
    let cgroup = std::fs::read_to_string("/sys/fs/cgroup/memory.max")
        .ok()
        .and_then(|s| s.trim().parse::<u64>().ok());
    Some(cgroup.map_or(total, |c| c.min(total)))
}

/// A `KEY: N kB` line of a /proc file, in bytes.
fn kib_field(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kib: u64 = line[key.len()..]
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib * 1024)
}
