//! What a policy answers for one robot, checked against the robot's limits and turned into
//! the command its process would send: the same bytes from the environment and from a robot
//! process running the policy ([`Action::command`]).

use swarmrt_protocol::{BROADCAST, Command, Frame};
use swarmrt_scenario::Config;

/// One robot's answer: forward speed, turn rate and, optionally, bytes to broadcast as one
/// opaque radio frame (carried by the world's radio model like any frame).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Action {
    /// Forward speed (m/s), within `robots.max_speed` either way.
    pub v: f64,
    /// Turn rate (rad/s), within `robots.max_turn_rate` either way.
    pub omega: f64,
    /// Bytes to broadcast this tick (at most the layout's payload); none when empty.
    pub say: Vec<u8>,
}

/// Why an action was refused: the robot, what was wrong and the bound it broke.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("agent robot_{robot}: {what}")]
pub struct ActionError {
    /// The robot whose action it was.
    pub robot: u32,
    /// What was wrong, with the bound.
    pub what: String,
}

impl Action {
    /// Refuses an action the world would refuse or a frame longer than `payload`, naming the
    /// robot and the bound.
    pub fn check(&self, cfg: &Config, robot: u32, payload: usize) -> Result<(), ActionError> {
        let refuse = |what: String| Err(ActionError { robot, what });
        let lim = &cfg.robots;
        for (name, value, max) in [
            ("v", self.v, lim.max_speed),
            ("omega", self.omega, lim.max_turn_rate),
        ] {
            if !value.is_finite() {
                return refuse(format!("{name} = {value} is not a finite number"));
            }
            if value.abs() > max * (1.0 + 1e-9) + 1e-9 {
                return refuse(format!("{name} = {value} is out of range [-{max}, {max}]"));
            }
        }
        if self.say.len() > payload {
            return refuse(format!(
                "says {} bytes; a frame holds at most {payload}",
                self.say.len()
            ));
        }
        Ok(())
    }

    /// The command robot `robot` sends for this action at `tick`: its lidar kept on (a
    /// policy reads it every tick), the bytes as one broadcast opaque frame.
    pub fn command(&self, robot: u32, tick: u64) -> Command {
        let mut c = Command::act(robot, tick);
        c.v = self.v;
        c.omega = self.omega;
        c.lidar_on = 1;
        if !self.say.is_empty()
            && let Ok(frame) = Frame::opaque(BROADCAST, &self.say)
        {
            c.outbox[0] = frame;
            c.outbox_len = 1;
        }
        c
    }
}
