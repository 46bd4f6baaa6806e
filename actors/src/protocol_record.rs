//! What a hosted protocol stack shows in a run's records (seed 3.5, 5.3): the one mapping from
//! a layer's requests, arrivals and indications to [`Observation`]s. Every host of a stack
//! uses it (the simulator's layer and robot actors, the real-network node, the model
//! checker's paths), so their traces and logs say the same things in the same words.

use nekosim_protocols::{Indication, LayerIx, Payload, Request, Wiring, APP, NET};

use crate::world::observation::Observation;
use crate::world::RobotId;

/// Name of a layer in records: its id, `"net"` or `"app"`.
pub fn layer_name(wiring: &Wiring, ix: LayerIx) -> String {
    match ix {
        NET => "net".into(),
        APP => "app".into(),
        i => wiring
            .ids
            .get(i as usize)
            .cloned()
            .unwrap_or_else(|| format!("layer{i}")),
    }
}

/// The application of `robot` asked layer `layer` for `req`: the record names the request's
/// kind (`broadcast`, `propose`, `send`, `request`) and carries its message.
pub fn request(robot: RobotId, layer: String, req: &Request) -> Observation {
    let (op, msg) = match req {
        Request::Broadcast { msg } => ("broadcast", msg),
        Request::Propose { value, .. } => ("propose", value),
        Request::Send { msg, .. } => ("send", msg),
        Request::Custom(msg) => ("request", msg),
    };
    Observation::Request {
        robot,
        layer,
        op: op.into(),
        msg: msg.clone(),
    }
}

/// `msg` from `from` arrived from the network at layer `layer` of `robot`.
pub fn receive(robot: RobotId, layer: String, from: RobotId, msg: &Payload) -> Observation {
    Observation::Receive {
        robot,
        from,
        layer,
        msg: msg.clone(),
    }
}

/// Layer `layer` of `robot` indicated `ind`: a delivery, a decision or what a failure detector
/// tells; `None` for a point-to-point delivery (its arrival from the network is recorded as
/// a receive) and for a protocol's own indications.
pub fn indication(robot: RobotId, layer: String, ind: &Indication) -> Option<Observation> {
    Some(match ind {
        Indication::BDeliver { id, msg } => Observation::Deliver {
            robot,
            layer,
            id: *id,
            msg: msg.clone(),
        },
        Indication::Decide { k, value } => Observation::Decide {
            robot,
            layer,
            k: *k,
            value: value.clone(),
        },
        Indication::Suspect(p) => Observation::Suspect {
            robot,
            layer,
            process: *p,
        },
        Indication::Trust(p) => Observation::Trust {
            robot,
            layer,
            process: *p,
        },
        Indication::Leader(p) => Observation::Leader {
            robot,
            layer,
            process: *p,
        },
        Indication::Deliver { .. } | Indication::Custom(_) => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nekosim_protocols::{app_payload, MsgId};

    #[test]
    fn a_request_is_named_by_its_kind_and_carries_its_message() {
        let m = app_payload(&"m");
        let cases = [
            (Request::Broadcast { msg: m.clone() }, "broadcast"),
            (
                Request::Propose {
                    k: 3,
                    value: m.clone(),
                },
                "propose",
            ),
            (
                Request::Send {
                    to: vec![1],
                    msg: m.clone(),
                },
                "send",
            ),
            (Request::Custom(m.clone()), "request"),
        ];
        for (req, word) in cases {
            assert_eq!(
                request(4, "l".into(), &req),
                Observation::Request {
                    robot: 4,
                    layer: "l".into(),
                    op: word.into(),
                    msg: m.clone(),
                }
            );
        }
    }

    #[test]
    fn deliveries_decisions_and_detector_news_are_recorded_and_nothing_else() {
        let m = app_payload(&"m");
        let id = MsgId { origin: 2, n: 7 };
        let at = |ind: &Indication| indication(1, "x".into(), ind);
        assert_eq!(
            at(&Indication::BDeliver { id, msg: m.clone() }),
            Some(Observation::Deliver {
                robot: 1,
                layer: "x".into(),
                id,
                msg: m.clone(),
            })
        );
        assert_eq!(
            at(&Indication::Decide {
                k: 5,
                value: m.clone()
            }),
            Some(Observation::Decide {
                robot: 1,
                layer: "x".into(),
                k: 5,
                value: m.clone(),
            })
        );
        assert_eq!(
            at(&Indication::Suspect(0)),
            Some(Observation::Suspect {
                robot: 1,
                layer: "x".into(),
                process: 0,
            })
        );
        assert_eq!(
            at(&Indication::Trust(0)),
            Some(Observation::Trust {
                robot: 1,
                layer: "x".into(),
                process: 0,
            })
        );
        assert_eq!(
            at(&Indication::Leader(2)),
            Some(Observation::Leader {
                robot: 1,
                layer: "x".into(),
                process: 2,
            })
        );
        assert_eq!(
            at(&Indication::Deliver {
                from: 0,
                msg: m.clone()
            }),
            None
        );
        assert_eq!(at(&Indication::Custom(m)), None);
    }
}
