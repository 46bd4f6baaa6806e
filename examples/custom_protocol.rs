//! A microprotocol written in Rust by a user, stacked from a scenario file and run by the whole
//! `nekosim` command (docs/extending.md walks through it).
//!
//! `RingGossip` is a broadcast layer: a process delivers its own message at once and hands it
//! to its `fanout` successors on the ring of process ids; every process that receives a message
//! for the first time delivers it and passes it on the same way. Its messages, configuration
//! and service are its own types; the registry line
//! `registry.protocol::<RingGossip>("RingGossip")` lets a scenario stack it with
//! `Layer(id: "gossip", protocol: RingGossip(fanout: 1), below: "net")`.
//!
//! Run: `cargo run --example custom_protocol -- run examples/user/ring_gossip.ron --log out/gossip.log`
//! (any `nekosim` command works: `validate`, `run --rrd`, ...).
//! Test: `cargo test --example custom_protocol`.

use std::collections::BTreeSet;
use std::fmt;
use std::process::ExitCode;

use nekosim::scenario::Registry;
use nekosim_protocols::{
    Ctx, FieldError, Indication, LayerIx, Microprotocol, MsgId, Out, Payload, Pid, Request,
    Service, Shape,
};
use serde::{Deserialize, Serialize};

/// What the ring offers the layers above: a broadcast (so anything needing one can sit on it).
const GOSSIP: Service = Service::new("Gossip", "ring gossip", &[Service::BROADCAST]);

/// The layer's one message: a broadcast message and its id, passed along the ring.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
struct Gossip {
    id: MsgId,
    payload: Payload,
}

/// `RingGossip(fanout: 2)`; `fanout` defaults to 1.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RingConfig {
    #[serde(default = "one")]
    fanout: u32,
}

fn one() -> u32 {
    1
}

/// Broadcast by relaying along the ring of process ids.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct RingGossip {
    fanout: u32,
    count: u64,
    delivered: BTreeSet<MsgId>,
}

impl RingGossip {
    /// The next `fanout` processes after `me`, stopping before `origin`.
    fn successors(&self, ctx: &Ctx, origin: Pid) -> Vec<Pid> {
        (1..=self.fanout.min(ctx.n - 1))
            .map(|k| (ctx.me + k) % ctx.n)
            .take_while(|&p| p != origin)
            .collect()
    }

    fn relay(&mut self, ctx: &Ctx, id: MsgId, payload: Payload, out: &mut Out<Self>) {
        if !self.delivered.insert(id) {
            return;
        }
        let next = self.successors(ctx, id.origin);
        out.send(
            next,
            Gossip {
                id,
                payload: payload.clone(),
            },
        );
        out.up(Indication::BDeliver { id, msg: payload });
    }
}

impl Microprotocol for RingGossip {
    type Msg = Gossip;
    type Timer = ();
    type Config = RingConfig;
    const NAME: &'static str = "RingGossip";

    fn shape(_: &RingConfig) -> Shape {
        Shape::on_links(GOSSIP)
    }

    fn new(c: RingConfig) -> Result<Self, FieldError> {
        if c.fanout == 0 {
            return Err(FieldError::new(
                "fanout",
                "fanout is 0",
                "a whole number >= 1",
            ));
        }
        Ok(Self {
            fanout: c.fanout,
            count: 0,
            delivered: BTreeSet::new(),
        })
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Broadcast { msg } = req {
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            self.relay(ctx, id, msg, out);
        }
    }

    fn on_message(&mut self, ctx: &Ctx, _from: Pid, m: Gossip, out: &mut Out<Self>) {
        self.relay(ctx, m.id, m.payload, out);
    }

    fn render(m: &Gossip, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "GOSSIP({}, {})", m.id, m.payload)
    }
}

/// The built-ins plus RingGossip.
fn registry() -> Registry {
    let mut r = Registry::with_builtins();
    r.protocol::<RingGossip>("RingGossip");
    r
}

#[cfg_attr(test, allow(dead_code))]
fn main() -> ExitCode {
    nekosim::cli::main_with(registry())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;
    use std::path::{Path, PathBuf};

    const SCENARIO: &str = "examples/user/ring_gossip.ron";

    fn root() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
    }

    /// Runs the command line `args` of this example's program; returns the exit code.
    fn cli(args: &[&str]) -> u8 {
        std::env::set_current_dir(root()).unwrap();
        nekosim::cli::run_cli(
            &registry(),
            std::iter::once("custom_protocol").chain(args.iter().copied()),
        )
    }

    fn records(trace: &str, kind: &str) -> Vec<serde_json::Value> {
        trace
            .lines()
            .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
            .filter(|v| v["kind"] == kind)
            .collect()
    }

    /// Runs the scenario file through the program; returns its log and trace.
    fn run(scenario: &Path, dir: &Path) -> (u8, String, String) {
        let (log, trace) = (dir.join("gossip.log"), dir.join("gossip.jsonl"));
        let code = cli(&[
            "run",
            scenario.to_str().unwrap(),
            "--quiet",
            "--log",
            log.to_str().unwrap(),
            "--trace",
            trace.to_str().unwrap(),
        ]);
        let read = |p: &Path| std::fs::read_to_string(p).unwrap_or_default();
        (code, read(&log), read(&trace))
    }

    #[test]
    fn every_robot_delivers_every_message_once_after_its_ring_distance() {
        let dir = tempfile::tempdir().unwrap();
        let (code, log, trace) = run(&root().join(SCENARIO), dir.path());
        assert_eq!(code, 0);
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
        // The trace shows the protocol's own rendering, the application message inside.
        let send = &records(&trace, "send")[0];
        assert_eq!(send["type"], "GOSSIP");
        let text = send["msg"].as_str().unwrap();
        assert!(
            text.starts_with("GOSSIP(") && text.contains("LOAD("),
            "{text}"
        );
    }

    /// The error the program gives for the scenario with `from` replaced by `to`, and where
    /// (line, column) `word` starts in the changed file.
    fn error(registry: &Registry, from: &str, to: &str, word: &str) -> (String, String) {
        use nekosim::scenario::{Overrides, Source};
        let text = std::fs::read_to_string(root().join(SCENARIO)).unwrap();
        assert!(text.contains(from));
        let text = text.replace(from, to);
        let e = Source::parse("ring_gossip.ron", &text)
            .and_then(|s| s.build(Overrides::default(), registry))
            .map(|_| ())
            .unwrap_err()
            .to_string();
        let (line, l) = text
            .lines()
            .enumerate()
            .find(|(_, l)| l.contains(to))
            .unwrap();
        let col = l.find(to).unwrap() + to.find(word).unwrap() + 1;
        (e, format!("ring_gossip.ron:{}:{col}: ", line + 1))
    }

    #[test]
    fn unknown_names_fields_and_bad_values_are_located_input_errors() {
        let r = registry();
        let (e, at) = error(&r, "RingGossip(fanout: 1)", "Gossip(fanout: 1)", "Gossip");
        assert!(
            e.starts_with(&format!(
                "{at}unknown protocol \"Gossip\"; expected one of "
            )) && e.contains("RingGossip"),
            "{e}"
        );
        let (e, at) = error(&r, "RingGossip(fanout: 1)", "RingGossip(fanot: 1)", "fanot");
        assert_eq!(
            e,
            format!("{at}RingGossip: unknown field `fanot`; expected one of `fanout`")
        );
        let (e, at) = error(&r, "RingGossip(fanout: 1)", "RingGossip(fanout: 0)", "0");
        assert_eq!(
            e,
            format!("{at}RingGossip: fanout is 0; expected a whole number >= 1")
        );
        // Without the registry line, the name is unknown (as to the stock `nekosim`).
        let stock = Registry::with_builtins();
        let same = "RingGossip(fanout: 1)";
        let (e, at) = error(&stock, same, same, "RingGossip");
        assert!(
            e.starts_with(&format!("{at}unknown protocol \"RingGossip\"")),
            "{e}"
        );
        // Validating the file with the program succeeds.
        assert_eq!(cli(&["validate", SCENARIO]), 0);
    }
}
