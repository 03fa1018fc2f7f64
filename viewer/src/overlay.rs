//! What the viewer asks of a behaviour: its roles and colours, and what its notes mean. The
//! answers come from the behaviour's own folder (`agent/src/behaviours/<name>/overlay.rs`,
//! through the registry), so a new behaviour brings its overlay without touching the viewer.

use serde_json::Value;

pub use swarmrt_agent::overlay::{Headline, LaneChange, RoleDef};

/// A behaviour's overlay, as the viewer uses it. Notes are the `note` field of a recorded
/// note event, as JSON.
pub trait Overlay: Send + Sync {
    /// The roles, indexed by the role byte.
    fn roles(&self) -> &'static [RoleDef];
    /// Robot `id`'s role at the start.
    fn initial_role(&self, id: u32) -> Option<u8>;
    /// The role robot `id` is in after reporting `note`, if it changed.
    fn role_after(&self, id: u32, note: &Value) -> Option<u8>;
    /// A timeline mark for `note`.
    fn headline(&self, note: &Value) -> Option<Headline>;
    /// The consensus lane change `note` makes.
    fn lane(&self, note: &Value) -> Option<LaneChange>;
}
