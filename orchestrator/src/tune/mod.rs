//! The pieces of `swarm tune` (the command itself is `commands/tune.rs`, the algorithm and its
//! defaults `docs/tune.md`): the optimiser as a pure state machine ([`pso`]), the tuned keys
//! and their bounds ([`space`]), and what a tune writes and reads back to resume
//! ([`record`]). Runs go through the sweep's pool (`sweep::runner`); the figures are
//! `swarmrt_analysis::plot::tune`.

pub mod pso;
pub mod record;
pub mod space;
