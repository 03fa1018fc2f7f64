//! Quadrant leader choice (seed 001, section 2.2).
//!
//! "Each robot considers itself as the origin of its local coordinate system ... and detects
//! other robots' locations in order to estimate in which quadrants they are positioned. A
//! robot is only assigned as the leader of its group when it detects the maximum number of
//! member robots located in the same quadrant. ... [When] more than one robot fulfil[s] the
//! requirements ..., one of these leaders is selected as the only leader of the group in a
//! stochastic manner (randomly)."
//!
//! Here a robot's group is what its range-and-bearing sensor sees; its score is the most
//! group members in one quadrant of its own frame. Every `claim_period` ticks each robot
//! broadcasts the best claim it knows of, ranked by (score, draw, id): its own, or a better
//! one a group member relayed. The draw is the paper's random choice among tied robots. From
//! `decide_tick` on a robot believes in that best claim, and keeps relaying it; a better claim
//! heard later from a group member replaces the belief.
//!
//! Relaying is what makes the choice hold when members do not all see each other: with each
//! robot comparing only the claims of the robots it senses (the first version), two robots
//! that cannot see each other's better rival both declared themselves leader (65 % exactly
//! one leader for 9 sparse robots, 97.2 % for 9 close ones). Relayed, the best claim floods
//! the whole connected group, so a group that senses itself as one settles on one leader.

use std::collections::BTreeSet;
use std::f64::consts::FRAC_PI_2;

use super::{ConsensusMsg, ConsensusNote};
use swarmrt_protocol::{BROADCAST, Neighbour};

use super::Notes;

/// A claim's rank: (score, draw, id), highest wins.
pub type Key = (u8, u32, u32);

/// The quadrant (0..4, counter-clockwise from the heading) of a bearing in the robot's
/// frame, half-open so every bearing has exactly one: 0 is [0°, 90°), 1 [90°, 180°),
/// 2 [180°, 270°) (that is [-180°, -90°), bearing 180° included), 3 [-90°, 0°).
pub fn quadrant(bearing: f64) -> usize {
    let q = (bearing / FRAC_PI_2).floor() as i64;
    q.rem_euclid(4) as usize
}

/// Most neighbours in a single quadrant.
pub fn score(neighbours: &[Neighbour]) -> u8 {
    let mut counts = [0u32; 4];
    for n in neighbours {
        counts[quadrant(n.bearing)] += 1;
    }
    counts.into_iter().max().unwrap_or(0).min(u8::MAX as u32) as u8
}

/// One robot's quadrant leader choice.
#[derive(Debug, Clone)]
pub struct Quadrant {
    id: u32,
    claim_period: u32,
    decide_tick: u64,
    draw: u32,
    score: u8,
    members: BTreeSet<u32>,
    /// The best claim heard from a group member (own or relayed), if any.
    heard: Option<Key>,
    belief: Option<Key>,
    /// Times the belief changed after it was first decided (tie-break rounds over the radio).
    changes: u32,
    noted: Option<u32>,
    msgs: Vec<(u32, ConsensusMsg)>,
}

impl Quadrant {
    /// Robot `id`'s core; `draw` is its seeded tie-break draw.
    pub fn new(id: u32, claim_period: u32, decide_tick: u64, draw: u32) -> Quadrant {
        Quadrant {
            id,
            claim_period: claim_period.max(1),
            decide_tick,
            draw,
            score: 0,
            members: BTreeSet::new(),
            heard: None,
            belief: None,
            changes: 0,
            noted: None,
            msgs: Vec::new(),
        }
    }

    /// This robot's rank.
    pub fn key(&self) -> Key {
        (self.score, self.draw, self.id)
    }

    /// The leader this robot believes in, once decided.
    pub fn leader(&self) -> Option<u32> {
        self.belief.map(|k| k.2)
    }

    /// Its current score.
    pub fn score(&self) -> u8 {
        self.score
    }

    /// The range-and-bearing reading of this tick: the group and the score.
    pub fn observe(&mut self, neighbours: &[Neighbour]) {
        self.score = score(neighbours);
        self.members = neighbours.iter().map(|n| n.id).collect();
    }

    /// Times its belief changed after the decision: how many rounds the radio needed to
    /// settle a tie (0 when the first decision held).
    pub fn changes(&self) -> u32 {
        self.changes
    }

    /// The best claim this robot knows of: its own or the best a group member relayed.
    pub fn best(&self) -> Key {
        self.heard.map_or(self.key(), |h| h.max(self.key()))
    }

    /// A claim heard from robot `from`; only group members (robots it senses) count.
    pub fn step(&mut self, from: u32, msg: &ConsensusMsg) {
        let key = match *msg {
            ConsensusMsg::QuadClaim { score, draw } => (score, draw, from),
            ConsensusMsg::QuadLeader {
                score,
                draw,
                leader,
            } => (score, draw, leader),
            _ => return,
        };
        if from == self.id || !self.members.contains(&from) {
            return;
        }
        self.heard = Some(self.heard.map_or(key, |h| h.max(key)));
        if let Some(b) = self.belief
            && key > b
        {
            self.belief = Some(key);
            self.changes += 1;
        }
    }

    /// Time passes: relay the best claim known, decide, keep the belief current.
    pub fn tick(&mut self, tick: u64, notes: &mut Notes) {
        let due = (tick + self.id as u64).is_multiple_of(self.claim_period as u64);
        let best = self.best();
        if due {
            self.msgs.push((
                BROADCAST,
                ConsensusMsg::QuadLeader {
                    score: best.0,
                    draw: best.1,
                    leader: best.2,
                },
            ));
        }
        if tick < self.decide_tick {
            return;
        }
        match self.belief {
            None => self.belief = Some(best),
            // Our own key may have grown if the group changed.
            Some(b) if best > b => {
                self.belief = Some(best);
                self.changes += 1;
            }
            _ => {}
        }
        let leader = self.leader();
        if leader != self.noted
            && let Some(l) = leader
        {
            let note = ConsensusNote::Quadrant {
                leader: l,
                leads: l == self.id,
                score: self.score,
            };
            if notes.room() >= Notes::cost(&note) {
                notes.push(note);
                self.noted = leader;
            }
        }
    }

    /// The messages to send, at most `budget`.
    pub fn ready(&mut self, budget: usize) -> Vec<(u32, ConsensusMsg)> {
        let mut out = std::mem::take(&mut self.msgs);
        out.truncate(budget);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn nb(id: u32, bearing: f64) -> Neighbour {
        Neighbour {
            id,
            range: 1.0,
            bearing,
        }
    }

    #[test]
    fn quadrants_of_bearings() {
        assert_eq!(quadrant(0.1), 0);
        assert_eq!(quadrant(PI / 2.0 + 0.1), 1);
        assert_eq!(quadrant(PI), 2);
        assert_eq!(quadrant(-PI), 2);
        assert_eq!(quadrant(-PI + 0.1), 2);
        assert_eq!(quadrant(-0.1), 3);
        assert_eq!(score(&[nb(1, 0.2), nb(2, 0.4), nb(3, -0.3)]), 2);
        assert_eq!(score(&[]), 0);
    }

    #[test]
    fn best_claim_wins_and_ties_go_to_the_draw() {
        let mut notes = Notes::new(200);
        // Robots 0 and 1 both see two members in one quadrant: the draw decides.
        let mut a = Quadrant::new(0, 1, 2, 10);
        let mut b = Quadrant::new(1, 1, 2, 20);
        let view = [nb(0, 0.3), nb(1, 0.3), nb(2, 0.5)];
        a.observe(&[view[1], view[2]]);
        b.observe(&[view[0], view[2]]);
        for t in 0..2 {
            a.tick(t, &mut notes);
            b.tick(t, &mut notes);
            for (_, m) in a.ready(4) {
                b.step(0, &m);
            }
            for (_, m) in b.ready(4) {
                a.step(1, &m);
            }
        }
        a.tick(2, &mut notes);
        b.tick(2, &mut notes);
        assert_eq!(a.leader(), Some(1));
        assert_eq!(b.leader(), Some(1));
        // A claim from a robot outside the group (not sensed) is ignored.
        let mut c = Quadrant::new(5, 1, 0, 0);
        c.observe(&[nb(1, 0.1)]);
        c.step(
            9,
            &ConsensusMsg::QuadLeader {
                score: 9,
                draw: 9,
                leader: 9,
            },
        );
        c.tick(0, &mut notes);
        assert_eq!(c.leader(), Some(5));
        // ... but a better announcement from a member replaces a decided belief.
        c.step(
            1,
            &ConsensusMsg::QuadLeader {
                score: 3,
                draw: 0,
                leader: 1,
            },
        );
        assert_eq!(c.leader(), Some(1));
        assert_eq!(c.changes(), 1);
    }

    #[test]
    fn the_best_claim_floods_a_chain_of_robots_that_do_not_all_see_each_other() {
        // 0 - 1 - 2 - 3 in a line of sight chain: each senses only its chain neighbours. Robot
        // 3 holds the best claim; robot 0 never senses it, yet must follow it.
        let mut notes = Notes::new(10_000);
        let draws = [5, 1, 2, 9];
        let mut q: Vec<Quadrant> = (0..4)
            .map(|i| Quadrant::new(i, 1, 10, draws[i as usize]))
            .collect();
        for (i, r) in q.iter_mut().enumerate() {
            let i = i as u32;
            let sees: Vec<Neighbour> = [i.wrapping_sub(1), i + 1]
                .into_iter()
                .filter(|&j| j < 4)
                .map(|j| nb(j, 0.2))
                .collect();
            r.observe(&sees);
        }
        for t in 0..12 {
            let mut sent = Vec::new();
            for r in q.iter_mut() {
                r.tick(t, &mut notes);
                sent.push(r.ready(8));
            }
            for (from, msgs) in sent.into_iter().enumerate() {
                for (_, m) in msgs {
                    for r in q.iter_mut() {
                        r.step(from as u32, &m);
                    }
                }
            }
        }
        // Scores: the ends see one member, the middle two see two (both at bearing 0.2), so
        // robots 1 and 2 tie on score 2 and robot 2's draw (2 > 1) wins everywhere.
        for r in &q {
            assert_eq!(r.leader(), Some(2), "robot {}", r.id);
        }
    }
}
