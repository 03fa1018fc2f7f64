//! The agent core: decodes the radio inbox, keeps what beacons told it, runs the behaviour.

use std::collections::BTreeMap;
use swarmrt_protocol::config::{BehaviourConfig, Config};
use swarmrt_protocol::{Command, Observation, RadioMsg, RobotState};

use crate::behaviours::Behaviour;
use crate::behaviours::formation::Formation;
use crate::behaviours::goto::Goto;

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
}

impl Agent {
    /// The agent of robot `id` for this scenario.
    pub fn new(cfg: &Config, id: u32) -> Agent {
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
        }
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
            match RadioMsg::decode(f.bytes()) {
                Some(msg) => {
                    if let RadioMsg::Beacon { x, y, theta } = msg {
                        let newer = self
                            .beacons
                            .get(&f.src)
                            .is_none_or(|b| b.sent_tick <= f.sent_tick);
                        if newer {
                            self.beacons.insert(
                                f.src,
                                BeaconInfo {
                                    sent_tick: f.sent_tick,
                                    x,
                                    y,
                                    theta,
                                },
                            );
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
        let mut cmd = self.behaviour.step(obs, &self.inbox);
        cmd.robot = self.id;
        cmd.tick = obs.tick;
        cmd
    }
}
