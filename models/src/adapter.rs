//! The adapter: one process's composed protocol stack ([`Stack`], the same layers and wiring a
//! scenario's `stack` builds) hosted as one stateright [`Actor`].
//!
//! - A hop between two layers of one process is applied inside the actor's step
//!   ([`Stack::step_local`]); only what leaves the process becomes a stateright command.
//! - A message between processes is a stateright network message ([`NetMsg`]), so the checker
//!   explores every order of deliveries the chosen network allows.
//! - A protocol timer is a stateright timer: it fires whenever the checker likes. Each process
//!   may fire at most [`Shared::timer_budget`] protocol timers, which keeps heartbeat-driven
//!   stacks finite; afterwards its timers are inert (the step is a no-op).
//! - Client requests (broadcasts or proposals) are issued one by one by a `Client` timer, so
//!   they interleave with deliveries.
//! - With crashes allowed, a process's sends leave one message at a time (a `Flush` timer), so a
//!   crash can cut a multicast short, as in the simulator where a crashed robot's unsent
//!   messages are lost.

use std::borrow::Cow;
use std::collections::{BTreeSet, VecDeque};
use std::sync::Arc;

use nekosim_protocols::{
    Ctx, Indication, Input, LayerIx, MsgId, Payload, Pid, Request, Routed, Stack, Wiring, APP, NET,
};
use stateright::actor::{model_timeout, Actor, ActorModelState, Id, Out};

/// A timer budget (the check options' `timer_budget`) that never runs out: firings are not
/// counted, so a process whose timer keeps firing can come back to a state it was in (a
/// liveness check needs those cycles). To keep the space finite, a state with two copies of one message
/// in flight is then outside the model: a timer that would send a second copy waits until the
/// first is delivered or lost.
pub const UNLIMITED_TIMERS: u32 = u32::MAX;

/// A state of a model: every process's [`ProcessState`], timers and crash flag, and the
/// messages in flight.
pub type State = ActorModelState<ProcessActor, ()>;

/// The processes of `s` that have not crashed, by index.
pub(crate) fn live(s: &State) -> impl Iterator<Item = usize> + '_ {
    (0..s.actor_states.len()).filter(|&i| !s.crashed[i])
}

/// A message between processes: `msg` travels from a layer to the same layer (`layer`) of the
/// destination.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NetMsg {
    pub layer: LayerIx,
    pub msg: Payload,
}

/// A stateright timer of one process.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ModelTimer {
    /// Issue the process's next client request.
    Client,
    /// Hand the next staged message to the network (only with crashes).
    Flush,
    /// A protocol layer's timer.
    Layer { layer: LayerIx, timer: Payload },
}

/// What a process has done so far: its stack plus what reached its application.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct ProcessState {
    pub stack: Stack,
    /// Client requests issued so far (a prefix of [`ProcessActor::requests`]).
    pub issued: usize,
    /// Protocol timers fired so far.
    pub fired: u32,
    /// Broadcast deliveries to the application, in order.
    pub delivered: Vec<(MsgId, Payload)>,
    /// Consensus decisions reaching the application, in order (a repeat is kept, so
    /// integrity can be checked).
    pub decided: Vec<(u64, Payload)>,
    /// Point-to-point deliveries to the application (sender, message), in order.
    pub received: Vec<(Pid, Payload)>,
    /// What the failure detector's indications told the application so far.
    pub detections: Detections,
    /// The last leader a leader election indicated.
    pub leader: Option<Pid>,
    /// Messages waiting to leave (destination, message); only with crashes.
    pub outbox: VecDeque<(Pid, NetMsg)>,
    /// Restarted after a crash. Protocols here are crash-stop, so such a process is inert, and
    /// the model's boundary excludes every state that has one (stateright always offers a
    /// recovery after a crash).
    pub zombie: bool,
}

/// What a process's application has heard from its failure detector, as much of the sequence
/// of its `Suspect` and `Trust` indications as any property reads:
///
/// - the suspicions in force: the processes whose last indication suspects them (what
///   "suspects" means for completeness and for every proposition of the liveness graph);
/// - whether some indication was ill-formed: the detector indicated its own process, suspected
///   a process it suspected already, or trusted one it did not suspect (well-formedness reads
///   the sequence only for such a fault, and once it has one it never loses it);
/// - the processes some indication trusted (a revoked suspicion is a trust of a process that
///   is live, which depends on the crashes, read only when the property is).
///
/// The sequence itself grows without end where a detector may suspect and trust again for
/// ever (unlimited timers), and so would the state space; this summary takes finitely many
/// values, and two sequences with the same summary satisfy the same properties. No step of a
/// process reads it: it only records what the application heard.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Detections {
    suspected: BTreeSet<Pid>,
    trusted: BTreeSet<Pid>,
    ill_formed: bool,
}

impl Detections {
    /// The summary of the indications `history` (process, suspected) heard by process `me`, in
    /// order.
    pub fn of(me: Pid, history: &[(Pid, bool)]) -> Self {
        let mut d = Self::default();
        for &(p, suspected) in history {
            d.record(me, p, suspected);
        }
        d
    }

    /// Records that process `me` heard `Suspect(p)` (`suspected`) or `Trust(p)`.
    pub fn record(&mut self, me: Pid, p: Pid, suspected: bool) {
        let alternates = if suspected {
            self.suspected.insert(p)
        } else {
            self.trusted.insert(p);
            self.suspected.remove(&p)
        };
        self.ill_formed |= p == me || !alternates;
    }

    /// Whether the last indication about `p` suspects it.
    pub fn suspects(&self, p: Pid) -> bool {
        self.suspected.contains(&p)
    }

    /// The processes whose last indication suspects them, in order.
    pub fn suspected(&self) -> impl Iterator<Item = Pid> + '_ {
        self.suspected.iter().copied()
    }

    /// The processes some indication trusted, in order.
    pub fn trusted(&self) -> impl Iterator<Item = Pid> + '_ {
        self.trusted.iter().copied()
    }

    /// No indication so far indicated the process itself, suspected a process already
    /// suspected, or trusted a process not suspected.
    pub fn well_formed(&self) -> bool {
        !self.ill_formed
    }

    /// Every suspicion in force in `before` still is.
    pub fn keeps_suspicions_of(&self, before: &Self) -> bool {
        before.suspected.is_subset(&self.suspected)
    }

    /// Every process `before` trusted is still one this summary trusted.
    pub fn keeps_trusts_of(&self, before: &Self) -> bool {
        before.trusted.is_subset(&self.trusted)
    }

    /// Only the suspicions in force, what the liveness graph reads.
    pub fn in_force(&self) -> Self {
        Self {
            suspected: self.suspected.clone(),
            ..Self::default()
        }
    }

    /// The same summary with every process `p` named `rename(p)`.
    pub fn renamed(&self, rename: impl Fn(Pid) -> Pid) -> Self {
        Self {
            suspected: self.suspected.iter().map(|&p| rename(p)).collect(),
            trusted: self.trusted.iter().map(|&p| rename(p)).collect(),
            ill_formed: self.ill_formed,
        }
    }
}

/// What never changes during a check and is the same for every process.
#[derive(Debug)]
pub struct Shared {
    pub n: u32,
    pub wiring: Wiring,
    /// Protocol timer firings allowed per process.
    pub timer_budget: u32,
    /// Sends leave one message at a time (so a crash can cut a multicast).
    pub staged_sends: bool,
    /// Layers whose messages are not sent: their messages only feed their own timers, and
    /// no timer may fire (a zero budget), so sending them could change nothing but the
    /// number of states.
    pub muted: Vec<LayerIx>,
    /// The layer checked: what its indications tell the application is recorded in
    /// [`ProcessState`] for the properties.
    pub entry: LayerIx,
}

/// A client request of the model: `req` issued by the application to `layer`.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct ClientRequest {
    pub layer: LayerIx,
    pub req: Request,
}

/// One process of a model.
#[derive(Clone, Debug)]
pub struct ProcessActor {
    pub shared: Arc<Shared>,
    /// The stack at start (a deliberately broken variant may have replaced a layer).
    pub init: Stack,
    /// This process's client requests, in issue order.
    pub requests: Vec<ClientRequest>,
}

/// What one step of a process did, for explaining a path.
#[derive(Clone, Debug, PartialEq)]
pub enum Happening {
    /// The application issued `req` to `layer`.
    Request { layer: LayerIx, req: Request },
    /// The application skipped a proposal for an instance it has already seen decided.
    Skipped { layer: LayerIx, req: Request },
    /// `msg` from `from` arrived at `layer`.
    Receive {
        from: Pid,
        layer: LayerIx,
        msg: Payload,
    },
    /// A protocol timer fired.
    Timer { layer: LayerIx, timer: Payload },
    /// `layer` handed `msg` for `to` to the network (or to the outbox, with crashes).
    Send {
        layer: LayerIx,
        to: Vec<Pid>,
        msg: Payload,
    },
    /// One staged message left for `to`.
    Flush { to: Pid, msg: NetMsg },
    /// An indication reached the application.
    App { layer: LayerIx, ind: Indication },
}

/// The storage a process saves at start: a later `on_start` with storage is a recovery.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Started;

impl ProcessActor {
    fn ctx(&self, id: Id) -> Ctx {
        Ctx {
            me: usize::from(id) as Pid,
            n: self.shared.n,
        }
    }

    /// Turns what left the stack into stateright commands and application observations.
    fn emit(
        &self,
        me: Pid,
        state: &mut ProcessState,
        routed: Vec<Routed>,
        o: &mut Out<Self>,
        log: &mut Vec<Happening>,
    ) {
        for r in routed {
            match r {
                Routed::Net { layer, .. } if self.shared.muted.contains(&layer) => {}
                Routed::Net { layer, to, msg } => {
                    for &d in &to {
                        let m = NetMsg {
                            layer,
                            msg: msg.clone(),
                        };
                        if self.shared.staged_sends {
                            state.outbox.push_back((d, m));
                        } else {
                            o.send(Id::from(d as usize), m);
                        }
                    }
                    log.push(Happening::Send { layer, to, msg });
                }
                Routed::App { layer, ind } => {
                    if layer == self.shared.entry {
                        match &ind {
                            Indication::BDeliver { id, msg } => {
                                state.delivered.push((*id, msg.clone()))
                            }
                            Indication::Decide { k, value } => {
                                state.decided.push((*k, value.clone()))
                            }
                            Indication::Deliver { from, msg } => {
                                state.received.push((*from, msg.clone()))
                            }
                            Indication::Suspect(p) => state.detections.record(me, *p, true),
                            Indication::Trust(p) => state.detections.record(me, *p, false),
                            Indication::Leader(p) => state.leader = Some(*p),
                            Indication::Custom(_) => {}
                        }
                    }
                    log.push(Happening::App { layer, ind });
                }
                Routed::SetTimer { layer, timer, .. } => {
                    o.set_timer(ModelTimer::Layer { layer, timer }, model_timeout())
                }
                Routed::CancelTimer { layer, timer } => {
                    o.cancel_timer(ModelTimer::Layer { layer, timer })
                }
                Routed::Layer { to, input } => {
                    // `step_local` keeps every hop to a layer; what is left is a request to
                    // the network other than a send, which `Wiring::check` rules out.
                    panic!("the network only carries sends; layer {to} got {input:?}")
                }
            }
        }
        if !state.outbox.is_empty() {
            o.set_timer(ModelTimer::Flush, model_timeout());
        }
    }

    /// Issues the next client request.
    fn issue(&self, id: Id, state: &mut ProcessState, o: &mut Out<Self>, log: &mut Vec<Happening>) {
        let ClientRequest { layer, req } = self.requests[state.issued].clone();
        state.issued += 1;
        if state.issued < self.requests.len() {
            o.set_timer(ModelTimer::Client, model_timeout());
        }
        // An application does not propose to an instance it has seen decided.
        if let Request::Propose { k, .. } = &req {
            if state.decided.iter().any(|(d, _)| d == k) {
                log.push(Happening::Skipped { layer, req });
                return;
            }
        }
        log.push(Happening::Request {
            layer,
            req: req.clone(),
        });
        let routed = state.stack.step_local(
            &self.shared.wiring,
            &self.ctx(id),
            layer,
            Input::Request { from: APP, req },
        );
        self.emit(self.ctx(id).me, state, routed, o, log);
    }

    /// A fresh process: its layers started, its first client request armed.
    pub fn start(&self, id: Id, o: &mut Out<Self>, log: &mut Vec<Happening>) -> ProcessState {
        let mut state = ProcessState {
            stack: self.init.clone(),
            issued: 0,
            fired: 0,
            delivered: Vec::new(),
            decided: Vec::new(),
            received: Vec::new(),
            detections: Detections::default(),
            leader: None,
            outbox: VecDeque::new(),
            zombie: false,
        };
        let routed = state.stack.start_all(&self.shared.wiring, &self.ctx(id));
        self.emit(self.ctx(id).me, &mut state, routed, o, log);
        if !self.requests.is_empty() {
            o.set_timer(ModelTimer::Client, model_timeout());
        }
        state
    }

    /// Delivers a network message. A delivery that changes nothing (a late ack, a second
    /// copy of a relayed message) leaves the state borrowed, which stateright takes as no
    /// transition: the message stays in flight but never branches the exploration.
    pub fn receive(
        &self,
        id: Id,
        state: &mut Cow<ProcessState>,
        src: Id,
        msg: NetMsg,
        o: &mut Out<Self>,
        log: &mut Vec<Happening>,
    ) {
        if state.zombie {
            return;
        }
        let mut next = (**state).clone();
        let mut out = Out::new();
        let from = usize::from(src) as Pid;
        log.push(Happening::Receive {
            from,
            layer: msg.layer,
            msg: msg.msg.clone(),
        });
        let routed = next.stack.step_local(
            &self.shared.wiring,
            &self.ctx(id),
            msg.layer,
            Input::Indication {
                from: NET,
                ind: Indication::Deliver { from, msg: msg.msg },
            },
        );
        self.emit(self.ctx(id).me, &mut next, routed, &mut out, log);
        if out.is_empty() && next == **state {
            return;
        }
        *state = Cow::Owned(next);
        o.append(&mut out);
    }

    /// Fires a timer.
    pub fn fire(
        &self,
        id: Id,
        state: &mut Cow<ProcessState>,
        timer: &ModelTimer,
        o: &mut Out<Self>,
        log: &mut Vec<Happening>,
    ) {
        if state.zombie {
            return;
        }
        match timer {
            ModelTimer::Client => self.issue(id, state.to_mut(), o, log),
            ModelTimer::Flush => {
                let s = state.to_mut();
                if let Some((to, m)) = s.outbox.pop_front() {
                    o.send(Id::from(to as usize), m.clone());
                    log.push(Happening::Flush { to, msg: m });
                }
                if !s.outbox.is_empty() {
                    o.set_timer(ModelTimer::Flush, model_timeout());
                }
            }
            ModelTimer::Layer { layer, timer: t } => {
                let (layer, t) = (*layer, t.clone());
                if state.fired >= self.shared.timer_budget {
                    // Spent: keep the timer and change nothing, which stateright treats as
                    // no transition at all.
                    o.set_timer(timer.clone(), model_timeout());
                    return;
                }
                let s = state.to_mut();
                // Unlimited firings are not counted, so a timer loop can close a cycle.
                if self.shared.timer_budget != UNLIMITED_TIMERS {
                    s.fired += 1;
                }
                log.push(Happening::Timer {
                    layer,
                    timer: t.clone(),
                });
                let routed =
                    s.stack
                        .step_local(&self.shared.wiring, &self.ctx(id), layer, Input::Timer(t));
                self.emit(self.ctx(id).me, s, routed, o, log);
            }
        }
    }
}

impl Actor for ProcessActor {
    type Msg = NetMsg;
    type Timer = ModelTimer;
    type State = ProcessState;
    type Storage = Started;
    type Random = ();

    fn on_start(&self, id: Id, storage: &Option<Started>, o: &mut Out<Self>) -> ProcessState {
        if storage.is_some() {
            return ProcessState {
                stack: self.init.clone(),
                issued: 0,
                fired: 0,
                delivered: Vec::new(),
                decided: Vec::new(),
                received: Vec::new(),
                detections: Detections::default(),
                leader: None,
                outbox: VecDeque::new(),
                zombie: true,
            };
        }
        o.save(Started);
        self.start(id, o, &mut Vec::new())
    }

    fn on_msg(
        &self,
        id: Id,
        state: &mut Cow<ProcessState>,
        src: Id,
        msg: NetMsg,
        o: &mut Out<Self>,
    ) {
        self.receive(id, state, src, msg, o, &mut Vec::new());
    }

    fn on_timeout(
        &self,
        id: Id,
        state: &mut Cow<ProcessState>,
        timer: &ModelTimer,
        o: &mut Out<Self>,
    ) {
        self.fire(id, state, timer, o, &mut Vec::new());
    }

    fn name(&self) -> String {
        String::from("process")
    }
}
