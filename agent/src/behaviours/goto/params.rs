//! `[behaviour]` of `kind = "goto"`.

use serde::{Deserialize, Serialize};
use swarmrt_scenario::reference::{Key, check_f, check_u, k, r};
use swarmrt_scenario::{Config, KeyError};

use crate::behaviour::Params;

/// Parameters of the go-to-goal behaviour.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GotoParams {
    /// Cruise speed in m/s.
    pub speed: f64,
    /// Obstacles closer than this (metres, from the robot centre) make the robot turn away.
    pub avoid_distance: f64,
    /// Ticks between pose beacons (0 = no beacons).
    pub beacon_period: u32,
    /// Distance between the goal slots robots spread into around the goal centre.
    pub slot_spacing: f64,
}

impl Default for GotoParams {
    fn default() -> Self {
        GotoParams {
            speed: 0.5,
            avoid_distance: 0.9,
            beacon_period: 5,
            slot_spacing: 0.6,
        }
    }
}

impl Params for GotoParams {
    #[rustfmt::skip]
    const KEYS: &'static [Key] = &[
        k("behaviour.speed", r(0.0, 1000.0), "m/s", "Cruise speed."),
        k("behaviour.avoid_distance", r(0.0, 1e6), "m", "Obstacles closer than this (from the robot centre) make the robot turn away."),
        k("behaviour.beacon_period", r(0.0, 1_000_000.0), "ticks", "Ticks between pose beacons (0: none)."),
        k("behaviour.slot_spacing", r(0.0, 1e6), "m", "Distance between the goal slots robots spread into around the goal centre."),
    ];

    fn validate(&self, _cfg: &Config) -> Result<(), KeyError> {
        let keys = Self::KEYS;
        check_f(keys, "behaviour.speed", self.speed)?;
        check_f(keys, "behaviour.avoid_distance", self.avoid_distance)?;
        check_u(keys, "behaviour.beacon_period", self.beacon_period as u64)?;
        check_f(keys, "behaviour.slot_spacing", self.slot_spacing)
    }
}
