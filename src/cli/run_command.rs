//! `nekosim run SCENARIO.ron`: its options, and the run with a spinner while the scenario is
//! built, a progress bar while it runs, Ctrl-C ending it with its outputs written, and the
//! summary.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::Ordering;

use super::{causes, interruptible, invalid, Failure, INTERRUPTED};
use crate::recording::{RecordingError, Target};
use crate::runner::{self, RunError, RunOptions};
use crate::scenario::{Overrides, Registry, Source};

/// The options of `nekosim run` (the help text above them is `Command::Run`'s doc).
#[derive(clap::Args, Debug)]
pub(super) struct RunArgs {
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
}

fn parse_set(text: &str) -> Result<(String, String), String> {
    let (path, value) = text
        .split_once('=')
        .ok_or_else(|| format!("{text:?}: expected PATH=VALUE, e.g. robots[0].count=200"))?;
    Ok((path.trim().to_string(), value.trim().to_string()))
}

/// Runs `args`' scenario; `Ok` carries the exit code.
pub(super) fn run(args: RunArgs, registry: &Registry) -> Result<u8, Failure> {
    let RunArgs {
        scenario,
        seed,
        until,
        log,
        trace,
        rrd,
        connect,
        set,
        quiet,
    } = args;
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
    let bar = (!quiet && std::io::stderr().is_terminal() && horizon.is_finite()).then(|| {
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
