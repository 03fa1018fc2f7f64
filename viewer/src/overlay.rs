//! What the viewer asks of a behaviour: its roles and colours, and what its notes mean. The
//! answers come from the behaviour's own folder (`agent/src/behaviours/<name>/overlay.rs`,
//! through the registry), so a new behaviour brings its overlay without touching the viewer.

use serde_json::Value;

pub use swarmrt_agent::overlay::{Headline, LaneChange, RoleDef};

/// What one recorded note means on the page.
#[derive(Debug, Default)]
pub struct Meaning {
    /// The role its robot is in after reporting it, if it changed.
    pub role: Option<u8>,
    /// A timeline mark.
    pub headline: Option<Headline>,
    /// The consensus lane change it makes.
    pub lane: Option<LaneChange>,
}

/// A behaviour's overlay, as the viewer uses it. Notes are the `note` field of a recorded
/// note event, as JSON, read once each.
pub trait Overlay: Send + Sync {
    /// The roles, indexed by the role byte.
    fn roles(&self) -> &'static [RoleDef];
    /// Robot `id`'s role at the start.
    fn initial_role(&self, id: u32) -> Option<u8>;
    /// What `note`, reported by robot `id`, means.
    fn read(&self, id: u32, note: &Value) -> Meaning;
}
