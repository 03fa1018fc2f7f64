//! The agent crate's integration tests, one binary (one link) for all of them: what crosses
//! the crate's public face (configs and their reference, the consensus layer inside the
//! agent, stable storage, the registry, the viewer overlay, metrics from notes, the wire
//! tags). Each behaviour's own tests sit beside it, in `src/behaviours/<name>/tests.rs`.

mod config_fuzz;
mod config_reference;
mod consensus;
mod consensus_wire;
#[path = "../common/mutate.rs"]
mod mutate;
mod note_metrics;
mod overlay;
mod registry;
mod storage;
mod wire_tags;
