//! Protocol layer actors (seed 3.5): each microprotocol instance of each robot is hosted by an
//! actor. The instance is the sans-IO state machine of `nekosim-protocols`; the actor turns
//! its routed effects into events of the virtual-time scheduler (hops to other layers and to
//! the network happen "now", timers at now + delay), so every hop is ordered and deterministic.

use std::collections::BTreeMap;
use std::sync::Arc;

use nekosim_protocols::stack::{step_layer, Routed, Wiring};
use nekosim_protocols::Layer;
use nekosim_protocols::{Ctx, Indication, Input, LayerIx, Payload as MsgPayload, NET};

use crate::handler::HandleEvent;
use crate::protocol_record;
pub use crate::protocol_record::layer_name;
use crate::world::event::{Event, EventClass, Notice, Payload, Target};
use crate::world::outbox::Outbox;
use crate::world::RobotId;

/// One protocol instance of one robot.
#[derive(Debug)]
pub struct LayerActor {
    robot: RobotId,
    ix: LayerIx,
    layer: Layer,
    wiring: Arc<Wiring>,
    ctx: Ctx,
    /// Current generation of each timer; a firing of an older generation was cancelled.
    timers: BTreeMap<MsgPayload, u64>,
}

impl LayerActor {
    /// Hosts `layer`, the `ix`-th layer of `robot`'s stack, among `n` processes.
    pub fn new(robot: RobotId, ix: LayerIx, layer: Layer, wiring: Arc<Wiring>, n: u32) -> Self {
        Self {
            robot,
            ix,
            layer,
            wiring,
            ctx: Ctx { me: robot, n },
            timers: BTreeMap::new(),
        }
    }
}

/// Carries out routed effects of layer `ix` of `robot`: the shared part of layer actors and of
/// the robot actor (whose requests go to the network or a layer the same way).
pub fn route_effects(
    robot: RobotId,
    wiring: &Wiring,
    routed: Vec<Routed>,
    timers: &mut BTreeMap<MsgPayload, u64>,
    out: &mut Outbox,
) {
    let now = out.now();
    let me = [Some(robot), None];
    for r in routed {
        match r {
            Routed::Layer { to, input } => {
                out.schedule(
                    now,
                    Target::Layer(robot, to),
                    EventClass::Eventual,
                    me,
                    Payload::LayerInput {
                        robot,
                        layer: to,
                        input: Box::new(input),
                    },
                );
            }
            Routed::Net { layer, to, msg } => {
                out.schedule(
                    now,
                    Target::Network,
                    EventClass::Eventual,
                    me,
                    Payload::NetSend {
                        from: robot,
                        layer,
                        to: to.into_boxed_slice(),
                        msg: Box::new(msg),
                    },
                );
            }
            Routed::App { layer, ind } => {
                let name = layer_name(wiring, layer);
                if let Some(obs) = protocol_record::indication(robot, name, &ind) {
                    out.record(obs);
                }
                out.notify(robot, Notice::Incoming { layer, ind });
            }
            Routed::SetTimer {
                layer,
                timer,
                after,
            } => {
                let generation = timers.entry(timer.clone()).or_insert(0);
                *generation += 1;
                out.schedule(
                    now + after.get().max(0.0),
                    Target::Layer(robot, layer),
                    EventClass::Eventual,
                    me,
                    Payload::LayerTimer {
                        robot,
                        layer,
                        timer: Box::new(timer),
                        generation: *generation,
                    },
                );
            }
            Routed::CancelTimer { timer, .. } => {
                *timers.entry(timer).or_insert(0) += 1;
            }
        }
    }
}

impl HandleEvent for LayerActor {
    fn handle_event(&mut self, event: Event, out: &mut Outbox) {
        let input = match event.payload {
            Payload::LayerInput { input, .. } => {
                if let Input::Indication {
                    from: NET,
                    ind: Indication::Deliver { from, msg },
                } = &*input
                {
                    let name = layer_name(&self.wiring, self.ix);
                    out.record(protocol_record::receive(self.robot, name, *from, msg));
                }
                Some(*input)
            }
            Payload::LayerTimer {
                timer, generation, ..
            } => (self.timers.get(&*timer) == Some(&generation)).then_some(Input::Timer(*timer)),
            _ => None,
        };
        if let Some(input) = input {
            match step_layer(&mut self.layer, &self.wiring, &self.ctx, self.ix, input) {
                Ok(routed) => {
                    route_effects(self.robot, &self.wiring, routed, &mut self.timers, out)
                }
                // The simulator only carries payloads the stack encoded itself.
                Err(e) => tracing::error!(robot = self.robot, layer = self.ix, "{e}"),
            }
        }
    }
}
