//! The world's ticks over processes: the schedule's faults, then the observations published
//! to every robot (and host), their answers collected (in lock-step, or by the wall clock),
//! the propagation rounds, the step and the records, in the order the in-process
//! [`swarmrt_harness`] lock-step calls the same cores, so both write the same bytes.

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use swarmrt_ipc::IpcError;
use swarmrt_protocol::control::{ProcessFault, WorldReport};
use swarmrt_protocol::{Observation, RobotState};
use swarmrt_scenario::Config;
use swarmrt_world::ProcessSignal;
use swarmrt_world::records::RecordWriter;

use super::control::{give_up, report};
use super::mode::Mode;
use super::realtime::Realtime;
use super::shell::Shell;
use super::timing::{TickPhases, TickTimer, thread_cpu_ns};

/// Minimum interval between progress reports on stdout.
const PROGRESS_EVERY: Duration = Duration::from_millis(200);
/// The first ticks are each reported at once, so the orchestrator knows exactly when every
/// process is up and the observation samples have all been used once (`swarm bench swarm`
/// reads memory then).
pub const EARLY_REPORTS: u64 = 32;

/// How the ticks wait for answers, and the observations they hand out.
struct Pace {
    /// `scenario.deadline_ms`: an answer later than this is counted late.
    deadline: Duration,
    /// The wall clock of a real-time run.
    realtime: Option<Realtime>,
    obs: Vec<Observation>,
    timer: TickTimer,
    last_progress: Instant,
}

impl Shell<'_> {
    /// Phase 2: ticks until the scenario ends or the run is stopped.
    pub(super) fn run_ticks(
        &mut self,
        cfg: &Config,
        mode: Mode,
        recorder: &mut RecordWriter,
    ) -> Result<(), IpcError> {
        let n = self.answers.commands.len();
        // The world times its stages too (wall clock, for `shell.timing` only).
        self.world.set_stage_timing(true);
        let events = self.world.drain_events();
        recorder.record(self.world.tick(), self.world.robots(), events)?;
        let mut pace = Pace {
            deadline: Duration::from_millis(cfg.scenario.deadline_ms),
            obs: vec![Observation::empty(0, 0); n],
            timer: TickTimer::default(),
            last_progress: Instant::now(),
            realtime: (mode == Mode::Realtime).then(|| Realtime::new(n, cfg.scenario.dt)),
        };
        while !self.interrupted && !self.world.finished() {
            let Some(phases) = self.tick(&mut pace, recorder)? else {
                break;
            };
            pace.timer.add(phases);
            self.report_progress(&mut pace.last_progress);
            if let Some(rt) = pace.realtime.as_mut() {
                rt.end_tick();
            }
        }
        self.stats.realtime = pace.realtime.map(|rt| rt.stats);
        self.stats.timing = pace.timer.summary();
        Ok(())
    }

    /// One tick; `None` when the run was stopped before the world could step.
    fn tick(
        &mut self,
        pace: &mut Pace,
        recorder: &mut RecordWriter,
    ) -> Result<Option<TickPhases>, IpcError> {
        let rejoining = self.carry_out_signals(pace.realtime.as_mut());
        let tick = self.world.tick();
        self.await_rejoin(rejoining)?;
        if self.interrupted {
            return Ok(None);
        }
        let t0 = Instant::now();
        self.world.observe(&mut pace.obs);
        let t1 = Instant::now();
        let cpu1 = thread_cpu_ns();
        self.publish(tick, &pace.obs)?;
        let publish_cpu = thread_cpu_ns().saturating_sub(cpu1);
        let t2 = Instant::now();
        match pace.realtime.as_mut() {
            Some(rt) => self.answer_realtime(tick, rt)?,
            None => {
                self.collect(tick, pace.deadline)?;
                if !self.interrupted {
                    self.propagate(tick, pace.deadline)?;
                }
            }
        }
        if self.interrupted {
            return Ok(None);
        }
        // With rounds, `wait` includes them.
        let t3 = Instant::now();
        self.world.step(&self.answers.commands);
        let events = self.world.drain_events();
        let radio = self.world.take_radio_rows();
        let t4 = Instant::now();
        recorder.record_tick(self.world.tick(), self.world.robots(), events, radio)?;
        let t5 = Instant::now();
        let ns = |a: Instant, b: Instant| (b - a).as_nanos() as u64;
        Ok(Some(TickPhases {
            observe: ns(t0, t1),
            publish: ns(t1, t2),
            wait: ns(t2, t3),
            step: ns(t3, t4),
            record: ns(t4, t5),
            publish_cpu,
            stages: self.world.take_stage_times(),
        }))
    }

    /// Reports the tick just completed: each of the first ones, then a few times a second.
    fn report_progress(&mut self, last: &mut Instant) {
        if self.world.tick() <= EARLY_REPORTS || last.elapsed() >= PROGRESS_EVERY {
            *last = Instant::now();
            report(&WorldReport::Tick {
                tick: self.world.tick(),
            });
        }
    }

    /// The schedule's process faults of this tick, passed to the orchestrator (which carries
    /// them out); returns the restarted robots that rejoin now.
    fn carry_out_signals(&mut self, mut realtime: Option<&mut Realtime>) -> BTreeSet<u32> {
        let mut rejoining: BTreeSet<u32> = BTreeSet::new();
        for signal in self.world.take_signals() {
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
            if let Some(rt) = realtime.as_deref_mut() {
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
    fn await_rejoin(&mut self, mut rejoining: BTreeSet<u32>) -> Result<(), IpcError> {
        let hello_since = Instant::now();
        while !rejoining.is_empty() {
            self.answers.pending.clear();
            self.gather()?;
            rejoining.retain(|r| {
                self.hellos.is_awaiting(*r)
                    && self.world.robots()[*r as usize].state != RobotState::Dead
            });
            if rejoining.is_empty() || self.interrupted {
                break;
            }
            if hello_since.elapsed() >= self.unresponsive {
                for &robot in &rejoining {
                    give_up(
                        &mut self.world,
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
    fn publish(&mut self, tick: u64, obs: &[Observation]) -> Result<(), IpcError> {
        self.answers.commands.iter_mut().for_each(|c| *c = None);
        self.answers.pending = self
            .world
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
    fn expect_answers(&self, base: u64) -> bool {
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

    /// The tick's propagation rounds (`radio.rounds` > 0), as [`swarmrt_harness`]'s
    /// `Lockstep::propagate` runs them: each round is published to the robots woken in it,
    /// their reactions are collected as a tick's answers are (deadline, unresponsive, deaths)
    /// and applied in ascending robot order.
    fn propagate(&mut self, tick: u64, deadline: Duration) -> Result<(), IpcError> {
        let Some(rounds) = self.rounds.take() else {
            return Ok(());
        };
        let mut acts = std::mem::take(&mut self.answers.commands);
        self.answers.commands = vec![None; acts.len()];
        self.world.start_rounds(&acts);
        let result = loop {
            let round = self.world.next_round();
            if round.is_empty() {
                break Ok(());
            }
            self.answers.commands.iter_mut().for_each(|c| *c = None);
            self.answers.pending = round.iter().map(|b| b.robot).collect();
            if let Err(e) = rounds.publish(tick, self.world.round(), &round) {
                break Err(e);
            }
            if let Err(e) = self.collect(tick, deadline) {
                break Err(e);
            }
            for b in &round {
                let answer = self.answers.commands[b.robot as usize];
                self.world.react(b.robot, answer.as_ref(), &mut acts);
            }
            if self.interrupted {
                break Ok(());
            }
        };
        self.answers.commands = acts;
        self.rounds = Some(rounds);
        result
    }

    /// Lock-step: waits until every pending robot answered. Past `deadline` the late ones are
    /// counted; past `scenario.unresponsive_ms` they are given up.
    fn collect(&mut self, tick: u64, deadline: Duration) -> Result<(), IpcError> {
        let sent_at = Instant::now();
        let mut late_logged = false;
        loop {
            let base = self.ports.bell.answers();
            self.gather()?;
            if self.answers.pending.is_empty() || self.interrupted {
                return Ok(());
            }
            let waited = sent_at.elapsed();
            if waited >= self.unresponsive {
                for robot in std::mem::take(&mut self.answers.pending) {
                    self.hellos.forget(robot);
                    give_up(&mut self.world, robot, waited, "no answer");
                }
                return Ok(());
            }
            let timeout = if waited < deadline {
                deadline - waited
            } else {
                if !late_logged {
                    late_logged = true;
                    self.stats.late += self.answers.pending.len() as u64;
                    tracing::warn!(tick, late = ?self.answers.pending, "robots past the deadline");
                }
                self.unresponsive - waited
            };
            if self.expect_answers(base) {
                continue;
            }
            self.sleep(timeout)?;
        }
    }
}
