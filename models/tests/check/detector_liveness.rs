//! The liveness of failure detectors and leader election against known answers, with
//! unlimited timers (so that heartbeats and checks go round in cycles): the shipped
//! `Heartbeat` is eventually complete under fair timers and no false suspicion of it lasts for
//! ever, while detectors written here with a seeded flaw fail with a lasso; eventual strong
//! accuracy is shown to be out of reach of a time-free model, which is why it is an assumption
//! of the stacks that use a detector; and `Omega` over `Heartbeat` keeps a stable leader
//! while electors written here with a seeded flaw do not. Every lasso is replayed through the
//! model, and what it shows is read from its states and steps, independently of the property
//! that found it.

use std::collections::BTreeSet;

use nekosim_models::adapter::ModelTimer;
use nekosim_models::config::{Action, UNLIMITED_TIMERS};
use nekosim_models::liveness::{Lasso, Liveness, Strength, Verdict};
use nekosim_models::temporal::{
    accurate, explore_stack, temporal_properties, Decision, StackFairness, StackGraph,
};
use nekosim_models::{build, CheckModel, Family, Options, State, Target};
use nekosim_protocols::heartbeat::{Beat, HeartbeatTimer};
use nekosim_protocols::{
    Ctx, FieldError, Indication, Layer, LayerIx, LayerSpec, Microprotocol, NoConfig, NoMsg, Out,
    Payload, Pid, Service, Shape, Stack,
};
use stateright::actor::ActorModelAction;

use super::liveness::{liveness, replays, verdict};

/// How a detector written here differs from `Heartbeat` when it checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Flaw {
    /// None: it suspects and trusts as `Heartbeat` does (a user's detector written alike).
    Flawless,
    /// Suspects nobody.
    NeverSuspects,
    /// Trusts again, at its next check, every process it suspects, heard from or not.
    Flips,
    /// Never trusts again a process it suspected.
    Sticky,
}

/// A heartbeat detector with a seeded flaw (a test-only layer): it beats and checks as
/// `Heartbeat` does, and decides whom to suspect as its flaw says.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(super) struct Flawed {
    flaw: Flaw,
    heard: BTreeSet<Pid>,
    suspected: BTreeSet<Pid>,
    /// Whether it says whom it suspects (`Microprotocol::suspicions`), as `Heartbeat` does.
    says: bool,
}

impl Flawed {
    fn layer(flaw: Flaw) -> Layer {
        Self::layer_saying(flaw, false)
    }

    /// The layer, saying whom it suspects when `says`.
    pub(super) fn layer_saying(flaw: Flaw, says: bool) -> Layer {
        Layer::new(Self {
            flaw,
            heard: BTreeSet::new(),
            suspected: BTreeSet::new(),
            says,
        })
    }
}

impl Microprotocol for Flawed {
    type Msg = Beat;
    type Timer = HeartbeatTimer;
    type Config = NoConfig;
    const NAME: &'static str = "FlawedHeartbeat";

    fn shape(_: &NoConfig) -> Shape {
        Shape::on_links(Service::FAILURE_DETECTOR)
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Err(FieldError::whole(
            "FlawedHeartbeat",
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
        for p in ctx.others() {
            let (heard, suspected) = (self.heard.contains(&p), self.suspected.contains(&p));
            let (suspect, trust) = match self.flaw {
                Flaw::Flawless => (!heard && !suspected, heard && suspected),
                Flaw::NeverSuspects => (false, false),
                Flaw::Flips => (!heard && !suspected, suspected),
                Flaw::Sticky => (!heard && !suspected, false),
            };
            if suspect {
                self.suspected.insert(p);
                out.up(Indication::Suspect(p));
            } else if trust {
                self.suspected.remove(&p);
                out.up(Indication::Trust(p));
            }
        }
        self.heard.clear();
        out.set_timer(HeartbeatTimer::Check, 2.0);
    }

    fn suspicions(&self) -> Option<Vec<Pid>> {
        self.says.then(|| self.suspected.iter().copied().collect())
    }
}

/// How an elector written here differs from `Omega`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Elector {
    /// Hands leadership to the next process at every tick of its timer.
    Rotates,
    /// Elects the lowest process it does not suspect, as `Omega`, but ignores trust: a
    /// process once suspected is never its leader again.
    DeafToTrust,
}

/// A leader election with a seeded flaw (a test-only layer).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct FlawedElector {
    flaw: Elector,
    suspected: BTreeSet<Pid>,
    leader: Option<Pid>,
}

impl FlawedElector {
    fn layer(flaw: Elector) -> Layer {
        Layer::new(Self {
            flaw,
            suspected: BTreeSet::new(),
            leader: None,
        })
    }

    fn elect(&mut self, leader: Pid, out: &mut Out<Self>) {
        if self.leader != Some(leader) {
            self.leader = Some(leader);
            out.up(Indication::Leader(leader));
        }
    }
}

impl Microprotocol for FlawedElector {
    type Msg = NoMsg;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "FlawedElector";

    fn shape(_: &NoConfig) -> Shape {
        Shape {
            provides: Service::LEADER,
            needs_below: Service::P2P,
            needs_uses: vec![Service::FAILURE_DETECTOR],
        }
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Err(FieldError::whole("FlawedElector", "a layer a test puts in"))
    }

    fn on_start(&mut self, _: &Ctx, out: &mut Out<Self>) {
        self.elect(0, out);
        if self.flaw == Elector::Rotates {
            out.set_timer((), 1.0);
        }
    }

    fn on_timer(&mut self, ctx: &Ctx, _: (), out: &mut Out<Self>) {
        let next = self.leader.map_or(0, |l| (l + 1) % ctx.n);
        self.elect(next, out);
        out.set_timer((), 1.0);
    }

    fn on_indication(&mut self, ctx: &Ctx, _: LayerIx, ind: Indication, out: &mut Out<Self>) {
        if self.flaw == Elector::DeafToTrust {
            if let Indication::Suspect(p) = ind {
                self.suspected.insert(p);
                let leader = (0..ctx.n)
                    .find(|p| *p == ctx.me || !self.suspected.contains(p))
                    .expect("a process elects itself at worst");
                self.elect(leader, out);
            }
        }
    }
}

/// The model of `Heartbeat` (or of the layer `tweak` puts in its place) on `n` processes,
/// of which `crashes` may crash, with unlimited timers; with `Omega` above it when
/// `elector`.
fn model(
    n: u32,
    crashes: u32,
    elector: bool,
    reduction: bool,
    tweak: impl Fn(Pid, &mut Stack),
) -> CheckModel {
    let mut stack = vec![LayerSpec::new(
        "fd",
        "Heartbeat(period: 1.0, timeout: 2.0)",
        "net",
        &[],
    )];
    if elector {
        stack.push(LayerSpec::new("omega", "Omega", "net", &["fd"]));
    }
    let target = Target {
        stack,
        entry: if elector { "omega" } else { "fd" }.into(),
        family: if elector {
            Family::Leader
        } else {
            Family::FailureDetector
        },
        timer_fed: vec!["fd".into()],
    };
    let opts = Options {
        processes: n,
        crashes,
        timer_budget: UNLIMITED_TIMERS,
        reduction,
        ..Options::default()
    };
    build(&target, &opts, tweak).expect("valid model")
}

fn detector(flaw: Flaw) -> impl Fn(Pid, &mut Stack) {
    move |_, s: &mut Stack| s.layers[0] = Flawed::layer(flaw)
}

fn elector(flaw: Elector) -> impl Fn(Pid, &mut Stack) {
    move |_, s: &mut Stack| s.layers[1] = FlawedElector::layer(flaw)
}

/// The lasso of a failing verdict.
fn lasso<'a>(d: &'a [Decision], name: &str) -> &'a Lasso<State, Action> {
    match verdict(d, name) {
        Verdict::Fails(lasso) => lasso,
        Verdict::Holds => panic!("{name} holds"),
    }
}

fn holds(d: &[Decision], name: &str) -> bool {
    matches!(verdict(d, name), Verdict::Holds)
}

/// The states of a lasso's cycle (its entry first).
fn cycle_states(lasso: &Lasso<State, Action>) -> Vec<&State> {
    std::iter::once(lasso.entry())
        .chain(lasso.cycle.iter().map(|(_, s)| s))
        .collect()
}

/// Whether `a`'s last indication about `b` suspects it, read from what reached `a`'s
/// application.
fn suspects(s: &State, a: usize, b: usize) -> bool {
    s.actor_states[a].detections.suspects(b as Pid)
}

/// Whether the step fires process `p`'s detector timer `timer` (the detector is layer 0).
fn fires(action: &Action, p: usize, timer: HeartbeatTimer) -> bool {
    matches!(action, ActorModelAction::Timeout(id, ModelTimer::Layer { layer: 0, timer: t })
        if usize::from(*id) == p && *t == Payload::encode(0, &timer))
}

/// Whether the step delivers a heartbeat from `from` to `to`.
fn beat_arrives(action: &Action, from: usize, to: usize) -> bool {
    matches!(action, ActorModelAction::Deliver { src, dst, msg }
        if usize::from(*src) == from && usize::from(*dst) == to && msg.layer == 0)
}

/// The crashed process and the live ones of a state.
fn crashed_and_live(s: &State) -> (usize, Vec<usize>) {
    let dead = (0..s.crashed.len())
        .find(|&p| s.crashed[p])
        .expect("a crash");
    (dead, (0..s.crashed.len()).filter(|&p| p != dead).collect())
}

#[test]
fn a_heartbeat_detector_is_eventually_complete_exactly_under_fair_timers() {
    // The same verdicts whether spent messages are forgotten or not.
    for reduction in [true, false] {
        let m = model(2, 1, false, reduction, |_, _| {});
        let names: Vec<&str> = temporal_properties(&m).iter().map(|p| p.name).collect();
        assert_eq!(names, ["strong completeness", "eventual trust"]);
        for fairness in [StackFairness::Weak, StackFairness::Strong] {
            let (states, cut, d) = liveness(&m, fairness);
            assert!(
                holds(&d, "strong completeness"),
                "{states} states, {cut} cut"
            );
            assert!(holds(&d, "eventual trust"), "{states} states, {cut} cut");
        }
        // Without fair timers the survivor may never check again: it beats for ever and
        // never suspects the crashed process.
        let (_, _, d) = liveness(&m, StackFairness::None);
        let lasso = lasso(&d, "strong completeness");
        replays(&m, lasso);
        let (dead, live) = crashed_and_live(lasso.entry());
        let p = live[0];
        assert!(!lasso.cycle.is_empty());
        assert!(lasso
            .cycle
            .iter()
            .any(|(a, _)| fires(a, p, HeartbeatTimer::Beat)));
        assert!(!lasso
            .cycle
            .iter()
            .any(|(a, _)| fires(a, p, HeartbeatTimer::Check)));
        for s in cycle_states(lasso) {
            assert!(!suspects(s, p, dead), "{s:?}");
            // Its check stays armed throughout, so weak fairness would have it fire.
            let check = ModelTimer::Layer {
                layer: 0,
                timer: Payload::encode(0, &HeartbeatTimer::Check),
            };
            assert!(s.timers_set[p].iter().any(|t| *t == check));
        }
    }
}

#[test]
fn a_detector_that_never_suspects_is_not_complete() {
    let m = model(2, 1, false, true, detector(Flaw::NeverSuspects));
    let (_, _, d) = liveness(&m, StackFairness::Weak);
    let lasso = lasso(&d, "strong completeness");
    replays(&m, lasso);
    // A fair livelock: the survivor beats and checks for ever and never suspects the crashed
    // process.
    let (dead, live) = crashed_and_live(lasso.entry());
    let p = live[0];
    assert!(lasso
        .cycle
        .iter()
        .any(|(a, _)| fires(a, p, HeartbeatTimer::Check)));
    assert!(lasso
        .cycle
        .iter()
        .any(|(a, _)| fires(a, p, HeartbeatTimer::Beat)));
    for (_, s) in lasso.stem.iter().chain(&lasso.cycle) {
        assert!(!suspects(s, p, dead), "{s:?}");
    }
    // Suspecting nobody, it never suspects a live process either.
    assert!(holds(&d, "eventual trust"));
}

#[test]
fn a_detector_that_trusts_again_without_hearing_is_not_complete() {
    let m = model(2, 1, false, true, detector(Flaw::Flips));
    let (_, _, d) = liveness(&m, StackFairness::Weak);
    let lasso = lasso(&d, "strong completeness");
    replays(&m, lasso);
    // The survivor suspects the crashed process, then trusts it again at its next check
    // without having heard from it, and so on for ever.
    let (dead, live) = crashed_and_live(lasso.entry());
    let p = live[0];
    let states = cycle_states(lasso);
    assert!(states.iter().any(|s| suspects(s, p, dead)));
    assert!(states.iter().any(|s| !suspects(s, p, dead)));
    assert!(!lasso.cycle.iter().any(|(a, _)| beat_arrives(a, dead, p)));
}

#[test]
fn no_false_suspicion_of_heartbeat_lasts_for_ever_while_a_sticky_one_does() {
    for reduction in [true, false] {
        let m = model(2, 0, false, reduction, |_, _| {});
        let names: Vec<&str> = temporal_properties(&m).iter().map(|p| p.name).collect();
        assert_eq!(names, ["eventual trust"]);
        let (states, _, d) = liveness(&m, StackFairness::Weak);
        assert!(holds(&d, "eventual trust"), "{states} states");
        // Without fairness a process may check for ever before the other's heartbeat
        // arrives.
        let (_, _, d) = liveness(&m, StackFairness::None);
        replays(&m, lasso(&d, "eventual trust"));

        // A detector that never trusts again keeps a false suspicion for ever, though the
        // suspected process's heartbeats keep arriving.
        let m = model(2, 0, false, reduction, detector(Flaw::Sticky));
        let (_, _, d) = liveness(&m, StackFairness::Weak);
        let lasso = lasso(&d, "eventual trust");
        replays(&m, lasso);
        let (a, b) = d[0].pair.expect("the pair the lasso is about");
        let (a, b) = (a as usize, b as usize);
        for s in cycle_states(lasso) {
            assert!(suspects(s, a, b), "{s:?}");
        }
        assert!(lasso.cycle.iter().any(|(x, _)| beat_arrives(x, b, a)));
        assert!(lasso
            .cycle
            .iter()
            .any(|(x, _)| fires(x, a, HeartbeatTimer::Check)));
    }
}

#[test]
fn no_false_suspicion_of_heartbeat_lasts_for_ever_among_three_processes() {
    let m = model(3, 0, false, true, |_, _| {});
    let (states, _, d) = liveness(&m, StackFairness::Weak);
    assert!(holds(&d, "eventual trust"), "{states} states");
    assert_eq!(states, 260_904);
}

/// Decides `kind` over `p` on `graph` under weak fairness, without assumption.
fn check_weak(
    graph: &StackGraph<'_>,
    kind: Liveness,
    p: impl Fn(&State) -> bool,
) -> Verdict<State, Action> {
    let system = &graph.system;
    match graph.check_under(kind, &|_| Some(Strength::Weak), &|_| true, |s| {
        p(&system.unpack(s))
    }) {
        Verdict::Holds => Verdict::Holds,
        Verdict::Fails(l) => Verdict::Fails(system.expand(&l)),
    }
}

/// No live process suspects a live process, read from what reached the applications.
fn no_false_suspicion(s: &State) -> bool {
    let live: Vec<usize> = (0..s.crashed.len()).filter(|&p| !s.crashed[p]).collect();
    live.iter()
        .all(|&a| live.iter().all(|&b| a == b || !suspects(s, a, b)))
}

#[test]
fn eventual_strong_accuracy_is_out_of_reach_of_a_time_free_model() {
    // `Heartbeat` is eventually accurate once delays stay below its timeout. The model has
    // no time: a check may always come before the heartbeat it waits for, even in a fair
    // run, so `<>[]` accuracy fails with a lasso in which a live process suspects a live
    // one, hears from it, trusts it again, and suspects it again. Hence the stacks that use
    // a detector assume eventual accuracy rather than the family stating it.
    let m = model(2, 0, false, true, |_, _| {});
    let (graph, _, _) = explore_stack(&m, Some(100_000), &|| false);
    let graph = graph.expect("a small graph");
    let Verdict::Fails(lasso) = check_weak(&graph, Liveness::EventuallyAlways, no_false_suspicion)
    else {
        panic!("Heartbeat is eventually accurate in a time-free model");
    };
    replays(&m, &lasso);
    let states = cycle_states(&lasso);
    assert!(states.iter().any(|s| !no_false_suspicion(s)));
    assert!(states.iter().any(|s| no_false_suspicion(s)));
    for p in 0..2 {
        assert!(lasso.cycle.iter().any(|(a, _)| beat_arrives(a, 1 - p, p)));
        assert!(lasso
            .cycle
            .iter()
            .any(|(a, _)| fires(a, p, HeartbeatTimer::Check)));
    }
    // The assumption reads the same suspicions in `Heartbeat`'s own state.
    for (_, s) in lasso.stem.iter().chain(&lasso.cycle) {
        assert_eq!(accurate(&m, s), no_false_suspicion(s), "{s:?}");
    }
    // A detector that suspects nobody is accurate from the start.
    let m = model(2, 0, false, true, detector(Flaw::NeverSuspects));
    let (graph, _, _) = explore_stack(&m, Some(100_000), &|| false);
    let graph = graph.expect("a small graph");
    let v = check_weak(&graph, Liveness::EventuallyAlways, no_false_suspicion);
    assert_eq!(v, Verdict::Holds);
}

/// The leader of each live process, in a state.
fn leaders(s: &State) -> Vec<Option<Pid>> {
    (0..s.crashed.len())
        .filter(|&p| !s.crashed[p])
        .map(|p| s.actor_states[p].leader)
        .collect()
}

#[test]
fn omega_over_heartbeat_keeps_a_stable_leader_with_and_without_a_crash() {
    for crashes in [0, 1] {
        let m = model(2, crashes, true, true, |_, _| {});
        let (states, _, d) = liveness(&m, StackFairness::Weak);
        assert!(
            holds(&d, "stable leader"),
            "{crashes} crashes, {states} states"
        );
    }
    // The verdict rests on eventual accuracy: judged on every fair run, the survivors'
    // detectors may suspect and trust each other again and again, and the leader of p1
    // changes with them.
    let m = model(2, 0, true, true, |_, _| {});
    let (graph, _, _) = explore_stack(&m, Some(100_000), &|| false);
    let graph = graph.expect("a small graph");
    let stable = temporal_properties(&m)[0];
    let v = check_weak(&graph, stable.kind, |s| stable.holds_in(&m, s, None));
    let Verdict::Fails(lasso) = v else {
        panic!("a stable leader without eventual accuracy");
    };
    replays(&m, &lasso);
    let states = cycle_states(&lasso);
    assert!(states.iter().any(|s| leaders(s) == [Some(0), Some(0)]));
    assert!(states.iter().any(|s| leaders(s) == [Some(0), Some(1)]));
    assert!(states.iter().any(|s| !accurate(&m, s)));
}

#[test]
fn an_elector_that_rotates_its_leader_is_not_stable() {
    for crashes in [0, 1] {
        let m = model(2, crashes, true, true, elector(Elector::Rotates));
        let (_, _, d) = liveness(&m, StackFairness::Weak);
        let lasso = lasso(&d, "stable leader");
        replays(&m, lasso);
        // Some live process's leader takes two values in the cycle, which the accuracy
        // assumption does not excuse: the detectors are accurate throughout.
        let states = cycle_states(lasso);
        let p = (0..2)
            .find(|&p| !lasso.entry().crashed[p])
            .expect("a survivor");
        let seen: BTreeSet<Option<Pid>> = states.iter().map(|s| s.actor_states[p].leader).collect();
        assert!(seen.len() >= 2, "{seen:?}");
        assert!(states.iter().all(|s| accurate(&m, s)));
    }
}

#[test]
fn an_elector_deaf_to_trust_keeps_a_stale_leader() {
    let m = model(2, 0, true, true, elector(Elector::DeafToTrust));
    let (_, _, d) = liveness(&m, StackFairness::Weak);
    let lasso = lasso(&d, "stable leader");
    replays(&m, lasso);
    // p1 suspected p0 once and elected itself; p1's detector trusts p0 again (the cycle is
    // accurate, so eventual accuracy does not excuse it), but p1 stays its own leader while
    // p0 leads itself.
    for s in cycle_states(lasso) {
        assert!(accurate(&m, s), "{s:?}");
        assert_eq!(leaders(s), [Some(0), Some(1)]);
    }
}
