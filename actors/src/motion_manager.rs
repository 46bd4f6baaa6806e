//! The motion manager actor (seed 4.2.3, fig. 4.4): brings robot states to the current time,
//! turns motion requests into motion events and predicts collisions, through the virtual
//! world it shares with the sensor manager.

use std::sync::{Arc, Mutex};

use crate::handler::HandleEvent;
use crate::world::event::Event;
use crate::world::outbox::Outbox;
use crate::world::virtual_world::VirtualWorld;

/// The motion manager.
#[derive(Debug)]
pub struct MotionManager {
    world: Arc<Mutex<VirtualWorld>>,
}

impl MotionManager {
    /// A motion manager over `world`.
    pub fn new(world: Arc<Mutex<VirtualWorld>>) -> Self {
        Self { world }
    }
}

impl HandleEvent for MotionManager {
    fn handle_event(&mut self, event: Event, out: &mut Outbox) {
        // The scheduler has one event in flight at a time, so this lock is never contended.
        let mut world = self.world.lock().expect("world lock");
        world.handle_motion(event.id, event.payload, out);
    }
}
