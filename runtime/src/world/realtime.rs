//! Real-time pacing (`--realtime`, DESIGN section 2): one tick every `scenario.dt` of wall
//! clock, with whatever commands arrived; a robot that sent nothing new keeps its last one.

use std::time::{Duration, Instant};

use swarmrt_protocol::{Command, CommandKind};

use super::stats::{RealtimeStats, ShellStats};

/// Real-time mode's clock and its memory of each robot's latest command.
pub(super) struct Realtime {
    last: Vec<Option<Command>>,
    /// True once `last` has been applied: its frames and notes went out, later ticks reuse
    /// only its motion.
    applied: Vec<bool>,
    /// Whether a command arrived in the current tick's window.
    fresh: Vec<bool>,
    /// When each robot's process last sent anything.
    heard_at: Vec<Instant>,
    period: Duration,
    /// When the current tick's window closes.
    tick_ends: Instant,
    pub(super) stats: RealtimeStats,
}

impl Realtime {
    /// `n` robots, one tick every `dt` seconds from now.
    pub(super) fn new(n: usize, dt: f64) -> Realtime {
        let period = Duration::from_secs_f64(dt);
        let now = Instant::now();
        Realtime {
            last: vec![None; n],
            applied: vec![false; n],
            fresh: vec![false; n],
            heard_at: vec![now; n],
            period,
            tick_ends: Instant::now() + period,
            stats: RealtimeStats {
                period_ms: period.as_secs_f64() * 1e3,
                ..RealtimeStats::default()
            },
        }
    }

    /// Forgets robot `r`'s command (killed, frozen or restarted: it must not move on it).
    pub(super) fn forget(&mut self, r: u32) {
        self.last[r as usize] = None;
        self.heard_at[r as usize] = Instant::now();
    }

    /// A command from robot `robot`'s bound process, while the world is at `tick`: its latest.
    pub(super) fn heard(&mut self, robot: u32, tick: u64, c: Command, stats: &mut ShellStats) {
        let i = robot as usize;
        self.heard_at[i] = Instant::now();
        if CommandKind::from_u32(c.kind) == Some(CommandKind::Hello) {
            stats.extra_commands += 1;
            return;
        }
        if c.tick < tick {
            self.stats.stale += 1;
        }
        if self.fresh[i] {
            stats.extra_commands += 1;
        }
        self.last[i] = Some(c);
        self.applied[i] = false;
        self.fresh[i] = true;
    }

    /// The command robot `r` acts on at `tick`: its latest, with motion only when it was
    /// applied before. A command naming a later tick is left as is, for the world to refuse.
    pub(super) fn command(&mut self, r: u32, tick: u64) -> Option<Command> {
        let i = r as usize;
        if !std::mem::take(&mut self.fresh[i]) {
            self.stats.missed += 1;
            *self.stats.missed_by_robot.entry(r).or_default() += 1;
        }
        let mut c = self.last[i]?;
        if c.tick <= tick {
            c.tick = tick;
        }
        if std::mem::replace(&mut self.applied[i], true) {
            c.outbox_len = 0;
            c.report_len = 0;
        }
        Some(c)
    }

    /// When the current tick's window closes.
    pub(super) fn window_closes(&self) -> Instant {
        self.tick_ends
    }

    /// When robot `r`'s process last sent anything.
    pub(super) fn heard_at(&self, r: u32) -> Instant {
        self.heard_at[r as usize]
    }

    /// The tick is over: the next window opens; a tick that overran its period restarts the
    /// clock from now rather than rushing to catch up.
    pub(super) fn end_tick(&mut self) {
        self.tick_ends += self.period;
        if Instant::now() > self.tick_ends {
            self.stats.overruns += 1;
            self.tick_ends = Instant::now() + self.period;
        }
    }
}
