//! Temporal properties of stacks against known answers: a Chandra-Toueg variant whose round
//! never ends livelocks (a lasso shows it), Retransmit over a lossy network is live exactly
//! under fair loss, and the shipped models keep their verdicts. The lassos are replayed
//! through the model as paths, and the graphs' verdicts are checked against a brute-force
//! enumeration of simple cycles on small graphs.

use nekosim_models::adapter::State;
use nekosim_models::config::{Action, UNLIMITED_TIMERS};
use nekosim_models::liveness::{Lasso, Verdict};
use nekosim_models::temporal::{
    decide, explore_stack, lasso_path, stored, Decision, StackFairness,
};
use nekosim_models::{
    build, find, run, CheckModel, Exploration, Family, NetworkKind, Options, Target,
};

use super::opts;
use nekosim_protocols::consensus::{ChandraToueg, CtMsg};
use nekosim_protocols::heartbeat::{Beat, HeartbeatTimer};
use nekosim_protocols::protocol::{FieldError, Microprotocol, NoConfig, Out, Round, Rounds};
use nekosim_protocols::{
    Ctx, Effect, Indication, Layer, LayerIx, LayerSpec, Pid, Request, Service, Shape, Stack,
};

/// Chandra-Toueg whose coordinators ignore the estimates of others: no round ever gathers a
/// majority, so no round ends unless its coordinator is suspected. A test-only variant.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct DeafCoordinator(ChandraToueg);

impl DeafCoordinator {
    fn forward(out: &mut Out<Self>, inner: Out<ChandraToueg>) {
        for e in inner.into_effects() {
            match e {
                Effect::Down(req) => out.down(req),
                Effect::Use { slot, req } => out.use_layer(slot, req),
                Effect::Up { to: Some(to), ind } => out.up_to(to, ind),
                Effect::Up { to: None, ind } => out.up(ind),
                Effect::SetTimer { .. } | Effect::CancelTimer(_) => {
                    unreachable!("Chandra-Toueg sets no timers")
                }
            }
        }
    }
}

impl Microprotocol for DeafCoordinator {
    type Msg = CtMsg;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "DeafCoordinatorCT";
    const ROUNDS: Rounds = Rounds::Numbered;

    fn round(msg: &CtMsg) -> Round {
        ChandraToueg::round(msg)
    }

    fn shape(c: &NoConfig) -> Shape {
        ChandraToueg::shape(c)
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_request(&mut self, ctx: &Ctx, from: LayerIx, req: Request, out: &mut Out<Self>) {
        let mut inner = Out::new(out.layer());
        self.0.on_request(ctx, from, req, &mut inner);
        Self::forward(out, inner);
    }

    fn on_indication(&mut self, ctx: &Ctx, from: LayerIx, ind: Indication, out: &mut Out<Self>) {
        let mut inner = Out::new(out.layer());
        self.0.on_indication(ctx, from, ind, &mut inner);
        Self::forward(out, inner);
    }

    fn on_message(&mut self, ctx: &Ctx, from: Pid, m: CtMsg, out: &mut Out<Self>) {
        if matches!(m, CtMsg::Estimate { .. }) {
            return;
        }
        let mut inner = Out::new(out.layer());
        self.0.on_message(ctx, from, m, &mut inner);
        Self::forward(out, inner);
    }
}

/// The whole graph of `model` and its temporal verdicts under `fairness`.
pub(super) fn liveness(
    model: &CheckModel,
    fairness: StackFairness,
) -> (usize, usize, Vec<Decision>) {
    let (graph, halted, tasks) = explore_stack(model, Some(3_000_000), &|| false);
    assert_eq!(halted, None);
    let graph = graph.expect("a small graph");
    let decisions = decide(model, &graph, fairness);
    eprintln!(
        "{} states, {} steps, {} cut, {tasks} tasks",
        graph.len(),
        graph.edge_count(),
        graph.cut_states(),
    );
    (graph.len(), graph.cut_states(), decisions)
}

pub(super) fn verdict<'a>(d: &'a [Decision], name: &str) -> &'a Verdict<State, Action> {
    &d.iter()
        .find(|d| d.property.name == name)
        .unwrap_or_else(|| panic!("no temporal property {name}"))
        .verdict
}

/// The lasso replays through the model, step by step, through the lasso's states (which are
/// the graph's: spent messages forgotten), and its cycle ends where it began.
pub(super) fn replays(model: &CheckModel, lasso: &Lasso<State, Action>) {
    let path = lasso_path(model, lasso).expect("a lasso is a path of the model");
    let states = path.into_states();
    assert_eq!(states.len(), 1 + lasso.stem.len() + lasso.cycle.len());
    let graph_states = lasso.stem.iter().chain(&lasso.cycle).map(|(_, s)| s);
    for (replayed, s) in states[1..].iter().zip(graph_states) {
        assert_eq!(stored(model, replayed), *s);
    }
    assert_eq!(stored(model, &states[lasso.stem.len()]), *lasso.entry());
    assert_eq!(
        stored(model, states.last().expect("a state")),
        *lasso.entry(),
        "the cycle closes"
    );
    // Nothing is forgotten without the reductions, except, with unlimited timers, the
    // messages to a crashed process.
    let crash = lasso.entry().crashed.contains(&true);
    let forgets = model.cfg.reduction || crash && model.cfg.timer_budget == UNLIMITED_TIMERS;
    if !forgets {
        assert_eq!(
            states.last(),
            Some(lasso.entry()),
            "the cycle closes exactly"
        );
    }
}

fn ct_model(n: u32, requests: u32, timers: u32, deaf: bool, reduction: bool) -> CheckModel {
    let opts = Options {
        processes: n,
        requests,
        timer_budget: timers,
        reduction,
        ..Options::default()
    };
    let def = find("ct-consensus").expect("shipped");
    build(&def.target(), &opts, |_, s: &mut Stack| {
        if deaf {
            s.layers[1] = Layer::new(DeafCoordinator::default());
        }
    })
    .expect("valid model")
}

#[test]
fn a_chandra_toueg_whose_rounds_never_end_livelocks() {
    // The same verdicts whether spent messages are forgotten or not.
    for reduction in [true, false] {
        a_chandra_toueg_whose_rounds_never_end_livelocks_with(reduction);
    }
}

fn a_chandra_toueg_whose_rounds_never_end_livelocks_with(reduction: bool) {
    // Two processes: a round needs both, so its coordinator waits for the other's estimate.
    let model = ct_model(2, 2, UNLIMITED_TIMERS, true, reduction);
    let (states, _, d) = liveness(&model, StackFairness::Weak);
    let Verdict::Fails(lasso) = verdict(&d, "termination") else {
        panic!("the deaf coordinator never decides ({states} states)");
    };
    replays(&model, lasso);
    // A livelock, not a deadlock: the detectors keep beating and checking in the cycle, and
    // nobody ever decides.
    assert!(!lasso.cycle.is_empty(), "{lasso:?}");
    assert!(lasso
        .cycle
        .iter()
        .any(|(a, _)| matches!(a, stateright::actor::ActorModelAction::Timeout(..))));
    for (_, s) in lasso.stem.iter().chain(&lasso.cycle) {
        assert!(s.actor_states.iter().all(|a| a.decided.is_empty()));
    }
    // The correct protocol in the same configuration terminates.
    let model = ct_model(2, 2, UNLIMITED_TIMERS, false, reduction);
    let (states, cut, d) = liveness(&model, StackFairness::Weak);
    assert!(
        matches!(verdict(&d, "termination"), Verdict::Holds),
        "{states} states, {cut} cut"
    );
}

/// A failure detector for runs without crashes: it suspects nobody, which is perfect where
/// nobody crashes, and its timer only marks time passing, so that a run may go on for ever.
/// A test-only layer in place of `Heartbeat`, whose graphs of Chandra-Toueg on three
/// processes are out of reach (more than a million and a half states).
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct Ticking {
    odd: bool,
}

impl Microprotocol for Ticking {
    type Msg = Beat;
    type Timer = HeartbeatTimer;
    type Config = NoConfig;
    const NAME: &'static str = "Ticking";

    fn shape(_: &NoConfig) -> Shape {
        Shape::on_links(Service::FAILURE_DETECTOR)
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_start(&mut self, _: &Ctx, out: &mut Out<Self>) {
        out.set_timer(HeartbeatTimer::Beat, 1.0);
    }

    fn on_timer(&mut self, _: &Ctx, _: HeartbeatTimer, out: &mut Out<Self>) {
        self.odd = !self.odd;
        out.set_timer(HeartbeatTimer::Beat, 1.0);
    }
}

#[test]
fn a_chandra_toueg_whose_rounds_never_end_livelocks_with_three_processes() {
    for requests in [2, 3] {
        let model = |deaf| {
            let opts = Options {
                processes: 3,
                requests,
                timer_budget: UNLIMITED_TIMERS,
                ..Options::default()
            };
            let def = find("ct-consensus").expect("shipped");
            build(&def.target(), &opts, |_, s: &mut Stack| {
                s.layers[0] = Layer::new(Ticking::default());
                if deaf {
                    s.layers[1] = Layer::new(DeafCoordinator::default());
                }
            })
            .expect("valid model")
        };
        // A round needs a majority: two estimates at the coordinator, which ignores them.
        // Nobody is ever suspected, so round 0 never ends, while time goes on.
        let deaf = model(true);
        let (states, _, d) = liveness(&deaf, StackFairness::Weak);
        let Verdict::Fails(lasso) = verdict(&d, "termination") else {
            panic!("the deaf coordinator never decides ({states} states)");
        };
        replays(&deaf, lasso);
        assert!(!lasso.cycle.is_empty(), "{lasso:?}");
        use stateright::actor::ActorModelAction::Timeout;
        assert!(lasso.cycle.iter().all(|(a, _)| matches!(a, Timeout(..))));
        for (_, s) in lasso.stem.iter().chain(&lasso.cycle) {
            assert!(s.actor_states.iter().all(|a| a.decided.is_empty()));
        }
        // Every proposal was made: the processes wait for a round that never ends.
        for (a, actor) in lasso.entry().actor_states.iter().zip(&deaf.actors) {
            assert_eq!(a.issued, actor.requests.len());
        }
        // The correct protocol over the same detector terminates.
        let (states, cut, d) = liveness(&model(false), StackFairness::Weak);
        assert!(
            matches!(verdict(&d, "termination"), Verdict::Holds),
            "{states} states, {cut} cut"
        );
    }
}

fn retransmit(network: NetworkKind, reduction: bool) -> CheckModel {
    let target = Target {
        stack: vec![LayerSpec::new("rt", "Retransmit(period: 0.5)", "net", &[])],
        entry: "rt".into(),
        family: Family::P2p { fifo: false },
        timer_fed: Vec::new(),
    };
    let opts = Options {
        processes: 2,
        requests: 1,
        network,
        timer_budget: UNLIMITED_TIMERS,
        reduction,
        ..Options::default()
    };
    build(&target, &opts, |_, _| {}).expect("valid model")
}

#[test]
fn retransmit_over_a_lossy_network_is_live_only_under_fair_loss() {
    // The same verdicts whether spent messages are forgotten or not.
    for reduction in [true, false] {
        retransmit_over_a_lossy_network_is_live_only_under_fair_loss_with(reduction);
    }
}

fn retransmit_over_a_lossy_network_is_live_only_under_fair_loss_with(reduction: bool) {
    let model = retransmit(NetworkKind::Lossy, reduction);
    for fairness in [StackFairness::None, StackFairness::Weak] {
        let (states, _, d) = liveness(&model, fairness);
        let Verdict::Fails(lasso) = verdict(&d, "reliable delivery") else {
            panic!("{fairness:?}: every copy may be lost ({states} states)");
        };
        replays(&model, lasso);
        // Nothing was delivered, and under weak fairness the cycle resends (a timer) and
        // loses the copy again for ever.
        assert!(lasso
            .stem
            .iter()
            .chain(&lasso.cycle)
            .all(|(_, s)| s.actor_states[1].received.is_empty()));
        if fairness == StackFairness::Weak {
            use stateright::actor::ActorModelAction::{Drop, Timeout};
            assert!(lasso.cycle.iter().any(|(a, _)| matches!(a, Drop(_))));
            assert!(lasso.cycle.iter().any(|(a, _)| matches!(a, Timeout(..))));
        }
    }
    let (states, cut, d) = liveness(&model, StackFairness::Strong);
    assert!(
        matches!(verdict(&d, "reliable delivery"), Verdict::Holds),
        "fair loss: {states} states, {cut} cut"
    );
    // On a reliable network weak fairness (fair delivery) is enough.
    let model = retransmit(NetworkKind::Unordered, reduction);
    let (_, _, d) = liveness(&model, StackFairness::Weak);
    assert!(matches!(verdict(&d, "reliable delivery"), Verdict::Holds));
}

/// Each verdict as whether it holds, and a failing one's lasso shape.
fn shapes(d: &[Decision]) -> Vec<(&'static str, bool)> {
    d.iter()
        .map(|d| (d.property.name, matches!(d.verdict, Verdict::Holds)))
        .collect()
}

#[test]
fn forgetting_spent_messages_keeps_the_temporal_verdicts_and_matches_the_search() {
    // (model, options, (graph states with spent messages forgotten, without), whether the
    // breadth-first search explores the same states: on a network that reorders messages,
    // where it applies no partial-order reduction, and where the liveness graph's bounds
    // cut the same runs.)
    let lossy = Options {
        network: NetworkKind::Lossy,
        ..opts(3, 1)
    };
    let crash = Options {
        crashes: 1,
        ..opts(3, 1)
    };
    let no_timers = Options {
        timer_budget: 0,
        ..opts(3, 1)
    };
    let two_proposals = Options {
        requests: 2,
        ..no_timers.clone()
    };
    let cases: [(&str, Options, (usize, usize), bool); 7] = [
        ("lamport-abcast", opts(2, 2), (26, 26), false),
        ("sequencer-abcast", opts(3, 1), (5, 5), false),
        ("consensus-abcast", no_timers.clone(), (94, 678), true),
        ("ct-consensus", two_proposals, (17, 23), true),
        ("reliable-broadcast", opts(3, 2), (49, 129), true),
        ("reliable-broadcast", lossy, (14, 19), true),
        ("reliable-broadcast", crash, (60, 84), true),
    ];
    let mut found = Vec::new();
    for (name, o, _, same_search) in &cases {
        // The graph explores every order of arrival, as `nekosim check` builds it.
        let model = |reduction| {
            let o = Options {
                reduction,
                defer_early: false,
                ..o.clone()
            };
            build(&find(name).unwrap().target(), &o, |_, _| {}).unwrap()
        };
        let (on, off) = (model(true), model(false));
        let fairness = StackFairness::of(o.network);
        let (states_on, _, d_on) = liveness(&on, fairness);
        let (states_off, _, d_off) = liveness(&off, fairness);
        assert_eq!(shapes(&d_on), shapes(&d_off), "{name} {o:?}");
        assert!(states_on <= states_off, "{name} {o:?}");
        if *same_search {
            let searched = run(on.clone(), Exploration::default());
            assert_eq!(states_on, searched.unique_states, "{name} {o:?}");
        }
        found.push((states_on, states_off));
    }
    let pinned: Vec<(usize, usize)> = cases.iter().map(|c| c.2).collect();
    assert_eq!(found, pinned);
}
