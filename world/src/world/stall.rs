//! The stall watch: a run whose live robots have all stopped short of their goals ends with a
//! reason instead of waiting out `scenario.ticks` (`scenario.stall_ticks`).

use serde::{Deserialize, Serialize};
use swarmrt_protocol::RobotState;

use super::World;

/// Why a run ended before its tick budget without every robot home: `metrics.json` `stalled`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stalled {
    /// The tick at which the run ended.
    pub tick: u64,
    /// Live robots short of their goal, none of which moved more than `distance` metres in
    /// the last `ticks` ticks.
    pub robots: Vec<u32>,
    /// `scenario.stall_ticks`.
    pub ticks: u64,
    /// `robots.radius`: a robot that stays within its own footprint has not moved.
    pub distance: f64,
}

impl Stalled {
    /// One line for the user, naming the robots (the first ten) and the key.
    pub fn line(&self) -> String {
        let shown: Vec<String> = self.robots.iter().take(10).map(u32::to_string).collect();
        let more = if self.robots.len() > 10 {
            format!(" and {} more", self.robots.len() - 10)
        } else {
            String::new()
        };
        format!(
            "run stalled at tick {}: robot{} {}{more} short of the goal moved less than {} m in \
             the last {} ticks while every other robot is home, down or dead; ended early (scenario.stall_ticks \
             = 0 waits out scenario.ticks)",
            self.tick,
            if self.robots.len() == 1 { "" } else { "s" },
            shown.join(", "),
            self.distance,
            self.ticks,
        )
    }
}

/// Where each robot was when it last moved more than the distance, and when.
#[derive(Debug, Clone, Default)]
pub(super) struct StallWatch {
    anchors: Vec<([f64; 3], u64)>,
}

impl World {
    /// Moves each robot's anchor when it left its footprint; ends the run (`metrics.stalled`)
    /// when every active robot short of its goal has kept its anchor for `stall_ticks` and no
    /// robot is frozen or restarting (it may yet come back and unblock the others).
    pub(super) fn check_stall(&mut self) {
        let limit = self.cfg.scenario.stall_ticks;
        if !self.cfg.scenario.stop_when_done || limit == 0 || self.metrics.stalled.is_some() {
            return;
        }
        let tick = self.tick;
        let d = self.cfg.robots.radius;
        let anchors = &mut self.stall.anchors;
        if anchors.len() != self.robots.len() {
            *anchors = self
                .robots
                .iter()
                .map(|r| ([r.x, r.y, r.z], tick))
                .collect();
        }
        let mut still = Vec::new();
        let mut waiting = false;
        for (r, (at, since)) in self.robots.iter().zip(anchors.iter_mut()) {
            let moved = (r.x - at[0]).powi(2) + (r.y - at[1]).powi(2) + (r.z - at[2]).powi(2);
            if moved > d * d {
                *at = [r.x, r.y, r.z];
                *since = tick;
            }
            match r.state {
                RobotState::Active if r.reached_tick.is_none() => {
                    if tick >= *since + limit {
                        still.push(r.id);
                    } else {
                        waiting = true;
                    }
                }
                RobotState::Frozen | RobotState::Restarting => waiting = true,
                _ => {}
            }
        }
        if !waiting && !still.is_empty() {
            self.metrics.stalled = Some(Stalled {
                tick,
                robots: still,
                ticks: limit,
                distance: d,
            });
        }
    }
}
