//! A protocol defined only in this test file is a first-class citizen: registered with one
//! line, stacked from a scenario's RON under a built-in, run by the simulator, rendered in the
//! trace, and its configuration errors are located in the file.

use std::collections::BTreeMap;
use std::fmt;

use nekosim::runner::{self, RunOptions};
use nekosim::scenario::{Overrides, Registry, Source};
use nekosim_protocols::{
    Ctx, FieldError, Indication, LayerIx, Microprotocol, MsgId, Out, Payload, Pid, Request,
    Service, Shape,
};
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// The message: a broadcast message travelling `left` more hops along the ring.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
struct Hop {
    id: MsgId,
    left: u32,
    payload: Payload,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RelayConfig {
    hops: u32,
}

/// A broadcast that reaches only the `hops` successors of the origin on the ring: each of
/// them delivers the message one hop after its predecessor.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct Relay {
    hops: u32,
    count: u64,
}

impl Microprotocol for Relay {
    type Msg = Hop;
    type Timer = ();
    type Config = RelayConfig;
    const NAME: &'static str = "Relay";

    fn shape(_: &RelayConfig) -> Shape {
        Shape::on_links(Service::BROADCAST)
    }

    fn new(c: RelayConfig) -> Result<Self, FieldError> {
        if c.hops == 0 {
            return Err(FieldError::new("hops", "hops is 0", "at least 1"));
        }
        Ok(Self {
            hops: c.hops,
            count: 0,
        })
    }

    fn on_request(&mut self, ctx: &Ctx, _: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Broadcast { msg } = req {
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            let next = (ctx.me + 1) % ctx.n;
            out.send(
                vec![next],
                Hop {
                    id,
                    left: self.hops - 1,
                    payload: msg.clone(),
                },
            );
            out.up(Indication::BDeliver { id, msg });
        }
    }

    fn on_message(&mut self, ctx: &Ctx, _: Pid, m: Hop, out: &mut Out<Self>) {
        if m.left > 0 {
            out.send(
                vec![(ctx.me + 1) % ctx.n],
                Hop {
                    left: m.left - 1,
                    ..m.clone()
                },
            );
        }
        out.up(Indication::BDeliver {
            id: m.id,
            msg: m.payload,
        });
    }

    fn render(m: &Hop, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "HOP({}, {} left, {})", m.id, m.left, m.payload)
    }
}

/// Six robots broadcast through `Relay` stacked on the built-in `Fifo`.
fn scenario(relay: &str) -> String {
    format!(
        r#"Scenario(
    seed: 3,
    until: 60.0,
    world: (size: Infinite),
    network: Reliable(delay: 0.5),
    stack: [
        Layer(id: "fifo", protocol: Fifo, below: "net"),
        Layer(id: "relay", protocol: {relay}, below: "fifo"),
    ],
    robots: [
        Group(count: 6, radius: 1.0, born: Points([(0.0, 0.0), (5.0, 0.0), (10.0, 0.0), (15.0, 0.0), (20.0, 0.0), (25.0, 0.0)]),
              algorithm: BroadcastLoad(layer: "relay", count: 2, mean_interval: 3.0)),
    ],
)"#
    )
}

fn registry() -> Registry {
    let mut r = Registry::with_builtins();
    r.protocol::<Relay>("Relay");
    r
}

fn build(text: &str, registry: &Registry) -> Result<nekosim::scenario::Built, String> {
    Source::parse("relay.ron", text)
        .and_then(|s| s.build(Overrides::default(), registry))
        .map_err(|e| e.to_string())
}

#[test]
fn a_protocol_defined_in_a_test_runs_from_ron_and_reaches_exactly_its_hops() {
    let built = build(&scenario("Relay(hops: 2)"), &registry()).expect("valid");
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.jsonl");
    runner::run(
        built,
        RunOptions {
            trace: Some(trace.clone()),
            ..RunOptions::default()
        },
    )
    .expect("runs");
    let records: Vec<Value> = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let of = |kind: &'static str| records.iter().filter(move |r| r["kind"] == kind);
    // Broadcast k of robot o is message "o:k", requested at t.
    let mut requested = BTreeMap::new();
    let mut count = BTreeMap::new();
    for r in of("request") {
        let o = r["robot"].as_u64().unwrap();
        let k = count.entry(o).or_insert(0);
        requested.insert(format!("{o}:{k}"), (o, r["t"].as_f64().unwrap()));
        *k += 1;
    }
    assert_eq!(requested.len(), 12, "6 robots x 2 broadcasts");
    // Oracle: the origin and its two successors deliver, one network delay (0.5 s) per hop;
    // nobody else does.
    let mut want = BTreeMap::new();
    for (id, (o, t)) in &requested {
        for d in 0..=2u64 {
            want.insert(((o + d) % 6, id.clone()), t + 0.5 * d as f64);
        }
    }
    let mut got = BTreeMap::new();
    for r in of("deliver").filter(|r| r["layer"] == "relay") {
        let key = (
            r["robot"].as_u64().unwrap(),
            r["msg"].as_str().unwrap().to_string(),
        );
        assert!(got.insert(key, r["t"].as_f64().unwrap()).is_none());
    }
    assert_eq!(
        got.keys().collect::<Vec<_>>(),
        want.keys().collect::<Vec<_>>()
    );
    for (k, t) in &want {
        assert!((got[k] - t).abs() < 1e-9, "{k:?} at {} not {t}", got[k]);
    }
    // The trace renders the user's message inside the built-in's header.
    let send = of("send").find(|r| r["layer"] == "fifo").unwrap();
    assert_eq!(send["type"], "FIFO");
    let text = send["msg"].as_str().unwrap();
    assert!(
        text.starts_with("FIFO#0(HOP(") && text.contains("1 left, LOAD("),
        "{text}"
    );
}

#[test]
fn its_configuration_errors_point_into_the_scenario_file() {
    let registry = registry();
    let at = |text: &str, word: &str| {
        let (line, l) = text
            .lines()
            .enumerate()
            .find(|(_, l)| l.contains("\"relay\""))
            .unwrap();
        format!("relay.ron:{}:{}: ", line + 1, l.find(word).unwrap() + 1)
    };
    let text = scenario("Relay(hosp: 2)");
    assert_eq!(
        build(&text, &registry).unwrap_err(),
        format!(
            "{}Relay: unknown field `hosp`; expected one of `hops`",
            at(&text, "hosp")
        )
    );
    let text = scenario("Relay(hops: 0)");
    assert_eq!(
        build(&text, &registry).unwrap_err(),
        format!("{}Relay: hops is 0; expected at least 1", at(&text, "0)"))
    );
    let text = scenario("Relay(hops: \"two\")");
    let e = build(&text, &registry).unwrap_err();
    assert!(e.starts_with(&at(&text, "\"two\"")), "{e}");
    // Without its registry line the protocol is unknown, at its name.
    let text = scenario("Relay(hops: 2)");
    let e = build(&text, &Registry::with_builtins()).unwrap_err();
    assert!(
        e.starts_with(&format!("{}unknown protocol \"Relay\"", at(&text, "Relay"))),
        "{e}"
    );
}

/// `Relay` checked from a scenario file: the model is the file's stack, with this test's
/// registry.
fn check_relay(hops: u32) -> (nekosim::check::Conclusion, String) {
    check_relay_in(hops, &registry())
}

fn check_relay_in(hops: u32, registry: &Registry) -> (nekosim::check::Conclusion, String) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("relay.ron");
    let text = format!(
        r#"Scenario(
    world: (size: Infinite),
    network: RandomDelay(lambda: 1.0),
    stack: [Layer(id: "relay", protocol: Relay(hops: {hops}), below: "net")],
    robots: [Group(count: 3, radius: 1.0)],
)"#
    );
    std::fs::write(&file, text).unwrap();
    let args = nekosim::check::CheckArgs {
        model: file.to_str().unwrap().to_string(),
        threads: 1,
        ..Default::default()
    };
    let mut out = Vec::new();
    let conclusion = nekosim::check::check(&args, registry, &mut out).expect("checks");
    (conclusion, String::from_utf8(out).unwrap())
}

#[test]
fn a_protocol_defined_in_a_test_is_model_checked_from_ron() {
    use nekosim::check::Conclusion;
    // Around the whole ring of 3, Relay is a broadcast: every property of the service holds.
    let (c, out) = check_relay(2);
    assert_eq!(c, Conclusion::Holds, "{out}");
    assert!(
        out.contains(
            "checking \"relay\" (broadcast): 3 processes, 2 requests, 0 crashes, unordered network"
        ),
        "{out}"
    );
    // Two broadcasts by p0 and p1, each relayed twice along the ring: every process delivers
    // both, so the witness needs all 2 requests + 2 x 2 relays delivered.
    assert!(
        out.contains("holds  everything delivered (sometimes): witness in 6 steps"),
        "{out}"
    );
    // One hop short of the ring (the seeded bug), the origin's predecessor never delivers:
    // agreement fails, and the counterexample ends at rest with p2 missing p0's message.
    let (c, out) = check_relay(1);
    assert_eq!(c, Conclusion::Fails, "{out}");
    assert!(
        out.contains("FAILS  agreement (always): counterexample in"),
        "{out}"
    );
    assert!(out.contains("HOP(0:0, 0 left, M 0)"), "{out}");
}

#[test]
fn properties_a_protocol_states_are_checked_alongside_its_services() {
    use nekosim::check::Conclusion;
    let mut r = registry();
    r.protocols
        // Two requests in all: the processes' counters never exceed them.
        .invariant::<Relay>("at most two broadcasts", |rs| {
            rs.iter().map(|r| r.count).sum::<u64>() <= 2
        })
        .reachable::<Relay>("p0 and p1 both broadcast", |rs| {
            rs.len() == 3 && rs[0].count == 1 && rs[1].count == 1
        });
    let (c, out) = check_relay_in(2, &r);
    assert_eq!(c, Conclusion::Holds, "{out}");
    assert!(
        out.contains("holds  at most two broadcasts (always)\n"),
        "{out}"
    );
    // Shortest paths: the two client requests; one request breaks "nobody broadcasts".
    assert!(
        out.contains("holds  p0 and p1 both broadcast (sometimes): witness in 2 steps"),
        "{out}"
    );
    // A stated invariant that does not hold is a counterexample like any other.
    r.protocols
        .invariant::<Relay>("nobody broadcasts", |rs| rs.iter().all(|r| r.count == 0));
    let (c, out) = check_relay_in(2, &r);
    assert_eq!(c, Conclusion::Fails, "{out}");
    assert!(
        out.contains("FAILS  nobody broadcasts (always): counterexample in 1 steps"),
        "{out}"
    );
}
