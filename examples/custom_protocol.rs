//! A custom microprotocol written in Rust and stacked from a scenario file.
//!
//! `RingGossip` is a broadcast layer: a process delivers its own message at once and hands it
//! to its `fanout` successors on the ring of process ids; every process that receives a message
//! for the first time delivers it and passes it on the same way. It is registered under the name
//! "RingGossip", so a scenario stacks it with
//! `Layer(id: "gossip", protocol: Custom(name: "RingGossip", params: {"fanout": 1.0}), below: "net")`.
//! Being a [`Microprotocol`], the very same code could be hosted by a stateright model.
//!
//! Run: `cargo run --example custom_protocol` (prints the Neko log).
//! Test: `cargo test --example custom_protocol`.

use std::collections::BTreeSet;

use nekosim::runner::{self, RunOptions};
use nekosim::scenario::{Overrides, Registry, Source};
use nekosim_protocols::service::{Ctx, Indication, LayerIx, Out, Request};
use nekosim_protocols::stack::Service;
use nekosim_protocols::{Content, Microprotocol, MsgId, Pid, Shape, Wire};

/// Broadcast by relaying along the ring of process ids.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct RingGossip {
    fanout: u32,
    count: u64,
    delivered: BTreeSet<MsgId>,
}

impl RingGossip {
    fn from_params(p: &std::collections::BTreeMap<String, f64>) -> Result<Self, String> {
        let fanout = p.get("fanout").copied().unwrap_or(1.0);
        if !(fanout >= 1.0 && fanout.fract() == 0.0 && fanout <= 1e6) {
            return Err(format!("fanout is {fanout}; expected a whole number >= 1"));
        }
        if let Some(k) = p.keys().find(|k| k.as_str() != "fanout") {
            return Err(format!("unknown parameter {k:?}; expected fanout"));
        }
        Ok(Self {
            fanout: fanout as u32,
            count: 0,
            delivered: BTreeSet::new(),
        })
    }

    /// The next `fanout` processes after `me`, stopping before `origin`.
    fn successors(&self, ctx: &Ctx, origin: Pid) -> Vec<Pid> {
        (1..=self.fanout.min(ctx.n - 1))
            .map(|k| (ctx.me + k) % ctx.n)
            .take_while(|&p| p != origin)
            .collect()
    }

    fn relay(&mut self, ctx: &Ctx, id: MsgId, msg: Wire, out: &mut Out) {
        if !self.delivered.insert(id) {
            return;
        }
        let header = Wire::Custom {
            protocol: "RingGossip".into(),
            tag: "GOSSIP".into(),
            data: Content::List(vec![
                Content::Int(id.origin as i64),
                Content::Int(id.n as i64),
            ]),
            inner: Some(Box::new(msg.clone())),
        };
        out.send(self.successors(ctx, id.origin), header);
        out.up(Indication::BDeliver { id, msg });
    }
}

impl Microprotocol for RingGossip {
    fn name(&self) -> &'static str {
        "RingGossip"
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out) {
        if let Request::Broadcast { msg } = req {
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            self.relay(ctx, id, msg, out);
        }
    }

    fn on_indication(&mut self, ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out) {
        if let Indication::Deliver {
            msg:
                Wire::Custom {
                    data: Content::List(d),
                    inner: Some(inner),
                    ..
                },
            ..
        } = ind
        {
            if let [Content::Int(origin), Content::Int(n)] = d[..] {
                let id = MsgId {
                    origin: origin as Pid,
                    n: n as u64,
                };
                self.relay(ctx, id, *inner, out);
            }
        }
    }
}

const SCENARIO: &str = r#"
Scenario(
    name: "ring_gossip",
    seed: 5,
    until: 100.0,
    world: (size: Infinite),
    network: Reliable(delay: 1.0),
    stack: [
        Layer(id: "gossip", protocol: Custom(name: "RingGossip", params: {"fanout": 1.0}), below: "net"),
    ],
    robots: [
        Group(count: 5, radius: 1.0, born: Points([(0.0, 0.0), (10.0, 0.0), (20.0, 0.0), (30.0, 0.0), (40.0, 0.0)]),
              algorithm: BroadcastLoad(layer: "gossip", count: 3, mean_interval: 2.0)),
    ],
)
"#;

fn registry() -> Registry {
    let mut r = Registry::new();
    r.register_protocol(
        "RingGossip",
        Shape {
            provides: Service::Broadcast,
            needs_below: Service::P2p,
            needs_uses: vec![],
        },
        RingGossip::from_params,
    );
    r
}

/// Runs `scenario` and returns the log and trace text.
fn run(scenario: &str) -> Result<(String, String), String> {
    let source = Source::parse("ring_gossip.ron", scenario).map_err(|e| e.to_string())?;
    let built = source
        .build(Overrides::default(), &registry())
        .map_err(|e| e.to_string())?;
    let dir = std::env::temp_dir().join(format!(
        "nekosim-gossip-{}-{}",
        std::process::id(),
        scenario.len()
    ));
    let (log, trace) = (dir.join("gossip.log"), dir.join("gossip.jsonl"));
    runner::run(
        built,
        RunOptions {
            log: Some(log.clone()),
            trace: Some(trace.clone()),
            ..RunOptions::default()
        },
    )
    .map_err(|e| e.to_string())?;
    let out = (
        std::fs::read_to_string(&log).unwrap(),
        std::fs::read_to_string(&trace).unwrap(),
    );
    let _ = std::fs::remove_dir_all(dir);
    Ok(out)
}

#[cfg_attr(test, allow(dead_code))]
fn main() {
    match run(SCENARIO) {
        Ok((log, _)) => print!("{log}"),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    fn records(trace: &str, kind: &str) -> Vec<serde_json::Value> {
        trace
            .lines()
            .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
            .filter(|v| v["kind"] == kind)
            .collect()
    }

    #[test]
    fn every_robot_delivers_every_message_once_after_its_ring_distance() {
        let (log, trace) = run(SCENARIO).expect("runs");
        let requests = records(&trace, "request");
        assert_eq!(requests.len(), 15, "5 robots x 3 broadcasts");
        // When each message was broadcast: origin:n -> time.
        let mut sent_at = BTreeMap::new();
        let mut count = BTreeMap::new();
        for r in &requests {
            let o = r["robot"].as_u64().unwrap();
            let k = count.entry(o).or_insert(0u64);
            sent_at.insert(format!("{o}:{k}"), r["t"].as_f64().unwrap());
            *k += 1;
        }
        let mut seen = BTreeMap::new();
        for d in records(&trace, "deliver") {
            let (robot, id) = (d["robot"].as_u64().unwrap(), d["msg"].as_str().unwrap());
            assert!(
                seen.insert((robot, id.to_string()), ()).is_none(),
                "robot {robot} delivered {id} twice"
            );
            let origin = d["origin"].as_u64().unwrap();
            // One hop per ring step, 1 s per hop on Reliable(delay: 1.0).
            let hops = (robot + 5 - origin) % 5;
            let latency = d["t"].as_f64().unwrap() - sent_at[id];
            assert!(
                (latency - hops as f64).abs() < 1e-9,
                "{id} reached robot {robot} after {latency} s; expected {hops} s"
            );
        }
        assert_eq!(seen.len(), 5 * 15, "every robot delivers every message");
        assert!(log.contains("GOSSIP"), "the log names the custom header");
    }

    #[test]
    fn unknown_names_and_bad_parameters_are_located_input_errors() {
        let unknown = SCENARIO.replace("Custom(name: \"RingGossip\"", "Custom(name: \"Gossip\"");
        let e = run(&unknown).unwrap_err();
        assert!(
            e.starts_with(
                "ring_gossip.ron:9:39: unknown protocol \"Gossip\"; registered: RingGossip"
            ),
            "{e}"
        );
        let bad = SCENARIO.replace("\"fanout\": 1.0", "\"fanout\": 0.5");
        let e = run(&bad).unwrap_err();
        assert!(
            e.starts_with("ring_gossip.ron:9:39: protocol \"RingGossip\": fanout is 0.5"),
            "{e}"
        );
    }
}
