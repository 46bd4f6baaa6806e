//! Model-checking benchmarks (`cargo bench --bench check`): states generated per second by a
//! full breadth-first check, single threaded, of
//! - `check/lamport-abcast n=3 k=2`: our Lamport abcast model (the protocol code the
//!   simulator runs, hosted by the adapter), its reductions off, and
//! - `check/paxos 2 clients 3 servers`: stateright's own Single Decree Paxos example, in the
//!   same run for comparison, checked by stateright's BFS and (for context) by the compact
//!   search our models use;
//! - `check/lamport-abcast n=3 k=3`, with the reductions (on this network that reorders, each
//!   link in send order, as Lamport's Fifo allows, and partial-order reduction) and without:
//!   the time of the whole check each way; both unique counts are printed.
//!
//! Criterion's throughput line (elem/s) is the states/s figure; the element count is the
//! number of states one check generates (duplicates included, as stateright counts them).
//! Criterion times the two checks minutes apart, and this machine's speed drifts more than
//! their difference in that time, so the bench also prints the ratio of the two measured in
//! pairs: rounds that time one check of each in turn.

mod paxos;

use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nekosim_models::compact::CompactBfs;
use nekosim_models::{build, find, run, Exploration, Options};
use stateright::actor::Network;
use stateright::{Checker, Model};

/// Lamport with its defaults and the reductions off: the raw throughput of the search.
fn lamport() -> nekosim_models::CheckModel {
    let def = find("lamport-abcast").expect("registered");
    let o = Options {
        reduction: false,
        ..Options::default()
    };
    build(&def.target(), &o, |_, _| {}).expect("valid")
}

/// Lamport with 3 broadcasts, with or without the reductions.
fn lamport_3(reduction: bool) -> nekosim_models::CheckModel {
    let def = find("lamport-abcast").expect("registered");
    let o = Options {
        requests: 3,
        reduction,
        ..Options::default()
    };
    build(&def.target(), &o, |_, _| {}).expect("valid")
}

fn paxos() -> paxos::PaxosModel {
    paxos::PaxosModelCfg {
        client_count: 2,
        server_count: 3,
        network: Network::new_unordered_nonduplicating([]),
    }
    .into_model()
}

/// Rounds of [`paired_ratio`].
const ROUNDS: usize = 31;

/// Lamport's states per second over Paxos's, from rounds that each time one check of each,
/// the first of the two alternating, so that a drift of the machine's speed falls on both
/// alike: the least, median and greatest of the rounds' ratios.
fn paired_ratio() -> [f64; 3] {
    let per_second = |check: &dyn Fn() -> usize| {
        let started = Instant::now();
        let states = check();
        states as f64 / started.elapsed().as_secs_f64()
    };
    let lamport = || run(lamport(), Exploration::default()).states;
    let paxos = || paxos().checker().spawn_bfs().join().state_count();
    let mut ratios: Vec<f64> = (0..ROUNDS)
        .map(|round| {
            if round % 2 == 0 {
                let l = per_second(&lamport);
                l / per_second(&paxos)
            } else {
                let p = per_second(&paxos);
                per_second(&lamport) / p
            }
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    [ratios[0], ratios[ROUNDS / 2], ratios[ROUNDS - 1]]
}

fn bench(c: &mut Criterion) {
    let [least, median, greatest] = paired_ratio();
    eprintln!(
        "lamport-abcast n=3 k=2 against paxos 2 clients 3 servers, states per second, \
         {ROUNDS} paired rounds: median {median:.2}x ({least:.2}x to {greatest:.2}x)"
    );
    let mut g = c.benchmark_group("check");
    g.sample_size(10);

    let states = run(lamport(), Exploration::default()).states;
    g.throughput(Throughput::Elements(states as u64));
    g.bench_function("lamport-abcast n=3 k=2", |b| {
        b.iter(|| {
            let o = run(lamport(), Exploration::default());
            assert_eq!(o.states, states);
        })
    });

    let states = paxos().checker().spawn_bfs().join().state_count();
    g.throughput(Throughput::Elements(states as u64));
    g.bench_function("paxos 2 clients 3 servers", |b| {
        b.iter(|| {
            let c = paxos().checker().spawn_bfs().join();
            assert_eq!(c.unique_state_count(), 16_668);
        })
    });

    // Context: the same Paxos model under nekosim's compact search (the checker `run` uses
    // for our models), so the checkers can be told apart from the models.
    g.bench_function("paxos 2 clients 3 servers, compact bfs", |b| {
        b.iter(|| {
            let c = CompactBfs::spawn(paxos(), 1, None, false, Default::default(), None).join();
            assert_eq!(c.unique_state_count(), 16_668);
        })
    });

    // The reductions: the same check's time with and without them (the throughput line
    // counts the states the search without them generates, for both).
    let without = run(lamport_3(false), Exploration::default());
    let with = run(lamport_3(true), Exploration::default());
    eprintln!(
        "lamport-abcast n=3 k=3: {} unique states with the reductions, {} without ({:.2}x fewer)",
        with.unique_states,
        without.unique_states,
        without.unique_states as f64 / with.unique_states as f64
    );
    g.throughput(Throughput::Elements(without.states as u64));
    for (name, reduction, unique) in [
        ("lamport-abcast n=3 k=3, reductions", true, 84_924),
        ("lamport-abcast n=3 k=3, no reduction", false, 584_565),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let o = run(lamport_3(reduction), Exploration::default());
                assert_eq!(o.unique_states, unique);
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
