//! Sans-IO microprotocols (seed 3.5): deterministic state machines whose effects are data, so
//! the simulator's actors and the stateright models run the very same code. Filled by the
//! communication issue.
