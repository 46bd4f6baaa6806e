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

use crate::scenario::{Overrides, Registry, Source};
use crate::sweep;
use clap::{Parser, Subcommand};

mod check_command;
mod run_command;

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
    Run(run_command::RunArgs),
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
    Check(check_command::CheckOptions),
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

/// Exit code of a run ended by Ctrl-C or SIGTERM (128 + SIGINT, as shells report it).
const INTERRUPTED: i32 = 130;

/// Runs a command; `Ok` carries the exit code (a check's counterexample is 1).
fn execute(command: Command, registry: &Registry) -> Result<u8, Failure> {
    match command {
        Command::Check(options) => check_command::check(options, registry),
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
        Command::Run(args) => run_command::run(args, registry),
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
