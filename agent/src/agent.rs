//! The agent core: decodes the radio inbox, runs consensus and the behaviour, fills the
//! command. Pure: no I/O, no clock.

use swarmrt_protocol::{BROADCAST, Command, CommandKind, Frame, Observation, RobotState};
use swarmrt_scenario::Config;

use crate::consensus::Consensus;
use crate::consensus::raft::Persistent;
use crate::consensus::{ConsensusMsg, Decision};
use crate::inbox::Heard;
use crate::registry::{self, Brain, Note, Out, RadioMsg, Tick};

/// The motion fields of a command: what a reaction starts from and may replace.
#[derive(Debug, Clone, Copy, Default)]
struct Motion {
    v: f64,
    omega: f64,
    velocity: [f64; 3],
    lidar_on: u8,
}

impl Motion {
    fn of(c: &Command) -> Motion {
        Motion {
            v: c.v,
            omega: c.omega,
            velocity: [c.vx, c.vy, c.vz],
            lidar_on: c.lidar_on,
        }
    }

    fn onto(self, c: &mut Command) {
        (c.v, c.omega, c.lidar_on) = (self.v, self.omega, self.lidar_on);
        [c.vx, c.vy, c.vz] = self.velocity;
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

    /// Decides this tick's command from this tick's observation.
    pub fn step(&mut self, obs: &Observation) -> Command {
        let cmd = self.decide(obs);
        self.decided = Motion::of(&cmd);
        cmd
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
        self.decided.onto(&mut cmd);
        let mut notes: Vec<Note> = Vec::new();
        self.brain.react(obs, &mut self.heard, &mut cmd, &mut notes);
        // A reaction's frames all travel within the tick.
        cmd.in_tick = cmd.outbox_len;
        let _ = cmd.set_notes(&notes);
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
        let mut notes: Vec<Note> = Vec::new();
        let mut proposals: Vec<Decision> = Vec::new();
        let tick = Tick {
            obs,
            heard: &mut self.heard,
            decisions: &decisions,
            leadership: self.consensus.as_ref().and_then(Consensus::leadership),
        };
        let mut out = Out {
            notes: &mut notes,
            proposals: &mut proposals,
        };
        self.brain.step(tick, &mut cmd, &mut out);
        match &mut self.consensus {
            Some(c) => {
                c.propose(&proposals);
                c.finish(&mut cmd, notes)
            }
            // A few small notes always fit the report.
            None => {
                let _ = cmd.set_notes(&notes);
            }
        }
        cmd
    }
}
