//! Real-time pacing (`--realtime`, DESIGN section 2): one tick every `scenario.dt` of wall
//! clock, with whatever commands arrived; a robot that sent nothing new keeps its last one.

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use swarmrt_ipc::IpcError;
use swarmrt_protocol::{Command, CommandKind};
use swarmrt_world::World;

use super::answers::{Origin, count_stranger, is_local};
use super::control::{drain_control, give_up, wait};
use super::shell::{Processes, ShellStats};
use crate::inbox;
use crate::supervisor::hello::Sample;

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
    fn heard(&mut self, robot: u32, tick: u64, c: Command, stats: &mut ShellStats) {
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

impl Processes<'_> {
    /// Real-time: takes whatever arrives until the tick's window closes, then every robot
    /// that expects a command acts on its latest.
    pub(super) fn answer_realtime(
        &mut self,
        world: &mut World,
        tick: u64,
        rt: &mut Realtime,
    ) -> Result<(), IpcError> {
        self.collect_until(world, rt)?;
        for robot in std::mem::take(&mut self.answers.pending) {
            if world.robots()[robot as usize].state.expects_command() {
                self.answers.commands[robot as usize] = rt.command(robot, tick);
            }
        }
        Ok(())
    }

    /// Until the window closes, takes every command that arrives as its robot's latest
    /// (binding restarted robots' fresh processes as in lock-step); at its end gives up on a
    /// robot that has sent nothing for `scenario.unresponsive_ms`.
    fn collect_until(&mut self, world: &mut World, rt: &mut Realtime) -> Result<(), IpcError> {
        let tick = world.tick();
        loop {
            self.receive_latest(tick, rt)?;
            self.interrupted |= drain_control(
                &self.control,
                self.node,
                world,
                &mut self.hellos,
                &mut BTreeSet::new(),
            )?;
            if self.interrupted {
                return Ok(());
            }
            let now = Instant::now();
            if now >= rt.tick_ends {
                // Once per tick, not per wake-up.
                self.give_up_silent(world, now, rt);
                return Ok(());
            }
            self.interrupted |= wait(&self.ports.listener, self.node, rt.tick_ends - now)?;
            if self.interrupted {
                return Ok(());
            }
        }
    }

    /// Receives every queued command as its robot's latest.
    fn receive_latest(&mut self, tick: u64, rt: &mut Realtime) -> Result<(), IpcError> {
        let remote_robot = &self.remote_robot;
        let stats = &mut self.stats;
        inbox::receive(
            &self.ports.commands,
            &mut self.hellos,
            Origin::Local,
            |r| is_local(remote_robot, r),
            |sample, c| match sample {
                Sample::Robot(robot) => rt.heard(robot, tick, c, stats),
                Sample::Hello(robot) => rt.forget(robot),
                Sample::BadHello | Sample::Unknown => count_stranger(sample, &c, stats),
            },
        )
    }

    /// Robots that expect a command and sent nothing for `scenario.unresponsive_ms`.
    fn give_up_silent(&mut self, world: &mut World, now: Instant, rt: &mut Realtime) {
        let hung: Vec<u32> = world
            .robots()
            .iter()
            .filter(|r| r.state.expects_command())
            .map(|r| r.id)
            .filter(|&r| now.duration_since(rt.heard_at[r as usize]) >= self.unresponsive)
            .collect();
        for robot in hung {
            self.hellos.forget(robot);
            let waited = now.duration_since(rt.heard_at[robot as usize]);
            give_up(world, robot, waited, "nothing sent");
            rt.forget(robot);
        }
    }
}
