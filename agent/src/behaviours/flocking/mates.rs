//! The flock-mates a robot has heard: heading and position from their last message, forgotten
//! after `time_out` (section II-A). Only what arrived over the radio is here.

use super::desired::V2;

/// What a robot knows about one flock-mate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mate {
    /// Its heading as it broadcast it (in the shared heading frame).
    pub heading: f64,
    /// Its position in the robot's dead-reckoned frame, from the range-and-bearing reading
    /// of its message; `None` if the sensor did not see it.
    pub position: Option<V2>,
    /// Tick its last message was heard.
    pub heard: u64,
}

/// Flock-mates by id.
#[derive(Debug, Clone, Default)]
pub struct Mates {
    by_id: Vec<Option<Mate>>,
}

impl Mates {
    /// Room for robots `0..count`.
    pub fn new(count: usize) -> Mates {
        Mates {
            by_id: vec![None; count],
        }
    }

    /// Records a message from `id` heard at `tick`; ids outside the swarm are ignored.
    pub fn heard(&mut self, id: u32, mate: Mate) {
        if let Some(slot) = self.by_id.get_mut(id as usize) {
            *slot = Some(mate);
        }
    }

    /// Forgets every mate last heard more than `time_out` ticks before `tick`.
    pub fn expire(&mut self, tick: u64, time_out: u64) {
        for slot in &mut self.by_id {
            if slot.is_some_and(|m| tick.saturating_sub(m.heard) > time_out) {
                *slot = None;
            }
        }
    }

    /// The mates still remembered, by id.
    pub fn iter(&self) -> impl Iterator<Item = (u32, &Mate)> {
        self.by_id
            .iter()
            .enumerate()
            .filter_map(|(i, m)| m.as_ref().map(|m| (i as u32, m)))
    }
}
