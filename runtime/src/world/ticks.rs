//! The world's ticks over processes: [`swarmrt_world::lockstep::tick`], the one lock-step
//! tick of both modes, driven with robots reached as processes ([`Robots`] for
//! [`Processes`]): the schedule's faults go to the orchestrator, the observations are
//! published to every robot (and host), their answers collected (in lock-step, or by the
//! wall clock), the propagation rounds published and collected; then the records.

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use swarmrt_ipc::IpcError;
use swarmrt_protocol::control::{ProcessFault, WorldReport};
use swarmrt_protocol::{Command, RobotState, RoundInbox};
use swarmrt_world::lockstep::{self, Robots};
use swarmrt_world::records::RecordWriter;
use swarmrt_world::{ProcessSignal, World};

use super::control::{give_up, report};
use super::shell::Processes;
use super::timing::{TickPhases, thread_cpu_ns};

/// Minimum interval between progress reports on stdout.
const PROGRESS_EVERY: Duration = Duration::from_millis(200);
/// The first ticks are each reported at once, so the orchestrator knows exactly when every
/// process is up and the observation samples have all been used once (`swarm bench swarm`
/// reads memory then).
pub const EARLY_REPORTS: u64 = 32;

impl Robots for Processes<'_> {
    type Error = IpcError;

    fn carry_out(
        &mut self,
        world: &mut World,
        signals: Vec<ProcessSignal>,
    ) -> Result<(), IpcError> {
        let rejoining = self.report_faults(signals);
        self.await_rejoin(world, rejoining)
    }

    fn answer(
        &mut self,
        world: &mut World,
        commands: &mut Vec<Option<Command>>,
    ) -> Result<(), IpcError> {
        let tick = world.tick();
        let mut obs = std::mem::take(&mut self.obs);
        self.stamps.observe = Instant::now();
        world.observe(&mut obs);
        self.stamps.publish = Instant::now();
        let cpu = thread_cpu_ns();
        let published = self.publish(world, tick, &obs);
        self.obs = obs;
        published?;
        self.stamps.publish_cpu = thread_cpu_ns().saturating_sub(cpu);
        self.stamps.wait = Instant::now();
        match self.realtime.take() {
            Some(mut rt) => {
                let answered = self.answer_realtime(world, tick, &mut rt);
                self.realtime = Some(rt);
                answered?;
            }
            None => self.collect(world, tick)?,
        }
        std::mem::swap(&mut self.answers.commands, commands);
        Ok(())
    }

    fn react(
        &mut self,
        world: &mut World,
        round: &[RoundInbox],
        reactions: &mut [Option<Command>],
    ) -> Result<(), IpcError> {
        let Some(rounds) = &self.rounds else {
            return Ok(());
        };
        let tick = world.tick();
        self.answers.commands.iter_mut().for_each(|c| *c = None);
        self.answers.tick = tick;
        self.answers.pending = round.iter().map(|b| b.robot).collect();
        rounds.publish(tick, world.round(), round)?;
        self.collect(world, tick)?;
        for b in round {
            reactions[b.robot as usize] = self.answers.commands[b.robot as usize];
        }
        Ok(())
    }

    fn stopped(&self) -> bool {
        self.interrupted
    }

    fn stepping(&mut self) {
        self.stamps.step = Instant::now();
    }
}

impl Processes<'_> {
    /// Phase 2: ticks until the scenario ends or the run is stopped.
    pub(super) fn run_ticks(
        &mut self,
        world: &mut World,
        recorder: &mut RecordWriter,
    ) -> Result<(), IpcError> {
        // The world times its stages too (wall clock, for `shell.timing` only).
        world.set_stage_timing(true);
        let events = world.drain_events();
        recorder.record(world.tick(), world.robots(), events)?;
        let mut commands = vec![None; self.answers.commands.len()];
        let mut last_progress = Instant::now();
        while !self.interrupted && !world.finished() {
            if !lockstep::tick(world, self, &mut commands)? {
                break;
            }
            let events = world.drain_events();
            let radio = world.take_radio_rows();
            let recording = Instant::now();
            recorder.record_tick(world.tick(), world.robots(), events, radio)?;
            self.time_tick(world, recording);
            self.report_progress(world.tick(), &mut last_progress);
            if let Some(rt) = self.realtime.as_mut() {
                rt.end_tick();
            }
        }
        self.stats.realtime = self.realtime.take().map(|rt| rt.stats);
        self.stats.timing = self.timer.summary();
        Ok(())
    }

    /// Adds the tick just recorded to `shell.timing` (the records were handed over at
    /// `recording`).
    fn time_tick(&mut self, world: &mut World, recording: Instant) {
        let s = self.stamps;
        let ns = |a: Instant, b: Instant| b.saturating_duration_since(a).as_nanos() as u64;
        self.timer.add(TickPhases {
            observe: ns(s.observe, s.publish),
            publish: ns(s.publish, s.wait),
            // With rounds, `wait` includes them.
            wait: ns(s.wait, s.step),
            step: ns(s.step, recording),
            record: ns(recording, Instant::now()),
            publish_cpu: s.publish_cpu,
            stages: world.take_stage_times(),
        });
    }

    /// Reports the tick just completed: each of the first ones, then a few times a second.
    fn report_progress(&mut self, tick: u64, last: &mut Instant) {
        if tick <= EARLY_REPORTS || last.elapsed() >= PROGRESS_EVERY {
            *last = Instant::now();
            report(&WorldReport::Tick { tick });
        }
    }

    /// The schedule's process faults of this tick, passed to the orchestrator (which carries
    /// them out); returns the restarted robots that rejoin now.
    fn report_faults(&mut self, signals: Vec<ProcessSignal>) -> BTreeSet<u32> {
        let mut rejoining: BTreeSet<u32> = BTreeSet::new();
        for signal in signals {
            let fault = match signal {
                ProcessSignal::Rejoin(robot) => {
                    rejoining.insert(robot);
                    continue;
                }
                ProcessSignal::Fault(fault) => fault,
            };
            let robot = fault.robot();
            // Its last command is no longer its answer: killed, frozen, thawed (its silence
            // while frozen was ordered, not a hang) or restarted.
            if let Some(rt) = self.realtime.as_mut() {
                rt.forget(robot);
            }
            match fault {
                ProcessFault::Kill { .. } => self.hellos.forget(robot),
                // Samples from the old process are no robot's answer any more.
                ProcessFault::Restart { .. } => self.hellos.expect_hello(robot),
                ProcessFault::Freeze { .. } | ProcessFault::Thaw { .. } => {}
            }
            report(&WorldReport::Fault(fault));
        }
        rejoining
    }

    /// A rejoining robot's fresh process must be bound before its first observation; one
    /// that says no hello for `scenario.unresponsive_ms` is given up.
    fn await_rejoin(
        &mut self,
        world: &mut World,
        mut rejoining: BTreeSet<u32>,
    ) -> Result<(), IpcError> {
        let hello_since = Instant::now();
        while !rejoining.is_empty() {
            self.answers.pending.clear();
            self.gather(world)?;
            rejoining.retain(|r| {
                self.hellos.is_awaiting(*r) && world.robots()[*r as usize].state != RobotState::Dead
            });
            if rejoining.is_empty() || self.interrupted {
                break;
            }
            if hello_since.elapsed() >= self.unresponsive {
                for &robot in &rejoining {
                    give_up(
                        world,
                        robot,
                        hello_since.elapsed(),
                        "never said hello after its restart",
                    );
                    self.hellos.forget(robot);
                }
                break;
            }
            self.sleep(self.unresponsive.saturating_sub(hello_since.elapsed()))?;
        }
        Ok(())
    }

    /// Publishes the tick's observations (locally and to the hosts) and notes which robots
    /// the tick waits for.
    fn publish(
        &mut self,
        world: &World,
        tick: u64,
        obs: &[swarmrt_protocol::Observation],
    ) -> Result<(), IpcError> {
        self.answers.commands.iter_mut().for_each(|c| *c = None);
        self.answers.tick = tick;
        self.answers.pending = world
            .robots()
            .iter()
            .filter(|r| r.state.expects_command())
            .map(|r| r.id)
            .collect();
        // Before the ring: the tick's last counting robot must see the new target.
        let base = self.ports.bell.answers();
        self.expect_answers(base);
        self.ports.publish(tick, obs)?;
        if let Some(rounds) = &self.rounds {
            for &robot in &self.answers.pending {
                rounds.wake(robot)?;
            }
        }
        if let Some(r) = self.remote.as_mut() {
            r.send_tick(tick, obs, &self.answers.pending)?;
        }
        Ok(())
    }

    /// Sets the bell's target for the pending robots that count their answers, given the
    /// answer count `base` read before the last gather: the last of them notifies. True when
    /// the count already reached it (an answer came in between): gather again, do not sleep.
    pub(super) fn expect_answers(&self, base: u64) -> bool {
        let Some(counting) = &self.counting else {
            return false;
        };
        let waiting = self
            .answers
            .pending
            .iter()
            .filter(|&&r| counting.get(r as usize).copied().unwrap_or(false))
            .count() as u64;
        let bell = &self.ports.bell;
        if waiting == 0 {
            // Only robots that notify every answer are left.
            bell.expect(0);
            return false;
        }
        let target = base + waiting;
        bell.expect(target);
        bell.answers() >= target
    }
}
