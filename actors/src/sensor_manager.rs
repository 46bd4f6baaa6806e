//! The sensor manager actor (seed 4.2.3, fig. 4.5): turns sensor requests into sensor events,
//! gathers the world's exact data for each sensor at trigger time and re-arms push sensors.
//! It owns its state (the sensors and every robot's armed push sensors, [`Sensing`]) and
//! reads the world it shares with the motion manager.

use std::sync::{Arc, Mutex};

use actix::prelude::*;

use crate::scheduler::{Deliver, HandleEvent};
use crate::world::event::Outbox;
use crate::world::virtual_world::{Sensing, VirtualWorld};

/// The sensor manager.
#[derive(Debug)]
pub struct SensorManager {
    world: Arc<Mutex<VirtualWorld>>,
    sensing: Sensing,
}

impl SensorManager {
    /// A sensor manager over `world`, with its own state `sensing`.
    pub fn new(world: Arc<Mutex<VirtualWorld>>, sensing: Sensing) -> Self {
        Self { world, sensing }
    }
}

impl Actor for SensorManager {
    type Context = Context<Self>;
}

impl HandleEvent for SensorManager {
    fn handle_event(&mut self, msg: Deliver) -> Vec<crate::world::event::Effect> {
        let mut out = Outbox::reusing(msg.now, msg.seq, msg.effects);
        let mut world = self.world.lock().expect("world lock");
        self.sensing.handle(&mut world, msg.event.payload, &mut out);
        out.into_effects()
    }
}

crate::scheduler::hosted!(SensorManager);
