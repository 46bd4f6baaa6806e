//! The families of services the checker knows: what a layer promises, which decides the
//! properties checked ([`crate::property`]).

use nekosim_protocols::Service;

/// What a protocol promises, which decides the properties checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Total-order (atomic) broadcast.
    Abcast,
    /// Reliable broadcast (no order).
    Broadcast,
    /// Consensus.
    Consensus,
    /// Point-to-point messages, with per-link FIFO order when `fifo`.
    P2p { fifo: bool },
    /// A failure detector (suspicions and trust).
    FailureDetector,
    /// Leader election (Omega).
    Leader,
}

impl Family {
    /// The family whose properties a layer providing `service` promises: the most specific
    /// first (a total-order broadcast is a broadcast, FIFO links are links; a user's service
    /// that implies one of these is checked as that one).
    pub fn of(service: Service) -> Option<Self> {
        [
            (Service::TOTAL_ORDER, Self::Abcast),
            (Service::BROADCAST, Self::Broadcast),
            (Service::CONSENSUS, Self::Consensus),
            (Service::FIFO_P2P, Self::P2p { fifo: true }),
            (Service::P2P, Self::P2p { fifo: false }),
            (Service::FAILURE_DETECTOR, Self::FailureDetector),
            (Service::LEADER, Self::Leader),
        ]
        .into_iter()
        .find(|(s, _)| service.serves(*s))
        .map(|(_, f)| f)
    }

    /// Whether the application issues requests to it (a failure detector and a leader
    /// election only tell).
    pub fn takes_requests(self) -> bool {
        !matches!(self, Self::FailureDetector | Self::Leader)
    }

    /// The service's name as reports print it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Abcast => "total-order broadcast",
            Self::Broadcast => "broadcast",
            Self::Consensus => "consensus",
            Self::P2p { fifo: true } => "FIFO point-to-point messages",
            Self::P2p { fifo: false } => "point-to-point messages",
            Self::FailureDetector => "failure detector",
            Self::Leader => "leader election",
        }
    }
}
