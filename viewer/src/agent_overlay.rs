//! The registry's behaviour overlays behind the viewer's [`Overlay`] trait: each behaviour's
//! folder says what its notes mean (`agent/src/behaviours/<name>/overlay.rs`).

use serde_json::Value;
use swarmrt_agent::registry::{Configured, Plugin};
use swarmrt_scenario::Config;

use crate::overlay::{Meaning, Overlay, RoleDef};

/// The overlay of the config's behaviour (none for a kind the registry does not know, which
/// a loaded config cannot have), its parameters parsed once.
pub fn for_config(cfg: &Config) -> Box<dyn Overlay> {
    let plugin = swarmrt_agent::registry::plugin(&cfg.behaviour.kind);
    Box::new(Registered {
        configured: plugin.and_then(|p| p.configure(cfg).ok()),
        plugin,
    })
}

struct Registered {
    plugin: Option<&'static dyn Plugin>,
    configured: Option<Box<dyn Configured>>,
}

impl Overlay for Registered {
    fn roles(&self) -> &'static [RoleDef] {
        self.plugin.map(|p| p.roles()).unwrap_or(&[])
    }
    fn initial_role(&self, id: u32) -> Option<u8> {
        self.configured.as_ref()?.initial_role(id)
    }
    /// The note is decoded into the behaviour's typed note once, then asked three things.
    fn read(&self, id: u32, note: &Value) -> Meaning {
        let Some((p, note)) = self.plugin.and_then(|p| Some((p, p.read_note(note)?))) else {
            return Meaning::default();
        };
        Meaning {
            role: self
                .configured
                .as_ref()
                .and_then(|c| c.role_after(id, &note)),
            headline: p.headline(&note),
            lane: p.lane(&note),
        }
    }
}
