//! The `nekosim` command line: run or validate a scenario file, or model-check a protocol
//! stack. [`main_with`] gives a user's own program the whole command with the protocols (and
//! algorithms) it registers:
//!
//! ```no_run
//! use nekosim::scenario::Registry;
//! # #[derive(Clone, Debug, PartialEq, Eq, Hash)] struct MyProtocol;
//! fn main() -> std::process::ExitCode {
//!     let mut registry = Registry::with_builtins();
//!     // registry.protocol::<MyProtocol>("MyProtocol");
//!     nekosim::cli::main_with(registry)
//! }
//! ```
//!
//! Exit codes: 0 success, 2 invalid input (the message names FILE:LINE:COL where it can),
//! 1 internal error, or for `check` a counterexample found; 3 a `check` stopped by its state or
//! memory budget before the search was exhaustive, with no property failed; 130 a run or a
//! check ended by Ctrl-C or SIGTERM (its outputs hold the run up to the virtual time reached,
//! or what the check found so far).

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::check::{self, CheckArgs};
use crate::recording::{RecordingError, Target};
use crate::runner::{self, RunError, RunOptions};
use crate::scenario::{Overrides, Registry, Source};
use crate::sweep;
use clap::{Parser, Subcommand};
use nekosim_models::{NetworkKind, Strategy};

#[derive(Parser, Debug)]
#[command(
    name = "nekosim",
    version,
    about = "Deterministic simulator of cooperative mobile robots (Neko robot simulation engine)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a scenario.
    Run {
        /// The scenario file (RON).
        scenario: PathBuf,
        /// Seed of every random stream (overrides the file).
        #[arg(long)]
        seed: Option<u64>,
        /// End time in simulated seconds (overrides the file).
        #[arg(long)]
        until: Option<f64>,
        /// Write the Neko-style text log here.
        #[arg(long)]
        log: Option<PathBuf>,
        /// Write the JSON Lines trace here.
        #[arg(long)]
        trace: Option<PathBuf>,
        /// Save a Rerun recording here (open it with `rerun FILE`).
        #[arg(long, value_name = "FILE")]
        rrd: Option<PathBuf>,
        /// Stream to a running Rerun viewer (default: the SDK's local viewer URL).
        #[arg(long, value_name = "URL", num_args = 0..=1, default_missing_value = "")]
        connect: Option<String>,
        /// Set the value at PATH of the scenario to VALUE (RON), e.g. `robots[0].count=200`,
        /// `network.lambda=10.0` (repeatable; what a sweep's failures.txt replays).
        #[arg(long = "set", value_name = "PATH=VALUE", value_parser = parse_set)]
        set: Vec<(String, String)>,
        /// Print nothing on success.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Run a parameter sweep: every point of its axes with every seed (docs/sweeps.md); exit
    /// 1 when some run failed a check or ended with an error.
    #[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
    Sweep {
        #[command(subcommand)]
        command: Option<SweepCommand>,
        /// The sweep file (RON).
        #[arg(required = true)]
        sweep: Option<PathBuf>,
        /// The directory for runs.csv, summary.csv, failures.txt and plots/.
        #[arg(long, required = true)]
        out: Option<PathBuf>,
        /// Runs at a time [default: the machine's cores].
        #[arg(long)]
        jobs: Option<usize>,
        /// Run only shard I of N (0 <= I < N): the runs whose number is I modulo N; the
        /// directory then holds runs.csv and shard.json, for `nekosim sweep merge`.
        #[arg(long, value_name = "I/N", value_parser = parse_shard)]
        shard: Option<(usize, usize)>,
        /// Print nothing but errors.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Run one node of a cluster file: its stack over TCP to its peers (docs/real-network.md).
    Node {
        /// The cluster file (RON).
        cluster: PathBuf,
        /// This node's id.
        #[arg(long)]
        id: u32,
        /// Write the Neko-style text log here.
        #[arg(long)]
        log: Option<PathBuf>,
        /// Write the JSON Lines trace here.
        #[arg(long)]
        trace: Option<PathBuf>,
        /// The cluster's start in milliseconds since the Unix epoch (trace times count from
        /// it; `nekosim cluster` sets it) [default: this node's start].
        #[arg(long, hide = true)]
        epoch: Option<u64>,
    },
    /// Start every node of a cluster file on this machine, wait, and collect their logs,
    /// traces and a summary in DIR.
    Cluster {
        /// The cluster file (RON).
        cluster: PathBuf,
        /// Where pI.log, pI.jsonl and summary.txt go.
        #[arg(long)]
        out: PathBuf,
    },
    /// Check a scenario file without running it.
    Validate {
        /// The scenario file (RON).
        scenario: PathBuf,
    },
    /// Model-check a scenario's protocol stack, or a shipped model, with stateright (exit 1
    /// when a property fails, 3 when a budget stops the search first).
    Check {
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
    },
}

#[derive(Subcommand, Debug)]
enum SweepCommand {
    /// Merge the directories of `nekosim sweep --shard I/N` into the files of the whole
    /// sweep (refused when a shard is missing, given twice, or of another sweep or binary).
    Merge {
        /// The shard directories.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Where the merged files go.
        #[arg(long)]
        out: PathBuf,
    },
}

fn parse_shard(text: &str) -> Result<(usize, usize), String> {
    let bad = || format!("{text:?}: expected I/N with 0 <= I < N, e.g. 0/4");
    let (i, n) = text.split_once('/').ok_or_else(bad)?;
    let (i, n): (usize, usize) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if i < n {
        Ok((i, n))
    } else {
        Err(bad())
    }
}

fn parse_set(text: &str) -> Result<(String, String), String> {
    let (path, value) = text
        .split_once('=')
        .ok_or_else(|| format!("{text:?}: expected PATH=VALUE, e.g. robots[0].count=200"))?;
    Ok((path.trim().to_string(), value.trim().to_string()))
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

/// A failure and its exit code.
struct Failure {
    code: u8,
    message: String,
}

fn invalid(e: impl std::fmt::Display) -> Failure {
    Failure {
        code: 2,
        message: e.to_string(),
    }
}

/// Runs the command line of `std::env::args` with the protocols and algorithms of
/// `registry`; returns the process's exit code.
pub fn main_with(registry: Registry) -> ExitCode {
    // A panic is an internal error: exit 1 with one line, never Rust's 101.
    std::panic::set_hook(Box::new(|info| {
        eprintln!("nekosim: internal error: {info}");
    }));
    ExitCode::from(run_cli(&registry, std::env::args_os()))
}

/// Runs the command line `args` (the program name first) with the protocols and algorithms
/// of `registry`, as [`main_with`] does; returns the exit code.
pub fn run_cli<I, T>(registry: &Registry, args: I) -> u8
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    // Errors only unless RUST_LOG says otherwise; the Rerun client's own report of an
    // unreachable viewer is left out, since nekosim reports it in one line (exit 2).
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("error,re_grpc_client=off"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return code;
        }
    };
    // A panic is an internal error (exit 1); `main_with` prints it as one line.
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        execute(cli.command, registry)
    }));
    match outcome {
        Ok(Ok(code)) => code,
        Ok(Err(f)) => {
            // Invalid input starts with FILE:LINE:COL, like a compiler's diagnostics.
            if f.code == 2 {
                eprintln!("{}", f.message);
            } else {
                eprintln!("nekosim: internal error: {}", f.message);
            }
            f.code
        }
        Err(_) => 1,
    }
}

/// Runs a command; `Ok` carries the exit code (a check's counterexample is 1).
/// Exit code of a run ended by Ctrl-C or SIGTERM (128 + SIGINT, as shells report it).
const INTERRUPTED: i32 = 130;

fn execute(command: Command, registry: &Registry) -> Result<u8, Failure> {
    match command {
        Command::Check { list: true, .. } => {
            print!("{}", check::list());
            Ok(0)
        }
        Command::Check {
            model,
            layer,
            processes,
            requests,
            crashes,
            network,
            strategy,
            seed,
            max_states,
            max_memory,
            spill_dir,
            no_spill,
            max_disk,
            spill_after,
            max_time,
            depth,
            threads,
            trace,
            rrd,
            timers,
            rounds,
            symmetry,
            no_reduction,
            compare_reduction,
            keep_going,
            no_liveness,
            quiet,
            synchrony,
            movement,
            register,
            fairness,
            property,
            goals,
            ..
        } => {
            if rrd.is_some() && !cfg!(feature = "rerun") {
                return Err(invalid(RecordingError::Unsupported));
            }
            let args = CheckArgs {
                model: model.unwrap_or_default(),
                layer,
                processes,
                requests,
                crashes,
                network: network.map(|n| match n {
                    NetArg::Unordered => NetworkKind::Unordered,
                    NetArg::Ordered => NetworkKind::Ordered,
                    NetArg::Lossy => NetworkKind::Lossy,
                }),
                strategy: match strategy {
                    StrategyArg::Bfs => Strategy::Bfs,
                    StrategyArg::Dfs => Strategy::Dfs,
                    StrategyArg::Simulation => Strategy::Simulation { seed },
                },
                max_states,
                max_memory,
                spill_dir,
                no_spill,
                max_disk,
                spill_after,
                max_time,
                depth,
                threads,
                trace,
                rrd,
                timers,
                rounds,
                symmetry,
                no_reduction,
                compare_reduction,
                keep_going,
                no_liveness,
                lcm: check::lcm::LcmOverrides {
                    synchrony,
                    rigid: movement.map(|m| m == MovementArg::Rigid),
                    register: register.map(|r| match r {
                        RegisterArg::Atomic => nekosim_actors::lcm::Register::Atomic,
                        RegisterArg::Regular => nekosim_actors::lcm::Register::Regular,
                        RegisterArg::Safe => nekosim_actors::lcm::Register::Safe,
                    }),
                    fairness,
                    property,
                },
                goals,
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
                progress: !quiet && std::io::stderr().is_terminal(),
            };
            let conclusion =
                check::check_live(&args, registry, &mut std::io::stdout().lock(), &live).map_err(
                    |e| match e {
                        check::CheckError::Recording(r) if !r.is_input_error() => Failure {
                            code: 1,
                            message: r.to_string(),
                        },
                        other => invalid(other),
                    },
                )?;
            Ok(conclusion.exit_code())
        }
        Command::Sweep {
            command: Some(SweepCommand::Merge { dirs, out }),
            ..
        } => {
            let outcome = sweep::merge(&dirs, &out).map_err(sweep_failure)?;
            println!(
                "merged {} shards: {} runs, {} failing, {} errors; wrote {}",
                dirs.len(),
                outcome.rows.len(),
                outcome.failing,
                outcome.errors,
                out.display()
            );
            Ok(u8::from(outcome.failing > 0))
        }
        Command::Sweep {
            sweep: file,
            out,
            jobs,
            shard,
            quiet,
            ..
        } => {
            let (Some(file), Some(out)) = (file, out) else {
                return Err(Failure {
                    code: 2,
                    message: "nekosim sweep: SWEEP and --out are required".into(),
                });
            };
            let loaded = sweep::Sweep::load(&file, registry).map_err(invalid)?;
            let plan = loaded.plan.clone();
            let todo = shard.map_or(plan.runs(), |(i, n)| {
                (0..plan.runs()).filter(|r| r % n == i).count()
            });
            let jobs = jobs
                .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
                .max(1);
            let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
                let bar = indicatif::ProgressBar::new(todo as u64);
                bar.set_style(
                    indicatif::ProgressStyle::with_template(
                        "{spinner} runs {pos}/{len} [{bar:40}] {msg} ({elapsed}, ETA {eta})",
                    )
                    .expect("template")
                    .progress_chars("=> "),
                );
                bar.set_message("0 failing");
                bar
            });
            let stop = Arc::new(AtomicBool::new(false));
            {
                let stop = stop.clone();
                let _ = ctrlc::set_handler(move || {
                    if stop.swap(true, Ordering::Relaxed) {
                        std::process::exit(INTERRUPTED);
                    }
                });
            }
            let started = std::time::Instant::now();
            let outcome = sweep::run(
                &loaded,
                registry,
                &sweep::SweepOptions {
                    jobs,
                    shard,
                    progress: bar.clone().map(|b| {
                        Box::new(move |done: usize, _: usize, failing: usize| {
                            b.set_position(done as u64);
                            b.set_message(format!("{failing} failing"));
                        }) as sweep::Progress
                    }),
                    stop: Some(stop),
                },
            );
            if let Some(b) = bar {
                b.finish_and_clear();
            }
            match shard {
                Some(s) => sweep::finish_shard(&plan, &outcome.rows, s, &out),
                None => sweep::finish(&plan, &outcome.rows, &out),
            }
            .map_err(sweep_failure)?;
            if !quiet {
                println!(
                    "sweep {}: {} runs ({} points x {} seeds{}), {} failing, {} errors, {} jobs, {:.1} s wall; wrote {}",
                    file.display(),
                    outcome.rows.len(),
                    plan.points(),
                    plan.seeds.len(),
                    shard.map_or(String::new(), |(i, n)| format!(", shard {i}/{n}")),
                    outcome.failing,
                    outcome.errors,
                    jobs,
                    started.elapsed().as_secs_f64(),
                    out.display()
                );
            }
            if outcome.interrupted {
                eprintln!(
                    "interrupted: {} of {todo} runs done; the outputs hold those",
                    outcome.rows.len()
                );
                return Ok(INTERRUPTED as u8);
            }
            Ok(u8::from(outcome.failing > 0))
        }
        Command::Validate { scenario } if is_cluster_file(&scenario) => {
            let c = crate::cluster::Cluster::load(&scenario, registry).map_err(invalid)?;
            println!(
                "{}: ok: cluster {:?}, {} nodes, stack {}",
                scenario.display(),
                c.name,
                c.nodes.len(),
                c.wiring.ids.join(" < ")
            );
            Ok(0)
        }
        Command::Node {
            cluster,
            id,
            log,
            trace,
            epoch,
        } => {
            let c = crate::cluster::Cluster::load(&cluster, registry).map_err(invalid)?;
            if id as usize >= c.nodes.len() {
                return Err(Failure {
                    code: 2,
                    message: format!(
                        "{}: no node {id}; the cluster has ids 0 to {}",
                        cluster.display(),
                        c.nodes.len() - 1
                    ),
                });
            }
            let s = crate::node::run(
                &c,
                registry,
                id,
                &crate::node::NodeOptions {
                    log,
                    trace,
                    epoch_ms: epoch,
                },
            )
            .map_err(|e| match e {
                crate::node::NodeError::Listen { .. } => invalid(e),
                other => Failure {
                    code: 1,
                    message: other.to_string(),
                },
            })?;
            println!(
                "node {id}: {} deliveries, {} decisions, {} copies sent{}",
                s.deliveries,
                s.decisions,
                s.sent,
                if s.crashed { ", crashed" } else { "" }
            );
            Ok(0)
        }
        Command::Cluster { cluster, out } => {
            let c = crate::cluster::Cluster::load(&cluster, registry).map_err(invalid)?;
            crate::cluster::run_local(&c, &cluster, &out).map_err(|e| Failure {
                code: 1,
                message: e,
            })
        }
        Command::Validate { scenario } => {
            let _ = interruptible();
            let source = Source::load(&scenario).map_err(invalid)?;
            let built = source
                .build(Overrides::default(), registry)
                .map_err(invalid)?;
            println!(
                "{}: ok: scenario {:?}, {} robots",
                scenario.display(),
                built.name,
                built.robots.len()
            );
            Ok(0)
        }
        Command::Run {
            scenario,
            seed,
            until,
            log,
            trace,
            rrd,
            connect,
            set,
            quiet,
        } => {
            if (rrd.is_some() || connect.is_some()) && !cfg!(feature = "rerun") {
                return Err(invalid(RecordingError::Unsupported));
            }
            let source = if set.is_empty() {
                Source::load(&scenario).map_err(invalid)?
            } else {
                let file = scenario.display().to_string();
                let mut text = std::fs::read_to_string(&scenario).map_err(|e| Failure {
                    code: 2,
                    message: format!("{file}: cannot read the scenario file: {e}"),
                })?;
                for (path, value) in &set {
                    text = crate::scenario::edit::set(&text, path, value).map_err(|e| Failure {
                        code: 2,
                        message: format!("{file}: --set {path}={value}: {e}"),
                    })?;
                }
                Source::parse(&file, &text).map_err(invalid)?
            };
            // The scenario's `outputs`, unless the command line says.
            let outputs = source.scenario.outputs.clone();
            let (log, trace, rrd) = (
                log.or(outputs.log),
                trace.or(outputs.trace),
                rrd.or(outputs.rrd),
            );
            if rrd.is_some() && !cfg!(feature = "rerun") {
                return Err(invalid(RecordingError::Unsupported));
            }
            let recording = Target {
                rrd,
                connect: connect.map(|u| (!u.is_empty()).then_some(u)),
            };
            let saved = recording.rrd.clone();
            // Start-up (placing and spawning the robots) shows on the terminal too: a large
            // run is not silent until its first event.
            let starting = (!quiet && std::io::stderr().is_terminal()).then(|| {
                let s = indicatif::ProgressBar::new_spinner();
                s.set_message("building the scenario (placing the robots)");
                s.enable_steady_tick(std::time::Duration::from_millis(200));
                s
            });
            let (stop, building) = interruptible();
            let built = source
                .build(Overrides { seed, until }, registry)
                .map_err(invalid);
            let built = match built {
                Ok(b) => b,
                Err(e) => {
                    if let Some(s) = &starting {
                        s.finish_and_clear();
                    }
                    return Err(e);
                }
            };
            let startup: Option<Box<dyn FnMut(usize, usize)>> = starting.clone().map(|s| {
                Box::new(move |done: usize, all: usize| {
                    if done < all {
                        s.set_message(format!("spawning the robots' actors: {done} of {all}"));
                    } else {
                        s.finish_and_clear();
                    }
                }) as Box<dyn FnMut(usize, usize)>
            });
            let horizon = built.until;
            let bar =
                (!quiet && std::io::stderr().is_terminal() && horizon.is_finite()).then(|| {
                    let bar = indicatif::ProgressBar::new((horizon * 1000.0) as u64);
                    bar.set_style(
                        indicatif::ProgressStyle::with_template(
                            "{spinner} simulated {msg} [{bar:40}] {percent}% ({elapsed})",
                        )
                        .expect("template")
                        .progress_chars("=> "),
                    );
                    bar
                });
            // The event count moves even while virtual time does not (a million robots' first
            // motions all happen at t = 0).
            let progress: Option<Box<dyn FnMut(f64, u64)>> = bar.clone().map(|b| {
                Box::new(move |t: f64, events: u64| {
                    b.set_position((t * 1000.0) as u64);
                    b.set_message(format!("{t:.1} s, {events} events"));
                }) as Box<dyn FnMut(f64, u64)>
            });
            // From here on, Ctrl-C (or SIGTERM) ends the run at the virtual time reached and
            // writes the outputs for the run up to there.
            building.store(false, Ordering::Relaxed);
            let result = runner::run(
                built,
                RunOptions {
                    log,
                    trace,
                    recording,
                    progress,
                    startup,
                    stop: Some(stop),
                    // `nekosim run` exits once the run is written.
                    exit_after: true,
                    note: None,
                    milestones: Vec::new(),
                },
            );
            if let Some(b) = bar {
                b.finish_and_clear();
            }
            let summary = result.map_err(|e| match e {
                RunError::CreateOutput { .. } => invalid(e),
                RunError::Recording(r) if r.is_input_error() => invalid(r),
                other => Failure {
                    code: 1,
                    message: causes(&other),
                },
            })?;
            if !quiet {
                println!(
                    "scenario: {} (seed {})\nrobots: {}, events: {}, collisions: {}, simulated time: {:.3} s, wall time: {:.3} s, events/s: {:.0}, cancelled events: {}",
                    summary.name,
                    summary.seed,
                    summary.robots,
                    summary.events,
                    summary.collisions,
                    summary.end_time,
                    summary.wall_seconds,
                    summary.events_per_second(),
                    summary.cancelled
                );
                if let Some(l) = &summary.latency {
                    println!(
                        "deliveries: {}, latency mean: {:.3} s, p50: {:.3} s, p99: {:.3} s, throughput: {:.3} deliveries/s",
                        l.deliveries, l.mean, l.p50, l.p99, l.throughput
                    );
                }
                for p in &summary.predicates {
                    println!("{}", p.text());
                }
                if let Some(path) = &saved {
                    let size = std::fs::metadata(path).map_or(0, |m| m.len());
                    println!(
                        "recording: {} ({:.1} MB); view it with `rerun {}`",
                        path.display(),
                        size as f64 / 1e6,
                        path.display()
                    );
                }
            }
            if summary.interrupted {
                eprintln!(
                    "interrupted at simulated time {:.3} s: the outputs hold the run up to there",
                    summary.end_time
                );
                return Ok(INTERRUPTED as u8);
            }
            Ok(0)
        }
    }
}

/// Sets the Ctrl-C (and SIGTERM) handler of a command that builds a scenario: while the
/// second flag holds (the scenario is being built, nothing is written yet), an interrupt ends
/// the process at once; after, it sets the first flag (the run then ends at the virtual time
/// reached), and a second interrupt ends the process at once.
fn interruptible() -> (Arc<AtomicBool>, Arc<AtomicBool>) {
    let stop = Arc::new(AtomicBool::new(false));
    let building = Arc::new(AtomicBool::new(true));
    let (s, b) = (stop.clone(), building.clone());
    // Without a handler (e.g. one already set), an interrupt kills the process.
    let _ = ctrlc::set_handler(move || {
        if b.load(Ordering::Relaxed) {
            eprintln!("interrupted while building the scenario: nothing was written");
            std::process::exit(INTERRUPTED);
        }
        if s.swap(true, Ordering::Relaxed) {
            std::process::exit(INTERRUPTED);
        }
    });
    (stop, building)
}

/// Whether `path` holds a cluster file rather than a scenario.
fn is_cluster_file(path: &std::path::Path) -> bool {
    std::fs::read_to_string(path).is_ok_and(|t| crate::cluster::is_cluster(&t))
}

/// A sweep's output error: the user's input (exit 2) or a write failure (exit 1).
fn sweep_failure(e: sweep::SweepError) -> Failure {
    match e {
        sweep::SweepError::Input(message) => Failure { code: 2, message },
        other => Failure {
            code: 1,
            message: other.to_string(),
        },
    }
}

/// An error and its causes, `: `-separated.
fn causes(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(c) = source {
        s.push_str(&format!(": {c}"));
        source = c.source();
    }
    s
}
