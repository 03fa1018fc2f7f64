//! Seeded random streams; defined in the protocol crate so robots draw the same way.

pub use swarmrt_protocol::rng::*;
