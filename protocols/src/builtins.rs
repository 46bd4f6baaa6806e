//! The built-in protocols (Neko's protocol library, seed 3.5), registered through the same
//! [`Protocols::protocol`] call a user's protocol is. Adding one is its own module plus one
//! line here.

use crate::registry::Protocols;

/// Registers every built-in protocol under its scenario name.
pub fn register(r: &mut Protocols) {
    r.protocol::<crate::fifo::Fifo>("Fifo")
        .protocol::<crate::retransmit::Retransmit>("Retransmit")
        .protocol::<crate::rbroadcast::ReliableBroadcast>("ReliableBroadcast")
        .protocol::<crate::lamport::LamportAbcast>("LamportAbcast")
        .protocol::<crate::sequencer::FixedSequencer>("FixedSequencer")
        .protocol::<crate::heartbeat::Heartbeat>("Heartbeat")
        .protocol::<crate::omega::Omega>("Omega")
        .protocol::<crate::consensus::ChandraToueg>("ChandraToueg")
        .protocol::<crate::consensus_abcast::ConsensusAbcast>("ConsensusAbcast");
}

// The registry itself knows no protocol; these constructors live here so that the registry
// does not depend on the protocols it registers.
impl Protocols {
    /// The built-in protocols (the same as [`Protocols::with_builtins`]).
    pub fn new() -> Self {
        Self::with_builtins()
    }

    /// Every built-in protocol of [`crate::builtins`], under its name.
    pub fn with_builtins() -> Self {
        let mut r = Self::empty();
        register(&mut r);
        r
    }
}

impl Default for Protocols {
    /// [`Protocols::with_builtins`].
    fn default() -> Self {
        Self::with_builtins()
    }
}
