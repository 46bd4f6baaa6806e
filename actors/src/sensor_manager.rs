//! The sensor manager actor (seed 4.2.3, fig. 4.5): turns sensor requests into sensor events,
//! gathers the world's exact data for each sensor at trigger time and re-arms push sensors.
//! It owns its state (the sensors and every robot's armed push sensors, [`Sensing`]) and
//! reads the world it shares with the motion manager.

use std::sync::{Arc, Mutex};

use crate::handler::HandleEvent;
use crate::world::event::Event;
use crate::world::outbox::Outbox;
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

impl HandleEvent for SensorManager {
    fn handle_event(&mut self, event: Event, out: &mut Outbox) {
        let mut world = self.world.lock().expect("world lock");
        self.sensing.handle(&mut world, event.payload, out);
    }
}
