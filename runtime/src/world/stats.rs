//! What only the world's shell knows of a run (`metrics.json` -> `shell`): wall-clock
//! dependent, so kept out of the replayable records.

use std::collections::BTreeMap;

use super::timing::TickTiming;

/// Numbers only the shell knows (wall-clock dependent, so kept out of the replayable records).
#[derive(Debug, Default, serde::Serialize)]
pub struct ShellStats {
    /// Robot-ticks in which a robot answered after `scenario.deadline_ms`.
    pub late: u64,
    /// Samples from publishers that never said hello as a robot of this run.
    pub unknown_sender: u64,
    /// Extra samples from a robot that had already answered the current tick.
    pub extra_commands: u64,
    /// Hellos that claimed an id already taken, or came from an already bound publisher.
    pub bad_hello: u64,
    /// Wall-clock cost of the ticks and where it went.
    pub timing: TickTiming,
    /// Traffic with each remote host (`--hosts` runs only).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub link: Vec<swarmrt_hosts::world_side::HostTraffic>,
    /// TLS handshakes refused on the hosts' port (`--hosts` runs only): strangers, or hosts
    /// with the wrong certificate, counted instead of logged one by one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tls: Option<swarmrt_hosts::noise::Refusals>,
    /// How the wall clock went (`--realtime` runs only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub realtime: Option<RealtimeStats>,
}

/// What happened against the wall clock in a real-time run (`shell.realtime`).
#[derive(Debug, Default, serde::Serialize)]
pub struct RealtimeStats {
    /// The tick period, `scenario.dt` in milliseconds.
    pub period_ms: f64,
    /// Robot-ticks in which a robot sent nothing new and kept its last command (or stood
    /// still, having sent none yet).
    pub missed: u64,
    /// The robots that missed ticks, with how many.
    pub missed_by_robot: BTreeMap<u32, u64>,
    /// Commands that arrived answering an earlier tick than the current one (applied as the
    /// robot's latest).
    pub stale: u64,
    /// Ticks whose own work (sensing, stepping, recording) overran the period; the clock
    /// then restarts from the late tick rather than rushing to catch up.
    pub overruns: u64,
}
