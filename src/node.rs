//! One node of a cluster (docs/real-network.md): the cluster file's stack, the very code the
//! simulator and the model checker run, hosted in an OS process. The node owns one [`Stack`]
//! and routes its effects as the model checker does ([`Stack::step_local`]): the hops inside
//! the process at once, then what leaves it: sends over TCP to the peers (the `link` module), timers
//! on the real clock, indications to the node's application. What it records is what the
//! simulator records ([`protocol_record`]).
//!
//! A run is a sequence of named steps: open the outputs (`run`), start the links and the
//! clock (`serve`), start the application and the stack (`Node::start`), then route what
//! the stack produced (`Node::route`), carry out what the application asked (`Node::act`)
//! and react to the next event (`Node::handle`) until the node stops.

mod link;

use std::collections::HashMap;
use std::io;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::rc::Rc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use nekosim_actors::protocol_record::{self, layer_name};
use nekosim_actors::world::geometry::Point;
use nekosim_actors::world::motion::{Kinematics, Pose};
use nekosim_actors::world::observation::{Observation, Record};
use nekosim_protocols::codec::install;
use nekosim_protocols::payload::Payload;
use nekosim_protocols::service::{Ctx, Indication, Input, LayerIx, APP, NET};
use nekosim_protocols::{Routed, Stack, WireError, Wiring};
use tokio::net::TcpListener;
use tokio::signal::unix::{signal, Signal, SignalKind};
use tokio::sync::mpsc;

use crate::apps::{AppAction, AppIo, NodeApp};
use crate::cluster::Cluster;
use crate::log::NekoLog;
use crate::output::AtomicFile;
use crate::scenario::Registry;
use crate::trace::to_line;

pub use link::{tag, Arrival, Auth, Challenge, Frame, Hello, MAGIC, MAX_FRAME, VERSION};
use link::{Links, Peers};

/// How long a node goes on after its application is done, so its peers get its last
/// messages (acknowledgements they may still wait for).
const LINGER: Duration = Duration::from_millis(1500);

/// What the node's loop reacts to.
#[derive(Debug)]
enum Event {
    Frame(Arrival),
    Timer {
        layer: LayerIx,
        timer: Payload,
        gen: u64,
    },
    App(u64),
    Stop,
    Crash,
}

impl From<Arrival> for Event {
    fn from(a: Arrival) -> Self {
        Event::Frame(a)
    }
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
        let t = seconds_since(self.start);
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

    /// Records each of `obs` (none, for an indication no record shows).
    fn record_all(&mut self, obs: impl IntoIterator<Item = Observation>) {
        for o in obs {
            self.record(o);
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

/// Hosts node `me` of `n` on the actix runtime: listens at `addr`, dials the peers, starts the
/// clock, then runs the node until it stops.
async fn serve(
    cluster: &Cluster,
    app: Box<dyn NodeApp>,
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
    let (tx, rx) = mpsc::unbounded_channel::<Event>();
    let peers = Rc::new(Peers {
        cluster: cluster.name.clone(),
        key: cluster.key.clone(),
        me,
        addrs: cluster.nodes.clone(),
        cuts: (0..n).map(|p| cluster.cuts(me, p)).collect(),
        clock: out.start,
    });
    link::listen(listener, peers.clone(), tx.clone());
    let links = Links::dial(&peers);
    start_clock(cluster, me, out.start, &tx);
    let mut node = Node {
        me,
        n,
        wiring: &cluster.wiring,
        ctx: Ctx { me, n },
        stack: cluster.template.clone(),
        app,
        actions: Vec::new(),
        out,
        tx,
        links: &links,
        timers: HashMap::new(),
        generation: 0,
        summary: NodeSummary {
            deliveries: 0,
            decisions: 0,
            sent: 0,
            crashed: false,
        },
    };
    node.run(rx).await;
    let summary = node.summary;
    // A crashed node's writers stop at once; otherwise they send what they hold, briefly.
    links.close(!summary.crashed).await;
    Ok(summary)
}

/// Sends `ev` to the node's loop after `d`.
fn after(d: Duration, ev: Event, tx: &mpsc::UnboundedSender<Event>) {
    let tx = tx.clone();
    actix::spawn(async move {
        tokio::time::sleep(d).await;
        let _ = tx.send(ev);
    });
}

/// Schedules the end of the cluster's duration and node `me`'s crash fault (times since
/// `start`), and a stop on Ctrl-C or SIGTERM, which writes the files of the run so far.
fn start_clock(cluster: &Cluster, me: u32, start: SystemTime, tx: &mpsc::UnboundedSender<Event>) {
    let elapsed = seconds_since(start);
    let at = |t: f64| Duration::from_secs_f64((t - elapsed).max(0.0));
    after(at(cluster.duration), Event::Stop, tx);
    if let Some(t) = cluster.crash_of(me) {
        after(at(t), Event::Crash, tx);
    }
    // The handlers are in place before the node's loop starts: a signal that comes before
    // the loop first waits is never left to the default action, which would lose the files.
    let mut int = signal(SignalKind::interrupt()).ok();
    let mut term = signal(SignalKind::terminate()).ok();
    let tx = tx.clone();
    actix::spawn(async move {
        tokio::select! {
            _ = next(int.as_mut()) => {}
            _ = next(term.as_mut()) => {}
        }
        let _ = tx.send(Event::Stop);
    });
}

/// The next delivery of a signal, or never if it cannot be watched.
async fn next(signal: Option<&mut Signal>) {
    match signal {
        Some(s) => {
            s.recv().await;
        }
        None => std::future::pending().await,
    }
}

/// Seconds from `start` to now.
fn seconds_since(start: SystemTime) -> f64 {
    SystemTime::now()
        .duration_since(start)
        .unwrap_or_default()
        .as_secs_f64()
}

/// A running node: its stack, its application and what connects them to the world.
struct Node<'a> {
    me: u32,
    n: u32,
    wiring: &'a Wiring,
    ctx: Ctx,
    stack: Stack,
    app: Box<dyn NodeApp>,
    /// What the application asked for and the node has not carried out yet.
    actions: Vec<AppAction>,
    out: &'a mut Out,
    /// The node's own loop, for timers and messages a node sends itself.
    tx: mpsc::UnboundedSender<Event>,
    links: &'a Links,
    /// The generation of each layer's pending timer; a firing of another was cancelled.
    timers: HashMap<(LayerIx, Payload), u64>,
    generation: u64,
    summary: NodeSummary,
}

/// Whether the node goes on after an event.
enum Flow {
    /// On, with what the stack produced.
    Go(Vec<Routed>),
    Stop,
}

impl Node<'_> {
    /// Runs the node until the cluster's duration, a stop, its crash, or a moment after its
    /// application is done.
    async fn run(&mut self, mut rx: mpsc::UnboundedReceiver<Event>) {
        let mut todo = self.start();
        let mut done = false;
        loop {
            self.route(std::mem::take(&mut todo));
            todo = self.act();
            if !todo.is_empty() {
                continue;
            }
            if self.app.done() && !done {
                done = true;
                after(LINGER, Event::Stop, &self.tx);
            }
            let Some(ev) = rx.recv().await else { break };
            match self.handle(ev) {
                Flow::Go(routed) => todo = routed,
                Flow::Stop => break,
            }
        }
    }

    /// Starts the application, then every layer, bottom-up in stack order, as
    /// [`Stack::start_all`] does; what leaves the stack.
    fn start(&mut self) -> Vec<Routed> {
        let mut io = AppIo::new(self.me, self.n, seconds_since(self.out.start));
        self.app.start(&mut io);
        self.actions = io.take();
        let mut todo = Vec::new();
        for l in 0..self.stack.layers.len() as LayerIx {
            todo.extend(self.local(l, Input::Start).unwrap_or_default());
        }
        todo
    }

    /// Runs `input` at `layer` and every hop it causes inside the process; what leaves the
    /// process, or why `layer` refused `input`. What a failure detector tells only other
    /// layers (a suspicion for the consensus layer) is recorded too, once per run, so the
    /// trace shows the detector at work.
    fn local(&mut self, layer: LayerIx, input: Input) -> Result<Vec<Routed>, WireError> {
        let mut heard: Vec<(LayerIx, Indication)> = Vec::new();
        let leaving =
            self.stack
                .step_local_with(self.wiring, &self.ctx, layer, input, |_, input| {
                    if let Input::Indication { from, ind } = input {
                        let detector = matches!(
                            ind,
                            Indication::Suspect(_) | Indication::Trust(_) | Indication::Leader(_)
                        );
                        if detector && !heard.iter().any(|(f, i)| f == from && i == ind) {
                            heard.push((*from, ind.clone()));
                        }
                    }
                })?;
        for (from, ind) in heard {
            // Unless the application hears it too (recorded with what leaves the process).
            let to_app = leaving
                .iter()
                .any(|r| matches!(r, Routed::App { layer, ind: i } if *layer == from && *i == ind));
            if !to_app {
                let name = layer_name(self.wiring, from);
                self.out
                    .record_all(protocol_record::indication(self.me, name, &ind));
            }
        }
        Ok(leaving)
    }

    /// Carries out what left the stack: sends, indications to the application, timers.
    fn route(&mut self, todo: Vec<Routed>) {
        for r in todo {
            match r {
                Routed::Net { layer, to, msg } => self.send(layer, to, msg),
                Routed::App { layer, ind } => {
                    let name = layer_name(self.wiring, layer);
                    let mut io = AppIo::new(self.me, self.n, seconds_since(self.out.start));
                    self.app.indication(&mut io, &name, &ind);
                    self.actions.extend(io.take());
                    match ind {
                        Indication::BDeliver { .. } => self.summary.deliveries += 1,
                        Indication::Decide { .. } => self.summary.decisions += 1,
                        _ => {}
                    }
                    self.out
                        .record_all(protocol_record::indication(self.me, name, &ind));
                }
                Routed::SetTimer {
                    layer,
                    timer,
                    after: delay,
                } => {
                    self.generation += 1;
                    self.timers.insert((layer, timer.clone()), self.generation);
                    let ev = Event::Timer {
                        layer,
                        timer,
                        gen: self.generation,
                    };
                    after(Duration::from_secs_f64(delay.get().max(0.0)), ev, &self.tx);
                }
                Routed::CancelTimer { layer, timer } => {
                    self.timers.remove(&(layer, timer));
                }
                Routed::Layer { .. } => {}
            }
        }
    }

    /// Layer `layer` sends `msg` to the same layer of the nodes `to`.
    fn send(&mut self, layer: LayerIx, to: Vec<u32>, msg: Payload) {
        self.out.record(Observation::Send {
            robot: self.me,
            to: to.clone(),
            layer: layer_name(self.wiring, layer),
            msg: msg.clone(),
            arrive: Vec::new(),
        });
        self.summary.sent += to.len() as u64;
        for p in to {
            let bytes = msg.bytes().to_vec();
            if p == self.me {
                let _ = self.tx.send(Event::Frame(Arrival {
                    from: p,
                    layer,
                    bytes,
                }));
            } else {
                self.links.send(p, layer, bytes);
            }
        }
    }

    /// Carries out what the application asked for; what its requests made leave the stack.
    fn act(&mut self) -> Vec<Routed> {
        let mut todo = Vec::new();
        for a in std::mem::take(&mut self.actions) {
            match a {
                AppAction::After { seconds, tag } => after(
                    Duration::from_secs_f64(seconds.max(0.0)),
                    Event::App(tag),
                    &self.tx,
                ),
                AppAction::Request { layer, req, .. } => {
                    let Some(ix) = self.wiring.index(&layer) else {
                        eprintln!(
                            "node {}: the application asked layer {layer:?}, which the stack does not have",
                            self.me
                        );
                        continue;
                    };
                    self.out
                        .record(protocol_record::request(self.me, layer, &req));
                    let input = Input::Request { from: APP, req };
                    todo.extend(self.local(ix, input).unwrap_or_default());
                }
            }
        }
        todo
    }

    /// Reacts to one event.
    fn handle(&mut self, ev: Event) -> Flow {
        match ev {
            Event::Frame(Arrival { from, layer, bytes }) => {
                Flow::Go(self.arrive(from, layer, bytes))
            }
            Event::Timer { layer, timer, gen } => {
                let key = (layer, timer);
                if self.timers.get(&key) != Some(&gen) {
                    return Flow::Go(Vec::new());
                }
                self.timers.remove(&key);
                let (layer, timer) = key;
                Flow::Go(self.local(layer, Input::Timer(timer)).unwrap_or_default())
            }
            Event::App(tag) => {
                let mut io = AppIo::new(self.me, self.n, seconds_since(self.out.start));
                self.app.timer(&mut io, tag);
                self.actions = io.take();
                Flow::Go(Vec::new())
            }
            Event::Stop => Flow::Stop,
            Event::Crash => {
                self.out.record(Observation::Crash {
                    robot: self.me,
                    state: Kinematics::at_rest(Pose {
                        pos: Point::origin(),
                        angle: 0.0,
                    }),
                });
                self.summary.crashed = true;
                Flow::Stop
            }
        }
    }

    /// A message from node `from` arrived for layer `layer`; a message that does not decode
    /// as its layer's changes nothing.
    fn arrive(&mut self, from: u32, layer: LayerIx, bytes: Vec<u8>) -> Vec<Routed> {
        let me = self.me;
        if layer as usize >= self.stack.layers.len() {
            eprintln!("node {me}: a frame from node {from} for layer {layer}, which the stack does not have; dropped");
            return Vec::new();
        }
        let msg = Payload::from_parts(layer, &bytes);
        let name = layer_name(self.wiring, layer);
        self.out
            .record(protocol_record::receive(me, name, from, &msg));
        let input = Input::Indication {
            from: NET,
            ind: Indication::Deliver { from, msg },
        };
        self.local(layer, input).unwrap_or_else(|e| {
            eprintln!("node {me}: a message from node {from} that does not decode ({e}); dropped");
            Vec::new()
        })
    }
}
