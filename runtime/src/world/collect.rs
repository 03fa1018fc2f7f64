//! Waiting for the robots' answers: in lock-step until every pending robot answered (a tick's
//! answers, or a round's reactions), or by the wall clock until the tick's window closes.

use std::collections::BTreeSet;
use std::time::Instant;

use swarmrt_ipc::IpcError;
use swarmrt_world::World;

use super::answers::{Origin, count_stranger, is_local};
use super::control::{drain_control, give_up, wait};
use super::realtime::Realtime;
use super::shell::Processes;
use crate::inbox;
use crate::supervisor::hello::Sample;

impl Processes<'_> {
    /// Lock-step: waits until every pending robot answered (a tick's answers, or a round's
    /// reactions). Past `scenario.deadline_ms` the late ones are counted; past
    /// `scenario.unresponsive_ms` they are given up.
    pub(super) fn collect(&mut self, world: &mut World, tick: u64) -> Result<(), IpcError> {
        let sent_at = Instant::now();
        let mut late_logged = false;
        loop {
            let base = self.ports.bell.answers();
            self.gather(world)?;
            if self.answers.pending.is_empty() || self.interrupted {
                return Ok(());
            }
            let waited = sent_at.elapsed();
            if waited >= self.unresponsive {
                for robot in std::mem::take(&mut self.answers.pending) {
                    self.hellos.forget(robot);
                    give_up(world, robot, waited, "no answer");
                }
                return Ok(());
            }
            let timeout = if waited < self.deadline {
                self.deadline - waited
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
            if now >= rt.window_closes() {
                // Once per tick, not per wake-up.
                self.give_up_silent(world, now, rt);
                return Ok(());
            }
            self.interrupted |= wait(&self.ports.listener, self.node, rt.window_closes() - now)?;
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
            .filter(|&r| now.duration_since(rt.heard_at(r)) >= self.unresponsive)
            .collect();
        for robot in hung {
            self.hellos.forget(robot);
            let waited = now.duration_since(rt.heard_at(robot));
            give_up(world, robot, waited, "nothing sent");
            rt.forget(robot);
        }
    }
}
