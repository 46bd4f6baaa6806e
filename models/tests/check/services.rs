//! Properties of the services beyond broadcast and consensus: point-to-point links (FIFO or
//! not), failure detectors and leader election, each checked on a correct stack and caught on
//! a layer written here with a seeded bug. The oracle is the counterexample's own last state,
//! read independently of the property that found it.

use nekosim_models::adapter::Happening;
use nekosim_models::config::Action;
use nekosim_models::explain::{explain, Event};
use nekosim_models::reason::reason;
use nekosim_models::{
    build_in, run, CheckModel, Exploration, Family, NetworkKind, Options, Outcome, State, Target,
};
use nekosim_protocols::{
    AppMsg, Content, Ctx, FieldError, Indication, LayerIx, LayerSpec, Microprotocol, NoConfig, Out,
    Payload, Pid, Protocols, Request, Service, Shape,
};
use serde::{Deserialize, Serialize};
use stateright::Path;

/// Claims FIFO links but only passes messages through: FIFO on an ordered network, not on
/// one that reorders.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct PassThrough;

#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
struct Carried(Payload);

impl Microprotocol for PassThrough {
    type Msg = Carried;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "PassThrough";

    fn shape(_: &NoConfig) -> Shape {
        Shape::on_links(Service::FIFO_P2P)
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self)
    }

    fn on_request(&mut self, _ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Send { to, msg } = req {
            out.send(to, Carried(msg));
        }
    }

    fn on_message(&mut self, _ctx: &Ctx, from: Pid, m: Carried, out: &mut Out<Self>) {
        out.up(Indication::Deliver { from, msg: m.0 });
    }
}

/// A failure detector that trusts everybody at start without having suspected anyone.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct EagerTrust;

impl Microprotocol for EagerTrust {
    type Msg = ();
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "EagerTrust";

    fn shape(_: &NoConfig) -> Shape {
        Shape::on_links(Service::FAILURE_DETECTOR)
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self)
    }

    fn on_start(&mut self, ctx: &Ctx, out: &mut Out<Self>) {
        for p in ctx.others() {
            out.up(Indication::Trust(p));
        }
    }
}

fn protocols() -> Protocols {
    let mut p = Protocols::with_builtins();
    p.protocol::<PassThrough>("PassThrough");
    p.protocol::<EagerTrust>("EagerTrust");
    p
}

fn model(stack: &[(&str, &str, &str, &[&str])], opts: &Options) -> CheckModel {
    let protocols = protocols();
    let stack = stack
        .iter()
        .map(|(id, p, below, uses)| LayerSpec::new(id, p, below, uses))
        .collect();
    let target = Target::of_stack(stack, None, &protocols).expect("a checkable stack");
    build_in(&protocols, &target, opts, |_, _| {}).expect("valid model")
}

fn check(stack: &[(&str, &str, &str, &[&str])], opts: &Options) -> Outcome {
    run(model(stack, opts), Exploration::default())
}

/// What reached process `q`'s application from its detector along `path`, in order: each
/// step replayed ([`explain`]), independently of what the states keep of it.
fn indications(m: &CheckModel, path: &Path<State, Action>, q: usize) -> Vec<(Pid, bool)> {
    explain(m, path)
        .into_iter()
        .flat_map(|step| step.events)
        .filter_map(|e| match e {
            Event::At {
                process,
                what: Happening::App { ind, .. },
            } if process as usize == q => match ind {
                Indication::Suspect(p) => Some((p, true)),
                Indication::Trust(p) => Some((p, false)),
                _ => None,
            },
            _ => None,
        })
        .collect()
}

fn opts(requests: u32, network: NetworkKind) -> Options {
    Options {
        requests,
        network,
        ..Options::default()
    }
}

fn names(o: &Outcome) -> Vec<&'static str> {
    o.verdicts.iter().map(|v| v.name).collect()
}

/// The last state of the path found for property `name` (a witness or counterexample).
fn last_state(o: &Outcome, name: &str) -> State {
    o.verdict(name)
        .and_then(|v| v.path.as_ref())
        .unwrap_or_else(|| panic!("no path for {name:?}"))
        .last_state()
        .clone()
}

fn holds(o: &Outcome) -> bool {
    o.all_hold() && o.stopped.is_none()
}

#[test]
fn the_service_of_the_top_layer_decides_the_family() {
    let protocols = protocols();
    let of = |stack: Vec<LayerSpec>| Target::of_stack(stack, None, &protocols).unwrap().family;
    assert_eq!(
        of(vec![LayerSpec::new("l", "Fifo", "net", &[])]),
        Family::P2p { fifo: true }
    );
    assert_eq!(
        of(vec![LayerSpec::new(
            "l",
            "Retransmit(period: 1.0)",
            "net",
            &[]
        )]),
        Family::P2p { fifo: false }
    );
    assert_eq!(
        of(vec![LayerSpec::new(
            "l",
            "Heartbeat(period: 1.0, timeout: 2.0)",
            "net",
            &[]
        )]),
        Family::FailureDetector
    );
}

#[test]
fn fifo_links_hold_on_a_network_that_reorders() {
    // Four messages: p0 sends M0 and then M3 to p1 and p2, so FIFO order has work to do.
    let o = check(
        &[("fifo", "Fifo", "net", &[])],
        &opts(4, NetworkKind::Unordered),
    );
    assert_eq!(
        names(&o),
        [
            "no creation",
            "no duplication",
            "FIFO order",
            "reliable delivery",
            "everything delivered"
        ]
    );
    assert!(holds(&o), "{:?}", o.verdicts);
}

#[test]
fn a_layer_claiming_fifo_without_sequencing_is_caught_where_the_network_reorders() {
    let stack = [("links", "PassThrough", "net", &[][..])];
    let ordered = check(&stack, &opts(4, NetworkKind::Ordered));
    assert!(holds(&ordered), "{:?}", ordered.verdicts);

    let o = check(&stack, &opts(4, NetworkKind::Unordered));
    let v = o.verdict("FIFO order").unwrap();
    assert!(!v.holds);
    for other in ["no creation", "no duplication", "reliable delivery"] {
        assert!(o.verdict(other).unwrap().holds, "{other}");
    }
    // The counterexample's last state: some process got M3 from p0 before M0.
    let last = v.path.as_ref().unwrap().last_state();
    let m = |g| AppMsg::new("M", Content::Int(g)).payload();
    let swapped = last.actor_states.iter().any(|a| {
        let from0: Vec<&Payload> = a
            .received
            .iter()
            .filter(|(f, _)| *f == 0)
            .map(|(_, m)| m)
            .collect();
        from0 == [&m(3), &m(0)]
    });
    assert!(swapped, "{:?}", last.actor_states);
}

#[test]
fn fifo_directly_on_a_lossy_network_is_not_checked_for_reliability_but_stays_safe() {
    let o = check(
        &[("fifo", "Fifo", "net", &[])],
        &opts(2, NetworkKind::Lossy),
    );
    assert_eq!(
        names(&o),
        [
            "no creation",
            "no duplication",
            "FIFO order",
            "everything delivered"
        ]
    );
    assert!(holds(&o), "{:?}", o.verdicts);
}

#[test]
fn retransmission_over_a_lossy_network_neither_creates_nor_duplicates() {
    let o = check(
        &[("rt", "Retransmit(period: 1.0)", "net", &[])],
        &Options {
            timer_budget: 2,
            ..opts(2, NetworkKind::Lossy)
        },
    );
    assert!(holds(&o), "{:?}", o.verdicts);
}

#[test]
fn a_heartbeat_detector_is_complete_and_revokes_false_suspicions() {
    let stack = [("fd", "Heartbeat(period: 1.0, timeout: 2.0)", "net", &[][..])];
    let crashes = Options {
        crashes: 1,
        ..opts(0, NetworkKind::Unordered)
    };
    let crash = check(&stack, &crashes);
    assert_eq!(names(&crash), ["well-formed suspicions", "completeness"]);
    assert!(holds(&crash), "{:?}", crash.verdicts);
    // The witness's last state: a crashed process every live one suspects, by the last
    // indication about it the path's steps told each live one.
    let path = crash
        .verdict("completeness")
        .unwrap()
        .path
        .as_ref()
        .unwrap();
    let last = path.last_state();
    let m = model(&stack, &crashes);
    let dead = (0..3).find(|&p| last.crashed[p]).expect("a crash");
    for q in (0..3).filter(|&q| !last.crashed[q]) {
        let about: Vec<bool> = indications(&m, path, q)
            .iter()
            .filter(|(p, _)| *p as usize == dead)
            .map(|(_, s)| *s)
            .collect();
        assert_eq!(about.last(), Some(&true), "p{q} suspects p{dead}");
    }

    let two = check(
        &stack,
        &Options {
            timer_budget: 2,
            ..opts(0, NetworkKind::Unordered)
        },
    );
    assert_eq!(
        names(&two),
        ["well-formed suspicions", "false suspicion revoked"]
    );
    assert!(holds(&two), "{:?}", two.verdicts);
}

#[test]
fn a_detector_trusting_before_suspecting_is_caught_at_start() {
    let stack = [("fd", "EagerTrust", "net", &[][..])];
    let o = check(&stack, &opts(0, NetworkKind::Unordered));
    let v = o.verdict("well-formed suspicions").unwrap();
    assert!(!v.holds);
    let path = v.path.as_ref().unwrap();
    assert_eq!(path.clone().into_actions().len(), 0);
    // The state keeps only that something was ill-formed; the reason finds what in the
    // path's steps.
    let m = model(&stack, &opts(0, NetworkKind::Unordered));
    assert_eq!(indications(&m, path, 0)[0], (1, false));
    assert_eq!(
        reason(&m, "well-formed suspicions", path).as_deref(),
        Some("p0 trusts p1 without having suspected it (step 0)")
    );
}

#[test]
fn omega_over_heartbeat_agrees_on_a_live_leader_after_a_crash() {
    let o = check(
        &[
            ("fd", "Heartbeat(period: 1.0, timeout: 2.0)", "net", &[]),
            ("omega", "Omega", "net", &["fd"]),
        ],
        &Options {
            crashes: 1,
            ..opts(0, NetworkKind::Unordered)
        },
    );
    assert_eq!(names(&o), ["leader is a process", "common live leader"]);
    assert!(holds(&o), "{:?}", o.verdicts);
    let last = last_state(&o, "common live leader");
    let leaders: Vec<Option<Pid>> = (0..3)
        .filter(|&q| !last.crashed[q])
        .map(|q| last.actor_states[q].leader)
        .collect();
    let l = leaders[0].expect("a leader") as usize;
    assert!(leaders.iter().all(|x| *x == leaders[0]) && !last.crashed[l]);
    assert!(last.crashed.iter().any(|c| *c));
}
