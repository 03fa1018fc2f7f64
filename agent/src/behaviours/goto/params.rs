//! `[behaviour]` of `kind = "goto"`.

use serde::{Deserialize, Serialize};
use swarmrt_scenario::validate::{range_f, range_u64};
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
    fn validate(&self, _cfg: &Config) -> Result<(), KeyError> {
        range_f("behaviour.speed", self.speed, 0.0, 1000.0)?;
        range_f("behaviour.avoid_distance", self.avoid_distance, 0.0, 1e6)?;
        range_u64(
            "behaviour.beacon_period",
            self.beacon_period as u64,
            0,
            1_000_000,
        )?;
        range_f("behaviour.slot_spacing", self.slot_spacing, 0.0, 1e6)
    }
}
