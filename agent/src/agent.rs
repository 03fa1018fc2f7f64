//! The agent core: decodes the radio inbox, keeps what beacons told it, runs the behaviour.

use std::collections::BTreeMap;
use std::collections::btree_map::Entry;
use swarmrt_protocol::config::{BehaviourConfig, Config};
use swarmrt_protocol::{BROADCAST, Command, Observation, RadioMsg, RobotState};

use crate::behaviours::Behaviour;
use crate::behaviours::formation::Formation;
use crate::behaviours::goto::Goto;
use crate::consensus::Consensus;
use crate::consensus::raft::Persistent;

/// A radio message as the behaviour sees it: who sent it, when, and what it says.
#[derive(Debug, Clone, PartialEq)]
pub struct Decoded {
    /// Sender id (set by the world, not by the sender).
    pub src: u32,
    /// Tick at which it was sent.
    pub sent_tick: u64,
    /// The message.
    pub msg: RadioMsg,
}

/// What a robot last heard in a neighbour's beacon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeaconInfo {
    /// Tick at which the beacon was sent.
    pub sent_tick: u64,
    /// Reported x.
    pub x: f64,
    /// Reported y.
    pub y: f64,
    /// Reported heading.
    pub theta: f64,
}

/// One robot's brain.
pub struct Agent {
    id: u32,
    behaviour: Box<dyn Behaviour + Send>,
    beacons: BTreeMap<u32, BeaconInfo>,
    malformed: u64,
    inbox: Vec<Decoded>,
    consensus: Option<Consensus>,
}

impl Agent {
    /// The agent of robot `id` for this scenario.
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
        let behaviour: Box<dyn Behaviour + Send> = match &cfg.behaviour {
            BehaviourConfig::Goto(g) => Box::new(Goto::new(cfg, g, id)),
            BehaviourConfig::Formation(f) => Box::new(Formation::new(cfg, f, id)),
        };
        Agent {
            id,
            behaviour,
            beacons: BTreeMap::new(),
            malformed: 0,
            inbox: Vec::new(),
            consensus,
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

    /// Latest beacon per neighbour, as heard over the radio.
    pub fn beacons(&self) -> &BTreeMap<u32, BeaconInfo> {
        &self.beacons
    }

    /// Frames that did not decode (counted, never fatal).
    pub fn malformed(&self) -> u64 {
        self.malformed
    }

    /// Decides this tick's command from this tick's observation.
    pub fn step(&mut self, obs: &Observation) -> Command {
        self.inbox.clear();
        for f in obs.inbox() {
            if f.dst != BROADCAST && f.dst != self.id {
                // Not for us (the world routes unicast only to its addressee, but answers
                // such as a granted vote must never be taken for one's own).
                continue;
            }
            match RadioMsg::decode(f.bytes()) {
                Some(msg) => {
                    if let RadioMsg::Beacon { x, y, theta } = msg {
                        let heard = BeaconInfo {
                            sent_tick: f.sent_tick,
                            x,
                            y,
                            theta,
                        };
                        // One lookup per beacon (a 1,000-robot tick decodes ~35,000).
                        match self.beacons.entry(f.src) {
                            Entry::Vacant(v) => {
                                v.insert(heard);
                            }
                            Entry::Occupied(mut o) => {
                                if o.get().sent_tick <= f.sent_tick {
                                    o.insert(heard);
                                }
                            }
                        }
                    }
                    self.inbox.push(Decoded {
                        src: f.src,
                        sent_tick: f.sent_tick,
                        msg,
                    });
                }
                None => self.malformed += 1,
            }
        }
        if RobotState::from_u8(obs.state) != Some(RobotState::Active) {
            // Knocked down or dead: nothing to decide.
            return Command::act(self.id, obs.tick);
        }
        // Consensus first: robots act only on committed decisions, and a decision applied
        // this tick already shapes this tick's command.
        let decisions = match &mut self.consensus {
            Some(c) => c.step(obs, &self.inbox),
            None => Vec::new(),
        };
        for d in &decisions {
            self.behaviour.apply(d);
        }
        let mut cmd = self.behaviour.step(obs, &self.inbox);
        cmd.robot = self.id;
        cmd.tick = obs.tick;
        if let Some(c) = &mut self.consensus {
            c.finish(&mut cmd);
        }
        cmd
    }
}
