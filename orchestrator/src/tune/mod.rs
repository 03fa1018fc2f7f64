//! The pieces of `swarm tune`: the optimiser as a pure state machine ([`pso`]).

pub mod pso;
