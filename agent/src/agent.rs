//! The agent core: decodes the radio inbox, runs consensus and the behaviour, and composes
//! the command from what they decided, in one place. Pure: no I/O, no clock.

use swarmrt_protocol::{BROADCAST, Command, CommandKind, Frame, Observation, RobotState};
use swarmrt_scenario::Config;

use crate::consensus::persist::{Persist, Persistent};
use crate::consensus::{Consensus, ConsensusMsg, Decision, Ready};
use crate::inbox::Heard;
use crate::registry::{self, Brain, Decided, Motion, Note, RadioMsg, Tick};

impl Motion {
    fn of(c: &Command) -> Motion {
        Motion {
            v: c.v,
            omega: c.omega,
            velocity: [c.vx, c.vy, c.vz],
            lidar_on: c.lidar_on != 0,
        }
    }

    fn onto(self, c: &mut Command) {
        (c.v, c.omega, c.lidar_on) = (self.v, self.omega, self.lidar_on as u8);
        [c.vx, c.vy, c.vz] = self.velocity;
    }
}

/// A robot's answer to one observation, in raft-rs's `Ready` shape: the command, and what
/// of its persistent Raft state changed and must be durable before the command leaves. The
/// command is reachable only through [`Step::persist_then`] (or, for a driver that keeps no
/// storage, [`Step::without_storage`]), so a shell writes before it sends by construction.
#[derive(Debug)]
#[must_use = "the command leaves only through `persist_then`"]
pub struct Step {
    command: Command,
    persist: Option<Persist>,
}

impl Step {
    /// What must be durable first (`None`: nothing changed, or no stable storage).
    pub fn persist(&self) -> Option<&Persist> {
        self.persist.as_ref()
    }

    /// Hands what must be durable to `save`, then gives the command to send; `save`'s
    /// error keeps the command back.
    pub fn persist_then<E>(
        self,
        save: impl FnOnce(Persist) -> Result<(), E>,
    ) -> Result<Command, E> {
        if let Some(p) = self.persist {
            save(p)?;
        }
        Ok(self.command)
    }

    /// The command, dropping what should have been made durable: for drivers that keep no
    /// stable storage (tests; the fuzzer, which takes whole states itself).
    pub fn without_storage(self) -> Command {
        self.command
    }
}

/// One robot's brain.
pub struct Agent {
    id: u32,
    brain: Box<dyn Brain>,
    malformed: u64,
    consensus: Option<Consensus>,
    heard: Vec<Heard<RadioMsg>>,
    consensus_inbox: Vec<Heard<ConsensusMsg>>,
    /// This tick's motion as last decided (by `step` or a reaction), for the next reaction.
    decided: Motion,
    /// What the behaviour decided, a buffer kept from tick to tick.
    out: Decided,
}

impl Agent {
    /// The agent of robot `id` for this scenario (whose `[behaviour]` a registered behaviour
    /// accepts: the orchestrator resolved it before starting any robot).
    pub fn new(cfg: &Config, id: u32) -> Agent {
        Self::with_consensus(cfg, id, Consensus::new(cfg, id))
    }

    /// Robot `id` in a fresh process after `incarnation` scheduled restarts: no memory at
    /// all; its consensus timeouts come from a new random stream, as a rebooted robot's would.
    pub fn fresh(cfg: &Config, id: u32, incarnation: u32) -> Agent {
        Self::with_consensus(cfg, id, Consensus::fresh(cfg, id, incarnation))
    }

    /// Robot `id` restarting after a crash: a fresh behaviour, and a consensus layer that
    /// kept its persistent Raft state (term, vote, commit, log) and re-applies the committed
    /// decisions. `incarnation` counts the restarts.
    pub fn restore(cfg: &Config, id: u32, state: Persistent, incarnation: u32) -> Agent {
        Self::with_consensus(cfg, id, Consensus::restore(cfg, id, state, incarnation))
    }

    fn with_consensus(cfg: &Config, id: u32, consensus: Option<Consensus>) -> Agent {
        let brain = registry::brain(cfg, id).unwrap_or_else(|(key, message)| {
            panic!("`[behaviour]` was not resolved before building robots: key `{key}`: {message}")
        });
        Agent {
            id,
            brain,
            malformed: 0,
            consensus,
            heard: Vec::new(),
            consensus_inbox: Vec::new(),
            decided: Motion::default(),
            out: Decided::default(),
        }
    }

    /// The consensus layer, when the scenario has `[consensus]`.
    pub fn consensus(&self) -> Option<&Consensus> {
        self.consensus.as_ref()
    }

    /// The robot id.
    pub fn id(&self) -> u32 {
        self.id
    }

    /// Frames that did not decode (counted, never fatal).
    pub fn malformed(&self) -> u64 {
        self.malformed
    }

    /// Decides this tick's command from this tick's observation, with what of its Raft
    /// state must be durable before the command is sent.
    pub fn step(&mut self, obs: &Observation) -> Step {
        let command = self.decide(obs);
        self.decided = Motion::of(&command);
        // Taken whether or not the robot was active, so storage follows the core exactly.
        let persist = self.consensus.as_mut().and_then(Consensus::take_persist);
        Step { command, persist }
    }

    /// Reacts to a propagation round of the tick of `obs` (`radio.rounds`): `frames` reached
    /// this robot within the tick. The React command carries the motion as the behaviour
    /// now wants it (unchanged if it does not react) and the frames it passes on.
    pub fn react(&mut self, obs: &Observation, frames: &[Frame]) -> Command {
        self.decode(frames);
        let mut cmd = Command::act(self.id, obs.tick);
        cmd.kind = CommandKind::React as u32;
        if RobotState::from_u8(obs.state) != Some(RobotState::Active) {
            return cmd;
        }
        self.out.clear();
        self.brain
            .react(obs, &mut self.heard, self.decided, &mut self.out);
        put_behaviour(&mut cmd, &self.out);
        // A reaction's frames all travel within the tick.
        cmd.in_tick = cmd.outbox_len;
        let _ = cmd.set_notes(&self.out.notes);
        self.decided = Motion::of(&cmd);
        cmd
    }

    /// Sorts the frames meant for this robot into behaviour and consensus messages; counts
    /// the ones that do not decode.
    fn decode(&mut self, frames: &[Frame]) {
        self.heard.clear();
        self.consensus_inbox.clear();
        if self.consensus.is_none() && !self.brain.listens() {
            // Nobody would read them.
            return;
        }
        for f in frames {
            if f.dst != BROADCAST && f.dst != self.id {
                // Not for us (the world routes unicast only to its addressee, but answers
                // such as a granted vote must never be taken for one's own).
                continue;
            }
            if f.opaque_bytes().is_some() {
                // Raw bytes between robots of another kind (e.g. foreign controllers).
                continue;
            }
            let Some(msg) = RadioMsg::decode(f.bytes()) else {
                self.malformed += 1;
                continue;
            };
            let (src, sent_tick) = (f.src, f.sent_tick);
            match msg {
                RadioMsg::Consensus(msg) => self.consensus_inbox.push(Heard {
                    src,
                    sent_tick,
                    msg,
                }),
                msg => self.heard.push(Heard {
                    src,
                    sent_tick,
                    msg,
                }),
            }
        }
    }

    fn decide(&mut self, obs: &Observation) -> Command {
        self.decode(obs.inbox());
        let mut cmd = Command::act(self.id, obs.tick);
        if RobotState::from_u8(obs.state) != Some(RobotState::Active) {
            // Knocked down or dead: nothing to decide.
            return cmd;
        }
        // Consensus first: robots act only on committed decisions, and a decision applied
        // this tick already shapes this tick's command.
        let decisions: Vec<Decision> = match &mut self.consensus {
            Some(c) => c.step(obs, &self.consensus_inbox),
            None => Vec::new(),
        };
        self.out.clear();
        let tick = Tick {
            obs,
            heard: &mut self.heard,
            decisions: &decisions,
            leadership: self.consensus.as_ref().and_then(Consensus::leadership),
        };
        self.brain.step(tick, &mut self.out);
        put_behaviour(&mut cmd, &self.out);
        match &mut self.consensus {
            Some(c) => {
                c.propose(&self.out.proposals);
                let ready = c.ready(cmd.outbox().len());
                put_consensus(&mut cmd, ready, &mut self.out.notes);
            }
            // A few small notes always fit the report.
            None => {
                let _ = cmd.set_notes(&self.out.notes);
            }
        }
        cmd
    }
}

/// Writes the behaviour's motion and frames into `cmd` (those within the tick first); a
/// full outbox drops a frame, as the radio would.
fn put_behaviour(cmd: &mut Command, out: &Decided) {
    out.motion.onto(cmd);
    for (k, (dst, msg)) in out.frames.iter().enumerate() {
        if cmd.push_frame(*dst, msg).is_ok() && k < out.in_tick {
            cmd.in_tick += 1;
        }
    }
}

/// Writes the consensus layer's frames after the behaviour's, and its notes after the
/// behaviour's `notes` into the report.
fn put_consensus(cmd: &mut Command, ready: Ready, notes: &mut Vec<Note>) {
    for (dst, m) in ready.frames {
        // `ready` took only the frames left free, and each fits one.
        let pushed = cmd.push_frame(dst, &RadioMsg::Consensus(m));
        debug_assert!(pushed.is_ok(), "a consensus frame always fits");
    }
    if ready.notes.is_empty() {
        let _ = cmd.set_notes(notes);
        return;
    }
    let theirs = notes.len();
    notes.extend(ready.notes.iter().cloned().map(Note::Consensus));
    if cmd.set_notes(notes).is_err() {
        // The behaviour used more than its share: consensus notes must reach the record
        // (the checker rebuilds every log from them), so they win.
        tracing::warn!(
            dropped = theirs,
            "behaviour notes dropped: report full with consensus notes"
        );
        let only: Vec<Note> = ready.notes.into_iter().map(Note::Consensus).collect();
        let _ = cmd.set_notes(&only);
    }
}
