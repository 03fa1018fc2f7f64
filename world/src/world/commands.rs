//! Stage `commands`: each command is checked against the protocol and the robot's limits,
//! then accepted (its notes become events) or refused (counted, the robot stands still).

use swarmrt_protocol::{
    BROADCAST, Command, CommandKind, MAX_OUTBOX, MAX_PAYLOAD, PROTOCOL_VERSION, RobotState,
};

use super::{Event, World};

impl World {
    /// Checks a command against the protocol and the robot's limits; `Err` names the problem.
    pub fn validate(&self, robot: usize, cmd: &Command) -> Result<(), &'static str> {
        let lim = &self.cfg.robots;
        if cmd.version != PROTOCOL_VERSION {
            return Err("wrong protocol version");
        }
        if cmd.robot as usize != robot {
            return Err("robot id does not match its slot");
        }
        if CommandKind::from_u32(cmd.kind) != Some(CommandKind::Act) {
            return Err("not an Act command");
        }
        if cmd.tick != self.tick {
            return Err("command for another tick");
        }
        if !cmd.v.is_finite() || !cmd.omega.is_finite() {
            return Err("non-finite speed");
        }
        let eps = 1e-9;
        if let Some(aerial) = &lim.aerial {
            if !(cmd.vx.is_finite() && cmd.vy.is_finite() && cmd.vz.is_finite()) {
                return Err("non-finite speed");
            }
            if cmd.vx.hypot(cmd.vy) > lim.max_speed * (1.0 + eps) + eps
                || cmd.vz.abs() > aerial.max_vertical_speed * (1.0 + eps) + eps
            {
                return Err("speed out of range");
            }
        }
        if cmd.v.abs() > lim.max_speed * (1.0 + eps) + eps
            || cmd.omega.abs() > lim.max_turn_rate * (1.0 + eps) + eps
        {
            return Err("speed out of range");
        }
        if cmd.outbox_len as usize > MAX_OUTBOX {
            return Err("outbox length out of range");
        }
        (self.vocabulary.read_notes)(cmd.report()?)?;
        for f in cmd.outbox() {
            if f.len as usize > MAX_PAYLOAD {
                return Err("oversized radio frame");
            }
            if f.dst != BROADCAST && f.dst as usize >= self.robots.len() {
                return Err("radio frame to an unknown robot");
            }
            // The world routes bytes, but bytes no robot could read are refused at the
            // boundary rather than delivered as noise. An opaque frame is for robots of
            // its sender's kind, which read it themselves.
            if f.opaque_bytes().is_none() && !(self.vocabulary.check_frame)(f.bytes()) {
                return Err("malformed radio frame");
            }
        }
        Ok(())
    }

    /// Accepts or refuses each active robot's command, in robot-id order: `Some` for an
    /// accepted command, `None` for a refused, missing or not expected one.
    pub(super) fn accept_commands<'c>(
        &mut self,
        commands: &'c [Option<Command>],
    ) -> Vec<Option<&'c Command>> {
        let n = self.robots.len();
        let tick = self.tick;
        let mut accepted: Vec<Option<&Command>> = vec![None; n];
        for i in 0..n {
            if self.robots[i].state != RobotState::Active {
                continue;
            }
            if let Some(cmd) = &commands[i] {
                match self.validate(i, cmd) {
                    Ok(()) => {
                        accepted[i] = Some(cmd);
                        // validate() decoded it once already; this cannot fail.
                        let report = cmd.report().unwrap_or_default();
                        for note in (self.vocabulary.read_notes)(report).unwrap_or_default() {
                            if note.claims_leadership {
                                self.leader = Some(i as u32);
                            }
                            self.events.push(Event::Note {
                                tick,
                                robot: i as u32,
                                note: note.json,
                            });
                        }
                    }
                    Err(reason) => self.reject(i as u32, reason),
                }
            }
        }
        accepted
    }

    /// Counts a refused command; the first refusal per robot and reason becomes an event.
    pub fn reject(&mut self, robot: u32, reason: &'static str) {
        self.metrics.rejected += 1;
        if (robot as usize) < self.robots.len() && self.rejected_once.insert((robot, reason)) {
            tracing::warn!(robot, reason, tick = self.tick, "command rejected");
            self.events.push(Event::Rejected {
                tick: self.tick,
                robot,
                reason: reason.to_string(),
            });
        }
    }
}
