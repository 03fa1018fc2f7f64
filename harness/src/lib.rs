//! The world and robot cores called directly, in one process, in exactly the order the
//! process shells call them (after raft-rs's `harness/`): one lock-step loop for every
//! in-process caller (`swarm run --in-process`, sweeps, benchmarks), the Raft and radio test
//! networks, the fuzz drivers, and the one config loader every command shares.
//!
//! - [`lockstep`]: the tick loop (faults' restarts, observe, every running robot's step, the
//!   world's step).
//! - [`env`]: a learning environment's world, the tick split around a policy that answers
//!   between its halves (the Python package's `swarmrt.env`).
//! - [`raft_net`]: Raft cores alone in an in-memory network with cut links.
//! - [`fuzz`]: real agents over the world's radio medium with crashes, restarts and
//!   partitions, checked every tick (`swarm fuzz`).
//! - [`consensus_check`]: Raft's safety properties and the consensus metrics, from the notes
//!   alone (`events.jsonl`, or the fuzz drivers' note stream in memory).
//! - [`config`]: [`config::load_run_config`], a scenario file and its `--set` as a run needs
//!   them (schema and bounds, `[behaviour]`, map and start layout, robot programs).
//!
//! ```
//! use swarmrt_harness::lockstep::Lockstep;
//!
//! let cfg = swarmrt_agent::registry::from_toml_str("doc.toml", r#"
//!     [scenario]
//!     name = "doc"
//!     ticks = 20
//!     [map]
//!     bounds = [0.0, 0.0, 10.0, 10.0]
//!     goal = { x = 8.0, y = 2.0, radius = 1.0 }
//!     [robots]
//!     count = 2
//! "#, &[]).unwrap();
//! let mut run = Lockstep::new(&cfg).unwrap();
//! while !run.world().finished() {
//!     run.step();
//! }
//! assert_eq!(run.world().tick(), 20);
//! assert!(run.world().robots()[0].x > 2.0, "the goal is ahead");
//! ```
#![warn(missing_docs)]

pub mod config;
pub mod consensus_check;
pub mod env;
pub mod fuzz;
pub mod lockstep;
pub mod raft_net;
