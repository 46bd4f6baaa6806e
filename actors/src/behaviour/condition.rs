//! Waiting for a [`Condition`] (seed 7.2): what [`Behaviour::WaitFor`] waits for and what
//! ends an [`Behaviour::Until`].
//!
//! [`Behaviour::WaitFor`]: super::Behaviour::WaitFor
//! [`Behaviour::Until`]: super::Behaviour::Until

use super::runtime::{Runtime, Scope};
use super::tree::Condition;

impl Runtime {
    pub(super) async fn condition(&self, scope: &Scope, c: Condition) {
        match c {
            Condition::Time(t) => self.robot.sleep(t).await,
            Condition::Message => self.message().await,
            Condition::Proximity(range) => {
                let k = self.activate(scope, Some(range)).await;
                self.interrupt(k).await;
                self.deactivate(k).await;
            }
            Condition::Contact => {
                let k = self.activate(scope, None).await;
                self.interrupt(k).await;
                self.deactivate(k).await;
            }
        }
    }
}
