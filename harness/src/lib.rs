//! The world and robot cores called directly, in one process, in exactly the order the
//! process shells call them (after raft-rs's `harness/`): one lock-step loop for every
//! in-process caller (`swarm run --in-process`, sweeps, benchmarks), the Raft and radio test
//! networks, the fuzz drivers, and the full config loader the callers share.
//!
//! - [`lockstep`]: the tick loop (faults' restarts, observe, every running robot's step, the
//!   world's step).
//! - [`raft_net`]: Raft cores alone in an in-memory network with cut links.
//! - [`fuzz`]: real agents over the world's radio medium with crashes, restarts and
//!   partitions, checked every tick (`swarm fuzz`).
//! - [`load_config`]: a scenario as a run needs it.
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

pub mod fuzz;
pub mod lockstep;
pub mod raft_net;

use std::path::Path;

use swarmrt_scenario::{Config, ConfigError};
use swarmrt_world::World;

/// Loads a config as a run needs it: the file with `--set` overrides, the `[behaviour]`
/// parameters resolved by the behaviour that owns them, and the map and start layout built
/// once, so a bad obstacle or a crowded start is a user error before anything starts.
pub fn load_config(path: &Path, set: &[String]) -> Result<Config, ConfigError> {
    let cfg = swarmrt_agent::registry::load(path, set)?;
    World::new(&cfg, swarmrt_agent::registry::VOCABULARY).map_err(|e| ConfigError {
        file: path.display().to_string(),
        key: e.key,
        message: e.message,
    })?;
    Ok(cfg)
}
