//! A run directory written in other formats, for other tools (`swarm export`).
//!
//! - [`mcap`]: the run as an MCAP file with Foxglove's well-known schemas (the Foxglove app,
//!   Lichtblick, any MCAP reader).

pub mod mcap;
