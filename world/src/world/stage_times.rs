//! Wall-clock time per stage of a tick (rapier's `StagesCounters`), for the shell's timing
//! report (`metrics.json` → `shell.timing`). Off by default: the core reads the clock only
//! when the shell switches timing on, and what it measures never reaches a record.

use std::time::{Duration, Instant};

/// A stage of a tick; each lives in its own file of `world/src/world/`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Stage {
    /// `faults.rs`: the faults of a tick boundary.
    Faults,
    /// `commands.rs`: accept or refuse each command, notes to events.
    Commands,
    /// `route.rs`: route the frames sent, deliver the frames due.
    Radio,
    /// `kinematics.rs`: unicycle integration with swept obstacle checks.
    Kinematics,
    /// `contacts.rs`: robot-robot contacts.
    Contacts,
    /// `sensing.rs`: the observations ([`World::observe`](super::World::observe)) and the
    /// goal check.
    Sensing,
}

impl Stage {
    /// Every stage.
    pub const ALL: [Stage; 6] = [
        Stage::Faults,
        Stage::Commands,
        Stage::Radio,
        Stage::Kinematics,
        Stage::Contacts,
        Stage::Sensing,
    ];

    /// The stage's name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Faults => "faults",
            Stage::Commands => "commands",
            Stage::Radio => "radio",
            Stage::Kinematics => "kinematics",
            Stage::Contacts => "contacts",
            Stage::Sensing => "sensing",
        }
    }
}

/// Time spent in each [`Stage`] while timing was on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StageTimes {
    enabled: bool,
    nanos: [u64; Stage::ALL.len()],
}

impl StageTimes {
    /// True while the stages are being timed.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Time spent in `stage`.
    pub fn get(&self, stage: Stage) -> Duration {
        Duration::from_nanos(self.nanos[stage as usize])
    }

    /// Time spent in all stages together.
    pub fn total(&self) -> Duration {
        Duration::from_nanos(self.nanos.iter().sum())
    }

    pub(super) fn set_enabled(&mut self, on: bool) {
        self.enabled = on;
    }

    /// Sets every stage back to zero.
    pub(super) fn clear(&mut self) {
        self.nanos = [0; Stage::ALL.len()];
    }

    /// The start of a timed stage: `None` (and no clock read) while timing is off.
    pub(super) fn start(&self) -> Option<Instant> {
        self.enabled.then(Instant::now)
    }

    /// Adds the time since `start` to `stage`.
    pub(super) fn stop(&mut self, stage: Stage, start: Option<Instant>) {
        if let Some(start) = start {
            self.nanos[stage as usize] += start.elapsed().as_nanos() as u64;
        }
    }
}
