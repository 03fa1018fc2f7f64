//! Whose answer a command is: the world's side of the command inbox ([`crate::inbox`]), for
//! its own host's robots and, through [`super::remote`], the remote hosts' ones.

use std::collections::BTreeSet;

use iceoryx2::identifiers::UniquePublisherId;
use swarmrt_ipc::{self as ipc, IpcError};
use swarmrt_protocol::Command;

use super::stats::ShellStats;
use crate::inbox;
use crate::supervisor::hello::{Bindings, Sample};

/// Where a command came from: a local robot's publisher, or a remote host's robot (its host
/// bound the publisher there).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Origin {
    Local(UniquePublisherId),
    Remote(u32),
}

/// Who speaks for which robot, local and remote, and who waits for a hello (before tick 0
/// every robot; later, robots restarted by the schedule until their fresh process says it).
pub(super) type Hellos = Bindings<Origin>;

/// The current tick's answers and whom they are still awaited from.
#[derive(Debug, Default)]
pub(super) struct Answers {
    /// The robots whose answer the current tick waits for (none before tick 0).
    pub(super) pending: BTreeSet<u32>,
    /// The answers, by robot.
    pub(super) commands: Vec<Option<Command>>,
    /// The tick the answers are awaited for.
    pub(super) tick: u64,
}

impl Answers {
    /// Applies one classified command sample: a bound robot's first sample after the
    /// observation is its answer, whatever it says (World::validate refuses a later tick,
    /// a wrong kind, id or version, and the robot stands still this tick instead of the world
    /// waiting for ever); the rest is counted. A sample naming an earlier tick is a copy
    /// left over from a tick already answered, not this tick's answer: taking it would
    /// refuse the robot's real answer still on its way, by the luck of wake-up timing.
    pub(super) fn take(&mut self, sample: Sample, c: Command, stats: &mut ShellStats) {
        match sample {
            Sample::Robot(_) if c.tick < self.tick => stats.extra_commands += 1,
            Sample::Robot(robot) if self.pending.remove(&robot) => {
                self.commands[robot as usize] = Some(c)
            }
            Sample::Robot(_) => stats.extra_commands += 1,
            Sample::Hello(robot) => tracing::debug!(robot, pid = c.pid, "robot ready"),
            Sample::BadHello | Sample::Unknown => count_stranger(sample, &c, stats),
        }
    }
}

/// Counts a sample that is no robot's: a hello for a taken or foreign id, or anything from a
/// publisher that never said hello.
pub(super) fn count_stranger(sample: Sample, c: &Command, stats: &mut ShellStats) {
    if sample == Sample::BadHello {
        stats.bad_hello += 1;
        tracing::warn!(
            robot = c.robot,
            "ignoring a hello that claims a taken or foreign id"
        );
    } else {
        stats.unknown_sender += 1;
        if stats.unknown_sender == 1 {
            tracing::warn!(
                claimed = c.robot,
                "command from a publisher that is no robot of this run"
            );
        }
    }
}

/// True when a local publisher may claim robot `r`: no robot of a remote host.
pub(super) fn is_local(remote_robot: &[bool], r: u32) -> bool {
    !remote_robot.get(r as usize).copied().unwrap_or(true)
}

/// Receives every queued command sample from the robots of this host into `answers`.
pub(super) fn receive(
    commands: &ipc::CommandSubscribers,
    remote_robot: &[bool],
    hellos: &mut Hellos,
    answers: &mut Answers,
    stats: &mut ShellStats,
) -> Result<(), IpcError> {
    inbox::receive(
        commands,
        hellos,
        Origin::Local,
        |r| is_local(remote_robot, r),
        |sample, c| answers.take(sample, c, stats),
    )
}
