//! A detector's indications kept as a summary ([`Detections`]) against the whole sequence of
//! them. The oracle is a model written here around the checked one: its state is the checked
//! state plus, for each process, every `Suspect` and `Trust` that reached the application, read
//! by replaying each step through the adapter, and its properties are read from those
//! sequences as they are defined (the last indication about a process, the alternation, a
//! trust of a live process). stateright's own breadth-first search explores it with a finite
//! timer budget. The summarised model must give the same verdicts (under stateright's search
//! and under nekosim's, reductions on), and its states must be exactly the oracle's states
//! with each sequence replaced by its summary.

use std::borrow::Cow;
use std::collections::{BTreeSet, HashSet};

use nekosim_models::adapter::{Detections, Happening};
use nekosim_models::config::Action;
use nekosim_models::{
    build, run, CheckModel, Exploration, Family, Options, Outcome, State, Target,
};
use nekosim_protocols::heartbeat::{Beat, HeartbeatTimer};
use nekosim_protocols::{
    Ctx, FieldError, Indication, Layer, LayerSpec, Microprotocol, NoConfig, Out, Pid, Service,
    Shape, Stack,
};
use stateright::actor::{ActorModelAction, Id};
use stateright::{Checker, Expectation, Model, Property, StateRecorder};

/// What reached each process's application from its detector, in order.
type Heard = Vec<Vec<(Pid, bool)>>;

/// The checked model, with every process's whole sequence of indications kept beside it.
struct WithHistory(CheckModel);

impl WithHistory {
    /// The detector indications in `log` that reached the application from the layer checked.
    fn told(&self, log: Vec<Happening>) -> impl Iterator<Item = (Pid, bool)> {
        let entry = self.0.actors[0].shared.entry;
        log.into_iter().filter_map(move |h| match h {
            Happening::App { layer, ind } if layer == entry => match ind {
                Indication::Suspect(p) => Some((p, true)),
                Indication::Trust(p) => Some((p, false)),
                _ => None,
            },
            _ => None,
        })
    }
}

impl Model for WithHistory {
    type State = (State, Heard);
    type Action = Action;

    fn init_states(&self) -> Vec<Self::State> {
        let heard: Heard = (0..self.0.actors.len())
            .map(|i| {
                let mut log = Vec::new();
                self.0.actors[i].start(Id::from(i), &mut stateright::actor::Out::new(), &mut log);
                self.told(log).collect()
            })
            .collect();
        Model::init_states(&self.0)
            .into_iter()
            .map(|s| (s, heard.clone()))
            .collect()
    }

    fn actions(&self, s: &Self::State, actions: &mut Vec<Action>) {
        Model::actions(&self.0, &s.0, actions);
    }

    fn next_state(&self, s: &Self::State, action: Action) -> Option<Self::State> {
        let next = Model::next_state(&self.0, &s.0, action.clone())?;
        let mut heard = s.1.clone();
        let mut log = Vec::new();
        let mut out = stateright::actor::Out::new();
        let at = match action {
            ActorModelAction::Deliver { src, dst, msg } => {
                let i = usize::from(dst);
                let mut p = Cow::Borrowed(&*s.0.actor_states[i]);
                self.0.actors[i].receive(dst, &mut p, src, msg, &mut out, &mut log);
                i
            }
            ActorModelAction::Timeout(id, timer) => {
                let i = usize::from(id);
                let mut p = Cow::Borrowed(&*s.0.actor_states[i]);
                self.0.actors[i].fire(id, &mut p, &timer, &mut out, &mut log);
                i
            }
            _ => 0,
        };
        heard[at].extend(self.told(log));
        Some((next, heard))
    }

    fn within_boundary(&self, s: &Self::State) -> bool {
        Model::within_boundary(&self.0, &s.0)
    }

    fn properties(&self) -> Vec<Property<Self>> {
        vec![
            Property::always("well-formed suspicions", |_, s: &Self::State| {
                well_formed(&s.1)
            }),
            Property::sometimes("completeness", |_, s: &Self::State| completeness(s)),
            Property::sometimes("false suspicion revoked", |_, s: &Self::State| revoked(s)),
        ]
    }
}

/// Each process's indications never name itself and, about each other process, alternate
/// suspect, trust, suspect...
fn well_formed(heard: &Heard) -> bool {
    heard.iter().enumerate().all(|(me, told)| {
        told.iter().all(|&(p, _)| p as usize != me)
            && (0..heard.len() as Pid).all(|q| {
                let about: Vec<bool> = told.iter().filter(|t| t.0 == q).map(|t| t.1).collect();
                about.iter().enumerate().all(|(k, &s)| s == (k % 2 == 0))
            })
    })
}

/// A process crashed, and every live one's last indication about every crashed one suspects
/// it.
fn completeness((s, heard): &(State, Heard)) -> bool {
    let n = s.crashed.len();
    let last = |a: usize, t: usize| heard[a].iter().rev().find(|x| x.0 as usize == t);
    s.crashed.iter().any(|c| *c)
        && (0..n).filter(|&a| !s.crashed[a]).all(|a| {
            (0..n)
                .filter(|&t| s.crashed[t])
                .all(|t| last(a, t).is_some_and(|x| x.1))
        })
}

/// A live process heard a trust of a live process.
fn revoked((s, heard): &(State, Heard)) -> bool {
    (0..s.crashed.len()).filter(|&a| !s.crashed[a]).any(|a| {
        heard[a]
            .iter()
            .any(|&(p, sus)| !sus && !s.crashed[p as usize])
    })
}

/// How a detector written here breaks well-formedness, at its first check.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Fault {
    /// Suspects its own process.
    Itself,
    /// Suspects every other process it has not heard from, at every check, never trusting.
    Again,
    /// Trusts every other process it has heard from, suspected or not.
    Unsuspected,
}

/// A heartbeat detector with a seeded fault (a test-only layer).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct Faulty {
    fault: Fault,
    heard: BTreeSet<Pid>,
}

impl Microprotocol for Faulty {
    type Msg = Beat;
    type Timer = HeartbeatTimer;
    type Config = NoConfig;
    const NAME: &'static str = "FaultyHeartbeat";

    fn shape(_: &NoConfig) -> Shape {
        Shape::on_links(Service::FAILURE_DETECTOR)
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Err(FieldError::whole(
            "FaultyHeartbeat",
            "a layer a test puts in",
        ))
    }

    fn on_start(&mut self, ctx: &Ctx, out: &mut Out<Self>) {
        out.send(ctx.others(), Beat);
        out.set_timer(HeartbeatTimer::Beat, 1.0);
        out.set_timer(HeartbeatTimer::Check, 2.0);
    }

    fn on_message(&mut self, _: &Ctx, from: Pid, _: Beat, _: &mut Out<Self>) {
        self.heard.insert(from);
    }

    fn on_timer(&mut self, ctx: &Ctx, timer: HeartbeatTimer, out: &mut Out<Self>) {
        if timer == HeartbeatTimer::Beat {
            out.send(ctx.others(), Beat);
            out.set_timer(HeartbeatTimer::Beat, 1.0);
            return;
        }
        match self.fault {
            Fault::Itself => out.up(Indication::Suspect(ctx.me)),
            Fault::Again => {
                for p in ctx.others().into_iter().filter(|p| !self.heard.contains(p)) {
                    out.up(Indication::Suspect(p));
                }
            }
            Fault::Unsuspected => {
                for &p in &self.heard {
                    out.up(Indication::Trust(p));
                }
            }
        }
        self.heard.clear();
        out.set_timer(HeartbeatTimer::Check, 2.0);
    }
}

/// The model of `Heartbeat` (or of a faulty one) on `n` processes, `crashes` of which may
/// crash, each firing at most `timers` protocol timers.
fn model(n: u32, crashes: u32, timers: u32, fault: Option<Fault>) -> CheckModel {
    let target = Target {
        stack: vec![LayerSpec::new(
            "fd",
            "Heartbeat(period: 1.0, timeout: 2.0)",
            "net",
            &[],
        )],
        entry: "fd".into(),
        family: Family::FailureDetector,
        timer_fed: vec!["fd".into()],
    };
    let opts = Options {
        processes: n,
        crashes,
        timer_budget: timers,
        ..Options::default()
    };
    build(&target, &opts, |_, s: &mut Stack| {
        if let Some(fault) = fault {
            s.layers[0] = Layer::new(Faulty {
                fault,
                heard: BTreeSet::new(),
            });
        }
    })
    .expect("valid model")
}

/// Whether a property with this expectation holds, given whether the search found a
/// discovery for it.
fn holds(expectation: &Expectation, discovered: bool) -> bool {
    match expectation {
        Expectation::Always | Expectation::Eventually => !discovered,
        Expectation::Sometimes => discovered,
    }
}

/// Compares the summarised model with the oracle: the same verdict for every property the
/// model checks, by stateright's search and by nekosim's; where both searches were
/// exhaustive, the same states once each sequence is summarised. Returns the oracle's
/// unique states and the model's if the states were compared, and the model's verdicts by
/// nekosim.
fn compare(
    n: u32,
    crashes: u32,
    timers: u32,
    fault: Option<Fault>,
) -> (Option<(usize, usize)>, Outcome) {
    let what = format!("{n} processes, {crashes} crashes, timers {timers}, {fault:?}");
    let oracle = WithHistory(model(n, crashes, timers, fault));
    let oracle_props = oracle.properties();
    let (seen_full, full) = StateRecorder::new_with_accessor();
    let full_checker = oracle.checker().visitor(seen_full).spawn_bfs().join();
    let summarised = model(n, crashes, timers, fault);
    let (seen_summed, summed) = StateRecorder::new_with_accessor();
    let checker = summarised
        .clone()
        .checker()
        .visitor(seen_summed)
        .spawn_bfs()
        .join();
    let outcome = run(model(n, crashes, timers, fault), Exploration::default());

    for p in summarised.properties() {
        let o = oracle_props
            .iter()
            .find(|q| q.name == p.name)
            .unwrap_or_else(|| panic!("the oracle states {:?}", p.name));
        let truth = holds(&o.expectation, full_checker.discovery(o.name).is_some());
        let by_stateright = holds(&p.expectation, checker.discovery(p.name).is_some());
        let by_nekosim = outcome.verdict(p.name).expect("a verdict").holds;
        assert_eq!(
            (by_stateright, by_nekosim),
            (truth, truth),
            "{what}: {:?}",
            p.name
        );
    }
    assert!(outcome.stopped.is_none(), "{what}");

    let (full, summed) = (full(), summed());
    let exhaustive = full_checker.discoveries().len() < oracle_props.len()
        && checker.discoveries().len() < summarised.properties().len();
    if exhaustive {
        let mut image: HashSet<State> = HashSet::new();
        for (s, heard) in &full {
            for (me, told) in heard.iter().enumerate() {
                assert_eq!(
                    s.actor_states[me].detections,
                    Detections::of(me as Pid, told),
                    "{what}: p{me} heard {told:?}"
                );
            }
            image.insert(s.clone());
        }
        let summed_set: HashSet<State> = summed.iter().cloned().collect();
        assert_eq!(summed_set.len(), summed.len(), "{what}");
        assert_eq!(image, summed_set, "{what}");
    }
    (exhaustive.then_some((full.len(), summed.len())), outcome)
}

/// With a finite timer budget, a process's fired timers and its detector's state already
/// tell its indications apart, so no two states of the whole history share a summary and the
/// counts are equal; what the summary merges only shows with unlimited timers, where the
/// whole history has no end (tests/integration/check.rs checks that case finishes).
#[test]
fn heartbeat_summarised_gives_the_verdicts_and_states_of_its_whole_history() {
    // (processes, crashes, timers), stateright's unique states with the whole history and
    // summarised, and nekosim's (which forgets spent messages).
    for (n, crashes, timers, full, summed, nekosim) in [
        (2, 0, 1, 49, 49, 49),
        (2, 0, 2, 274, 274, 274),
        (2, 1, 1, 513, 513, 473),
        (2, 1, 2, 3945, 3945, 3183),
        (3, 0, 1, 6293, 6293, 6293),
    ] {
        let what = format!("{n} processes, {crashes} crashes, timers {timers}");
        let (counts, outcome) = compare(n, crashes, timers, None);
        assert!(outcome.all_hold(), "{what}: {:?}", outcome.verdicts);
        assert_eq!(counts, Some((full, summed)), "{what}");
        assert_eq!(outcome.unique_states, nekosim, "{what}");
    }
}

#[test]
fn faulty_detectors_summarised_fail_as_their_whole_history_does() {
    for fault in [Fault::Itself, Fault::Again, Fault::Unsuspected] {
        for (crashes, timers) in [(0, 2), (1, 2)] {
            let (_, outcome) = compare(2, crashes, timers, Some(fault));
            let v = outcome.verdict("well-formed suspicions").unwrap();
            assert!(!v.holds, "{fault:?}");
        }
    }
}
