//! The network actor (seed 3.4, fig. 3.8): robots and layers hand it messages; it decides with
//! the scenario's network model when (and whether) each copy arrives and schedules the arrival
//! at the destination's layer, or at its algorithm for direct messages.

use std::sync::{Arc, Mutex};

use nekosim_protocols::{Indication, Input, APP, NET};

use crate::handler::HandleEvent;
use crate::world::event::{Event, EventClass, Notice, Payload, Target};
use crate::world::network::Network;
use crate::world::observation::Observation;
use crate::world::outbox::Outbox;
use crate::world::virtual_world::VirtualWorld;

/// The simulated network.
#[derive(Debug)]
pub struct NetworkActor {
    net: Network,
    /// Read-only: positions for radio networks.
    world: Arc<Mutex<VirtualWorld>>,
    /// Names of the stack's layers, for traces.
    wiring: Arc<nekosim_protocols::Wiring>,
}

impl NetworkActor {
    /// A network actor.
    pub fn new(
        net: Network,
        world: Arc<Mutex<VirtualWorld>>,
        wiring: Arc<nekosim_protocols::Wiring>,
    ) -> Self {
        Self { net, world, wiring }
    }
}

impl HandleEvent for NetworkActor {
    fn handle_event(&mut self, event: Event, out: &mut Outbox) {
        let now = out.now();
        if let Payload::NetSend {
            from,
            layer,
            to,
            msg,
        } = event.payload
        {
            let world = self.world.lock().expect("world lock");
            let pos = |id| world.state_at(id, now).pos;
            let blocked = |a, b| world.obstacles().blocks(a, b);
            let copies = self.net.transmit_among(now, from, &to, &pos, &blocked);
            drop(world);
            out.record(Observation::Send {
                robot: from,
                to: to.to_vec(),
                layer: crate::layer::layer_name(&self.wiring, layer),
                msg: (*msg).clone(),
                arrive: if copies.iter().map(|(d, _)| d).eq(to.iter()) {
                    copies.iter().map(|(_, at)| *at).collect()
                } else {
                    to.iter()
                        .map(|d| copies.iter().find(|(c, _)| c == d).and_then(|(_, at)| *at))
                        .collect()
                },
            });
            for (d, at) in copies {
                let Some(at) = at else { continue };
                let ind = Indication::Deliver {
                    from,
                    msg: (*msg).clone(),
                };
                if layer == APP {
                    out.schedule(
                        at,
                        Target::Robot(d),
                        EventClass::Eventual,
                        [Some(d), None],
                        Payload::Notice(Box::new(Notice::Incoming { layer: NET, ind })),
                    );
                } else {
                    out.schedule(
                        at,
                        Target::Layer(d, layer),
                        EventClass::Eventual,
                        [Some(d), None],
                        Payload::LayerInput {
                            robot: d,
                            layer,
                            input: Box::new(Input::Indication { from: NET, ind }),
                        },
                    );
                }
            }
        }
    }
}
