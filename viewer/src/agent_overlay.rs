//! The registry's behaviour overlays behind the viewer's [`Overlay`] trait: each behaviour's
//! folder says what its notes mean (`agent/src/behaviours/<name>/overlay.rs`).

use serde_json::Value;
use swarmrt_agent::registry::Plugin;
use swarmrt_scenario::Config;

use crate::overlay::{Headline, LaneChange, Overlay, RoleDef};

/// The overlay of the config's behaviour (none for a kind the registry does not know, which
/// a loaded config cannot have).
pub fn for_config(cfg: &Config) -> Box<dyn Overlay> {
    Box::new(Registered {
        plugin: swarmrt_agent::registry::plugin(&cfg.behaviour.kind),
        cfg: cfg.clone(),
    })
}

struct Registered {
    plugin: Option<&'static dyn Plugin>,
    cfg: Config,
}

impl Overlay for Registered {
    fn roles(&self) -> &'static [RoleDef] {
        self.plugin.map(|p| p.roles()).unwrap_or(&[])
    }
    fn initial_role(&self, id: u32) -> Option<u8> {
        self.plugin?.initial_role(&self.cfg, id)
    }
    fn role_after(&self, id: u32, note: &Value) -> Option<u8> {
        self.plugin?.role_after(&self.cfg, id, note)
    }
    fn headline(&self, note: &Value) -> Option<Headline> {
        self.plugin?.headline(note)
    }
    fn lane(&self, note: &Value) -> Option<LaneChange> {
        self.plugin?.lane(note)
    }
}
