//! Stateright models that explore the interleavings of the protocols in `nekosim-protocols`
//! (the same code the simulator runs). Filled by the model-checking issue.
