//! Real-network mode on localhost (docs/real-network.md): the same stacks as in simulation,
//! between OS processes over authenticated TCP. Total order is checked from the nodes' JSONL
//! traces; one node is killed with SIGKILL; a cut link heals; a rogue client is refused.

use std::collections::BTreeSet;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use nekosim::node::{tag, Auth, Challenge, Frame, Hello, MAGIC, VERSION};
use serde_json::Value;

fn nekosim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_nekosim"))
}

/// `k` ports free on 127.0.0.1 a moment ago.
fn free_ports(k: usize) -> Vec<u16> {
    let ls: Vec<std::net::TcpListener> = (0..k)
        .map(|_| std::net::TcpListener::bind("127.0.0.1:0").unwrap())
        .collect();
    ls.iter().map(|l| l.local_addr().unwrap().port()).collect()
}

const KEY: &[u8; 32] = b"0123456789abcdef0123456789abcdef";

/// A cluster file of three nodes on free ports in `dir`.
fn cluster(dir: &Path, stack: &str, app: &str, faults: &str, duration: f64) -> (PathBuf, Vec<u16>) {
    std::fs::write(dir.join("cluster.key"), KEY).unwrap();
    let ports = free_ports(3);
    let nodes: Vec<String> = ports
        .iter()
        .enumerate()
        .map(|(i, p)| format!("Node(id: {i}, addr: \"127.0.0.1:{p}\")"))
        .collect();
    let text = format!(
        "Cluster(name: \"test\", nodes: [{}], key_file: \"cluster.key\", stack: [{stack}], app: {app}, faults: [{faults}], duration: {duration:?})",
        nodes.join(", ")
    );
    let file = dir.join("cluster.ron");
    std::fs::write(&file, text).unwrap();
    (file, ports)
}

fn records(trace: &Path) -> Vec<Value> {
    std::fs::read_to_string(trace)
        .unwrap_or_else(|e| panic!("{}: {e}", trace.display()))
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// The ids of the messages a node delivered, in order.
fn delivered(trace: &Path) -> Vec<String> {
    records(trace)
        .iter()
        .filter(|r| r["kind"] == "deliver")
        .map(|r| r["msg"].as_str().unwrap().to_string())
        .collect()
}

fn all_ids(nodes: &[u32], count: u32) -> BTreeSet<String> {
    nodes
        .iter()
        .flat_map(|o| (0..count).map(move |k| format!("{o}:{k}")))
        .collect()
}

fn epoch() -> String {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_millis()
        .to_string()
}

fn node(file: &Path, id: u32, dir: &Path, epoch: &str) -> Child {
    nekosim()
        .arg("node")
        .arg(file)
        .args(["--id", &id.to_string(), "--epoch", epoch, "--trace"])
        .arg(dir.join(format!("p{id}.jsonl")))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn stderr_of(child: Child) -> String {
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// `nekosim cluster FILE --out DIR/out`, which must succeed; the output directory.
fn run_cluster(file: &Path, dir: &Path) -> PathBuf {
    let out = dir.join("out");
    let o = nekosim()
        .arg("cluster")
        .arg(file)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    out
}

/// Consensus-based atomic broadcast with a heartbeat detector (seed fig. 3.10).
const CONSENSUS_ABCAST: &str =
    "Layer(id: \"fd\", protocol: Heartbeat(period: 0.1, timeout: 0.5), below: \"net\"), \
    Layer(id: \"rb\", protocol: ReliableBroadcast, below: \"net\"), \
    Layer(id: \"consensus\", protocol: ChandraToueg, below: \"net\", uses: [\"fd\"]), \
    Layer(id: \"abcast\", protocol: ConsensusAbcast, below: \"rb\", uses: [\"consensus\"])";

const LAMPORT: &str = "Layer(id: \"fifo\", protocol: Fifo, below: \"net\"), Layer(id: \"abcast\", protocol: LamportAbcast, below: \"fifo\")";

#[test]
fn three_nodes_of_lamport_abcast_deliver_every_broadcast_in_one_total_order() {
    let dir = tempfile::tempdir().unwrap();
    let (file, _) = cluster(
        dir.path(),
        LAMPORT,
        "BroadcastLoad(layer: \"abcast\", count: 20, period: 0.01)",
        "",
        20.0,
    );
    let out = run_cluster(&file, dir.path());
    let orders: Vec<Vec<String>> = (0..3)
        .map(|i| delivered(&out.join(format!("p{i}.jsonl"))))
        .collect();
    let ids = all_ids(&[0, 1, 2], 20);
    for (i, order) in orders.iter().enumerate() {
        assert_eq!(order.len(), 60, "node {i} delivered {order:?}");
        assert_eq!(
            order.iter().cloned().collect::<BTreeSet<_>>(),
            ids,
            "node {i}"
        );
        assert_eq!(order, &orders[0], "node {i}'s order differs from node 0's");
    }
    // Each delivery carries what its origin broadcast, and times count from the start.
    for i in 0..3 {
        let rs = records(&out.join(format!("p{i}.jsonl")));
        let mut last = 0.0;
        for r in &rs {
            let t = r["t"].as_f64().unwrap();
            assert!(t >= last && t < 20.0, "node {i}: time {t} after {last}");
            last = t;
            if r["kind"] == "deliver" {
                let (o, k) = r["msg"].as_str().unwrap().split_once(':').unwrap();
                assert_eq!(r["content"], format!("\"p{o}.{k}\""), "{r}");
            }
        }
        assert!(std::fs::read_to_string(out.join(format!("p{i}.log")))
            .unwrap()
            .contains("Request: layer abcast | broadcast"));
    }
    let summary = std::fs::read_to_string(out.join("summary.txt")).unwrap();
    assert!(summary.contains("deliveries: 180,"), "{summary}");
}

#[test]
fn ctrl_c_stops_every_node_and_keeps_what_they_wrote() {
    use std::os::unix::process::CommandExt;
    let dir = tempfile::tempdir().unwrap();
    // Far more than can be done before the interrupt.
    let (file, _) = cluster(
        dir.path(),
        LAMPORT,
        "BroadcastLoad(layer: \"abcast\", count: 100000, period: 0.01)",
        "",
        60.0,
    );
    let out = dir.path().join("out");
    let child = nekosim()
        .arg("cluster")
        .arg(&file)
        .arg("--out")
        .arg(&out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0)
        .spawn()
        .unwrap();
    // Long enough for three nodes to start and deliver while the test binary's other tests
    // (model checks, SPIN's compiles, the Python build) load both cores; still far short of
    // the run's 60 s.
    std::thread::sleep(Duration::from_millis(4000));
    // A terminal's Ctrl-C: SIGINT to the whole process group.
    let ok = Command::new("kill")
        .args(["-s", "INT", "--", &format!("-{}", child.id())])
        .status()
        .unwrap()
        .success();
    assert!(ok);
    let started = std::time::Instant::now();
    let o = child.wait_with_output().unwrap();
    assert!(
        started.elapsed() < Duration::from_secs(10),
        "the nodes took {:?} to stop",
        started.elapsed()
    );
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let orders: Vec<Vec<String>> = (0..3)
        .map(|i| delivered(&out.join(format!("p{i}.jsonl"))))
        .collect();
    let n = orders.iter().map(Vec::len).min().unwrap();
    assert!(n > 10, "only {n} deliveries before the interrupt");
    for (i, o) in orders.iter().enumerate() {
        assert_eq!(o[..n], orders[0][..n], "node {i}'s order differs");
        assert!(
            std::fs::metadata(out.join(format!("p{i}.log")))
                .unwrap()
                .len()
                > 0
        );
    }
    assert!(out.join("summary.txt").exists());
}

#[test]
fn consensus_proposals_decide_one_value_per_instance_everywhere() {
    let dir = tempfile::tempdir().unwrap();
    let stack =
        "Layer(id: \"fd\", protocol: Heartbeat(period: 0.1, timeout: 0.5), below: \"net\"), \
                 Layer(id: \"consensus\", protocol: ChandraToueg, below: \"net\", uses: [\"fd\"])";
    let (file, _) = cluster(
        dir.path(),
        stack,
        "Proposals(layer: \"consensus\", count: 5)",
        "",
        15.0,
    );
    let out = run_cluster(&file, dir.path());
    let mut decided: std::collections::BTreeMap<u64, BTreeSet<String>> = Default::default();
    for i in 0..3 {
        let ds: Vec<Value> = records(&out.join(format!("p{i}.jsonl")))
            .into_iter()
            .filter(|r| r["kind"] == "decide")
            .collect();
        assert_eq!(ds.len(), 5, "node {i} decided {ds:?}");
        for d in ds {
            decided
                .entry(d["instance"].as_u64().unwrap())
                .or_default()
                .insert(d["value"].as_str().unwrap().to_string());
        }
    }
    assert_eq!(decided.len(), 5);
    for (k, values) in decided {
        // Agreement, and validity: the value is one a node proposed.
        assert_eq!(values.len(), 1, "instance {k}: {values:?}");
        let v = values.into_iter().next().unwrap();
        assert!(["\"p0\"", "\"p1\"", "\"p2\""].contains(&v.as_str()), "{v}");
    }
    let summary = std::fs::read_to_string(out.join("summary.txt")).unwrap();
    assert!(
        summary.contains("node 2: 0 deliveries, 5 decisions"),
        "{summary}"
    );
}

#[test]
fn consensus_abcast_survivors_keep_order_when_a_node_is_killed_and_suspect_it() {
    let dir = tempfile::tempdir().unwrap();
    let stack = CONSENSUS_ABCAST;
    let (file, _) = cluster(
        dir.path(),
        stack,
        "BroadcastLoad(layer: \"abcast\", count: 15, period: 0.1)",
        "",
        6.0,
    );
    let e = epoch();
    let nodes: Vec<Child> = (0..3).map(|i| node(&file, i, dir.path(), &e)).collect();
    let mut nodes = nodes.into_iter();
    let (a, b, mut c) = (
        nodes.next().unwrap(),
        nodes.next().unwrap(),
        nodes.next().unwrap(),
    );
    std::thread::sleep(Duration::from_millis(700));
    c.kill().unwrap(); // SIGKILL: no goodbye, no trace.
    c.wait().unwrap();
    stderr_of(a);
    stderr_of(b);
    assert!(
        !dir.path().join("p2.jsonl").exists(),
        "a killed node writes nothing"
    );
    let (o0, o1) = (
        delivered(&dir.path().join("p0.jsonl")),
        delivered(&dir.path().join("p1.jsonl")),
    );
    // One total order: the shorter is a prefix of the longer.
    let n = o0.len().min(o1.len());
    assert_eq!(o0[..n], o1[..n], "the survivors' orders differ");
    // Every broadcast of a survivor is delivered by both.
    let ids = all_ids(&[0, 1], 15);
    for (i, o) in [&o0, &o1].into_iter().enumerate() {
        let got: BTreeSet<String> = o.iter().cloned().collect();
        assert!(
            got.is_superset(&ids),
            "node {i} misses {:?}",
            ids.difference(&got)
        );
        assert_eq!(got.len(), o.len(), "node {i} delivered a message twice");
    }
    for i in 0..2 {
        let suspects = records(&dir.path().join(format!("p{i}.jsonl")))
            .iter()
            .filter(|r| r["kind"] == "suspect" && r["process"] == 2)
            .count();
        assert!(suspects > 0, "node {i} never suspected the killed node 2");
    }
}

#[test]
fn a_scripted_crash_ends_a_node_and_the_others_go_on_in_one_order() {
    let dir = tempfile::tempdir().unwrap();
    let stack = CONSENSUS_ABCAST;
    let (file, _) = cluster(
        dir.path(),
        stack,
        "BroadcastLoad(layer: \"abcast\", count: 10, period: 0.1)",
        "Crash(node: 2, at: 0.5)",
        5.0,
    );
    let out = run_cluster(&file, dir.path());
    // Node 2's trace ends with its crash, about half a second in.
    let r2 = records(&out.join("p2.jsonl"));
    let last = r2.last().unwrap();
    assert_eq!(last["kind"], "crash", "{last}");
    let t = last["t"].as_f64().unwrap();
    assert!((0.5..1.0).contains(&t), "crashed at {t}");
    let (o0, o1) = (
        delivered(&out.join("p0.jsonl")),
        delivered(&out.join("p1.jsonl")),
    );
    let n = o0.len().min(o1.len());
    assert_eq!(o0[..n], o1[..n]);
    let got: BTreeSet<String> = o0.iter().cloned().collect();
    assert!(got.is_superset(&all_ids(&[0, 1], 10)), "{got:?}");
}

#[test]
fn a_cut_link_heals_and_retransmit_and_fifo_recover_the_total_order() {
    let dir = tempfile::tempdir().unwrap();
    let stack = "Layer(id: \"rt\", protocol: Retransmit(period: 0.1), below: \"net\"), \
                 Layer(id: \"fifo\", protocol: Fifo, below: \"rt\"), \
                 Layer(id: \"abcast\", protocol: LamportAbcast, below: \"fifo\")";
    let (file, _) = cluster(
        dir.path(),
        stack,
        "BroadcastLoad(layer: \"abcast\", count: 20, period: 0.05)",
        "Cut(between: (0, 1), from: 0.2, to: 1.2)",
        15.0,
    );
    let out = run_cluster(&file, dir.path());
    let orders: Vec<Vec<String>> = (0..3)
        .map(|i| delivered(&out.join(format!("p{i}.jsonl"))))
        .collect();
    for (i, order) in orders.iter().enumerate() {
        assert_eq!(order.len(), 60, "node {i}");
        assert_eq!(order, &orders[0], "node {i}'s order differs");
    }
    // Node 0's messages to node 1 sent during the cut were lost, so they were sent again.
    let rs = records(&out.join("p0.jsonl"));
    let to_1_during_cut = rs
        .iter()
        .filter(|r| {
            let t = r["t"].as_f64().unwrap();
            r["kind"] == "send" && r["to"] == serde_json::json!([1]) && (0.25..1.15).contains(&t)
        })
        .count();
    assert!(
        to_1_during_cut > 0,
        "node 0 sent nothing to node 1 during the cut"
    );
    let last_delivery = rs
        .iter()
        .filter(|r| r["kind"] == "deliver")
        .map(|r| r["t"].as_f64().unwrap())
        .fold(0.0, f64::max);
    assert!(
        last_delivery > 1.2,
        "deliveries ended at {last_delivery}, before the link healed"
    );
}

fn send_msg(s: &mut TcpStream, bytes: &[u8]) {
    let _ = s.write_all(&(bytes.len() as u32).to_be_bytes());
    let _ = s.write_all(bytes);
}

fn recv_msg(s: &mut TcpStream) -> Option<Vec<u8>> {
    let mut len = [0u8; 4];
    s.read_exact(&mut len).ok()?;
    let mut buf = vec![0; u32::from_be_bytes(len) as usize];
    s.read_exact(&mut buf).ok()?;
    Some(buf)
}

/// Whether the node closed the connection (reads end) within a few seconds.
fn closed(s: &mut TcpStream) -> bool {
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let mut buf = [0u8; 64];
    loop {
        match s.read(&mut buf) {
            Ok(0) => return true,
            Ok(_) => continue,
            Err(e) => return e.kind() == std::io::ErrorKind::ConnectionReset,
        }
    }
}

/// A handshake as `from` to `to` with `key`; the stream, what was sent, and the session key.
fn handshake(port: u16, from: u32, to: u32, key: &[u8]) -> (TcpStream, Vec<Vec<u8>>, Vec<u8>) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    let hello = Hello {
        magic: MAGIC,
        version: VERSION,
        cluster: "test".into(),
        from,
        to,
        nonce: [7; 16],
    };
    let h = postcard::to_allocvec(&hello).unwrap();
    send_msg(&mut s, &h);
    let ch: Challenge = postcard::from_bytes(&recv_msg(&mut s).expect("a challenge")).unwrap();
    let parts = |label: &'static [u8]| -> Vec<Vec<u8>> {
        vec![
            label.to_vec(),
            b"test".to_vec(),
            from.to_le_bytes().to_vec(),
            to.to_le_bytes().to_vec(),
            hello.nonce.to_vec(),
            ch.nonce.to_vec(),
        ]
    };
    let sign = |label: &'static [u8], key: &[u8]| {
        let p = parts(label);
        let refs: Vec<&[u8]> = p.iter().map(Vec::as_slice).collect();
        tag(key, &refs)
    };
    let auth = postcard::to_allocvec(&Auth {
        mac: sign(b"nekosim dial", key),
    })
    .unwrap();
    send_msg(&mut s, &auth);
    (s, vec![h, auth], sign(b"nekosim session", KEY).to_vec())
}

#[test]
fn rogue_clients_are_logged_and_refused_while_deliveries_stay_correct() {
    let dir = tempfile::tempdir().unwrap();
    let (file, ports) = cluster(
        dir.path(),
        LAMPORT,
        "BroadcastLoad(layer: \"abcast\", count: 40, period: 0.05)",
        "",
        20.0,
    );
    let e = epoch();
    let nodes: Vec<Child> = (0..3).map(|i| node(&file, i, dir.path(), &e)).collect();
    std::thread::sleep(Duration::from_millis(300));
    let port = ports[0];

    // Garbage.
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    send_msg(&mut s, b"GET / HTTP/1.1\r\nHost: x\r\n\r\n");
    assert!(closed(&mut s), "garbage: not closed");
    // A frame over the size limit.
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    let _ = s.write_all(&(64u32 << 20).to_be_bytes());
    assert!(closed(&mut s), "oversized: not closed");
    // Another protocol version.
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    let old = Hello {
        magic: MAGIC,
        version: VERSION + 1,
        cluster: "test".into(),
        from: 1,
        to: 0,
        nonce: [1; 16],
    };
    send_msg(&mut s, &postcard::to_allocvec(&old).unwrap());
    assert!(closed(&mut s), "version mismatch: not closed");
    // A node the file does not list.
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    let stranger = Hello {
        magic: MAGIC,
        version: VERSION,
        cluster: "test".into(),
        from: 9,
        to: 0,
        nonce: [1; 16],
    };
    send_msg(&mut s, &postcard::to_allocvec(&stranger).unwrap());
    assert!(closed(&mut s), "unknown peer: not closed");
    // The wrong key.
    let (mut s, _, _) = handshake(port, 2, 0, b"not the key, not the key, not it");
    assert!(closed(&mut s), "wrong key: not closed");
    // With the key (a peer that knows it), a frame for a layer the stack does not have is
    // dropped; replayed on the same link it is refused as out of sequence.
    let (mut s, sent, session) = handshake(port, 2, 0, KEY);
    let frame = Frame {
        seq: 0,
        layer: 99,
        bytes: vec![1, 2, 3],
        tag: tag(
            &session,
            &[&0u64.to_le_bytes(), &99u16.to_le_bytes(), &[1, 2, 3]],
        ),
    };
    let captured = postcard::to_allocvec(&frame).unwrap();
    send_msg(&mut s, &captured);
    send_msg(&mut s, &captured);
    assert!(closed(&mut s), "replayed frame: not closed");
    // The whole captured conversation replayed on a new connection: the node's fresh nonce
    // makes the recorded proof wrong.
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    send_msg(&mut s, &sent[0]);
    let _ = recv_msg(&mut s);
    send_msg(&mut s, &sent[1]);
    send_msg(&mut s, &captured);
    assert!(closed(&mut s), "replayed handshake: not closed");
    // A frame whose tag is wrong.
    let (mut s, _, session) = handshake(port, 1, 0, KEY);
    let forged = Frame {
        seq: 0,
        layer: 0,
        bytes: vec![0],
        tag: tag(&session[..16], &[b"forged"]),
    };
    send_msg(&mut s, &postcard::to_allocvec(&forged).unwrap());
    assert!(closed(&mut s), "forged frame: not closed");

    let mut errs = nodes.into_iter().map(stderr_of);
    let err0 = errs.next().unwrap();
    errs.for_each(drop);
    for says in [
        "does not decode",
        "over the",
        "version mismatch",
        "unknown peer",
        "failed handshake",
        "layer 99",
        "out of sequence (expected 1): a replay",
        "fails authentication",
    ] {
        assert!(err0.contains(says), "node 0's log lacks {says:?}:\n{err0}");
    }
    assert!(
        err0.lines().all(|l| l.starts_with("node 0: ")),
        "one line each:\n{err0}"
    );
    let orders: Vec<Vec<String>> = (0..3)
        .map(|i| delivered(&dir.path().join(format!("p{i}.jsonl"))))
        .collect();
    for (i, order) in orders.iter().enumerate() {
        assert_eq!(order.len(), 120, "node {i}");
        assert_eq!(order, &orders[0], "node {i}'s order differs");
    }
}

#[test]
fn bad_cluster_files_are_refused_at_their_place() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cluster.key"), KEY).unwrap();
    std::fs::write(dir.path().join("short.key"), b"short").unwrap();
    let base = |nodes: &str, key: &str, app: &str| {
        format!(
            "Cluster(\n  name: \"t\",\n  nodes: [{nodes}],\n  key_file: \"{key}\",\n  stack: [{LAMPORT}],\n  app: {app},\n  duration: 5.0,\n)"
        )
    };
    let two = "Node(id: 0, addr: \"127.0.0.1:7100\"), Node(id: 1, addr: \"127.0.0.1:7101\")";
    let load = "BroadcastLoad(layer: \"abcast\", count: 1, period: 0.1)";
    for (text, says) in [
        (
            base(
                "Node(id: 0, addr: \"127.0.0.1:7100\"), Node(id: 0, addr: \"127.0.0.1:7101\")",
                "cluster.key",
                load,
            ),
            "3:57: duplicate node id 0",
        ),
        (
            base(
                "Node(id: 0, addr: \"127.0.0.1:7100\"), Node(id: 1, addr: \"127.0.0.1:7100\")",
                "cluster.key",
                load,
            ),
            "3:66: duplicate address 127.0.0.1:7100",
        ),
        (
            base(two, "missing.key", load),
            "4:13: cannot read the key file",
        ),
        (base(two, "short.key", load), "4:13: the key file"),
        (
            base(
                two,
                "cluster.key",
                "BroadcastLoad(layer: \"nope\", count: 1, period: 0.1)",
            ),
            "6:29: BroadcastLoad: unknown layer \"nope\"",
        ),
        (
            base(two, "cluster.key", "BroadcastLoad(layer: \"fifo\", count: 1, period: 0.1)"),
            "6:29: BroadcastLoad: layer \"fifo\" provides FifoP2p; expected a layer providing Broadcast",
        ),
        (
            base("Node(id: 0, addr: \"localhost\")", "cluster.key", load),
            "3:29: \"localhost\" is not an address",
        ),
    ] {
        let file = dir.path().join("bad.ron");
        std::fs::write(&file, &text).unwrap();
        let o = nekosim().arg("validate").arg(&file).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{text}\n{err}");
        assert!(
            err.starts_with(&format!("{}:{says}", file.display())),
            "expected {says:?}:\n{err}"
        );
    }
}

/// A user's application, registered like the built-ins.
#[derive(Debug)]
struct Hello3 {
    layer: String,
    heard: u32,
    n: u32,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Hello3Config {
    layer: String,
}

impl nekosim::apps::ConfiguredApp for Hello3 {
    type Config = Hello3Config;
    fn configure(
        c: Hello3Config,
        setting: &nekosim::registry::Setting,
        _: u32,
        n: u32,
    ) -> Result<Self, nekosim_protocols::FieldError> {
        if setting.layer(&c.layer).is_none() {
            return Err(nekosim_protocols::FieldError::new(
                "layer",
                "no such layer",
                "a layer of the stack",
            ));
        }
        Ok(Self {
            layer: c.layer,
            heard: 0,
            n,
        })
    }
}

impl nekosim::apps::NodeApp for Hello3 {
    fn start(&mut self, io: &mut nekosim::apps::AppIo) {
        let text = format!("hello from {}", io.me);
        io.broadcast(&self.layer, &text);
    }
    fn indication(
        &mut self,
        _: &mut nekosim::apps::AppIo,
        layer: &str,
        ind: &nekosim_protocols::service::Indication,
    ) {
        if layer == self.layer
            && matches!(ind, nekosim_protocols::service::Indication::BDeliver { .. })
        {
            self.heard += 1;
        }
    }
    fn done(&self) -> bool {
        self.heard == self.n
    }
}

#[test]
fn a_registered_application_drives_the_nodes_like_a_builtin() {
    let dir = tempfile::tempdir().unwrap();
    let (file, _) = cluster(dir.path(), LAMPORT, "Hello3(layer: \"abcast\")", "", 15.0);
    let text = std::fs::read_to_string(&file).unwrap();
    let e: u64 = epoch().parse().unwrap();
    std::thread::scope(|s| {
        for id in 0..3u32 {
            let (text, dir) = (text.clone(), dir.path().to_path_buf());
            s.spawn(move || {
                let mut registry = nekosim::scenario::Registry::with_builtins();
                registry.app::<Hello3>("Hello3");
                let c = nekosim::cluster::Cluster::parse("cluster.ron", &text, &dir, &registry)
                    .unwrap();
                let opts = nekosim::node::NodeOptions {
                    log: None,
                    trace: Some(dir.join(format!("p{id}.jsonl"))),
                    epoch_ms: Some(e),
                };
                let summary = nekosim::node::run(&c, &registry, id, &opts).unwrap();
                assert_eq!(summary.deliveries, 3, "node {id}");
            });
        }
    });
    let orders: Vec<Vec<Value>> = (0..3)
        .map(|i| {
            records(&dir.path().join(format!("p{i}.jsonl")))
                .into_iter()
                .filter(|r| r["kind"] == "deliver")
                .map(|r| r["content"].clone())
                .collect()
        })
        .collect();
    let mut contents: Vec<String> = orders[0]
        .iter()
        .map(|c| c.as_str().unwrap().to_string())
        .collect();
    assert_eq!(orders[1], orders[0]);
    assert_eq!(orders[2], orders[0]);
    contents.sort();
    assert_eq!(
        contents,
        ["\"hello from 0\"", "\"hello from 1\"", "\"hello from 2\""]
    );
    // The built-in's registry does not know it: the binary refuses the file.
    let o = nekosim().arg("validate").arg(&file).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("Hello3"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}
