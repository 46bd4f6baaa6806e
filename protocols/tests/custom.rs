//! User protocols registered by name: wired and hosted exactly like built-ins.

use std::collections::hash_map::DefaultHasher;
use std::collections::BTreeMap;
use std::hash::{Hash, Hasher};

use nekosim_protocols::fifo::Fifo;
use nekosim_protocols::lamport::LamportAbcast;
use nekosim_protocols::stack::{Layer, LayerSpec, ProtocolSpec, Service, Stack, Wiring};
use nekosim_protocols::{Content, Ctx, CustomLayer, Input, Protocols, Request, Shape, Wire};

fn custom(name: &str) -> ProtocolSpec {
    ProtocolSpec::Custom {
        name: name.into(),
        params: BTreeMap::new(),
    }
}

/// Fifo registered as a user protocol "MyFifo", and a P2p-only variant "Plain".
fn registry() -> Protocols {
    let mut p = Protocols::new();
    p.register(
        "MyFifo",
        Shape {
            provides: Service::FifoP2p,
            needs_below: Service::P2p,
            needs_uses: vec![],
        },
        |params| match params.get("bad") {
            Some(_) => Err("bad parameter".to_string()),
            None => Ok(Fifo::default()),
        },
    );
    p.register(
        "Plain",
        Shape {
            provides: Service::P2p,
            needs_below: Service::P2p,
            needs_uses: vec![],
        },
        |_| Ok(Fifo::default()),
    );
    p
}

fn hash<T: Hash>(t: &T) -> u64 {
    let mut h = DefaultHasher::new();
    t.hash(&mut h);
    h.finish()
}

#[test]
fn wiring_uses_the_registered_shapes() {
    let reg = registry();
    let over = |below_proto: ProtocolSpec| {
        Wiring::check_with(
            &[
                LayerSpec::new("links", below_proto, "net", &[]),
                LayerSpec::new("abcast", ProtocolSpec::LamportAbcast, "links", &[]),
            ],
            &reg,
        )
    };
    assert!(over(custom("MyFifo")).is_ok());
    let e = over(custom("Plain")).unwrap_err();
    assert_eq!((e.layer, e.field), (1, "below"));
    assert!(
        e.message.contains("needs FIFO point-to-point messages"),
        "{}",
        e.message
    );
    let e = over(custom("Nope")).unwrap_err();
    assert_eq!((e.layer, e.field), (0, "protocol"));
    assert_eq!(
        e.message,
        "unknown protocol \"Nope\"; registered: MyFifo, Plain"
    );
    let e = over(ProtocolSpec::Custom {
        name: "MyFifo".into(),
        params: BTreeMap::from([("bad".to_string(), 1.0)]),
    })
    .unwrap_err();
    assert_eq!(e.message, "protocol \"MyFifo\": bad parameter");
    // Without the registry the name is unknown.
    let e = Wiring::check(&[LayerSpec::new("links", custom("MyFifo"), "net", &[])]).unwrap_err();
    assert!(
        e.message.contains("no custom protocol is registered"),
        "{}",
        e.message
    );
}

#[test]
fn a_registered_protocol_behaves_exactly_like_the_built_in_it_wraps() {
    let reg = registry();
    let specs = |links: ProtocolSpec| {
        vec![
            LayerSpec::new("links", links, "net", &[]),
            LayerSpec::new("abcast", ProtocolSpec::LamportAbcast, "links", &[]),
        ]
    };
    let (builtin, user) = (specs(ProtocolSpec::Fifo), specs(custom("MyFifo")));
    let wiring = Wiring::check_with(&user, &reg).unwrap();
    assert_eq!(wiring, Wiring::check(&builtin).unwrap());
    let ctx = Ctx { me: 0, n: 2 };
    let mut a = Stack::new(&builtin);
    let mut b = Stack::with_protocols(&user, &reg).unwrap();
    assert!(matches!(b.layers[0], Layer::Custom(_)));
    assert_eq!(a.start_all(&wiring, &ctx), b.start_all(&wiring, &ctx));
    let msg = |i| Wire::app("M", Content::Int(i));
    let inputs = [
        (
            1,
            Input::Request {
                from: nekosim_protocols::APP,
                req: Request::Broadcast { msg: msg(1) },
            },
        ),
        (
            1,
            Input::Request {
                from: nekosim_protocols::APP,
                req: Request::Broadcast { msg: msg(2) },
            },
        ),
    ];
    let mut routed_a = Vec::new();
    for (l, i) in inputs.clone() {
        routed_a.extend(a.step_local(&wiring, &ctx, l, i));
    }
    let mut routed_b = Vec::new();
    for (l, i) in inputs {
        routed_b.extend(b.step_local(&wiring, &ctx, l, i));
    }
    assert!(!routed_a.is_empty());
    assert_eq!(routed_a, routed_b);
    // Lamport layers are built-ins in both and end in the same state.
    assert_eq!(a.layers[1], b.layers[1]);
    // The wrapped Fifo has the same state as the built-in one.
    let (Layer::Fifo(fa), Layer::Custom(cb)) = (&a.layers[0], &b.layers[0]) else {
        panic!("layer kinds");
    };
    assert_eq!(Some(fa), cb.downcast_ref::<Fifo>());
}

#[test]
fn custom_layers_compare_and_hash_by_value() {
    let reg = registry();
    let fresh = || reg.build("MyFifo", &BTreeMap::new()).expect("builds");
    let (x, y) = (fresh(), fresh());
    assert_eq!(x, y);
    assert_eq!(hash(&x), hash(&y));
    let mut z = x.clone();
    let mut out = nekosim_protocols::Out::new();
    z.protocol_mut().handle(
        &Ctx { me: 0, n: 2 },
        Input::Request {
            from: 1,
            req: Request::Send {
                to: vec![1],
                msg: Wire::app("M", Content::Int(1)),
            },
        },
        &mut out,
    );
    assert_ne!(x, z, "a step changes the state");
    assert_eq!(z.clone(), z);
    // Different protocol types never compare equal, even when both are fresh.
    let other = CustomLayer::new(LamportAbcast::default());
    assert_ne!(x, other);
    assert_eq!(x.name(), "Fifo");
}
