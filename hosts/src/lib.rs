//! One swarm across several hosts (issue 16). The world stays on one host; groups of robots
//! run on others, each beside a `swarm-host` process. Inside a host iceoryx2 stays the
//! transport; between hosts, Zenoh carries two messages per remote host per tick.
//!
//! - [`hosts_file`]: `hosts.toml`, which host runs which robots.
//! - [`wire`]: the messages on the link and their bytes.
//! - [`link`]: Zenoh sessions, key expressions, the handshake's layout hash.
//! - [`world_side`]: the world's end of the link.
//! - [`noise`]: refused TLS handshakes, counted and summarised instead of logged one by one.
//!
//! The `swarm-host` process itself is `swarmrt_runtime::host`, beside the other process shells.

pub mod certs;
pub mod hosts_file;
pub mod link;
pub mod noise;
pub mod wire;
pub mod world_side;

pub use hosts_file::{Host, HostsFile};
