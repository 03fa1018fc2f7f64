//! `[faults]`: a schedule of faults the world applies at tick boundaries, so a faulted run
//! still replays from its seed. The orchestrator performs the real signal for process faults.

use serde::{Deserialize, Serialize};

use crate::bounds::{Bounds, Key, k, r};

/// The fault schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FaultsConfig {
    /// SIGKILL a robot's process; it counts as dead from exactly that tick.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub kill: Vec<KillFault>,
    /// SIGSTOP a robot's process from `from` to `to` (SIGCONT): it stands still, silent, and
    /// answers again from `to` on.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub freeze: Vec<FreezeFault>,
    /// SIGKILL a robot's process and start a fresh one with the same id: it is offline for
    /// `down_ticks`, then rejoins with no memory.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub restart: Vec<RestartFault>,
    /// Probability per running robot per tick that its process is killed (drawn from the seed).
    #[serde(skip_serializing_if = "is_zero")]
    pub kill_rate: f64,
    /// Probability per running robot per tick that its process is frozen for `freeze_ticks`.
    #[serde(skip_serializing_if = "is_zero")]
    pub freeze_rate: f64,
    /// Length of a random freeze, ticks.
    pub freeze_ticks: u64,
    /// Split the radio: robots in different groups cannot hear each other from `from` to `to`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub partition: Vec<PartitionFault>,
    /// All radio off from `from` to `to`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub blackout: Vec<Window>,
}

/// `[[faults.kill]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KillFault {
    /// Tick at which the robot is dead.
    pub tick: u64,
    /// A robot id, or `"leader"`: the robot that last reported itself leader.
    pub robot: FaultTarget,
}

/// Which robot a process fault hits.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(
    untagged,
    expecting = "expected a robot id (an integer from 0) or \"leader\""
)]
pub enum FaultTarget {
    /// This robot.
    Id(u32),
    /// A named target; only `"leader"` is valid.
    Named(String),
}

/// `[[faults.freeze]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FreezeFault {
    /// A robot id, or `"leader"`.
    pub robot: FaultTarget,
    /// First frozen tick.
    pub from: u64,
    /// First tick it answers again.
    pub to: u64,
}

/// `[[faults.restart]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RestartFault {
    /// Tick at which the old process is killed.
    pub tick: u64,
    /// A robot id, or `"leader"`.
    pub robot: FaultTarget,
    /// Ticks offline before the fresh process rejoins (a reboot is not instant).
    #[serde(default = "default_down_ticks")]
    pub down_ticks: u64,
}

fn default_down_ticks() -> u64 {
    10
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Most scheduled restarts a run may hold: each may briefly need a spare iceoryx2 port until
/// the old process's ports are reclaimed.
pub const MAX_RESTARTS: usize = 256;

#[rustfmt::skip]
mod keys {
    use super::*;

    /// `faults.kill_rate`.
    pub const KILL_RATE: Key = k("faults.kill_rate", r(0.0, 1.0), "", "Probability per running robot per tick that its process is killed.").absent("0.0");
    /// `faults.freeze_rate`.
    pub const FREEZE_RATE: Key = k("faults.freeze_rate", r(0.0, 1.0), "", "Probability per running robot per tick that it is frozen.").absent("0.0");
    /// `faults.freeze_ticks`.
    pub const FREEZE_TICKS: Key = k("faults.freeze_ticks", r(1.0, 1_000_000.0), "ticks", "Length of a random freeze.");
    /// `faults.kill[i].tick`.
    pub const KILL_TICK: Key = k("faults.kill[i].tick", Bounds::Any, "tick", "Tick from which the robot is dead.");
    /// `faults.kill[i].robot`.
    pub const KILL_ROBOT: Key = k("faults.kill[i].robot", Bounds::Rule("an id below `robots.count`, or `\"leader\"`"), "", "The robot, or the one that last reported itself leader.").ty("integer or \"leader\"");
    /// `faults.freeze[i].robot`.
    pub const FREEZE_ROBOT: Key = k("faults.freeze[i].robot", Bounds::Rule("an id below `robots.count`, or `\"leader\"`"), "", "The robot to SIGSTOP.").ty("integer or \"leader\"");
    /// `faults.freeze[i].from`.
    pub const FREEZE_FROM: Key = k("faults.freeze[i].from", Bounds::Any, "tick", "First frozen tick.");
    /// `faults.freeze[i].to`.
    pub const FREEZE_TO: Key = k("faults.freeze[i].to", Bounds::Rule("after `from`"), "tick", "First tick it answers again (SIGCONT).");
    /// `faults.restart[i].tick`.
    pub const RESTART_TICK: Key = k("faults.restart[i].tick", Bounds::Any, "tick", "Tick at which the old process is killed.");
    /// `faults.restart[i].robot`.
    pub const RESTART_ROBOT: Key = k("faults.restart[i].robot", Bounds::Rule("an id below `robots.count`, or `\"leader\"`"), "", "The robot to restart with no memory.").ty("integer or \"leader\"");
    /// `faults.restart[i].down_ticks`.
    pub const RESTART_DOWN_TICKS: Key = k("faults.restart[i].down_ticks", r(1.0, 1_000_000.0), "ticks", "Ticks offline before the fresh process rejoins.");
    /// `faults.partition[i].from`.
    pub const PARTITION_FROM: Key = k("faults.partition[i].from", Bounds::Any, "tick", "First tick of the partition.");
    /// `faults.partition[i].to`.
    pub const PARTITION_TO: Key = k("faults.partition[i].to", Bounds::Rule("after `from`"), "tick", "First tick after it.");
    /// `faults.partition[i].groups`.
    pub const PARTITION_GROUPS: Key = k("faults.partition[i].groups", Bounds::Rule("disjoint ids below `robots.count`"), "", "Groups that cannot hear each other; robots listed nowhere form one more.");
    /// `faults.blackout[i].from`.
    pub const BLACKOUT_FROM: Key = k("faults.blackout[i].from", Bounds::Any, "tick", "First tick with every radio off.");
    /// `faults.blackout[i].to`.
    pub const BLACKOUT_TO: Key = k("faults.blackout[i].to", Bounds::Rule("after `from`"), "tick", "First tick after it.");

    /// Every key of `[faults]`, in the order of the reference.
    pub const KEYS: &[Key] = &[
        KILL_RATE, FREEZE_RATE, FREEZE_TICKS, KILL_TICK, KILL_ROBOT, FREEZE_ROBOT, FREEZE_FROM,
        FREEZE_TO, RESTART_TICK, RESTART_ROBOT, RESTART_DOWN_TICKS, PARTITION_FROM, PARTITION_TO,
        PARTITION_GROUPS, BLACKOUT_FROM, BLACKOUT_TO,
    ];
}
pub use keys::*;

/// `[[faults.partition]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartitionFault {
    /// First tick of the partition.
    pub from: u64,
    /// First tick after it.
    pub to: u64,
    /// Disjoint groups of robot ids; robots listed nowhere form one more group.
    pub groups: Vec<Vec<u32>>,
}

/// A span of ticks, `from` included, `to` excluded.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Window {
    /// First tick.
    pub from: u64,
    /// First tick after.
    pub to: u64,
}

impl Default for FaultsConfig {
    fn default() -> Self {
        FaultsConfig {
            kill: Vec::new(),
            freeze: Vec::new(),
            restart: Vec::new(),
            kill_rate: 0.0,
            freeze_rate: 0.0,
            freeze_ticks: 20,
            partition: Vec::new(),
            blackout: Vec::new(),
        }
    }
}

impl FaultTarget {
    fn validate(&self, key: &str, robots: u32) -> Result<(), (String, String)> {
        match self {
            FaultTarget::Id(id) if *id >= robots => Err((
                key.to_string(),
                format!("expected a robot id in [0, {}], got {id}", robots - 1),
            )),
            FaultTarget::Named(name) if name != "leader" => Err((
                key.to_string(),
                format!("expected a robot id or \"leader\", got \"{name}\""),
            )),
            _ => Ok(()),
        }
    }
}

impl FaultsConfig {
    /// Checks ids against `robots` and windows for order; `Err((key, expected))`.
    pub fn validate(&self, robots: u32) -> Result<(), (String, String)> {
        for (i, k) in self.kill.iter().enumerate() {
            k.robot
                .validate(&format!("faults.kill[{i}].robot"), robots)?;
        }
        for (i, f) in self.freeze.iter().enumerate() {
            f.robot
                .validate(&format!("faults.freeze[{i}].robot"), robots)?;
            window(&format!("faults.freeze[{i}]"), f.from, f.to)?;
        }
        if self.restart.len() > MAX_RESTARTS {
            return Err((
                "faults.restart".into(),
                format!(
                    "expected at most {MAX_RESTARTS} restarts, got {}",
                    self.restart.len()
                ),
            ));
        }
        for (i, r) in self.restart.iter().enumerate() {
            r.robot
                .validate(&format!("faults.restart[{i}].robot"), robots)?;
            let key = format!("faults.restart[{i}].down_ticks");
            let (lo, hi) = (
                RESTART_DOWN_TICKS.lo() as u64,
                RESTART_DOWN_TICKS.hi() as u64,
            );
            if !(lo..=hi).contains(&r.down_ticks) {
                return Err((
                    key,
                    format!("expected a value in [{lo}, {hi}], got {}", r.down_ticks),
                ));
            }
        }
        for (row, v) in [(KILL_RATE, self.kill_rate), (FREEZE_RATE, self.freeze_rate)] {
            if !(row.lo()..=row.hi()).contains(&v) {
                return Err((
                    row.path.into(),
                    format!(
                        "expected a probability per robot per tick in [{}, {}], got {v}",
                        row.lo(),
                        row.hi()
                    ),
                ));
            }
        }
        let (lo, hi) = (FREEZE_TICKS.lo() as u64, FREEZE_TICKS.hi() as u64);
        if !(lo..=hi).contains(&self.freeze_ticks) {
            return Err((
                FREEZE_TICKS.path.into(),
                format!(
                    "expected a value in [{lo}, {hi}], got {}",
                    self.freeze_ticks
                ),
            ));
        }
        for (i, p) in self.partition.iter().enumerate() {
            window(&format!("faults.partition[{i}]"), p.from, p.to)?;
            let mut seen = std::collections::BTreeSet::new();
            for id in p.groups.iter().flatten() {
                if *id >= robots || !seen.insert(*id) {
                    return Err((
                        format!("faults.partition[{i}].groups"),
                        format!(
                            "expected disjoint groups of robot ids in [0, {}], got {id} twice or out of range",
                            robots - 1
                        ),
                    ));
                }
            }
        }
        for (i, b) in self.blackout.iter().enumerate() {
            window(&format!("faults.blackout[{i}]"), b.from, b.to)?;
        }
        Ok(())
    }

    /// Per robot, a radio group label at `tick`: robots with different labels cannot hear
    /// each other. `None` when no radio fault is active.
    pub fn radio_groups(&self, tick: u64, robots: usize) -> Option<Vec<u64>> {
        let active = |from: u64, to: u64| from <= tick && tick < to;
        let mut labels: Option<Vec<u64>> = None;
        if self.blackout.iter().any(|b| active(b.from, b.to)) {
            return Some((0..robots as u64).collect());
        }
        for p in self.partition.iter().filter(|p| active(p.from, p.to)) {
            let l = labels.get_or_insert_with(|| vec![0; robots]);
            let rest = p.groups.len() as u64;
            for (r, label) in l.iter_mut().enumerate() {
                let g = p
                    .groups
                    .iter()
                    .position(|g| g.contains(&(r as u32)))
                    .map_or(rest, |g| g as u64);
                // Combine with earlier partitions: different in any means apart.
                *label = label.wrapping_mul(1_000_003).wrapping_add(g + 1);
            }
        }
        labels
    }
}

fn window(key: &str, from: u64, to: u64) -> Result<(), (String, String)> {
    if from < to {
        Ok(())
    } else {
        Err((
            format!("{key}.to"),
            format!("expected a tick after from = {from}, got {to}"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_split_blackout_isolates_and_nothing_is_none() {
        let f = FaultsConfig {
            partition: vec![PartitionFault {
                from: 10,
                to: 20,
                groups: vec![vec![0, 1], vec![2]],
            }],
            blackout: vec![Window { from: 30, to: 31 }],
            ..FaultsConfig::default()
        };
        assert_eq!(f.radio_groups(5, 4), None);
        let g = f.radio_groups(10, 4).unwrap();
        assert_eq!(g[0], g[1]);
        assert_ne!(g[0], g[2]);
        assert_ne!(g[2], g[3]);
        assert_ne!(g[0], g[3]);
        assert_eq!(f.radio_groups(20, 4), None);
        let b = f.radio_groups(30, 3).unwrap();
        assert!(b[0] != b[1] && b[1] != b[2] && b[0] != b[2]);
        assert!(f.validate(4).is_ok());
        assert_eq!(f.validate(2).unwrap_err().0, "faults.partition[0].groups");
    }
}
