//! One node of a cluster (docs/real-network.md): the cluster file's stack, the very code the
//! simulator and the model checker run, hosted on the actix runtime: each layer an actor, a
//! loop that routes their effects in the order `Stack::step_local` gives (as the simulator's
//! scheduler routes them in virtual time), the real clock for timers, and TCP to the peers.
//!
//! Every peer link is authenticated: the dialing node sends `Hello` (cluster name, both ids, a
//! fresh nonce); the listening node answers with its own nonce and an HMAC-SHA256 over the
//! transcript under the cluster key; the dialer answers with its HMAC. Both then derive a
//! session key from the transcript, and every frame (a sequence number, the layer and the
//! message's wire encoding) carries an HMAC under it, with sequence numbers strictly
//! increasing, so a captured frame replayed on this or another connection is refused. Frames
//! are length-prefixed and limited to [`MAX_FRAME`] bytes. A connection that breaks any rule
//! is logged in one line and closed; the protocol state is untouched.

use std::collections::HashMap;
use std::io;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use actix::{Actor, Addr, Handler};
use hmac::{Hmac, Mac};
use nekosim_actors::world::geometry::Point;
use nekosim_actors::world::motion::{Kinematics, Pose};
use nekosim_actors::world::observation::{Observation, Record};
use nekosim_protocols::payload::{install, Payload};
use nekosim_protocols::service::{Ctx, Indication, Input, Request, APP, NET};
use nekosim_protocols::stack::Routed;
use serde::{Deserialize, Serialize};
use sha2::Sha256;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::mpsc;

use crate::apps::{AppAction, AppIo, NodeApp};
use crate::cluster::Cluster;
use crate::log::NekoLog;
use crate::output::AtomicFile;
use crate::scenario::Registry;
use crate::trace::to_line;

type HmacSha256 = Hmac<Sha256>;

/// The wire protocol's version; a peer of another version is refused.
pub const VERSION: u16 = 1;
/// The largest frame accepted [bytes].
pub const MAX_FRAME: u32 = 1 << 20;
/// The first bytes of a `Hello`.
pub const MAGIC: [u8; 4] = *b"NEKO";
/// How long a handshake may take.
const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(5);
/// How long a node goes on after its application is done, so its peers get its last
/// messages (acknowledgements they may still wait for).
const LINGER: Duration = Duration::from_millis(1500);

/// The dialer's first message.
#[derive(Debug, Serialize, Deserialize)]
pub struct Hello {
    pub magic: [u8; 4],
    pub version: u16,
    pub cluster: String,
    pub from: u32,
    pub to: u32,
    pub nonce: [u8; 16],
}

/// The listener's answer: its nonce and its proof of the key.
#[derive(Debug, Serialize, Deserialize)]
pub struct Challenge {
    pub nonce: [u8; 16],
    pub mac: [u8; 32],
}

/// The dialer's proof of the key.
#[derive(Debug, Serialize, Deserialize)]
pub struct Auth {
    pub mac: [u8; 32],
}

/// A message on an authenticated link: `tag` is the HMAC of `(seq, layer, bytes)` under the
/// session key.
#[derive(Debug, Serialize, Deserialize)]
pub struct Frame {
    pub seq: u64,
    pub layer: u16,
    pub bytes: Vec<u8>,
    pub tag: [u8; 32],
}

/// HMAC-SHA256 of `parts`, each prefixed by its length.
fn mac(key: &[u8], parts: &[&[u8]]) -> HmacSha256 {
    let mut m = HmacSha256::new_from_slice(key).expect("HMAC takes keys of any length");
    for p in parts {
        m.update(&(p.len() as u64).to_le_bytes());
        m.update(p);
    }
    m
}

/// HMAC-SHA256 of `parts` under `key`, each part prefixed by its length: how handshakes and
/// frames are signed.
pub fn tag(key: &[u8], parts: &[&[u8]]) -> [u8; 32] {
    mac(key, parts).finalize().into_bytes().into()
}

/// Constant-time check of `expected` against the HMAC of `parts`.
fn verify(key: &[u8], parts: &[&[u8]], expected: &[u8]) -> bool {
    mac(key, parts).verify_slice(expected).is_ok()
}

/// The handshake transcript: what both sides sign.
struct Transcript<'a> {
    cluster: &'a str,
    from: [u8; 4],
    to: [u8; 4],
    nonce_c: [u8; 16],
    nonce_s: [u8; 16],
}

impl Transcript<'_> {
    fn parts<'p>(&'p self, label: &'p [u8]) -> [&'p [u8]; 6] {
        [
            label,
            self.cluster.as_bytes(),
            &self.from,
            &self.to,
            &self.nonce_c,
            &self.nonce_s,
        ]
    }
}

fn bad(message: impl Into<String>) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, message.into())
}

async fn read_msg(s: &mut TcpStream) -> io::Result<Vec<u8>> {
    let len = s.read_u32().await?;
    if len > MAX_FRAME {
        return Err(bad(format!(
            "a frame of {len} bytes, over the {MAX_FRAME}-byte limit"
        )));
    }
    let mut buf = vec![0; len as usize];
    s.read_exact(&mut buf).await?;
    Ok(buf)
}

async fn write_msg(s: &mut TcpStream, bytes: &[u8]) -> io::Result<()> {
    s.write_u32(bytes.len() as u32).await?;
    s.write_all(bytes).await
}

fn decode<T: for<'de> Deserialize<'de>>(bytes: &[u8], what: &str) -> io::Result<T> {
    nekosim_protocols::payload::decode_bytes(bytes)
        .map_err(|e| bad(format!("a {what} that does not decode ({e})")))
}

fn nonce() -> [u8; 16] {
    rand::random()
}

/// The dialer's side: proves the key, checks the listener's proof; the session key.
async fn dial_handshake(
    s: &mut TcpStream,
    key: &[u8],
    cluster: &str,
    me: u32,
    peer: u32,
) -> io::Result<Vec<u8>> {
    let hello = Hello {
        magic: MAGIC,
        version: VERSION,
        cluster: cluster.to_string(),
        from: me,
        to: peer,
        nonce: nonce(),
    };
    write_msg(
        s,
        &postcard::to_allocvec(&hello).map_err(|e| bad(e.to_string()))?,
    )
    .await?;
    let ch: Challenge = decode(&read_msg(s).await?, "challenge")?;
    let t = Transcript {
        cluster,
        from: me.to_le_bytes(),
        to: peer.to_le_bytes(),
        nonce_c: hello.nonce,
        nonce_s: ch.nonce,
    };
    if !verify(key, &t.parts(b"nekosim accept"), &ch.mac) {
        return Err(bad("the peer does not know the cluster key"));
    }
    let auth = Auth {
        mac: tag(key, &t.parts(b"nekosim dial")),
    };
    write_msg(
        s,
        &postcard::to_allocvec(&auth).map_err(|e| bad(e.to_string()))?,
    )
    .await?;
    Ok(tag(key, &t.parts(b"nekosim session")).to_vec())
}

/// The listener's side: the peer's id and the session key, or why the peer is refused.
async fn accept_handshake(
    s: &mut TcpStream,
    key: &[u8],
    cluster: &str,
    me: u32,
    n: u32,
) -> io::Result<(u32, Vec<u8>)> {
    let hello: Hello = decode(&read_msg(s).await?, "hello")?;
    if hello.magic != MAGIC {
        return Err(bad("not a nekosim peer"));
    }
    if hello.version != VERSION {
        return Err(bad(format!(
            "version mismatch: the peer speaks version {}, this node {VERSION}",
            hello.version
        )));
    }
    if hello.cluster != cluster || hello.to != me || hello.from >= n || hello.from == me {
        return Err(bad(format!(
            "unknown peer: node {} of cluster {:?} (to node {})",
            hello.from, hello.cluster, hello.to
        )));
    }
    let t = Transcript {
        cluster,
        from: hello.from.to_le_bytes(),
        to: me.to_le_bytes(),
        nonce_c: hello.nonce,
        nonce_s: nonce(),
    };
    let ch = Challenge {
        nonce: t.nonce_s,
        mac: tag(key, &t.parts(b"nekosim accept")),
    };
    write_msg(
        s,
        &postcard::to_allocvec(&ch).map_err(|e| bad(e.to_string()))?,
    )
    .await?;
    let auth: Auth = decode(&read_msg(s).await?, "authentication")?;
    if !verify(key, &t.parts(b"nekosim dial"), &auth.mac) {
        return Err(bad(format!(
            "failed handshake: node {} does not know the cluster key",
            hello.from
        )));
    }
    Ok((hello.from, tag(key, &t.parts(b"nekosim session")).to_vec()))
}

/// One layer of the node's stack, hosted as an actor: a protocol instance and its handler.
struct LayerActor {
    layer: nekosim_protocols::Layer,
    ix: u16,
    wiring: nekosim_protocols::Wiring,
    ctx: Ctx,
}

impl Actor for LayerActor {
    type Context = actix::Context<Self>;
}

/// An input for a layer; the answer is where its effects go.
#[derive(actix::Message)]
#[rtype(result = "Result<Vec<Routed>, String>")]
struct Step(Input);

impl Handler<Step> for LayerActor {
    type Result = Result<Vec<Routed>, String>;

    fn handle(&mut self, Step(input): Step, _: &mut Self::Context) -> Self::Result {
        nekosim_protocols::stack::step_layer(
            &mut self.layer,
            &self.wiring,
            &self.ctx,
            self.ix,
            input,
        )
        .map_err(|e| e.to_string())
    }
}

/// Runs `input` at layer `ix`'s actor; where its effects go, or why the input was refused.
async fn step(stack: &[Addr<LayerActor>], ix: u16, input: Input) -> Result<Vec<Routed>, String> {
    match stack.get(ix as usize) {
        Some(a) => a.send(Step(input)).await.map_err(|e| e.to_string())?,
        None => Err(format!("no layer {ix}")),
    }
}

/// Whether now falls in one of `cuts` (seconds since `start`).
fn in_cut(cuts: &[(f64, f64)], start: SystemTime) -> bool {
    if cuts.is_empty() {
        return false;
    }
    let t = SystemTime::now()
        .duration_since(start)
        .unwrap_or_default()
        .as_secs_f64();
    cuts.iter().any(|(a, b)| *a <= t && t < *b)
}

/// What the node's loop reacts to.
#[derive(Debug)]
enum Event {
    Frame {
        from: u32,
        layer: u16,
        bytes: Vec<u8>,
    },
    Timer {
        layer: u16,
        timer: Payload,
        gen: u64,
    },
    App(u64),
    Stop,
    Crash,
}

/// Where a node writes and when its clock starts.
#[derive(Debug, Default)]
pub struct NodeOptions {
    pub log: Option<PathBuf>,
    pub trace: Option<PathBuf>,
    /// The cluster's start, in milliseconds since the Unix epoch (trace times count from it);
    /// default: this node's start.
    pub epoch_ms: Option<u64>,
}

/// What a node did.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeSummary {
    pub deliveries: u64,
    pub decisions: u64,
    pub sent: u64,
    pub crashed: bool,
}

/// Why a node could not run.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    #[error("node {id}: cannot listen on {addr}: {error}")]
    Listen {
        id: u32,
        addr: SocketAddr,
        error: io::Error,
    },
    #[error("{path}: cannot write: {error}")]
    Output { path: String, error: io::Error },
    #[error("no node {0} in the cluster")]
    NoNode(u32),
    #[error("the application: {0}")]
    App(String),
}

/// The node's outputs: the Neko log and the JSONL trace, with times since the start.
struct Out {
    start: SystemTime,
    seq: u64,
    log: Option<(AtomicFile, NekoLog)>,
    trace: Option<AtomicFile>,
}

impl Out {
    fn record(&mut self, obs: Observation) {
        let t = SystemTime::now()
            .duration_since(self.start)
            .unwrap_or_default()
            .as_secs_f64();
        self.seq += 1;
        let r = Record {
            t,
            seq: self.seq,
            obs,
        };
        if let Some((f, neko)) = self.log.as_mut() {
            if let Some(line) = neko.line(&r) {
                f.line(&line);
            }
        }
        if let Some(f) = self.trace.as_mut() {
            f.line(&to_line(&r));
        }
    }
}

/// Runs node `id` of `cluster` until its application is done (plus a moment for its peers),
/// the cluster's duration, or its crash fault.
pub fn run(
    cluster: &Cluster,
    registry: &Registry,
    id: u32,
    opts: &NodeOptions,
) -> Result<NodeSummary, NodeError> {
    let n = cluster.nodes.len() as u32;
    let app = registry
        .apps
        .build(&cluster.app, &cluster.setting, id, n)
        .map_err(|e| NodeError::App(e.message))?;
    let addr = *cluster
        .nodes
        .get(id as usize)
        .ok_or(NodeError::NoNode(id))?;
    let create = |p: &Option<PathBuf>| {
        p.as_ref()
            .map(|p| {
                AtomicFile::create(p).map_err(|error| NodeError::Output {
                    path: p.display().to_string(),
                    error,
                })
            })
            .transpose()
    };
    let start = opts
        .epoch_ms
        .map_or_else(SystemTime::now, |ms| UNIX_EPOCH + Duration::from_millis(ms));
    let mut out = Out {
        start,
        seq: 0,
        log: create(&opts.log)?.map(|f| (f, NekoLog::new())),
        trace: create(&opts.trace)?,
    };
    let summary = actix::System::new().block_on(serve(cluster, app, id, n, addr, &mut out))?;
    let Out { log, trace, .. } = out;
    for (file, path) in [(log.map(|l| l.0), &opts.log), (trace, &opts.trace)] {
        if let (Some(f), Some(p)) = (file, path) {
            f.commit().map_err(|error| NodeError::Output {
                path: p.display().to_string(),
                error,
            })?;
        }
    }
    Ok(summary)
}

async fn serve(
    cluster: &Cluster,
    mut app: Box<dyn NodeApp>,
    me: u32,
    n: u32,
    addr: SocketAddr,
    out: &mut Out,
) -> Result<NodeSummary, NodeError> {
    let _codecs = install(&cluster.wiring.codecs);
    let listener = TcpListener::bind(addr)
        .await
        .map_err(|error| NodeError::Listen {
            id: me,
            addr,
            error,
        })?;
    let (tx, mut rx) = mpsc::unbounded_channel::<Event>();
    let key = cluster.key.clone();
    let name = cluster.name.clone();

    // Incoming links: authenticated frames become events.
    {
        let (tx, key, name) = (tx.clone(), key.clone(), name.clone());
        let all_cuts: Vec<Vec<(f64, f64)>> = (0..n).map(|p| cluster.cuts(me, p)).collect();
        let clock = out.start;
        actix::spawn(async move {
            loop {
                let Ok((mut s, from_addr)) = listener.accept().await else {
                    continue;
                };
                let (tx, key, name) = (tx.clone(), key.clone(), name.clone());
                let all_cuts = all_cuts.clone();
                actix::spawn(async move {
                    let cuts_of = |p: u32| all_cuts.get(p as usize).cloned().unwrap_or_default();
                    let r = async {
                        let (peer, session) = tokio::time::timeout(
                            HANDSHAKE_TIMEOUT,
                            accept_handshake(&mut s, &key, &name, me, n),
                        )
                        .await
                        .map_err(|_| bad("handshake timed out"))??;
                        let mut next = 0u64;
                        loop {
                            let f: Frame = decode(&read_msg(&mut s).await?, "frame")?;
                            let ok = verify(
                                &session,
                                &[&f.seq.to_le_bytes(), &f.layer.to_le_bytes(), &f.bytes],
                                &f.tag,
                            );
                            if !ok {
                                return Err(bad(format!("node {peer}: a frame that fails authentication")));
                            }
                            if f.seq != next {
                                return Err(bad(format!(
                                    "node {peer}: frame {} out of sequence (expected {next}): a replay",
                                    f.seq
                                )));
                            }
                            next += 1;
                            if in_cut(&cuts_of(peer), clock) {
                                continue;
                            }
                            if tx
                                .send(Event::Frame {
                                    from: peer,
                                    layer: f.layer,
                                    bytes: f.bytes,
                                })
                                .is_err()
                            {
                                return Ok(());
                            }
                        }
                    }
                    .await;
                    if let Err(e) = r {
                        if e.kind() != io::ErrorKind::UnexpectedEof {
                            eprintln!("node {me}: connection from {from_addr}: {e}; closed");
                        }
                    }
                });
            }
        });
    }

    // Outgoing links: one writer per peer, reconnecting with backoff.
    let mut links: HashMap<u32, mpsc::UnboundedSender<(u16, Vec<u8>)>> = HashMap::new();
    let mut writers = Vec::new();
    for (peer, &peer_addr) in cluster.nodes.iter().enumerate() {
        let peer = peer as u32;
        if peer == me {
            continue;
        }
        let (ltx, mut lrx) = mpsc::unbounded_channel::<(u16, Vec<u8>)>();
        links.insert(peer, ltx);
        let (key, name) = (key.clone(), name.clone());
        let cuts = cluster.cuts(me, peer);
        let clock = out.start;
        writers.push(actix::spawn(async move {
            let mut pending: Option<(u16, Vec<u8>)> = None;
            let mut backoff = Duration::from_millis(20);
            loop {
                let connected = async {
                    let mut s = TcpStream::connect(peer_addr).await?;
                    s.set_nodelay(true)?;
                    let session = tokio::time::timeout(
                        HANDSHAKE_TIMEOUT,
                        dial_handshake(&mut s, &key, &name, me, peer),
                    )
                    .await
                    .map_err(|_| bad("handshake timed out"))??;
                    Ok::<_, io::Error>((s, session))
                }
                .await;
                let (mut s, session) = match connected {
                    Ok(c) => c,
                    Err(e) => {
                        if e.kind() == io::ErrorKind::InvalidData {
                            eprintln!("node {me}: link to node {peer}: {e}");
                        }
                        if pending.is_none() && lrx.is_closed() && lrx.is_empty() {
                            return;
                        }
                        tokio::time::sleep(backoff).await;
                        backoff = (backoff * 2).min(Duration::from_secs(1));
                        continue;
                    }
                };
                backoff = Duration::from_millis(20);
                let mut seq = 0u64;
                loop {
                    let next = match pending.take() {
                        Some(m) => Some(m),
                        None => lrx.recv().await,
                    };
                    let Some((layer, bytes)) = next else {
                        let _ = s.shutdown().await;
                        return;
                    };
                    if in_cut(&cuts, clock) {
                        // The link is cut: the frame is lost.
                        continue;
                    }
                    let frame = Frame {
                        seq,
                        layer,
                        tag: tag(
                            &session,
                            &[&seq.to_le_bytes(), &layer.to_le_bytes(), &bytes],
                        ),
                        bytes,
                    };
                    let buf = postcard::to_allocvec(&frame).expect("frames encode");
                    if write_msg(&mut s, &buf).await.is_err() {
                        // Sent again on the next connection.
                        pending = Some((frame.layer, frame.bytes));
                        break;
                    }
                    seq += 1;
                }
            }
        }));
    }

    // The application's schedule, the duration and the crash fault.
    let started = Instant::now();
    let elapsed0 = SystemTime::now()
        .duration_since(out.start)
        .unwrap_or_default()
        .as_secs_f64();
    let at = move |t: f64| Duration::from_secs_f64((t - elapsed0).max(0.0));
    let after = |d: Duration, ev: Event, tx: &mpsc::UnboundedSender<Event>| {
        let tx = tx.clone();
        actix::spawn(async move {
            tokio::time::sleep(d).await;
            let _ = tx.send(ev);
        });
    };
    after(at(cluster.duration), Event::Stop, &tx);
    {
        // Ctrl-C (or SIGTERM): stop, and write the files of the run so far.
        let tx = tx.clone();
        actix::spawn(async move {
            let mut term =
                tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()).ok();
            tokio::select! {
                _ = tokio::signal::ctrl_c() => {}
                _ = async { match term.as_mut() { Some(t) => { t.recv().await; } None => std::future::pending::<()>().await } } => {}
            }
            let _ = tx.send(Event::Stop);
        });
    }
    if let Some(t) = cluster.crash_of(me) {
        after(at(t), Event::Crash, &tx);
    }

    // The stack: each layer an actor; this loop routes their effects, in the FIFO order of
    // `Stack::step_local`, as the simulator's scheduler does.
    let wiring = &cluster.wiring;
    let ctx = Ctx { me, n };
    let stack: Vec<Addr<LayerActor>> = cluster
        .template
        .clone()
        .layers
        .into_iter()
        .enumerate()
        .map(|(ix, layer)| {
            LayerActor {
                layer,
                ix: ix as u16,
                wiring: wiring.clone(),
                ctx,
            }
            .start()
        })
        .collect();
    let mut timers: HashMap<(u16, Payload), u64> = HashMap::new();
    let mut generation = 0u64;
    let mut summary = NodeSummary {
        deliveries: 0,
        decisions: 0,
        sent: 0,
        crashed: false,
    };
    let mut done = false;
    let now = |out: &Out| {
        SystemTime::now()
            .duration_since(out.start)
            .unwrap_or_default()
            .as_secs_f64()
    };
    let mut io = AppIo::new(me, n, now(out));
    app.start(&mut io);
    let mut actions = io.take();
    let name_of = |ix: u16| nekosim_actors::layer::layer_name(wiring, ix);
    // Every layer starts, bottom-up in stack order, as `Stack::start_all` does.
    let mut todo = Vec::new();
    for l in 0..stack.len() as u16 {
        let hop = Routed::Layer {
            to: l,
            input: Input::Start,
        };
        todo.extend(local(&stack, wiring, &ctx, vec![hop], out).await);
    }
    loop {
        // Route what the stack produced.
        for r in std::mem::take(&mut todo) {
            match r {
                Routed::Net { layer, to, msg } => {
                    out.record(Observation::Send {
                        robot: me,
                        to: to.clone(),
                        layer: name_of(layer),
                        msg: msg.clone(),
                        arrive: Vec::new(),
                    });
                    summary.sent += to.len() as u64;
                    for p in to {
                        if p == me {
                            let _ = tx.send(Event::Frame {
                                from: me,
                                layer,
                                bytes: msg.bytes().to_vec(),
                            });
                        } else if let Some(l) = links.get(&p) {
                            let _ = l.send((layer, msg.bytes().to_vec()));
                        }
                    }
                }
                Routed::App { layer, ind } => {
                    let name = name_of(layer);
                    let mut io = AppIo::new(me, n, now(out));
                    app.indication(&mut io, &name, &ind);
                    actions.extend(io.take());
                    match ind {
                        Indication::BDeliver { id, msg } => {
                            summary.deliveries += 1;
                            out.record(Observation::Deliver {
                                robot: me,
                                layer: name,
                                id,
                                msg,
                            });
                        }
                        Indication::Decide { k, value } => {
                            summary.decisions += 1;
                            out.record(Observation::Decide {
                                robot: me,
                                layer: name,
                                k,
                                value,
                            });
                        }
                        Indication::Suspect(p) => out.record(Observation::Suspect {
                            robot: me,
                            layer: name,
                            process: p,
                        }),
                        Indication::Trust(p) => out.record(Observation::Trust {
                            robot: me,
                            layer: name,
                            process: p,
                        }),
                        Indication::Leader(p) => out.record(Observation::Leader {
                            robot: me,
                            layer: name,
                            process: p,
                        }),
                        Indication::Deliver { .. } | Indication::Custom(_) => {}
                    }
                }
                Routed::SetTimer {
                    layer,
                    timer,
                    after: delay,
                } => {
                    generation += 1;
                    timers.insert((layer, timer.clone()), generation);
                    after(
                        Duration::from_secs_f64(delay.get().max(0.0)),
                        Event::Timer {
                            layer,
                            timer,
                            gen: generation,
                        },
                        &tx,
                    );
                }
                Routed::CancelTimer { layer, timer } => {
                    timers.remove(&(layer, timer));
                }
                Routed::Layer { .. } => {}
            }
        }
        // What the application asked for.
        for a in std::mem::take(&mut actions) {
            match a {
                AppAction::After { seconds, tag } => after(
                    Duration::from_secs_f64(seconds.max(0.0)),
                    Event::App(tag),
                    &tx,
                ),
                AppAction::Request { layer, op, req } => {
                    let Some(ix) = wiring.index(&layer) else {
                        eprintln!("node {me}: the application asked layer {layer:?}, which the stack does not have");
                        continue;
                    };
                    let msg = match &req {
                        Request::Broadcast { msg } => msg.clone(),
                        Request::Propose { value, .. } => value.clone(),
                        Request::Send { msg, .. } => msg.clone(),
                        Request::Custom(p) => p.clone(),
                    };
                    out.record(Observation::Request {
                        robot: me,
                        layer: layer.clone(),
                        op: op.into(),
                        msg,
                    });
                    let hop = Routed::Layer {
                        to: ix,
                        input: Input::Request { from: APP, req },
                    };
                    todo.extend(local(&stack, wiring, &ctx, vec![hop], out).await);
                }
            }
        }
        if !todo.is_empty() {
            continue;
        }
        if app.done() && !done {
            done = true;
            after(LINGER, Event::Stop, &tx);
        }
        let Some(ev) = rx.recv().await else { break };
        match ev {
            Event::Frame { from, layer, bytes } => {
                if layer as usize >= stack.len() {
                    eprintln!("node {me}: a frame from node {from} for layer {layer}, which the stack does not have; dropped");
                    continue;
                }
                let msg = Payload::from_parts(layer, &bytes);
                out.record(Observation::Receive {
                    robot: me,
                    from,
                    layer: name_of(layer),
                    msg: msg.clone(),
                });
                let input = Input::Indication {
                    from: NET,
                    ind: Indication::Deliver { from, msg },
                };
                // A message that does not decode as its layer's changes nothing.
                match step(&stack, layer, input).await {
                    Ok(routed) => todo = local(&stack, wiring, &ctx, routed, out).await,
                    Err(e) => eprintln!(
                        "node {me}: a message from node {from} that does not decode ({e}); dropped"
                    ),
                }
            }
            Event::Timer { layer, timer, gen } => {
                if timers.get(&(layer, timer.clone())) == Some(&gen) {
                    timers.remove(&(layer, timer.clone()));
                    let hop = Routed::Layer {
                        to: layer,
                        input: Input::Timer(timer),
                    };
                    todo = local(&stack, wiring, &ctx, vec![hop], out).await;
                }
            }
            Event::App(tag) => {
                let mut io = AppIo::new(me, n, now(out));
                app.timer(&mut io, tag);
                actions = io.take();
            }
            Event::Stop => break,
            Event::Crash => {
                out.record(Observation::Crash {
                    robot: me,
                    state: Kinematics::at_rest(Pose {
                        pos: Point::origin(),
                        angle: 0.0,
                    }),
                });
                summary.crashed = true;
                break;
            }
        }
    }
    // Let the writers send what they hold, briefly.
    drop(links);
    if !summary.crashed {
        for w in writers {
            let _ = tokio::time::timeout(Duration::from_secs(2), w).await;
        }
    }
    let _ = started;
    Ok(summary)
}

/// Runs the hops inside the process that `routed` starts, in the FIFO order of
/// `Stack::step_local`; returns what leaves the process. Failure-detector indications that
/// only other layers hear (a suspicion for the consensus layer) are recorded too, so the
/// trace shows the detector at work.
async fn local(
    stack: &[Addr<LayerActor>],
    wiring: &nekosim_protocols::Wiring,
    ctx: &Ctx,
    routed: Vec<Routed>,
    out: &mut Out,
) -> Vec<Routed> {
    let mut queue = std::collections::VecDeque::new();
    let mut leaving = Vec::new();
    let mut route = |r: Routed,
                     queue: &mut std::collections::VecDeque<(u16, Input)>,
                     heard: &mut Vec<(u16, Indication)>| match r {
        Routed::Layer { to, input } if to != NET => {
            if let Input::Indication { from, ind } = &input {
                if matches!(
                    ind,
                    Indication::Suspect(_) | Indication::Trust(_) | Indication::Leader(_)
                ) && !heard.contains(&(*from, ind.clone()))
                {
                    heard.push((*from, ind.clone()));
                }
            }
            queue.push_back((to, input));
        }
        other => leaving.push(other),
    };
    let mut heard = Vec::new();
    for r in routed {
        route(r, &mut queue, &mut heard);
    }
    while let Some((l, i)) = queue.pop_front() {
        for r in step(stack, l, i).await.unwrap_or_default() {
            route(r, &mut queue, &mut heard);
        }
    }
    for (from, ind) in heard {
        // Unless the application hears it too (recorded with what leaves the process).
        let to_app = leaving
            .iter()
            .any(|r| matches!(r, Routed::App { layer, ind: i } if *layer == from && *i == ind));
        if to_app {
            continue;
        }
        let (robot, layer) = (ctx.me, nekosim_actors::layer::layer_name(wiring, from));
        out.record(match ind {
            Indication::Suspect(process) => Observation::Suspect {
                robot,
                layer,
                process,
            },
            Indication::Trust(process) => Observation::Trust {
                robot,
                layer,
                process,
            },
            Indication::Leader(process) => Observation::Leader {
                robot,
                layer,
                process,
            },
            _ => unreachable!("only detector indications are kept"),
        });
    }
    leaving
}
