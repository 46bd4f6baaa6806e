//! Cluster files: the same protocol stack as a scenario's, hosted by OS processes that talk
//! over TCP (Neko's promise that a prototyped algorithm runs unchanged on a real network,
//! seed 2.2 and 3.4). See docs/real-network.md.
//!
//! ```ron
//! Cluster(
//!     name: "lamport3",
//!     nodes: [Node(id: 0, addr: "127.0.0.1:7100"), Node(id: 1, addr: "127.0.0.1:7101")],
//!     key_file: "cluster.key",
//!     stack: [Layer(id: "fifo", protocol: Fifo, below: "net"), ...],
//!     app: BroadcastLoad(layer: "abcast", count: 50, period: 0.02),
//!     faults: [Crash(node: 2, at: 1.5)],
//!     duration: 20.0,
//! )
//! ```

use std::net::SocketAddr;
use std::path::Path;

use nekosim_actors::registry::Setting;
use nekosim_protocols::{LayerSpec, Spec, Stack, Wiring};
use serde::Deserialize;

use crate::scenario::{locate, Pos, Registry, ScenarioError};

/// The least number of bytes a cluster key has.
pub const MIN_KEY_BYTES: usize = 16;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Cluster")]
struct Raw {
    name: String,
    nodes: Vec<RawNode>,
    key_file: String,
    stack: Vec<LayerSpec>,
    app: Spec,
    #[serde(default)]
    faults: Vec<NodeFault>,
    duration: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Node")]
struct RawNode {
    id: u32,
    addr: String,
}

/// A fault injected into a node.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum NodeFault {
    /// The node's process exits `at` seconds after the start.
    Crash { node: u32, at: f64 },
    /// The link between two nodes is cut from `from` to `to` seconds after the start: every
    /// frame either sends on it is lost (both directions), then it heals.
    Cut {
        between: (u32, u32),
        from: f64,
        to: f64,
    },
}

/// A cluster file read and checked.
#[derive(Debug)]
pub struct Cluster {
    pub file: String,
    pub name: String,
    /// Node `i`'s address.
    pub nodes: Vec<SocketAddr>,
    pub key: Vec<u8>,
    pub wiring: Wiring,
    /// A node's fresh stack.
    pub template: Stack,
    /// The application every node runs (built by [`crate::scenario::Registry::apps`]).
    pub app: Spec,
    /// The stack's layers and their services, which the application is checked against.
    pub setting: Setting,
    pub faults: Vec<NodeFault>,
    pub duration: f64,
}

impl Cluster {
    /// Reads and checks the cluster file at `path`; problems are reported at FILE:LINE:COL.
    pub fn load(path: &Path, registry: &Registry) -> Result<Self, ScenarioError> {
        let (file, text) = crate::scenario::read_file(path, "cluster")?;
        Self::parse(
            &file,
            &text,
            path.parent().unwrap_or(Path::new("")),
            registry,
        )
    }

    /// Parses cluster text; `dir` is where the key file's path starts.
    pub fn parse(
        file: &str,
        text: &str,
        dir: &Path,
        registry: &Registry,
    ) -> Result<Self, ScenarioError> {
        let raw: Raw = crate::scenario::read_ron(file, text)?;
        let starts = locate(text);
        let at = |path: &str, message: String| ScenarioError {
            file: file.to_string(),
            pos: starts
                .get(path)
                .copied()
                .or_else(|| starts.get("").copied()),
            message,
        };
        if raw.name.is_empty() {
            return Err(at("name", "the cluster's name is empty".into()));
        }
        if raw.nodes.is_empty() {
            return Err(at("nodes", "no nodes".into()));
        }
        let mut nodes: Vec<Option<SocketAddr>> = vec![None; raw.nodes.len()];
        for (k, n) in raw.nodes.iter().enumerate() {
            if n.id as usize >= raw.nodes.len() {
                return Err(at(
                    &format!("nodes[{k}].id"),
                    format!(
                        "node id {} out of range; the {} nodes have ids 0 to {}",
                        n.id,
                        raw.nodes.len(),
                        raw.nodes.len() - 1
                    ),
                ));
            }
            if nodes[n.id as usize].is_some() {
                return Err(at(
                    &format!("nodes[{k}].id"),
                    format!("duplicate node id {}", n.id),
                ));
            }
            let addr: SocketAddr = n.addr.parse().map_err(|_| {
                at(
                    &format!("nodes[{k}].addr"),
                    format!(
                        "{:?} is not an address; expected IP:PORT such as \"127.0.0.1:7100\"",
                        n.addr
                    ),
                )
            })?;
            if nodes.iter().flatten().any(|a| *a == addr) {
                return Err(at(
                    &format!("nodes[{k}].addr"),
                    format!("duplicate address {addr}"),
                ));
            }
            nodes[n.id as usize] = Some(addr);
        }
        let nodes: Vec<SocketAddr> = nodes.into_iter().flatten().collect();
        let key_path = dir.join(&raw.key_file);
        let key = std::fs::read(&key_path).map_err(|e| {
            at(
                "key_file",
                format!(
                    "cannot read the key file {}: {e} (the path is relative to the cluster file)",
                    key_path.display()
                ),
            )
        })?;
        if key.len() < MIN_KEY_BYTES {
            return Err(at(
                "key_file",
                format!(
                    "the key file {} has {} bytes; expected at least {MIN_KEY_BYTES} random bytes",
                    key_path.display(),
                    key.len()
                ),
            ));
        }
        let (wiring, template) = Wiring::check(&raw.stack, &registry.protocols)
            .map_err(|e| at(&format!("stack[{}]", e.layer), e.to_string()))?;
        let setting = Setting {
            layers: wiring
                .ids
                .iter()
                .cloned()
                .zip(wiring.provides.iter().copied())
                .collect(),
            lcm: Default::default(),
        };
        // Every node's application is built the same way: node 0's stands for all.
        registry
            .apps
            .build(&raw.app, &setting, 0, raw.nodes.len() as u32)
            .map_err(|e| {
                let path = match &e.field {
                    Some(f) if !f.starts_with('[') => format!("app.{f}"),
                    _ => "app".to_string(),
                };
                at(&path, e.message.clone())
            })?;
        for (k, f) in raw.faults.iter().enumerate() {
            match f {
                NodeFault::Crash { node, at: t } => {
                    if *node as usize >= nodes.len() {
                        return Err(at(&format!("faults[{k}].node"), format!("no node {node}")));
                    }
                    if !(t.is_finite() && *t >= 0.0) {
                        return Err(at(
                            &format!("faults[{k}].at"),
                            format!("crash time is {t}; expected a number >= 0"),
                        ));
                    }
                }
                NodeFault::Cut {
                    between: (a, b),
                    from,
                    to,
                } => {
                    for x in [a, b] {
                        if *x as usize >= nodes.len() {
                            return Err(at(
                                &format!("faults[{k}].between"),
                                format!("no node {x}"),
                            ));
                        }
                    }
                    if a == b {
                        return Err(at(
                            &format!("faults[{k}].between"),
                            "a link joins two different nodes".into(),
                        ));
                    }
                    if !(from.is_finite() && to.is_finite() && 0.0 <= *from && from < to) {
                        return Err(at(
                            &format!("faults[{k}].from"),
                            format!("the cut lasts from {from} to {to}; expected 0 <= from < to"),
                        ));
                    }
                }
            }
        }
        if !(raw.duration.is_finite() && raw.duration > 0.0) {
            return Err(at(
                "duration",
                format!(
                    "duration is {}; expected a number of seconds > 0",
                    raw.duration
                ),
            ));
        }
        Ok(Self {
            file: file.to_string(),
            name: raw.name,
            nodes,
            key,
            wiring,
            template,
            app: raw.app,
            setting,
            faults: raw.faults,
            duration: raw.duration,
        })
    }

    /// When node `id` crashes, if a fault says so.
    pub fn crash_of(&self, id: u32) -> Option<f64> {
        self.faults
            .iter()
            .filter_map(|f| match f {
                NodeFault::Crash { node, at } if *node == id => Some(*at),
                _ => None,
            })
            .reduce(f64::min)
    }

    /// The windows `[from, to)` [s since the start] when the link between `a` and `b` is cut.
    pub fn cuts(&self, a: u32, b: u32) -> Vec<(f64, f64)> {
        self.faults
            .iter()
            .filter_map(|f| match f {
                NodeFault::Cut {
                    between: (x, y),
                    from,
                    to,
                } if (*x, *y) == (a, b) || (*x, *y) == (b, a) => Some((*from, *to)),
                _ => None,
            })
            .collect()
    }
}

/// Whether `text` is a cluster file (its first identifier is `Cluster`).
pub fn is_cluster(text: &str) -> bool {
    text.lines()
        .map(|l| l.split("//").next().unwrap_or("").trim())
        .find(|l| !l.is_empty() && !l.starts_with("#!"))
        .is_some_and(|l| l.starts_with("Cluster"))
}

/// The position of `path` in `text`, for callers that report later errors.
pub fn position(text: &str, path: &str) -> Option<Pos> {
    locate(text).get(path).copied()
}

/// Runs every node of `cluster` (read from `file`) as a child process of this program on this
/// machine, waits for them, and writes `out/pI.log`, `out/pI.jsonl` and `out/summary.txt`;
/// returns the exit code (0 when every node ended normally, a crash fault included).
pub fn run_local(cluster: &Cluster, file: &Path, out: &Path) -> Result<u8, String> {
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let exe = std::env::current_exe().map_err(|e| format!("this program: {e}"))?;
    let epoch = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_err(|e| e.to_string())?
        .as_millis()
        .to_string();
    let mut children = Vec::new();
    for id in 0..cluster.nodes.len() {
        let child = std::process::Command::new(&exe)
            .arg("node")
            .arg(file)
            .args(["--id", &id.to_string(), "--epoch", &epoch])
            .arg("--log")
            .arg(out.join(format!("p{id}.log")))
            .arg("--trace")
            .arg(out.join(format!("p{id}.jsonl")))
            .stdout(std::process::Stdio::null())
            .spawn()
            .map_err(|e| format!("cannot start node {id}: {e}"))?;
        children.push((id, child));
    }
    // Ctrl-C reaches the children too (one process group): they stop and write their files;
    // this process waits for them rather than dying first.
    let _ = ctrlc::set_handler(|| {});
    let mut failed = Vec::new();
    for (id, mut child) in children {
        match child.wait() {
            Ok(s) if s.success() => {}
            Ok(s) => failed.push(format!("node {id} ended with {s}")),
            Err(e) => failed.push(format!("node {id}: {e}")),
        }
    }
    let summary = summarize(out, cluster.nodes.len());
    std::fs::write(out.join("summary.txt"), &summary)
        .map_err(|e| format!("{}: {e}", out.join("summary.txt").display()))?;
    print!("{summary}");
    if failed.is_empty() {
        Ok(0)
    } else {
        eprintln!("{}", failed.join("; "));
        Ok(1)
    }
}

/// Deliveries per node, broadcast latency (request to each delivery) and throughput, from the
/// nodes' traces in `dir`.
pub fn summarize(dir: &Path, nodes: usize) -> String {
    let mut requests: std::collections::HashMap<(u64, u64), f64> = Default::default();
    let mut counts: std::collections::HashMap<u64, u64> = Default::default();
    let mut delivers = Vec::new();
    let mut lines = String::new();
    // Link delays: each copy's send and its receive, matched in FIFO order per (from, to,
    // layer, message).
    let mut sends: std::collections::HashMap<
        (u64, u64, String, String),
        std::collections::VecDeque<f64>,
    > = Default::default();
    let mut receives = Vec::new();
    for id in 0..nodes {
        let path = dir.join(format!("p{id}.jsonl"));
        let text = std::fs::read_to_string(&path).unwrap_or_default();
        let mut own = 0;
        let mut decisions = 0;
        for l in text.lines() {
            let Ok(r) = serde_json::from_str::<serde_json::Value>(l) else {
                continue;
            };
            let t = r["t"].as_f64().unwrap_or(0.0);
            match r["kind"].as_str() {
                Some("request") if r["op"] == "broadcast" => {
                    let robot = r["robot"].as_u64().unwrap_or(0);
                    let n = counts.entry(robot).or_insert(0);
                    requests.insert((robot, *n), t);
                    *n += 1;
                }
                Some("send") => {
                    let from = r["robot"].as_u64().unwrap_or(0);
                    for to in r["to"].as_array().into_iter().flatten() {
                        let key = (
                            from,
                            to.as_u64().unwrap_or(0),
                            r["layer"].to_string(),
                            r["msg"].to_string(),
                        );
                        sends.entry(key).or_default().push_back(t);
                    }
                }
                Some("receive") => {
                    let key = (
                        r["from"].as_u64().unwrap_or(0),
                        r["robot"].as_u64().unwrap_or(0),
                        r["layer"].to_string(),
                        r["msg"].to_string(),
                    );
                    receives.push((key, t));
                }
                Some("decide") => decisions += 1,
                Some("deliver") => {
                    own += 1;
                    let id = r["msg"].as_str().unwrap_or("");
                    if let Some((o, n)) = id.split_once(':') {
                        if let (Ok(o), Ok(n)) = (o.parse::<u64>(), n.parse::<u64>()) {
                            delivers.push(((o, n), t));
                        }
                    }
                }
                _ => {}
            }
        }
        lines.push_str(&format!(
            "node {id}: {own} deliveries, {decisions} decisions{}\n",
            if text.is_empty() { " (no trace)" } else { "" }
        ));
    }
    let delays: Vec<f64> = receives
        .into_iter()
        .filter_map(|(k, t)| sends.get_mut(&k)?.pop_front().map(|t0| t - t0))
        .collect();
    if !delays.is_empty() {
        lines.push_str(&format!(
            "link delay (send to receive, other nodes): mean {:.6} s over {} copies\n",
            delays.iter().sum::<f64>() / delays.len() as f64,
            delays.len()
        ));
    }
    let mut samples: Vec<f64> = delivers
        .iter()
        .filter_map(|(k, t)| requests.get(k).map(|t0| t - t0))
        .collect();
    samples.sort_by(f64::total_cmp);
    if let (Some(first), Some(last)) = (
        requests.values().copied().reduce(f64::min),
        delivers.iter().map(|d| d.1).reduce(f64::max),
    ) {
        let n = samples.len().max(1);
        let rank = |q: f64| {
            samples
                .get(((q * n as f64).ceil() as usize).clamp(1, n) - 1)
                .copied()
                .unwrap_or(0.0)
        };
        let mean = samples.iter().sum::<f64>() / n as f64;
        let span = last - first;
        lines.push_str(&format!(
            "deliveries: {}, latency mean: {mean:.4} s, p50: {:.4} s, p99: {:.4} s, throughput: {:.1} deliveries/s\n",
            samples.len(),
            rank(0.5),
            rank(0.99),
            if span > 0.0 { samples.len() as f64 / span } else { 0.0 }
        ));
    }
    lines
}
