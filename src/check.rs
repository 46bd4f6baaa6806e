//! `nekosim check MODEL|SCENARIO.ron`: model-check a protocol stack with stateright (the
//! protocol code the simulator runs): a scenario file's own `stack`, built-in and registered
//! user protocols alike, or one of the shipped scenarios by name. Reports as it goes: progress
//! on a terminal, each property the moment it fails; by default it stops at the first
//! counterexample (`--keep-going` explores on for the others). Prints the checker's figures and
//! each property's verdict, explains every counterexample step by step and ends it with the
//! reason in the property's terms, and optionally writes it (or a witness) as a JSONL trace
//! with `seq` as the step number. A breadth-first search that nears its memory budget spills
//! to disk and goes on. A search stopped by its state, memory, disk or time budget, or by
//! Ctrl-C, says what it explored and writes what it found. Models, properties and budgets:
//! docs/model-checking.md.

use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use nekosim_models::config::UNLIMITED_TIMERS;
use nekosim_models::explain::{describe, explain};
use nekosim_models::reason::reason;
use nekosim_models::spill::Spilled;
use nekosim_models::temporal::StackFairness;
use nekosim_models::{
    available_memory, build_in, run_watched, Budget, CheckModel, Discovery, Exploration,
    ModelError, NetworkKind, Options, Progress, Stopped, Strategy, Target, Watch,
};
use nekosim_protocols::Microprotocol;
use stateright::Expectation;

use crate::recording::RecordingError;
use crate::scenario::{CheckNetwork, FaultSpec, Overrides, Registry, ScenarioError, Source};

mod budgets;
pub mod lcm;
pub mod lcm_search;
mod reduction;
mod temporal;
mod trace;

pub use budgets::{
    default_spill_parent, duration_text, fresh_spill_dir, parse_duration, parse_size, parse_timers,
    remove_spills, size_text,
};
use reduction::compare_reduction;
pub use reduction::{reduction_in_effect, Reduction};
pub use trace::{trace_lines, CheckEvent, CheckRecord};
use trace::{write_recording, write_trace};

/// The models `nekosim check NAME` knows: each is a scenario file shipped under
/// `examples/check/` (name, file, what it checks), so `check lamport-abcast` and
/// `check examples/check/lamport_abcast.ron` are the same search.
pub const SHORTCUTS: [(&str, &str, &str); 5] = [
    (
        "lamport-abcast",
        "examples/check/lamport_abcast.ron",
        include_str!("../examples/check/lamport_abcast.ron"),
    ),
    (
        "sequencer-abcast",
        "examples/check/sequencer_abcast.ron",
        include_str!("../examples/check/sequencer_abcast.ron"),
    ),
    (
        "consensus-abcast",
        "examples/check/consensus_abcast.ron",
        include_str!("../examples/check/consensus_abcast.ron"),
    ),
    (
        "ct-consensus",
        "examples/check/ct_consensus.ron",
        include_str!("../examples/check/ct_consensus.ron"),
    ),
    (
        "reliable-broadcast",
        "examples/check/reliable_broadcast.ron",
        include_str!("../examples/check/reliable_broadcast.ron"),
    ),
];

/// The default memory budget: half of what this process may use, and at most 4 GiB.
pub const DEFAULT_MEMORY_CAP: u64 = 4 << 30;

/// The default memory budget ([`DEFAULT_MEMORY_CAP`], or half the machine's memory when
/// that is less); `None` where the machine's memory cannot be read.
pub fn default_memory_budget() -> Option<u64> {
    available_memory().map(|m| (m / 2).min(DEFAULT_MEMORY_CAP))
}

/// What the command was asked to check. A field left `None` comes from the scenario's
/// `check` section, else from the scenario itself, else the command's default.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct CheckArgs {
    /// A shortcut name or a scenario file.
    pub model: String,
    pub layer: Option<String>,
    pub processes: Option<u32>,
    pub requests: Option<u32>,
    pub crashes: Option<u32>,
    pub network: Option<NetworkKind>,
    pub depth: Option<usize>,
    pub threads: usize,
    pub trace: Option<PathBuf>,
    /// Save the counterexample (or witness) as a Rerun recording here.
    pub rrd: Option<PathBuf>,
    /// Protocol timer firings per process.
    pub timers: Option<u32>,
    /// Last Chandra-Toueg round explored.
    pub rounds: Option<u64>,
    pub strategy: Strategy,
    pub max_states: Option<usize>,
    /// `None`: [`default_memory_budget`].
    pub max_memory: Option<u64>,
    /// Where a breadth-first search spills when it nears the memory budget (`None`:
    /// [`default_spill_parent`]).
    pub spill_dir: Option<PathBuf>,
    /// Stop at the memory budget instead of spilling.
    pub no_spill: bool,
    /// The bytes the spill files may take at once (`None`: unlimited).
    pub max_disk: Option<u64>,
    /// Also spill whenever this many visited states are in memory (tests spill small
    /// searches with it).
    pub spill_after: Option<usize>,
    /// Stop the search after this long.
    pub max_time: Option<Duration>,
    /// Symmetry reduction (also on when the scenario's `check` section asks for it).
    pub symmetry: bool,
    /// No reduction ([`Reduction`]; on by default).
    pub no_reduction: bool,
    /// Also search without the reduction and report both counts.
    pub compare_reduction: bool,
    /// Explore on after a counterexample, to settle every property; by default the search
    /// stops at the first.
    pub keep_going: bool,
    /// Decide no temporal property (no liveness graph is built).
    pub no_liveness: bool,
    /// Overrides of a Look-Compute-Move scenario's settings ([`lcm`]); its `fairness` is
    /// also a stack's liveness fairness (none, weak or strong).
    pub lcm: lcm::LcmOverrides,
    /// What a search of Look-Compute-Move robots checks ([`lcm_search`]; default:
    /// collision-free).
    pub goals: Vec<nekosim_actors::lcm::search::Goal>,
}

/// What a check does beside its report while it runs.
#[derive(Debug, Default)]
pub struct Live {
    /// Set (by Ctrl-C) to stop the search: the check then reports what it found and explored
    /// so far, writes the requested outputs, and concludes [`Conclusion::Interrupted`].
    pub interrupt: Option<Arc<AtomicBool>>,
    /// Draw the search's progress on stderr (a terminal): states, depth, rate, memory.
    pub progress: bool,
}

/// How a check ended, as the command's exit code says it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Conclusion {
    /// Every property holds on the whole space explored (exit 0).
    Holds,
    /// A property fails (exit 1).
    Fails,
    /// A budget stopped the search before it was exhaustive and no property failed (exit 3).
    Unsettled,
    /// Ctrl-C stopped the search; what it found was reported and written (exit 130, as
    /// shells report SIGINT).
    Interrupted,
}

impl Conclusion {
    pub fn exit_code(self) -> u8 {
        match self {
            Self::Holds => 0,
            Self::Fails => 1,
            Self::Unsettled => 3,
            Self::Interrupted => 130,
        }
    }
}

/// Why a check could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CheckError {
    /// Bad arguments (exit 2).
    #[error("unknown model {name:?}; expected a scenario file (.ron) or one of {known}")]
    UnknownModel { name: String, known: String },
    /// Bad arguments (exit 2).
    #[error("{0}")]
    Model(#[from] ModelError),
    /// Bad arguments (exit 2).
    #[error("symmetry reduction needs --strategy bfs")]
    SymmetryStrategy,
    /// A bad scenario (exit 2), located in its file.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// The trace file could not be written (exit 2, like any output the user names).
    #[error("cannot write the trace {}: {source}", path.display())]
    Trace { path: PathBuf, source: io::Error },
    /// The recording could not be made (exit 2 when the user's input is at fault).
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// Bad arguments for a Look-Compute-Move check (exit 2).
    #[error("{0}")]
    Lcm(String),
    /// The spill directory's parent is not a directory (exit 2).
    #[error("cannot spill to {}: {source}", path.display())]
    SpillDir { path: PathBuf, source: io::Error },
}

/// Properties a protocol states itself, checked alongside its service's whenever it is in
/// the stack checked: the scenario registry's door to [`nekosim_protocols::Protocols`]'s, so
/// `registry.protocol::<P>("P").invariant::<P>(..)` reads as one declaration.
impl Registry {
    /// An `always` property over `P`'s state at every process (in process order, crashed
    /// processes included).
    pub fn invariant<P: Microprotocol>(
        &mut self,
        name: &str,
        holds: impl Fn(&[&P]) -> bool + Send + Sync + 'static,
    ) -> &mut Self {
        self.protocols.invariant::<P>(name, holds);
        self
    }

    /// A `sometimes` property over `P`'s state at every process: a witness that the
    /// configuration is reachable at all.
    pub fn reachable<P: Microprotocol>(
        &mut self,
        name: &str,
        holds: impl Fn(&[&P]) -> bool + Send + Sync + 'static,
    ) -> &mut Self {
        self.protocols.reachable::<P>(name, holds);
        self
    }
}

/// The model names, one per line.
pub fn list() -> String {
    SHORTCUTS.iter().map(|(n, ..)| format!("{n}\n")).collect()
}

/// A check's model, resolved from a scenario and the arguments.
#[derive(Debug)]
pub struct Resolved {
    /// What the report calls the model: the shortcut's name or the file.
    pub name: String,
    pub target: Target,
    pub options: Options,
}

/// The network semantics of a scenario's network (docs/model-checking.md): a fixed delay
/// keeps each link's order (`ordered`); random and distance-dependent delays reorder
/// (`unordered`); a network that can lose messages, or a partition, is `lossy`; a network
/// the checker does not know is `unordered`.
pub fn network_kind(network: Option<&str>, partitioned: bool) -> NetworkKind {
    match network {
        _ if partitioned => NetworkKind::Lossy,
        None | Some("Reliable") => NetworkKind::Ordered,
        Some("Lossy" | "Radio") => NetworkKind::Lossy,
        Some(_) => NetworkKind::Unordered,
    }
}

/// Reads the shortcut or scenario file `args.model` and derives the model to check: the
/// scenario's stack through `registry`'s protocols, then each parameter from the command
/// line, else the scenario's `check` section, else the scenario, else the default.
pub fn resolve(args: &CheckArgs, registry: &Registry) -> Result<Resolved, CheckError> {
    let source = match SHORTCUTS.iter().find(|(n, ..)| *n == args.model) {
        Some((_, file, text)) => Source::parse(file, text)?,
        None if args.model.ends_with(".ron") || Path::new(&args.model).is_file() => {
            Source::load(Path::new(&args.model))?
        }
        None => {
            return Err(CheckError::UnknownModel {
                name: args.model.clone(),
                known: SHORTCUTS.map(|(n, ..)| n).join(", "),
            })
        }
    };
    // Everything a run would reject is rejected here too, located in the file.
    let built = source.build(Overrides::default(), registry)?;
    let s = &source.scenario;
    if s.stack.is_empty() {
        return Err(source
            .place("stack", "the scenario has no stack to check")
            .into());
    }
    let settings = s.check.clone().unwrap_or_default();
    let layer = args.layer.clone().or(settings.layer.clone());
    let target = Target::of_stack(s.stack.clone(), layer.as_deref(), &registry.protocols)?;
    let defaults = Options::default();
    let crashes_in_faults = s
        .faults
        .iter()
        .filter(|f| matches!(f, FaultSpec::Crash { .. }))
        .count() as u32;
    let partitioned = s
        .faults
        .iter()
        .any(|f| matches!(f, FaultSpec::Partition { .. }));
    let network = args.network.unwrap_or_else(|| match settings.network {
        Some(CheckNetwork::Unordered) => NetworkKind::Unordered,
        Some(CheckNetwork::Ordered) => NetworkKind::Ordered,
        Some(CheckNetwork::Lossy) => NetworkKind::Lossy,
        None => network_kind(s.network.as_ref().map(|n| n.name()), partitioned),
    });
    let processes = args
        .processes
        .or(settings.processes)
        .unwrap_or(built.robots.len() as u32);
    if args.processes.is_none() && !(2..=8).contains(&processes) {
        let at = if settings.processes.is_some() {
            "check.processes"
        } else {
            "robots"
        };
        return Err(source
            .place(
                at,
                format!("{processes} processes to check; expected 2 to 8 (or give --processes N)"),
            )
            .into());
    }
    let options = Options {
        processes,
        requests: args
            .requests
            .or(settings.requests)
            .unwrap_or(defaults.requests),
        crashes: args
            .crashes
            .or(settings.crashes)
            .unwrap_or(crashes_in_faults),
        network,
        timer_budget: args
            .timers
            .or(settings.timers)
            .unwrap_or(defaults.timer_budget),
        max_round: args
            .rounds
            .or(settings.rounds)
            .unwrap_or(defaults.max_round),
        partial_multicasts: defaults.partial_multicasts,
        symmetry: args.symmetry || settings.symmetry.unwrap_or(false),
        reduction: !args.no_reduction,
        defer_early: defaults.defer_early,
    };
    if options.symmetry && args.strategy != Strategy::Bfs {
        return Err(CheckError::SymmetryStrategy);
    }
    Ok(Resolved {
        name: args.model.clone(),
        target,
        options,
    })
}

/// Runs a check and prints its report on `out`.
pub fn check(
    args: &CheckArgs,
    registry: &Registry,
    out: &mut dyn Write,
) -> Result<Conclusion, CheckError> {
    check_live(args, registry, out, &Live::default())
}

/// What a check says while its search runs: the progress line on stderr and each
/// discovery on the report.
struct Reporter<'a> {
    out: &'a mut dyn Write,
    live: &'a Live,
    start: Instant,
    max_memory: Option<u64>,
    max_time: Option<Duration>,
    /// Where the search spills, and what it has spilled.
    spill_dir: Option<PathBuf>,
    spilled: Option<Spilled>,
    /// A progress line is on stderr.
    drawn: bool,
}

impl Reporter<'_> {
    fn clear(&mut self) {
        if self.drawn {
            let mut e = io::stderr().lock();
            let _ = write!(e, "\r\x1b[K");
            let _ = e.flush();
            self.drawn = false;
        }
    }
}

impl Watch for Reporter<'_> {
    fn progress(&mut self, at: &Progress) {
        if self.live.progress {
            let mut text = progress_text(at, self.start.elapsed().as_secs_f64(), self.max_memory);
            if let Some(s) = &self.spilled {
                text += &format!(", disk {}", size_text(s.bytes));
            }
            let mut e = io::stderr().lock();
            let _ = write!(e, "\r\x1b[K{text}");
            let _ = e.flush();
            self.drawn = true;
        }
    }

    fn discovered(&mut self, d: &Discovery) {
        if d.fails() {
            self.clear();
            let _ = writeln!(
                self.out,
                "found: {:?} fails, after {} unique states",
                d.name, d.unique_states
            );
            let _ = self.out.flush();
        }
    }

    fn interrupted(&self) -> bool {
        self.live
            .interrupt
            .as_ref()
            .is_some_and(|i| i.load(Ordering::Relaxed))
    }

    fn out_of_time(&self) -> Option<Duration> {
        self.max_time.filter(|&t| self.start.elapsed() >= t)
    }

    fn spilled(&mut self, so_far: &Spilled) {
        if self.spilled.is_none() {
            self.clear();
            eprintln!(
                "{}",
                budgets::spilling_text(self.spill_dir.as_deref(), so_far)
            );
        }
        self.spilled = Some(*so_far);
    }
}

/// The progress line: states generated and unique, the depth, the rate over `seconds`, and
/// the memory against its budget.
pub fn progress_text(at: &Progress, seconds: f64, max_memory: Option<u64>) -> String {
    let memory = match (at.memory, max_memory) {
        (Some(m), Some(b)) => format!(", memory {} of {}", size_text(m), size_text(b)),
        (Some(m), None) => format!(", memory {}", size_text(m)),
        (None, _) => String::new(),
    };
    format!(
        "checking: {} states, {} unique, depth {}, {:.0} states/s{memory}",
        at.states,
        at.unique_states,
        at.max_depth,
        at.states as f64 / seconds.max(1e-9)
    )
}

/// [`check`], telling the person waiting as it goes ([`Live`]).
pub fn check_live(
    args: &CheckArgs,
    registry: &Registry,
    out: &mut dyn Write,
    live: &Live,
) -> Result<Conclusion, CheckError> {
    // A Look-Compute-Move scenario of two rule-table robots is checked on its own finite
    // model; every other scenario's stack goes to stateright.
    let is_file = args.model.ends_with(".ron") || Path::new(&args.model).is_file();
    if is_file && !SHORTCUTS.iter().any(|(n, ..)| *n == args.model) {
        let source = Source::load(Path::new(&args.model))?;
        let watch = || lcm::Watch {
            max_memory: args.max_memory.or_else(default_memory_budget),
            interrupt: live.interrupt.clone(),
        };
        let robots = lcm::rule_table_of(&source).is_some()
            || (source.scenario.lcm.is_some() && source.scenario.stack.is_empty());
        if robots {
            budgets::stack_only(args)?;
        }
        if let Some(table) = lcm::rule_table_of(&source) {
            return lcm::check(&source, table?, args, watch(), out);
        }
        // Other Look-Compute-Move scenarios: the search beyond exhaustive checking.
        if source.scenario.lcm.is_some() && source.scenario.stack.is_empty() {
            return lcm_search::check(&source, registry, args, &watch(), out);
        }
    }
    let robot_only = lcm::LcmOverrides {
        fairness: None,
        ..args.lcm
    };
    if robot_only.any() {
        return Err(CheckError::Lcm(
            "--synchrony, --movement, --register and --property apply to a Look-Compute-Move scenario whose two robots run a rule table".into(),
        ));
    }
    let fairness = match args.lcm.fairness {
        None => None,
        Some(lcm::RobotFairness::None) => Some(StackFairness::None),
        Some(lcm::RobotFairness::Weak) => Some(StackFairness::Weak),
        Some(lcm::RobotFairness::Strong) => Some(StackFairness::Strong),
        Some(_) => {
            return Err(CheckError::Lcm(
                "a stack's liveness fairness is none, weak or strong; bounded fairness applies to Look-Compute-Move robots".into(),
            ))
        }
    };
    let Resolved {
        name,
        target,
        options: opts,
    } = resolve(args, registry)?;
    let model = build_in(&registry.protocols, &target, &opts, |_, _| {})?;
    // Outputs that can never be written are refused before the search, which may be long.
    let is_dir = || io::Error::new(io::ErrorKind::InvalidInput, "is a directory");
    if let Some(path) = args.trace.as_ref().filter(|p| p.is_dir()) {
        return Err(CheckError::Trace {
            path: path.clone(),
            source: is_dir(),
        });
    }
    if let Some(path) = args.rrd.as_ref().filter(|p| p.is_dir()) {
        return Err(RecordingError::Create {
            path: path.display().to_string(),
            message: is_dir().to_string(),
        }
        .into());
    }
    let budget = Budget {
        max_states: args.max_states,
        max_memory: args.max_memory.or_else(default_memory_budget),
    };
    let spill = budgets::spill(args)?;
    let network = NetworkKind::NAMES[match opts.network {
        NetworkKind::Unordered => 0,
        NetworkKind::Ordered => 1,
        NetworkKind::Lossy => 2,
    }];
    let strategy = match args.strategy {
        Strategy::Bfs => "bfs".to_string(),
        Strategy::Dfs => "dfs".to_string(),
        Strategy::Simulation { seed } => format!("simulation (seed {seed})"),
    };
    let w = |out: &mut dyn Write, s: String| {
        let _ = writeln!(out, "{s}");
    };
    let layers: Vec<&str> = target.stack.iter().map(|l| l.id.as_str()).collect();
    w(
        out,
        format!(
            "model: {name}: stack [{}], checking {:?} ({}): {} processes, {} requests, {} crashes, {network} network, timer budget {}, last round {}{}",
            layers.join(", "),
            target.entry,
            target.family.name(),
            opts.processes,
            if target.family.takes_requests() { opts.requests } else { 0 },
            opts.crashes,
            if opts.timer_budget == UNLIMITED_TIMERS {
                "unlimited".to_string()
            } else {
                opts.timer_budget.to_string()
            },
            opts.max_round,
            args.depth.map_or(String::new(), |d| format!(", depth bound {d}")),
        ),
    );
    w(
        out,
        format!(
            "search: {strategy}{}{}, {} thread{}, budget {} states, {} memory",
            if opts.symmetry {
                " with symmetry reduction"
            } else {
                ""
            },
            match reduction_in_effect(&opts, args, model.cfg.in_send_order) {
                Ok(Reduction::PartialOrder) => " with partial-order reduction",
                Ok(Reduction::PartialOrderInSendOrder) => {
                    " with partial-order reduction, links in send order"
                }
                Ok(Reduction::InSendOrder) => " with links in send order",
                Ok(Reduction::SpentMessages) => " forgetting spent messages",
                Err(_) => "",
            },
            args.threads.max(1),
            if args.threads > 1 { "s" } else { "" },
            budget
                .max_states
                .map_or("unlimited".into(), |n| n.to_string()),
            budget.max_memory.map_or("unlimited".into(), size_text),
        ) + &budgets::search_text(args, spill.as_ref()),
    );
    let _ = out.flush();
    // The command times the checker; the models crate never reads the wall clock.
    let start = Instant::now();
    let mut reporter = Reporter {
        out: &mut *out,
        live,
        start,
        max_memory: budget.max_memory,
        max_time: args.max_time,
        spill_dir: spill.as_ref().map(|s| s.dir.clone()),
        spilled: None,
        drawn: false,
    };
    let how = Exploration {
        threads: args.threads,
        depth: args.depth,
        first_counterexample: !args.keep_going,
        strategy: args.strategy,
        budget,
        spill,
    };
    let outcome = run_watched(model.clone(), how.clone(), &mut reporter);
    reporter.clear();
    let spilled = reporter.spilled;
    let seconds = start.elapsed().as_secs_f64();
    w(
        out,
        format!(
            "states: {}, unique states: {}, depth: {}, seconds: {:.3}, states/s: {:.0}",
            outcome.states,
            outcome.unique_states,
            outcome.max_depth,
            seconds,
            outcome.states as f64 / seconds.max(1e-9)
        ),
    );
    if let Some(s) = spilled {
        w(out, budgets::spilled_text(&s));
    }
    if args.compare_reduction {
        let again = (&target, &opts, args);
        let with = (&outcome, model.cfg.in_send_order);
        compare_reduction(out, &registry.protocols, again, (how, live), with)?;
    }
    if let Some(spent) = outcome.stopped {
        let what = match spent {
            Stopped::Interrupted => "Ctrl-C".to_string(),
            Stopped::States { limit } => format!("the state budget ({limit} states)"),
            Stopped::Memory { limit, seen } => format!(
                "the memory budget ({}; resident {})",
                size_text(limit),
                size_text(seen)
            ),
            Stopped::Time { limit } => format!("the time budget ({})", duration_text(limit)),
            Stopped::Disk { limit } => {
                format!("the disk budget ({} of spill files)", size_text(limit))
            }
            Stopped::DiskError { kind } => format!("a spill file error ({kind})"),
        };
        w(
            out,
            format!(
                "stopped by {what} before the search was exhaustive: {} unique states, depth {} reached",
                outcome.unique_states, outcome.max_depth
            ),
        );
    }
    let stopped = outcome.stopped.is_some();
    // Stopped at the first counterexample, the search settled no other property.
    let cut_short = !args.keep_going && outcome.any_fails();
    for v in &outcome.verdicts {
        let how = match v.expectation {
            Expectation::Always => "always",
            Expectation::Sometimes => "sometimes",
            Expectation::Eventually => "eventually",
        };
        let detail = match (&v.expectation, &v.path) {
            (Expectation::Sometimes, Some(p)) => {
                format!(": witness in {} steps", p.clone().into_actions().len())
            }
            (Expectation::Sometimes, None) if stopped || cut_short => {
                ": not reached in what was explored".to_string()
            }
            (Expectation::Sometimes, None) => ": never reached".to_string(),
            (_, Some(p)) => format!(
                ": counterexample in {} steps",
                p.clone().into_actions().len()
            ),
            (_, None) if stopped => ": no counterexample in what was explored".to_string(),
            (_, None) if cut_short => {
                ": not settled (the search stopped at the first counterexample; --keep-going explores on)".to_string()
            }
            (_, None) => String::new(),
        };
        let mark = if v.path.is_none() && (stopped || cut_short) {
            "open  "
        } else if v.holds {
            "holds "
        } else {
            "FAILS "
        };
        w(out, format!("  {mark} {} ({how}){detail}", v.name));
    }
    for v in outcome.verdicts.iter().filter(|v| !v.holds) {
        if let Some(path) = &v.path {
            w(out, format!("counterexample of {:?}:", v.name));
            for step in explain(&model, path) {
                for (i, e) in step.events.iter().enumerate() {
                    let head = if i == 0 {
                        format!("step {:>3}:", step.index)
                    } else {
                        " ".repeat(9)
                    };
                    w(out, format!("  {head} {}", describe(&model, e)));
                }
            }
            if let Some(why) = reason(&model, v.name, path) {
                w(out, format!("  so {:?} fails: {why}", v.name));
            }
        }
    }
    // Liveness is decided on the whole graph, once the search has covered it and found no
    // counterexample: a counterexample already ends the check, and a search cut short says
    // nothing of the cycles it did not see.
    let whole = outcome.stopped.is_none()
        && !outcome.any_fails()
        && args.depth.is_none()
        && !matches!(args.strategy, Strategy::Simulation { .. });
    let live_part = (whole && !args.no_liveness).then(|| {
        let watch = lcm::Watch {
            max_memory: budget.max_memory,
            interrupt: live.interrupt.clone(),
        };
        let fairness = fairness.unwrap_or(StackFairness::of(opts.network));
        let check = |out: &mut dyn Write, model: &CheckModel| {
            temporal::check(out, model, opts.network, fairness, args.max_states, &watch)
        };
        if model.cfg.in_send_order {
            // The graph explores every order of arrival (crate::reduction's "Early arrivals").
            let every_order = Options {
                defer_early: false,
                ..opts.clone()
            };
            let live_model = build_in(&registry.protocols, &target, &every_order, |_, _| {})?;
            let live = check(out, &live_model);
            Ok::<_, CheckError>((live, live_model))
        } else {
            Ok((check(out, &model), model.clone()))
        }
    });
    let (live_part, live_model) = match live_part.transpose()? {
        Some((l, m)) => (Some(l), m),
        None => (None, model.clone()),
    };
    let lasso = live_part.as_ref().and_then(|l| l.lasso.as_ref());
    // A lasso is written when the search found no counterexample (rather than a witness).
    let lasso = lasso.filter(|_| {
        !outcome
            .verdicts
            .iter()
            .any(|v| !v.holds && v.path.is_some())
    });
    if let Some(path) = &args.trace {
        let written = match lasso {
            Some((o, stem, why)) => write_trace(&live_model, o, Some((*stem, why)), path),
            None => write_trace(&model, &outcome, None, path),
        };
        written.map_err(|source| CheckError::Trace {
            path: path.clone(),
            source,
        })?;
    }
    if let Some(path) = &args.rrd {
        match lasso {
            Some((o, stem, why)) => {
                write_recording(&name, &live_model, o, Some((*stem, why)), path)?
            }
            None => write_recording(&name, &model, &outcome, None, path)?,
        }
    }
    let live_conclusion = live_part.map_or(Conclusion::Holds, |l| l.conclusion);
    Ok(
        if outcome.stopped == Some(Stopped::Interrupted)
            || live_conclusion == Conclusion::Interrupted
        {
            Conclusion::Interrupted
        } else if outcome.any_fails() || live_conclusion == Conclusion::Fails {
            Conclusion::Fails
        } else if stopped || live_conclusion == Conclusion::Unsettled {
            Conclusion::Unsettled
        } else if outcome.all_hold() {
            Conclusion::Holds
        } else {
            Conclusion::Fails
        },
    )
}
