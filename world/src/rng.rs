//! Seeded random streams; defined in the scenario crate so robots draw the same way.

pub use swarmrt_scenario::rng::*;
