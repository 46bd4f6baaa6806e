//! `nekosim check MODEL|SCENARIO.ron`: its options, turned into [`CheckArgs`], and the check
//! with Ctrl-C stopping the search and a progress line on a terminal.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use super::{invalid, Failure, INTERRUPTED};
use crate::check::{self, CheckArgs};
use crate::recording::RecordingError;
use crate::scenario::Registry;
use nekosim_models::{NetworkKind, Strategy};

/// The options of `nekosim check` (the help text above them is `Command::Check`'s doc).
#[derive(clap::Args, Debug)]
pub(super) struct CheckOptions {
    /// A scenario file (.ron) whose stack to check, or a shipped model (see --list).
    #[arg(required_unless_present = "list", value_name = "MODEL|SCENARIO")]
    model: Option<String>,
    /// Print the model names, one per line.
    #[arg(long, conflicts_with = "model")]
    list: bool,
    /// The layer whose service is checked [default: the stack's top layer].
    #[arg(long, value_name = "ID")]
    layer: Option<String>,
    /// Number of processes [default: the scenario's robots].
    #[arg(long)]
    processes: Option<u32>,
    /// Client requests (broadcasts or proposals), handed out round-robin [default: 2].
    #[arg(long)]
    requests: Option<u32>,
    /// Processes that may crash [default: the scenario's crash faults].
    #[arg(long)]
    crashes: Option<u32>,
    /// Network semantics [default: derived from the scenario's network].
    #[arg(long, value_enum)]
    network: Option<NetArg>,
    /// Search strategy.
    #[arg(long, value_enum, default_value_t = StrategyArg::Bfs)]
    strategy: StrategyArg,
    /// Seed of the random walks of `--strategy simulation`.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Stop after this many unique states (states visited, for a simulation) [default:
    /// unlimited; a simulation visits 1000000].
    #[arg(long, value_name = "N")]
    max_states: Option<usize>,
    /// Stop when the process's resident memory reaches SIZE (e.g. 512MiB, 4GiB)
    /// [default: half the machine's memory, at most 4GiB].
    #[arg(long, value_name = "SIZE", value_parser = check::parse_size)]
    max_memory: Option<u64>,
    /// Where a breadth-first search spills its visited states and frontier, compressed,
    /// when memory nears its budget (in a directory of its own, removed at the end)
    /// [default: $TMPDIR, else /var/tmp, else the system's temporary directory].
    #[arg(long, value_name = "DIR")]
    spill_dir: Option<PathBuf>,
    /// Stop at the memory budget instead of spilling to disk.
    #[arg(long, conflicts_with_all = ["spill_dir", "max_disk"])]
    no_spill: bool,
    /// Stop when the spill files would take more than SIZE [default: unlimited].
    #[arg(long, value_name = "SIZE", value_parser = check::parse_size)]
    max_disk: Option<u64>,
    /// Spill whenever this many visited states are in memory (for tests).
    #[arg(long, value_name = "N", hide = true)]
    spill_after: Option<usize>,
    /// Stop the search after DURATION (e.g. 90s, 10m, 2h) [default: unlimited].
    #[arg(long, value_name = "DURATION", value_parser = check::parse_duration)]
    max_time: Option<std::time::Duration>,
    /// Explore paths of at most this many steps.
    #[arg(long)]
    depth: Option<usize>,
    /// Checker threads.
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Write the counterexample (or a witness) here as a JSONL trace.
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Save the counterexample (or a witness) as a Rerun recording (.rrd).
    #[arg(long)]
    rrd: Option<PathBuf>,
    /// Protocol timer firings allowed per process, or `unlimited` (then a second copy of
    /// a message in flight is outside the model).
    #[arg(long, value_parser = check::parse_timers)]
    timers: Option<u32>,
    /// Last Chandra-Toueg round explored.
    #[arg(long)]
    rounds: Option<u64>,
    /// Symmetry reduction: explore one state per class of states equal up to renaming the
    /// processes (every layer must declare symmetry; bfs only).
    #[arg(long)]
    symmetry: bool,
    /// No reduction (with bfs: on an ordered network, partial-order reduction explores
    /// only the steps of a few processes where that keeps every verdict; on others, the
    /// search forgets messages that can no longer change their receiver).
    #[arg(long)]
    no_reduction: bool,
    /// Also search without the reduction and print both state counts.
    #[arg(long, conflicts_with = "no_reduction")]
    compare_reduction: bool,
    /// Explore on after a counterexample to settle every property [default: stop at the
    /// first counterexample].
    #[arg(long)]
    keep_going: bool,
    /// Decide no temporal property: no liveness graph is built after the search.
    #[arg(long)]
    no_liveness: bool,
    /// No progress line on the terminal.
    #[arg(long)]
    quiet: bool,
    /// Look-Compute-Move: the synchrony model [default: the scenario's].
    #[arg(long, value_name = "NAME", value_parser = check::lcm::parse_synchrony)]
    synchrony: Option<nekosim_actors::lcm::Synchrony>,
    /// Look-Compute-Move: rigid or non-rigid moves [default: the scenario's].
    #[arg(long, value_enum)]
    movement: Option<MovementArg>,
    /// Look-Compute-Move: what a Look reads from a light being written [default: the
    /// scenario's].
    #[arg(long, value_enum)]
    register: Option<RegisterArg>,
    /// Look-Compute-Move: weak, strong, none, bounded (spin-light's limit) or bounded:K
    /// [default: bounded]. A stack's liveness: none, weak or strong [default: weak, fair
    /// loss (strong) on a lossy network].
    #[arg(long, value_name = "FAIRNESS", value_parser = check::lcm::RobotFairness::parse)]
    fairness: Option<check::lcm::RobotFairness>,
    /// Look-Compute-Move: eventually, eventually-always or always-eventually "on one
    /// point" [default: eventually-always, as the scenario's gathered predicate].
    #[arg(long, value_name = "SHAPE", value_parser = check::lcm::parse_property)]
    property: Option<nekosim_models::liveness::Liveness>,
    /// Look-Compute-Move search (three or more robots, or algorithms on exact positions):
    /// collision-free, diameter-never-grows, gathered-within:K or converged-within:EPS:K;
    /// repeat for several [default: collision-free]. `--depth` is the rounds searched,
    /// `--strategy simulation` searches at random (`--max-states` runs).
    #[arg(long = "goal", value_name = "GOAL", value_parser = check::lcm_search::parse_goal)]
    goals: Vec<nekosim_actors::lcm::search::Goal>,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum StrategyArg {
    Bfs,
    Dfs,
    Simulation,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum MovementArg {
    Rigid,
    NonRigid,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum RegisterArg {
    Atomic,
    Regular,
    Safe,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum NetArg {
    Unordered,
    Ordered,
    Lossy,
}

/// Runs the check `options` ask for (or lists the models); `Ok` carries the exit code.
pub(super) fn check(options: CheckOptions, registry: &Registry) -> Result<u8, Failure> {
    if options.list {
        print!("{}", check::list());
        return Ok(0);
    }
    if options.rrd.is_some() && !cfg!(feature = "rerun") {
        return Err(invalid(RecordingError::Unsupported));
    }
    let args = CheckArgs {
        model: options.model.unwrap_or_default(),
        layer: options.layer,
        processes: options.processes,
        requests: options.requests,
        crashes: options.crashes,
        network: options.network.map(|n| match n {
            NetArg::Unordered => NetworkKind::Unordered,
            NetArg::Ordered => NetworkKind::Ordered,
            NetArg::Lossy => NetworkKind::Lossy,
        }),
        strategy: match options.strategy {
            StrategyArg::Bfs => Strategy::Bfs,
            StrategyArg::Dfs => Strategy::Dfs,
            StrategyArg::Simulation => Strategy::Simulation { seed: options.seed },
        },
        max_states: options.max_states,
        max_memory: options.max_memory,
        spill_dir: options.spill_dir,
        no_spill: options.no_spill,
        max_disk: options.max_disk,
        spill_after: options.spill_after,
        max_time: options.max_time,
        depth: options.depth,
        threads: options.threads,
        trace: options.trace,
        rrd: options.rrd,
        timers: options.timers,
        rounds: options.rounds,
        symmetry: options.symmetry,
        no_reduction: options.no_reduction,
        compare_reduction: options.compare_reduction,
        keep_going: options.keep_going,
        no_liveness: options.no_liveness,
        lcm: check::lcm::LcmOverrides {
            synchrony: options.synchrony,
            rigid: options.movement.map(|m| m == MovementArg::Rigid),
            register: options.register.map(|r| match r {
                RegisterArg::Atomic => nekosim_actors::lcm::Register::Atomic,
                RegisterArg::Regular => nekosim_actors::lcm::Register::Regular,
                RegisterArg::Safe => nekosim_actors::lcm::Register::Safe,
            }),
            fairness: options.fairness,
            property: options.property,
        },
        goals: options.goals,
    };
    // Ctrl-C (or SIGTERM) stops the search: the check reports what it found and
    // explored, writes the outputs asked for, and exits 130; a second one ends the
    // process at once.
    let interrupt = Arc::new(AtomicBool::new(false));
    {
        let interrupt = interrupt.clone();
        // A process ended at once leaves no spill files behind.
        let spills = (!args.no_spill)
            .then(|| args.spill_dir.clone())
            .map(|d| d.unwrap_or_else(check::default_spill_parent));
        // Without a handler (e.g. one already set), an interrupt kills the process.
        let _ = ctrlc::set_handler(move || {
            if interrupt.swap(true, Ordering::Relaxed) {
                if let Some(parent) = &spills {
                    check::remove_spills(parent);
                }
                std::process::exit(INTERRUPTED);
            }
        });
    }
    let live = check::Live {
        interrupt: Some(interrupt),
        progress: !options.quiet && std::io::stderr().is_terminal(),
    };
    let conclusion = check::check_live(&args, registry, &mut std::io::stdout().lock(), &live)
        .map_err(|e| match e {
            check::CheckError::Recording(r) if !r.is_input_error() => Failure {
                code: 1,
                message: r.to_string(),
            },
            other => invalid(other),
        })?;
    Ok(conclusion.exit_code())
}
