//! The motion manager actor (seed 4.2.3, fig. 4.4): brings robot states to the current time,
//! turns motion requests into motion events and predicts collisions, through the virtual
//! world it shares with the sensor manager.

use std::sync::{Arc, Mutex};

use actix::prelude::*;

use crate::scheduler::{Deliver, HandleEvent};
use crate::world::event::{Effect, Event, Outbox, Payload};
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

impl Actor for MotionManager {
    type Context = Context<Self>;
}

impl HandleEvent for MotionManager {
    fn handle_event(&mut self, msg: Deliver) -> Vec<Effect> {
        let mut out = Outbox::reusing(msg.now, msg.seq, msg.effects);
        // The scheduler has one event in flight at a time, so this lock is never contended.
        let mut world = self.world.lock().expect("world lock");
        world.handle_motion(msg.event.id, msg.event.payload, &mut out);
        out.into_effects()
    }

    fn prefetch(&self, next: Option<&Event>, after: Option<&Event>) {
        if let Ok(world) = self.world.try_lock() {
            world.prefetch(next.map(|e| e.concerns), after.map(|e| e.concerns));
            if let Some(Payload::CellCrossing { robot, offset }) = next.map(|e| &e.payload) {
                world.prefetch_crossing(*robot, *offset);
            }
        }
    }
}

crate::scheduler::hosted!(MotionManager);
