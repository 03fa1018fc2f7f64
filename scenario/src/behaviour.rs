//! `[behaviour]`: which behaviour every robot runs (`kind`) and its parameters, kept opaque
//! here. The behaviour that owns the parameters parses, defaults and validates them (the
//! registry in `swarmrt_agent::registry`), so adding a behaviour never touches this crate and
//! the world, which never reads them, does not rebuild when they change.

use serde::{Deserialize, Serialize};

/// The `[behaviour]` table: `kind` plus whatever keys that behaviour defines.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BehaviourSection {
    /// The behaviour's name, e.g. `"goto"` or `"formation"`.
    pub kind: String,
    /// Its parameters, in the order written (or, once resolved, in the order the behaviour
    /// declares them, defaults filled in).
    #[serde(flatten)]
    pub params: toml::Table,
}

impl Default for BehaviourSection {
    /// Go to the goal, with the behaviour's defaults (filled in when resolved).
    fn default() -> Self {
        BehaviourSection {
            kind: "goto".to_string(),
            params: toml::Table::new(),
        }
    }
}
