//! The process shells around the pure cores: each moves a core's inputs and outputs through
//! iceoryx2 (and Zenoh for remote hosts) and does nothing else.
//!
//! - [`world`]: the `swarm-world` process around `swarmrt_world::World`: creates the run's
//!   services, binds robots by their hello, runs lock-step (or realtime) ticks, relays remote
//!   hosts, writes the records.
//! - [`robot`]: the `swarm-agent` process around `swarmrt_agent::Agent`: says hello, sleeps
//!   until a tick, answers it.
//! - [`host`]: the `swarm-host` process: a remote host's stand-in for the world.
//! - [`inbox`]: the command inbox every shell reads its robots' answers through.
//! - [`supervisor`]: the robot process lifecycle all three drive (spawn, hello binding,
//!   kill, freeze, thaw, restart, reap, shut down), a pure state machine.
#![warn(missing_docs)]

pub mod host;
pub mod inbox;
pub mod robot;
pub mod supervisor;
pub mod world;
