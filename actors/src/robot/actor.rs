//! The robot actor (seed 4.1): the host-free handler that runs one robot's algorithm. Each
//! event that concerns the robot wakes it; it polls the algorithm's future until it is
//! pending and turns every request the algorithm made meanwhile into a scheduled event.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::fmt;
use std::rc::Rc;
use std::task::{Context as TaskContext, Waker};

use super::{
    Algorithm, AlgorithmFuture, Request, Robot, RobotInfo, RobotIo, Shared, Spare, Stream,
};
use crate::handler::HandleEvent;
use crate::world::event::{Event, EventClass, Notice, Payload, Target};
use crate::world::observation::Observation;
use crate::world::outbox::Outbox;
use nekosim_protocols::{Indication, Input, APP, NET};

/// The robot actor: hosts one algorithm.
pub struct RobotActor {
    pub(super) handle: Robot,
    algorithm: Box<dyn Algorithm>,
    task: Option<AlgorithmFuture>,
}

impl fmt::Debug for RobotActor {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RobotActor")
            .field("robot", &self.handle.shared.info)
            .field("algorithm", &self.algorithm.name())
            .field("running", &self.task.is_some())
            .finish()
    }
}

impl RobotActor {
    /// A robot running `algorithm`, with a random stream derived from `seed` and its id.
    pub fn new(
        info: RobotInfo,
        algorithm: Box<dyn Algorithm>,
        seed: u64,
        layers: std::sync::Arc<Vec<String>>,
    ) -> Self {
        Self {
            handle: Robot {
                shared: Rc::new(Shared {
                    info,
                    layers,
                    io: RefCell::new(RobotIo {
                        now: 0.0,
                        next_ticket: 0,
                        inbox: VecDeque::new(),
                        outbox: Vec::new(),
                        rng: Stream::new(seed),
                    }),
                }),
            },
            algorithm,
            task: None,
        }
    }
}

impl HandleEvent for RobotActor {
    fn handle_event(&mut self, event: Event, out: &mut Outbox) {
        let now = out.now();
        let id = self.handle.shared.info.id;
        {
            let mut io = self.handle.shared.io.borrow_mut();
            io.now = now;
            Spare::lend(&mut io);
        }
        match event.payload {
            Payload::Notice(n) if matches!(*n, Notice::Start) => {
                self.task = Some(self.algorithm.run(self.handle.clone()));
            }
            Payload::Notice(n) => {
                let n = *n;
                if let Notice::Incoming {
                    layer: NET,
                    ind: Indication::Deliver { from, msg },
                } = &n
                {
                    out.record(Observation::Receive {
                        robot: id,
                        from: *from,
                        layer: "app".into(),
                        msg: msg.clone(),
                    });
                }
                self.handle.shared.io.borrow_mut().inbox.push_back(n)
            }
            Payload::Timer { ticket, .. } => self
                .handle
                .shared
                .io
                .borrow_mut()
                .inbox
                .push_back(Notice::Timer { ticket }),
            _ => {}
        }
        if let Some(task) = self.task.as_mut() {
            let mut cx = TaskContext::from_waker(Waker::noop());
            if task.as_mut().poll(&mut cx).is_ready() {
                self.task = None;
            }
        }
        let mut requests = {
            let mut io = self.handle.shared.io.borrow_mut();
            io.rng.rest();
            std::mem::take(&mut io.outbox)
        };
        let me = [Some(id), None];
        for r in requests.drain(..) {
            match r {
                Request::Motion {
                    ticket,
                    motion,
                    at,
                    note,
                } => out.schedule(
                    at.max(now),
                    Target::MotionManager,
                    EventClass::Eventual,
                    me,
                    Payload::MotionRequest {
                        robot: id,
                        ticket,
                        motion: Box::new(motion),
                        note: note.map(Box::new),
                    },
                ),
                Request::Sensor { ticket, query, at } => out.schedule(
                    at.max(now),
                    Target::SensorManager,
                    EventClass::Eventual,
                    me,
                    Payload::SensorRequest {
                        robot: id,
                        ticket,
                        query: Box::new(query),
                    },
                ),
                Request::Timer { ticket, at } => out.schedule(
                    at,
                    Target::Robot(id),
                    EventClass::Eventual,
                    me,
                    Payload::Timer { robot: id, ticket },
                ),
                Request::Net { to, msg: wire } => out.schedule(
                    now,
                    Target::Network,
                    EventClass::Eventual,
                    me,
                    Payload::NetSend {
                        from: id,
                        layer: APP,
                        to: to.into_boxed_slice(),
                        msg: Box::new(wire),
                    },
                ),
                Request::Layer { ix, req } => {
                    out.record(crate::protocol_record::request(
                        id,
                        self.handle.layer_id(ix),
                        &req,
                    ));
                    out.schedule(
                        now,
                        Target::Layer(id, ix),
                        EventClass::Eventual,
                        me,
                        Payload::LayerInput {
                            robot: id,
                            layer: ix,
                            input: Box::new(Input::Request { from: APP, req }),
                        },
                    )
                }
                Request::ListEvents { of, ticket } => out.schedule(
                    now,
                    Target::EventManager,
                    EventClass::Eventual,
                    me,
                    Payload::ListEvents {
                        robot: id,
                        of,
                        ticket,
                    },
                ),
                Request::Log(text) => {
                    out.record(Observation::Log { robot: id, text });
                    continue;
                }
                Request::Record(obs) => {
                    out.record(obs);
                    continue;
                }
                Request::Light(light) => out.schedule(
                    now,
                    Target::SensorManager,
                    EventClass::Eventual,
                    me,
                    Payload::Light { robot: id, light },
                ),
            };
        }
        // An inbox is nearly always empty between handlings, and its buffer (four 80-byte
        // notices once a notice came) kept by each robot would take over a hundred megabytes
        // in a long run at a million robots.
        Spare::take_back(&mut self.handle.shared.io.borrow_mut().inbox, requests);
    }
}
