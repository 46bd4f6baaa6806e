//! User protocols through the public API only: a ring-gossip broadcast written in this file,
//! with its own message, configuration and service, registered by name, configured from its
//! RON text, wired and hosted exactly like the built-ins (and under and over them).

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::fmt;
use std::hash::{DefaultHasher, Hash, Hasher};

use nekosim_protocols::{
    AppMsg, Content, Ctx, FieldError, Indication, Input, LayerIx, LayerSpec, Microprotocol, MsgId,
    NoConfig, NoMsg, Out, Payload, Pid, ProtocolSpec, Protocols, Request, Routed, Service, Shape,
    Stack, StackError, Wiring, APP, NET,
};
use serde::{Deserialize, Serialize};

/// The service the gossip layer provides: a broadcast (so it serves a need for one), but not
/// every broadcast is gossip.
const GOSSIP: Service = Service::new("Gossip", "ring gossip", &[Service::BROADCAST]);

/// The gossip layer's message: a rumour, the broadcast message `id` and its payload.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
enum GossipMsg {
    Rumor { id: MsgId, payload: Payload },
}

/// `RingGossip(fanout: 2)`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RingGossipConfig {
    /// How many successors on the ring a process passes a new rumour to.
    fanout: u32,
}

/// Broadcast by gossip on a ring: the first time a process hears a rumour it delivers it and
/// passes it to its `fanout` successors (never back to its origin). Over reliable links
/// every process delivers every broadcast exactly once.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct RingGossip {
    fanout: u32,
    count: u64,
    seen: BTreeSet<MsgId>,
}

impl RingGossip {
    fn spread(&self, ctx: &Ctx, id: MsgId, payload: Payload, out: &mut Out<Self>) {
        let to: BTreeSet<Pid> = (1..=self.fanout)
            .map(|k| (ctx.me + k) % ctx.n)
            .filter(|&p| p != ctx.me && p != id.origin)
            .collect();
        out.send(to.into_iter().collect(), GossipMsg::Rumor { id, payload });
    }
}

impl Microprotocol for RingGossip {
    type Msg = GossipMsg;
    type Timer = ();
    type Config = RingGossipConfig;
    const NAME: &'static str = "RingGossip";

    fn shape(_: &RingGossipConfig) -> Shape {
        Shape::on_links(GOSSIP)
    }

    fn new(c: RingGossipConfig) -> Result<Self, FieldError> {
        if c.fanout == 0 {
            return Err(FieldError::new(
                "fanout",
                "fanout is 0",
                "at least 1 successor",
            ));
        }
        Ok(Self {
            fanout: c.fanout,
            count: 0,
            seen: BTreeSet::new(),
        })
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Broadcast { msg } = req {
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            self.seen.insert(id);
            self.spread(ctx, id, msg.clone(), out);
            out.up(Indication::BDeliver { id, msg });
        }
    }

    fn on_message(&mut self, ctx: &Ctx, _from: Pid, m: GossipMsg, out: &mut Out<Self>) {
        let GossipMsg::Rumor { id, payload } = m;
        if self.seen.insert(id) {
            self.spread(ctx, id, payload.clone(), out);
            out.up(Indication::BDeliver { id, msg: payload });
        }
    }

    fn render(m: &GossipMsg, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let GossipMsg::Rumor { id, payload } = m;
        write!(f, "GOSSIP({id}, {payload})")
    }
}

/// A layer that needs gossip below it: passes broadcasts down and deliveries up, counting
/// them.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct Tally {
    delivered: u64,
}

impl Microprotocol for Tally {
    type Msg = NoMsg;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "Tally";

    fn shape(_: &NoConfig) -> Shape {
        Shape {
            provides: Service::BROADCAST,
            needs_below: GOSSIP,
            needs_uses: vec![],
        }
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_request(&mut self, _ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Broadcast { .. } = req {
            out.down(req);
        }
    }

    fn on_indication(&mut self, _ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out<Self>) {
        if let Indication::BDeliver { .. } = ind {
            self.delivered += 1;
            out.up(ind);
        }
    }
}

/// The built-ins plus this file's protocols.
fn registry() -> Protocols {
    let mut r = Protocols::with_builtins();
    r.protocol::<RingGossip>("RingGossip")
        .protocol::<Tally>("Tally");
    r
}

fn check(specs: &[LayerSpec]) -> Result<(Wiring, Stack), StackError> {
    Wiring::check(specs, &registry())
}

fn layer(id: &str, protocol: &str, below: &str, uses: &[&str]) -> LayerSpec {
    LayerSpec::new(id, protocol, below, uses)
}

fn hash<T: Hash>(t: &T) -> u64 {
    let mut h = DefaultHasher::new();
    t.hash(&mut h);
    h.finish()
}

/// The application's message broadcast as process `p`'s `i`-th.
fn msg(p: Pid, i: u64) -> Payload {
    AppMsg::new("G", Content::Int(i64::from(p) * 100 + i as i64)).payload()
}

/// `n` processes running `specs` over a reliable in-memory network, in a fixed but scrambled
/// delivery order; each process first broadcasts `per_process` messages through the layer
/// `top`.
struct Run {
    wiring: Wiring,
    stacks: Vec<Stack>,
    /// What reached each process's application: (layer, indication).
    app: Vec<Vec<(LayerIx, Indication)>>,
    /// Messages sent over the network.
    sent: usize,
}

impl Run {
    fn new(n: u32, specs: &[LayerSpec], top: &str, per_process: u64) -> Self {
        let (wiring, stack) = check(specs).expect("valid stack");
        let top = wiring.index(top).expect("top layer");
        let mut run = Run {
            stacks: vec![stack; n as usize],
            wiring,
            app: vec![Vec::new(); n as usize],
            sent: 0,
        };
        let mut flight = VecDeque::new();
        for p in 0..n {
            let ctx = Ctx { me: p, n };
            let out = run.stacks[p as usize].start_all(&run.wiring, &ctx);
            run.route(p, out, &mut flight);
        }
        for p in 0..n {
            for i in 0..per_process {
                let input = Input::Request {
                    from: APP,
                    req: Request::Broadcast { msg: msg(p, i) },
                };
                let out =
                    run.stacks[p as usize].step_local(&run.wiring, &Ctx { me: p, n }, top, input);
                run.route(p, out, &mut flight);
            }
        }
        // Deliver everything, taking messages out of the middle of the queue so that links
        // reorder; timers are never fired (nothing here needs them).
        let mut k = 0usize;
        while !flight.is_empty() {
            k += 7;
            let (from, to, layer, msg) = flight.remove(k % flight.len()).expect("in range");
            let input = Input::Indication {
                from: NET,
                ind: Indication::Deliver { from, msg },
            };
            let out =
                run.stacks[to as usize].step_local(&run.wiring, &Ctx { me: to, n }, layer, input);
            run.route(to, out, &mut flight);
            assert!(run.sent < 100_000, "the run does not settle");
        }
        run
    }

    fn route(
        &mut self,
        p: Pid,
        routed: Vec<Routed>,
        flight: &mut VecDeque<(Pid, Pid, LayerIx, Payload)>,
    ) {
        for r in routed {
            match r {
                Routed::Net { layer, to, msg } => {
                    for d in to {
                        self.sent += 1;
                        flight.push_back((p, d, layer, msg.clone()));
                    }
                }
                Routed::App { layer, ind } => self.app[p as usize].push((layer, ind)),
                Routed::SetTimer { .. } | Routed::CancelTimer { .. } => {}
                Routed::Layer { to, input } => panic!("p{p}: unexpected hop to {to}: {input:?}"),
            }
        }
    }

    /// The broadcast deliveries of process `p`, in order, with the layer they came from.
    fn bdelivered(&self, p: Pid) -> Vec<(LayerIx, MsgId, Payload)> {
        self.app[p as usize]
            .iter()
            .filter_map(|(l, ind)| match ind {
                Indication::BDeliver { id, msg } => Some((*l, *id, msg.clone())),
                _ => None,
            })
            .collect()
    }
}

fn gossip_stack(fanout: u32) -> Vec<LayerSpec> {
    vec![
        layer(
            "gossip",
            &format!("RingGossip(fanout: {fanout})"),
            "net",
            &[],
        ),
        layer("tally", "Tally", "gossip", &[]),
    ]
}

#[test]
fn every_process_delivers_every_gossiped_message_exactly_once() {
    let per_process = 3;
    for n in 1..=5u32 {
        for fanout in 1..=3u32 {
            let run = Run::new(n, &gossip_stack(fanout), "tally", per_process);
            let tally = run.wiring.index("tally").unwrap();
            // Independently: every process's every message, once, with its content.
            let want: BTreeMap<MsgId, Payload> = (0..n)
                .flat_map(|p| (0..per_process).map(move |i| (MsgId { origin: p, n: i }, msg(p, i))))
                .collect();
            for p in 0..n {
                let got = run.bdelivered(p);
                assert!(
                    got.iter().all(|(l, _, _)| *l == tally),
                    "n {n} fanout {fanout}: p{p} hears gossip only through the tally: {got:?}"
                );
                let by_id: BTreeMap<MsgId, Payload> =
                    got.iter().map(|(_, id, m)| (*id, m.clone())).collect();
                assert_eq!(
                    got.len(),
                    want.len(),
                    "n {n} fanout {fanout}: p{p} exactly once"
                );
                assert_eq!(by_id, want, "n {n} fanout {fanout}: p{p}");
                // The user layer's own state, read back from the stack.
                let t = run.stacks[p as usize].layers[tally as usize]
                    .downcast_ref::<Tally>()
                    .expect("a Tally");
                assert_eq!(t.delivered, want.len() as u64);
            }
            if fanout == 1 {
                // A plain ring: each broadcast travels n - 1 links.
                assert_eq!(
                    run.sent,
                    (n as usize) * (per_process as usize) * (n as usize - 1)
                );
            }
        }
    }
}

#[test]
fn built_in_layers_run_over_a_user_protocol() {
    // Consensus-based atomic broadcast needs a broadcast below it: gossip serves.
    let specs = [
        layer("fd", "Heartbeat(period: 1.0, timeout: 3.0)", "net", &[]),
        layer("gossip", "RingGossip(fanout: 1)", "net", &[]),
        layer("consensus", "ChandraToueg", "net", &["fd"]),
        layer("abcast", "ConsensusAbcast", "gossip", &["consensus"]),
    ];
    let (n, per_process) = (3, 2);
    let run = Run::new(n, &specs, "abcast", per_process);
    let abcast = run.wiring.index("abcast").unwrap();
    let order = |p: Pid| -> Vec<(MsgId, Payload)> {
        run.bdelivered(p)
            .into_iter()
            .filter(|(l, _, _)| *l == abcast)
            .map(|(_, id, m)| (id, m))
            .collect()
    };
    let first = order(0);
    let want: BTreeSet<(MsgId, Payload)> = (0..n)
        .flat_map(|p| (0..per_process).map(move |i| (MsgId { origin: p, n: i }, msg(p, i))))
        .collect();
    assert_eq!(first.len(), want.len(), "{first:?}");
    assert_eq!(first.iter().cloned().collect::<BTreeSet<_>>(), want);
    for p in 1..n {
        assert_eq!(order(p), first, "total order: p{p} and p0");
    }
}

#[test]
fn the_user_service_is_checked_like_a_built_in_one() {
    // Tally needs gossip: a plain broadcast does not serve it ...
    let e = check(&[
        layer("rb", "ReliableBroadcast", "net", &[]),
        layer("tally", "Tally", "rb", &[]),
    ])
    .unwrap_err();
    assert_eq!((e.layer, e.field.as_str()), (1, "below"));
    assert!(e.message.contains("needs ring gossip below it"), "{e}");
    assert!(e.message.contains("provides broadcast"), "{e}");
    // ... nor do the links.
    let e = check(&[layer("tally", "Tally", "net", &[])]).unwrap_err();
    assert_eq!((e.layer, e.field.as_str()), (0, "below"));
    // Gossip does.
    let (wiring, _) = check(&gossip_stack(2)).unwrap();
    assert_eq!(wiring.provides, vec![GOSSIP, Service::BROADCAST]);
    assert_eq!(wiring.app_hears, vec![false, true]);
    // And gossip serves a need for a broadcast, below or used.
    assert!(check(&[
        layer("fd", "Heartbeat(period: 1.0, timeout: 3.0)", "net", &[]),
        layer("gossip", "RingGossip(fanout: 1)", "net", &[]),
        layer("consensus", "ChandraToueg", "net", &["fd"]),
        layer("abcast", "ConsensusAbcast", "gossip", &["consensus"]),
    ])
    .is_ok());
    assert!(GOSSIP.serves(Service::BROADCAST));
    assert!(!Service::BROADCAST.serves(GOSSIP));
    assert!(!Service::TOTAL_ORDER.serves(GOSSIP));
}

#[test]
fn an_unregistered_user_protocol_is_unknown() {
    let e = Wiring::check(&gossip_stack(1), &Protocols::with_builtins()).unwrap_err();
    assert_eq!((e.layer, e.field.as_str()), (0, "protocol"));
    assert!(e.message.contains("unknown protocol \"RingGossip\""), "{e}");
    assert!(e.message.contains("Fifo"), "{e}");
    // Registered, its name is among the expected ones of another unknown name.
    let e = check(&[layer("x", "Gosip(fanout: 1)", "net", &[])]).unwrap_err();
    assert!(e.message.contains("RingGossip"), "{e}");
    assert!(e.message.contains("Tally"), "{e}");
}

/// 1-based line and column of the first occurrence of `word` in `text`.
fn position(text: &str, word: &str) -> (usize, usize) {
    let at = text.find(word).expect("word in text");
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let col = at - before.rfind('\n').map_or(0, |nl| nl + 1) + 1;
    (line, col)
}

/// Two ways to misspell `fanout`: on the spec's one line, and on a later line.
const MISSPELLED: [&str; 2] = [
    "RingGossip(fanout: 2, fanuot: 1)",
    "RingGossip(\n  fanout: 2,\n  fanuot: 1,\n)",
];

#[test]
fn an_unknown_configuration_field_is_named_on_its_line() {
    for text in MISSPELLED {
        let e = check(&[layer("gossip", text, "net", &[])]).unwrap_err();
        assert_eq!((e.layer, e.field.as_str()), (0, "protocol"), "{text}");
        assert!(e.message.contains("`fanuot`"), "{e}");
        assert!(e.message.contains("`fanout`"), "{e}");
        let (line, col) = e.at.expect("a position");
        let (want_line, want_col) = position(text, "fanuot");
        assert_eq!(line, want_line, "{text}: {e}");
        // On the misspelt word (its first column, or the one just after it, where ron
        // stops reading it; see `an_unknown_configuration_field_is_pointed_at`).
        assert!(
            (want_col..=want_col + "fanuot".len()).contains(&col),
            "{text}: column {col}, the word starts at {want_col}"
        );
    }
}

/// The column names the unknown field's first character, as an editor would highlight it.
#[test]
fn an_unknown_configuration_field_is_pointed_at() {
    for text in MISSPELLED {
        let e = check(&[layer("gossip", text, "net", &[])]).unwrap_err();
        assert_eq!(e.at, Some(position(text, "fanuot")), "{text}: {e}");
    }
}

#[test]
fn a_configuration_the_protocol_refuses_names_its_field() {
    let e = check(&[
        layer("gossip", "RingGossip(fanout: 0)", "net", &[]),
        layer("tally", "Tally", "gossip", &[]),
    ])
    .unwrap_err();
    assert_eq!((e.layer, e.field.as_str()), (0, "protocol.fanout"));
    assert_eq!(e.at, None);
    assert!(e.message.starts_with("RingGossip: "), "{e}");
    assert!(e.message.contains("fanout is 0"), "{e}");
    // A value of the wrong type, a missing field, and a field for a protocol that takes none
    // are refused by the configuration types.
    for text in ["RingGossip(fanout: \"two\")", "RingGossip(fanout: -1)"] {
        let e = check(&[layer("gossip", text, "net", &[])]).unwrap_err();
        assert_eq!(e.field, "protocol", "{text}: {e}");
        assert!(e.at.is_some(), "{text}: {e}");
    }
    // A bare name has no configuration text to point into: the error is the protocol's.
    let e = check(&[layer("gossip", "RingGossip", "net", &[])]).unwrap_err();
    assert_eq!((e.field.as_str(), e.at), ("protocol", None), "{e}");
    assert_eq!(
        e.message,
        "RingGossip: RingGossipConfig is missing the field `fanout`; expected `fanout: VALUE`"
    );
    let e = check(&[
        layer("gossip", "RingGossip(fanout: 1)", "net", &[]),
        layer("tally", "Tally(every: 2)", "gossip", &[]),
    ])
    .unwrap_err();
    assert_eq!((e.layer, e.field.as_str()), (1, "protocol"));
    assert!(e.message.contains("takes no configuration"), "{e}");
}

#[test]
fn user_layers_compare_and_hash_by_value() {
    let reg = registry();
    let build = |text: &str| reg.build(&ProtocolSpec::new(text)).expect("builds");
    let (shape, x) = build("RingGossip(fanout: 2)");
    assert_eq!(shape, Shape::on_links(GOSSIP));
    let (_, y) = build("RingGossip(fanout: 2)");
    assert_eq!(x, y, "two fresh instances of one configuration");
    assert_eq!(hash(&x), hash(&y));
    assert_eq!(x.name(), "RingGossip");
    assert!(x.downcast_ref::<RingGossip>().is_some());
    assert!(x.downcast_ref::<Tally>().is_none());
    let mut z = x.clone();
    assert_eq!(z, x);
    assert_eq!(hash(&z), hash(&x));
    let effects = z
        .handle(
            &Ctx { me: 0, n: 3 },
            0,
            Input::Request {
                from: APP,
                req: Request::Broadcast { msg: msg(0, 0) },
            },
        )
        .unwrap();
    assert_eq!(effects.len(), 2, "a send and a delivery: {effects:?}");
    assert_ne!(x, z, "a step changes the state");
    assert_eq!(z.clone(), z);
    assert_eq!(hash(&z.clone()), hash(&z));
    // The configuration is part of the state; another protocol is never equal.
    let (_, w) = build("RingGossip(fanout: 3)");
    assert_ne!(x, w);
    let (_, t) = build("Tally");
    assert_eq!(t.name(), "Tally");
    assert_ne!(x, t);
    assert_ne!(t, x);
    // And so are stacks holding them.
    let (_, s) = check(&gossip_stack(2)).unwrap();
    let mut s2 = s.clone();
    assert_eq!(s, s2);
    assert_eq!(hash(&s), hash(&s2));
    s2.layers[0] = z;
    assert_ne!(s, s2);
}

#[test]
fn user_messages_render_through_the_registered_codec() {
    let (wiring, _) = check(&gossip_stack(1)).unwrap();
    let gossip = wiring.index("gossip").unwrap();
    assert_eq!(wiring.codec(gossip).map(|c| c.protocol), Some("RingGossip"));
    let rumor = Payload::encode(
        gossip,
        &GossipMsg::Rumor {
            id: MsgId { origin: 2, n: 5 },
            payload: msg(2, 5),
        },
    );
    assert_eq!(wiring.render(&rumor), "GOSSIP(2:5, G 205)");
    // The typed message survives the wire encoding.
    assert_eq!(
        rumor.decode::<GossipMsg>().unwrap(),
        GossipMsg::Rumor {
            id: MsgId { origin: 2, n: 5 },
            payload: msg(2, 5)
        }
    );
}
