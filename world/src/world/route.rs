//! Stage `radio`: the frames robots sent at this tick go into the [`RadioMedium`] from where
//! the robots were when sending; after the tick advances, the frames now due go into the
//! inboxes the next observations carry.
//!
//! [`RadioMedium`]: crate::radio::RadioMedium

use swarmrt_protocol::{Command, Frame, RobotState};

use super::World;

impl World {
    /// Routes what the accepted commands sent at this tick.
    pub(super) fn route_radio(&mut self, accepted: &[Option<&Command>]) {
        let tick = self.tick;
        let positions: Vec<(f64, f64)> = self.robots.iter().map(|r| (r.x, r.y)).collect();
        let can_talk: Vec<bool> = self
            .robots
            .iter()
            .map(|r| r.state == RobotState::Active)
            .collect();
        // Frames that travelled within the tick (`radio.rounds`) went already.
        let outboxes: Vec<&[Frame]> = accepted
            .iter()
            .map(|c| {
                c.map(|c| &c.outbox()[self.in_tick_frames(c)..])
                    .unwrap_or(&[])
            })
            .collect();
        let map = &self.map;
        let mut blocked = |a: usize, b: usize| map.blocks(positions[a], positions[b]);
        self.radio
            .send(tick, &outboxes, &positions, &can_talk, &mut blocked);
    }

    /// Fills the inboxes with the frames due at the (new) current tick.
    pub(super) fn deliver_radio(&mut self) {
        let can_talk: Vec<bool> = self
            .robots
            .iter()
            .map(|r| r.state == RobotState::Active)
            .collect();
        self.radio.deliver_due(self.tick, &can_talk);
    }
}
