//! Engine benchmarks (`cargo bench --bench engine`):
//! - `throughput/*`: events per second through the scheduler actor next to a raw actix
//!   `do_send` ring carrying the same number of messages;
//! - `placement/*`: placing a million robots at the seed's density (random born points);
//! - `random_movement/*`: the seed's random movement with collisions at 1k and 10k robots
//!   (events/s; wall time per simulated second = time per iteration / horizon);
//! - `scale`: the scale series at 1k, 100k and 1M robots (the seed's density, two simulated
//!   spans each): events/s, the steady-state cost of an event (the difference of the two
//!   spans' wall times over the difference of their events) and its ratio to 1k's, the
//!   real-time factor, the wall time to simulated second 1 (placement included) and peak RSS,
//!   for the actor-hosted run and for the kernel-alone reference (`nekosim::kernel::run`: the
//!   same handling code without actors), and the ratio of the two; also the same figures
//!   within the long run, from its first progress call at simulated second 1 to its last
//!   (start-up and teardown outside, no difference of two runs); then the later phase, seconds
//!   30 to 40 of a 40 s run (30 to 60 at 1k, where the robots have not yet crowded towards the
//!   world's middle), where the robots have turned and move on (`scale_late`). Timed by
//!   hand (a 1M run takes 5-40 s here), least of a few runs; run it alone with
//!   `cargo bench --bench engine -- scale`. `NEKOSIM_SCALE_SIZES=100000` runs one size.
//!   Each of the series' runs is a process of its own, as a `nekosim run` is: the bench
//!   starts itself again for it ([`CHILD`]), so that no run inherits the heap an earlier
//!   one left and each peak RSS is the run's own.
//! - `memory`: what random reads into a million robots' worth of memory cost an event on this
//!   machine, apart from the engine ([`memory`]).
//!
//! The allocator is the `nekosim` binary's (mimalloc, keeping freed memory:
//! `nekosim::allocator`), so the figures are the command's.

use actix::prelude::*;
use criterion::{criterion_group, BatchSize, Criterion, Throughput};
use nekosim::algorithm::RandomMovement;
use nekosim::world::born::random_born_points;
use nekosim::world::motion::Pose;
use nekosim::world::virtual_world::{RobotSpec, WorldConfig, WorldSize};
use nekosim::{Algorithm, AlgorithmFuture, Robot, SimConfig};
use rand::SeedableRng;

#[global_allocator]
static GLOBAL: nekosim::allocator::MiMalloc = nekosim::allocator::MiMalloc;

/// Sleeps one simulated second at a time, forever: one scheduler round trip per event.
#[derive(Debug)]
struct Ticker;

impl Algorithm for Ticker {
    fn name(&self) -> &str {
        "Ticker"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        Box::pin(async move {
            loop {
                robot.sleep(1.0).await;
            }
        })
    }
}

const TICKERS: usize = 100;
const TICKS: usize = 200;

fn ticker_config() -> SimConfig {
    let robots = (0..TICKERS)
        .map(|i| {
            let spec = RobotSpec {
                radius: 1.0,
                pose: Pose {
                    pos: nekosim::world::geometry::Point::new(10.0 * i as f64, 0.0),
                    angle: 0.0,
                },
            };
            (spec, Box::new(Ticker) as Box<dyn Algorithm>)
        })
        .collect();
    SimConfig {
        sensors: Default::default(),
        seed: 1,
        until: TICKS as f64 - 0.5,
        world: WorldConfig {
            size: WorldSize::Infinite,
            ghost_mode: true,
            walls: true,
            turn: Default::default(),
            cell_size: None,
            obstacles: Default::default(),
        },
        robots,
        arbiters: 1,
        record: false,
        observers: Default::default(),
        comms: Default::default(),
    }
}

#[derive(Message)]
#[rtype(result = "()")]
struct Token(u64);

struct Hop {
    next: Option<Recipient<Token>>,
}

impl Actor for Hop {
    type Context = Context<Self>;
}

impl Handler<Token> for Hop {
    type Result = ();
    fn handle(&mut self, t: Token, _: &mut Context<Self>) {
        if t.0 == 0 {
            System::current().stop();
        } else if let Some(n) = &self.next {
            n.do_send(Token(t.0 - 1));
        }
    }
}

#[derive(Message)]
#[rtype(result = "()")]
struct Link(Recipient<Token>);

impl Handler<Link> for Hop {
    type Result = ();
    fn handle(&mut self, l: Link, _: &mut Context<Self>) {
        self.next = Some(l.0);
    }
}

/// A ring of `n` actors passing one token `hops` times with `do_send`.
fn raw_ring(n: usize, hops: u64) {
    let sys = System::new();
    sys.block_on(async move {
        let addrs: Vec<Addr<Hop>> = (0..n).map(|_| Hop { next: None }.start()).collect();
        for (i, a) in addrs.iter().enumerate() {
            a.do_send(Link(addrs[(i + 1) % n].clone().recipient()));
        }
        addrs[0].do_send(Token(hops));
    });
    sys.run().unwrap();
}

fn throughput(c: &mut Criterion) {
    let events = nekosim::run(ticker_config()).unwrap().stats.events;
    let mut g = c.benchmark_group("throughput");
    g.sample_size(20);
    g.throughput(Throughput::Elements(events));
    g.bench_function("scheduler_actor", |b| {
        b.iter_batched(
            ticker_config,
            |cfg| nekosim::run(cfg).unwrap(),
            BatchSize::PerIteration,
        )
    });
    g.bench_function("raw_actix_do_send_ring", |b| {
        b.iter(|| raw_ring(TICKERS, events))
    });
    g.finish();
}

fn random_config(n: usize, until: f64) -> SimConfig {
    // The seed's density: 100 robots of radius 5 per 800×800.
    let side = 800.0 * (n as f64 / 100.0).sqrt();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(n as u64);
    let robots = random_born_points(n, 5.0, side, side, &[], &mut rng)
        .unwrap()
        .into_iter()
        .map(|p| {
            let spec = RobotSpec {
                radius: 5.0,
                pose: Pose { pos: p, angle: 0.0 },
            };
            (
                spec,
                Box::new(RandomMovement::default()) as Box<dyn Algorithm>,
            )
        })
        .collect();
    SimConfig {
        sensors: Default::default(),
        seed: 3,
        until,
        world: WorldConfig {
            size: WorldSize::from_origin(side, side),
            ghost_mode: false,
            walls: true,
            turn: Default::default(),
            cell_size: None,
            obstacles: Default::default(),
        },
        robots,
        arbiters: 1,
        record: false,
        observers: Default::default(),
        comms: Default::default(),
    }
}

/// Placing a million robots at the seed's density (`random_born_points`, the rejection
/// sampling behind every random born point): part of a large run's start-up.
fn placement(c: &mut Criterion) {
    let mut g = c.benchmark_group("placement");
    g.sample_size(10);
    let n = 1_000_000usize;
    let side = 800.0 * (n as f64 / 100.0).sqrt();
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function(format!("{n}_robots"), |b| {
        b.iter(|| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(n as u64);
            random_born_points(n, 5.0, side, side, &[], &mut rng).unwrap()
        })
    });
    g.finish();
}

fn random_movement(c: &mut Criterion) {
    let mut g = c.benchmark_group("random_movement");
    g.sample_size(10);
    for (n, until) in [(1_000usize, 100.0), (10_000, 20.0)] {
        let stats = nekosim::run(random_config(n, until)).unwrap().stats;
        eprintln!(
            "random_movement/{n}: {until} simulated s, {} events, {} collisions",
            stats.events, stats.collisions
        );
        g.throughput(Throughput::Elements(stats.events));
        g.bench_function(format!("{n}_robots_{until}s"), |b| {
            b.iter_batched(
                || random_config(n, until),
                |cfg| nekosim::run(cfg).unwrap(),
                BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

/// The environment variable that makes the bench a child that does one timed run of the scale
/// series and prints its figures ([`timed_from`]): `HOST ROBOTS UNTIL FROM`.
const CHILD: &str = "NEKOSIM_SCALE_CHILD";

/// Peak resident memory of this process so far [bytes] (`VmHWM`).
fn peak_rss() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

/// Who hosts a run's handling code: the actors (the product) or the kernel-alone reference.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Host {
    Actors,
    Kernel,
}

/// One timed run.
#[derive(Clone, Copy, Debug)]
struct Timed {
    /// Wall seconds of the run, placement excluded.
    wall: f64,
    /// Wall seconds of the placement.
    placement: f64,
    events: u64,
    /// Within the run, from the first progress call at simulated second 1 or later to the
    /// last one: (wall seconds, events, simulated seconds). The start-up, its burst of first
    /// touches of memory and the teardown stay outside, and so does the noise between two
    /// separate runs.
    inrun: (f64, u64, f64),
    /// Wall seconds from the start of the run to the end of spawning (the last start-up
    /// call), and from the last progress call to the run's return (the teardown).
    spawned: f64,
    teardown: f64,
    /// Peak resident memory of the run's process [bytes].
    peak_rss: u64,
}

impl Timed {
    /// The figures as one line of words, which [`Timed::parse`] reads back exactly.
    fn line(&self) -> String {
        format!(
            "{} {} {} {} {} {} {} {} {}",
            self.wall,
            self.placement,
            self.events,
            self.inrun.0,
            self.inrun.1,
            self.inrun.2,
            self.spawned,
            self.teardown,
            self.peak_rss
        )
    }

    fn parse(line: &str) -> Option<Self> {
        let w: Vec<&str> = line.split_whitespace().collect();
        let f = |i: usize| w.get(i)?.parse::<f64>().ok();
        let u = |i: usize| w.get(i)?.parse::<u64>().ok();
        (w.len() == 9).then_some(())?;
        Some(Self {
            wall: f(0)?,
            placement: f(1)?,
            events: u(2)?,
            inrun: (f(3)?, u(4)?, f(5)?),
            spawned: f(6)?,
            teardown: f(7)?,
            peak_rss: u(8)?,
        })
    }
}

fn timed(host: Host, n: usize, until: f64) -> Timed {
    timed_from(host, n, until, 1.0)
}

/// [`timed`], its in-run figures taken from the first progress call at simulated second
/// `from` or later, in a process of its own: this bench started again as a [`CHILD`].
fn timed_from(host: Host, n: usize, until: f64, from: f64) -> Timed {
    let exe = std::env::current_exe().expect("the bench's own executable");
    let out = std::process::Command::new(exe)
        .env(CHILD, format!("{host:?} {n} {until} {from}"))
        .stderr(std::process::Stdio::inherit())
        .output()
        .expect("the bench started again");
    assert!(
        out.status.success(),
        "the run's process failed: {}",
        out.status
    );
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines()
        .find_map(Timed::parse)
        .unwrap_or_else(|| panic!("no figures from the run's process: {text}"))
}

/// The [`CHILD`]'s part: the run that `job` names, its figures printed on one line.
fn child(job: &str) {
    let w: Vec<&str> = job.split_whitespace().collect();
    let host = match w.first().copied() {
        Some("Actors") => Host::Actors,
        Some("Kernel") => Host::Kernel,
        other => panic!("{CHILD}: unknown host {other:?}"),
    };
    let num = |i: usize| -> f64 {
        w.get(i)
            .and_then(|x| x.parse().ok())
            .unwrap_or_else(|| panic!("{CHILD}: `{job}` is not HOST ROBOTS UNTIL FROM"))
    };

    let t = timed_here(host, num(1) as usize, num(2), num(3));
    println!("{}", t.line());
}

/// One timed run in this process ([`timed_from`]).
fn timed_here(host: Host, n: usize, until: f64, from: f64) -> Timed {
    let placed = std::time::Instant::now();
    let mut cfg = random_config(n, until);
    let placement = placed.elapsed().as_secs_f64();
    let marks = std::rc::Rc::new(std::cell::Cell::new(None));
    let seen = marks.clone();
    cfg.observers.progress = Some(Box::new(move |t: f64, events: u64| {
        if t >= from {
            let now = (std::time::Instant::now(), events, t);
            seen.set(Some(
                seen.get().map_or((now, now), |(first, _)| (first, now)),
            ));
        }
    }));
    let started = std::time::Instant::now();
    let spawned = std::rc::Rc::new(std::cell::Cell::new(None));
    let spawn_seen = spawned.clone();
    cfg.observers.startup = Some(Box::new(move |i: usize, n: usize| {
        if i == n {
            spawn_seen.set(Some(started.elapsed().as_secs_f64()));
        }
    }));
    let stats = match host {
        Host::Actors => nekosim::run(cfg),
        Host::Kernel => nekosim::kernel::run(cfg),
    }
    .unwrap()
    .stats;
    let wall = started.elapsed().as_secs_f64();
    let inrun = marks.get().map_or((0.0, 0, 0.0), |(a, b)| {
        ((b.0 - a.0).as_secs_f64(), b.1 - a.1, b.2 - a.2)
    });
    let teardown = marks
        .get()
        .map_or(f64::NAN, |(_, b)| wall - (b.0 - started).as_secs_f64());
    Timed {
        wall,
        placement,
        events: stats.events,
        inrun,
        spawned: spawned.get().unwrap_or(f64::NAN),
        teardown,
        peak_rss: peak_rss(),
    }
}

/// The runs with the least wall times of `repeats` runs of each span, alternating:
/// (short run, long run).
fn spans(host: Host, n: usize, short: f64, long: f64, repeats: usize) -> (Timed, Timed) {
    let (mut a, mut b): (Option<Timed>, Option<Timed>) = (None, None);
    let least = |best: Option<Timed>, x: Timed| match best {
        Some(y) if y.wall <= x.wall => y,
        _ => x,
    };
    for _ in 0..repeats {
        a = Some(least(a, timed(host, n, short)));
        b = Some(least(b, timed(host, n, long)));
    }
    (a.expect("a run"), b.expect("a run"))
}

/// Whether the scale series runs `n` robots: every size unless `NEKOSIM_SCALE_SIZES` lists
/// some (`NEKOSIM_SCALE_SIZES=100000,1000000`). The ratios to 1k's are then to the first size
/// run.
fn size_wanted(n: usize) -> bool {
    std::env::var("NEKOSIM_SCALE_SIZES")
        .map_or(true, |v| v.split(',').any(|s| s.trim().parse() == Ok(n)))
}

/// The hosts that the filter asks for, by the names `{series}_kernel` and `{series}_actors`,
/// the kernel first.
fn hosts_wanted(series: &str, wanted: &dyn Fn(&str) -> bool) -> Vec<Host> {
    [(Host::Kernel, "kernel"), (Host::Actors, "actors")]
        .into_iter()
        .filter(|(_, host)| wanted(&format!("{series}_{host}")))
        .map(|(h, _)| h)
        .collect()
}

/// The scale series, each run in a process of its own ([`timed_from`]), so the peak
/// RSS printed is the larger of the two spans' own. `scale_actors` or `scale_kernel` as the
/// filter runs one host only. Skipped when the bench is filtered to something else.
fn scale(_: &mut Criterion) {
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let wanted = |name: &str| filter.is_empty() || filter.iter().any(|f| name.contains(f.as_str()));
    let hosts = hosts_wanted("scale", &wanted);
    let mut base_cost = [None, None];
    let mut base_inrun = [None, None];
    for (n, short, long, repeats) in [
        (1_000usize, 20.0, 100.0, 5),
        (100_000, 1.0, 20.0, 2),
        (1_000_000, 1.0, 11.0, 2),
    ]
    .into_iter()
    .filter(|s| size_wanted(s.0))
    {
        let mut steady = [None, None];
        for &host in &hosts {
            let (a, b) = spans(host, n, short, long, repeats);
            let cost = (b.wall - a.wall) / (b.events - a.events) as f64;
            let (in_wall, in_events, in_sim) = b.inrun;
            let in_cost = in_wall / in_events as f64;
            let k = host as usize;
            let base = *base_cost[k].get_or_insert(cost);
            let in_base = *base_inrun[k].get_or_insert(in_cost);
            steady[k] = Some((cost, b.wall));
            println!(
                "scale/{host:?}/{n}: {long} s: {} events in {:.3} s ({:.0} events/s); {short} s: \
                 {} events in {:.3} s; steady state (the difference): {:.2} us per event ({:.2}x \
                 1k's), {:.2}x real time; within the long run from simulated second 1: {} events \
                 in {:.3} s, {:.2} us per event ({:.2}x 1k's), {:.2}x real time; to simulated \
                 second 1: {:.2} s + placement {:.2} s (spawned at {:.2} s); teardown of the long \
                 run {:.2} s; peak RSS {:.2} GB",
                b.events,
                b.wall,
                b.events as f64 / b.wall,
                a.events,
                a.wall,
                cost * 1e6,
                cost / base,
                (long - short) / (b.wall - a.wall),
                in_events,
                in_wall,
                in_cost * 1e6,
                in_cost / in_base,
                in_sim / in_wall,
                if short == 1.0 { a.wall } else { f64::NAN },
                a.placement,
                a.spawned,
                b.teardown,
                a.peak_rss.max(b.peak_rss) as f64 / 1e9,
            );
        }
        if let [Some((ac, aw)), Some((kc, kw))] =
            [steady[Host::Actors as usize], steady[Host::Kernel as usize]]
        {
            println!(
                "scale/{n}: actors against the kernel alone: {:.2}x the steady cost per event, \
                 {:.2}x the long span's wall time",
                ac / kc,
                aw / kw
            );
        }
    }
    late(&wanted);
}

/// The scale series' later phase: seconds 30 to 40 of a 40 s run (30 to 60 at 1k). At the
/// start every robot of the seed's random movement turns in place towards its first
/// destination (up to a minute at the seed's turn speeds), so the first seconds have fewer
/// events, and cheaper ones, than the phase where the robots move on and collide; seconds 1
/// to 11 say little about that phase.
///
/// The 1k window stops at second 60 because the workload does not stay the same: every
/// destination is drawn over the whole world, so the robots crowd towards its middle: the
/// share of a 1k run's collisions between robots in the central quarter of the world grows
/// from seconds 30-60 on, with more events per robot and dearer ones (docs/performance.md
/// lists the shares). The drift's pace follows the world's side, 31.6 times longer at 1M, so the
/// robots of the 1M window are crowded no more than 1k's in seconds 30-60. `scale_late` as
/// the filter runs only this; least of fifteen runs at 1k, two at 100k, one at 1M.
fn late(wanted: &dyn Fn(&str) -> bool) {
    let hosts = hosts_wanted("scale_late", wanted);
    let mut base = [None, None];
    // 1k robots make about 300 events a simulated second: 30 s of them, 9,000 events, about
    // 8 ms, so the least of many runs.
    for (n, from, until, repeats) in [
        (1_000usize, 30.0, 60.0, 15),
        (100_000, 30.0, 40.0, 2),
        (1_000_000, 30.0, 40.0, 1),
    ]
    .into_iter()
    .filter(|s| size_wanted(s.0))
    {
        let mut seen = [None, None];
        for &host in &hosts {
            // The run with the least wall time within the window.
            let r = (0..repeats)
                .map(|_| timed_from(host, n, until, from))
                .min_by(|a, b| a.inrun.0.total_cmp(&b.inrun.0))
                .expect("a run");
            let (wall, events, sim) = r.inrun;
            let cost = wall / events as f64;
            let k = host as usize;
            let b = *base[k].get_or_insert(cost);
            seen[k] = Some((cost, r.wall));
            println!(
                "scale_late/{host:?}/{n}: simulated seconds {from}-{until} of a {until} s run: \
                 {events} events in {wall:.3} s ({:.0} events per simulated second), {:.2} us per \
                 event ({:.2}x 1k's), {:.2}x real time; the whole run {:.3} s ({} events)",
                events as f64 / sim,
                cost * 1e6,
                cost / b,
                sim / wall,
                r.wall,
                r.events,
            );
        }
        if let [Some((ac, aw)), Some((kc, kw))] =
            [seen[Host::Actors as usize], seen[Host::Kernel as usize]]
        {
            println!(
                "scale_late/{n}: actors against the kernel alone: {:.2}x the cost per event in \
                 seconds {from}-{until}, {:.2}x the whole run's wall time",
                ac / kc,
                aw / kw
            );
        }
    }
}

/// `memory`: what this machine's memory costs an event, apart from the engine. Each
/// of 400,000 "events" reads `reads` bytes at random 64-byte lines of one heap, then runs a
/// chain of 1,000 dependent multiply-rotate steps (about a handling's length here), the reads
/// either asked for two events ahead ([`prefetch_at`](nekosim::world::prefetch::prefetch_at),
/// as the engine's look-ahead does) or not. A 2.4 GB heap is a million robots' memory; a 4 MB
/// one stays in cache. Run it alone with `cargo bench --bench engine -- memory`.
fn memory(_: &mut Criterion) {
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    if !filter.is_empty() && !filter.iter().any(|f| "memory".contains(f.as_str())) {
        return;
    }
    const EVENTS: usize = 400_000;
    const LINE: usize = 64;
    let work = |mut h: u64| {
        for _ in 0..1_000 {
            h = h.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(7) ^ (h >> 3);
        }
        h
    };
    for mb in [2_400usize, 4] {
        let heap = vec![1u8; mb << 20];
        let lines = heap.len() / LINE;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        for (reads, ahead) in [(0, 0), (5, 0), (5, 2), (10, 2), (20, 0), (20, 2), (30, 2)] {
            if mb < 100 && reads == 0 {
                continue;
            }
            let at: Vec<usize> = (0..EVENTS * reads)
                .map(|_| rand::Rng::gen_range(&mut rng, 0..lines) * LINE)
                .collect();
            let start = std::time::Instant::now();
            let mut acc = 0u64;
            for e in 0..EVENTS {
                if ahead > 0 && e + ahead < EVENTS {
                    for &a in &at[(e + ahead) * reads..(e + ahead + 1) * reads] {
                        nekosim::world::prefetch::prefetch_at(heap.as_ptr() as usize + a, 1);
                    }
                }
                for &a in &at[e * reads..(e + 1) * reads] {
                    acc = acc.wrapping_add(u64::from(heap[a]));
                }
                acc = acc.wrapping_add(work(acc | 1) & 1);
            }
            std::hint::black_box(acc);
            let ns = start.elapsed().as_secs_f64() * 1e9 / EVENTS as f64;
            println!(
                "memory/{mb}MB: {reads} random reads an event, {}: {ns:.0} ns per event",
                if ahead > 0 {
                    format!("asked for {ahead} events ahead")
                } else {
                    "not asked for".to_string()
                }
            );
        }
    }
}

criterion_group!(
    benches,
    throughput,
    placement,
    random_movement,
    scale,
    memory
);

/// `criterion_main!`'s `main`, unless the bench was started again for one run of the scale
/// series ([`CHILD`]).
fn main() {
    if let Ok(job) = std::env::var(CHILD) {
        return child(&job);
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
