//! The JSON Lines trace: one object per observation, schema in docs/trace.md. Every object has
//! `t` (seconds), `seq` (strictly increasing) and `kind`, in that order.

use nekosim_actors::world::geometry::{Point, Vector};
use nekosim_actors::world::observation::{Observation, Record};
use nekosim_actors::world::{MotionOutcome, Obstacle};
use serde_json::{json, Map, Value};

use crate::log::wire_text;
use nekosim_protocols::payload::type_word;

fn pt(p: Point) -> Value {
    json!([p.x, p.y])
}

fn vec2(v: Vector) -> Value {
    json!([v.x, v.y])
}

fn obstacle(o: Obstacle) -> Value {
    match o {
        Obstacle::Robot(id) => json!(id),
        Obstacle::Boundary => json!("boundary"),
    }
}

/// Names of the fields every object has; custom motion parameters never take them.
const RESERVED: [&str; 6] = ["t", "seq", "kind", "robot", "ticket", "motion"];

/// The trace object of an observation.
pub fn to_json(r: &Record) -> Value {
    let mut m = Map::new();
    m.insert("t".into(), json!(r.t));
    m.insert("seq".into(), json!(r.seq));
    let mut put = |k: &str, v: Value| {
        m.insert(k.to_string(), v);
    };
    match &r.obs {
        Observation::Spawn {
            robot,
            pos,
            angle,
            radius,
        } => {
            put("kind", json!("spawn"));
            put("robot", json!(robot));
            put("pos", pt(*pos));
            put("angle", json!(angle));
            put("radius", json!(radius));
        }
        Observation::MotionRequest {
            robot,
            ticket,
            motion,
            params,
        } => {
            put("kind", json!("motion_request"));
            put("robot", json!(robot));
            put("ticket", json!(ticket));
            put("motion", json!(motion));
            for (k, v) in params {
                if !RESERVED.contains(&k.as_str()) {
                    put(k, json!(v));
                }
            }
        }
        Observation::MotionStep {
            robot, step, state, ..
        } => {
            put("kind", json!(step.name()));
            put("robot", json!(robot));
            put("pos", pt(state.pos));
            put("angle", json!(state.angle));
            put("vel", vec2(state.vel));
            put("omega", json!(state.omega));
        }
        Observation::MotionFinish {
            robot,
            state,
            outcome,
        } => {
            put("kind", json!("motion_finish"));
            put("robot", json!(robot));
            put("pos", pt(state.pos));
            put("angle", json!(state.angle));
            put("outcome", json!(outcome.name()));
            match outcome {
                MotionOutcome::Collided { with } => put("other", obstacle(*with)),
                MotionOutcome::Rejected(reason) => put("reason", json!(reason)),
                _ => {}
            }
        }
        Observation::Collision {
            robot,
            other,
            pos,
            angle,
            other_pos,
        } => {
            put("kind", json!("collision"));
            put("robot", json!(robot));
            put("other", obstacle(*other));
            put("pos", pt(*pos));
            put("angle", json!(angle));
            put("other_pos", pt(*other_pos));
        }
        Observation::SensorRequest { robot, query, .. } => {
            put("kind", json!("sensor_request"));
            put("robot", json!(robot));
            put("sensor", json!(query.kind().name()));
            put("value", json!(query));
        }
        Observation::Log { robot, text } => {
            put("kind", json!("log"));
            put("robot", json!(robot));
            put("text", json!(text));
        }
        Observation::Request {
            robot,
            layer,
            op,
            msg,
        } => {
            put("kind", json!("request"));
            put("robot", json!(robot));
            put("layer", json!(layer));
            put("op", json!(op));
            put("msg", json!(wire_text(msg)));
        }
        Observation::Send {
            robot,
            to,
            layer,
            msg,
        } => {
            put("kind", json!("send"));
            put("robot", json!(robot));
            put("to", json!(to));
            put("layer", json!(layer));
            let text = wire_text(msg);
            let ty = type_word(&text).to_string();
            put("msg", json!(text));
            put("type", json!(ty));
        }
        Observation::Receive {
            robot,
            from,
            layer,
            msg,
        } => {
            put("kind", json!("receive"));
            put("robot", json!(robot));
            put("from", json!(from));
            put("layer", json!(layer));
            let text = wire_text(msg);
            let ty = type_word(&text).to_string();
            put("msg", json!(text));
            put("type", json!(ty));
        }
        Observation::Deliver {
            robot,
            layer,
            id,
            msg,
        } => {
            put("kind", json!("deliver"));
            put("robot", json!(robot));
            put("layer", json!(layer));
            put("msg", json!(id.to_string()));
            put("origin", json!(id.origin));
            put("content", json!(wire_text(msg)));
        }
        Observation::Decide {
            robot,
            layer,
            k,
            value,
        } => {
            put("kind", json!("decide"));
            put("robot", json!(robot));
            put("layer", json!(layer));
            put("instance", json!(k));
            put("value", json!(wire_text(value)));
        }
        Observation::Suspect {
            robot,
            layer,
            process,
        }
        | Observation::Trust {
            robot,
            layer,
            process,
        }
        | Observation::Leader {
            robot,
            layer,
            process,
        } => {
            let kind = match &r.obs {
                Observation::Suspect { .. } => "suspect",
                Observation::Trust { .. } => "trust",
                _ => "leader",
            };
            put("kind", json!(kind));
            put("robot", json!(robot));
            put("layer", json!(layer));
            put("process", json!(process));
        }
        Observation::Crash { robot, state } => {
            put("kind", json!("crash"));
            put("robot", json!(robot));
            put("pos", pt(state.pos));
            put("angle", json!(state.angle));
        }
        Observation::SensorReply {
            robot,
            sensor,
            value,
            interrupt,
        } => {
            put("kind", json!("sensor_reply"));
            put("robot", json!(robot));
            put("sensor", json!(sensor.name()));
            put("value", json!(value));
            put("interrupt", json!(interrupt));
        }
    }
    Value::Object(m)
}
