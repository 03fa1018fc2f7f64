//! The swarm's turn from the three observers' lidar verdicts (seed 000, section 5.2) and the
//! epsilon-greedy escape from loops (section 5.3).

/// A turn for one step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dir {
    /// Clockwise by the turn angle.
    Right = -1,
    /// Keep the heading.
    Straight = 0,
    /// Counter-clockwise by the turn angle.
    Left = 1,
}

impl Dir {
    /// +1 left, 0 straight, -1 right.
    pub fn sign(self) -> f64 {
        self as i8 as f64
    }

    /// The other side; straight stays straight.
    pub fn opposite(self) -> Dir {
        match self {
            Dir::Left => Dir::Right,
            Dir::Right => Dir::Left,
            Dir::Straight => Dir::Straight,
        }
    }
}

/// Which observers see an obstacle, and how far the side observers' nearest one is.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Seen {
    /// The left observer.
    pub left: bool,
    /// The middle observer.
    pub middle: bool,
    /// The right observer.
    pub right: bool,
    /// Metres from the left observer to the nearest obstacle in its cone (when `left`).
    pub left_range: f64,
    /// Metres from the right observer to the nearest obstacle in its cone (when `right`).
    pub right_range: f64,
}

impl Seen {
    /// Obstacle or not per observer, with no ranges (they matter only when both sides see).
    pub fn flags(left: bool, middle: bool, right: bool) -> Seen {
        Seen {
            left,
            middle,
            right,
            ..Seen::default()
        }
    }

    /// True when any observer sees something.
    pub fn any(self) -> bool {
        self.left || self.middle || self.right
    }
}

/// The turn toward the target: `target_error` is the target's bearing relative to the swarm
/// heading; within `half_turn` the swarm is heading at it.
pub fn toward(target_error: f64, half_turn: f64) -> Dir {
    if target_error > half_turn {
        Dir::Left
    } else if target_error < -half_turn {
        Dir::Right
    } else {
        Dir::Straight
    }
}

/// Section 5.2's table. `coin` picks a side (true = left) when an obstacle is dead ahead and the
/// swarm is heading straight at the target; side ranges within `tie` metres count as equal.
pub fn decide(
    seen: Seen,
    previous: Dir,
    target_error: f64,
    half_turn: f64,
    tie: f64,
    coin: impl FnOnce() -> bool,
) -> Dir {
    let Seen {
        left,
        middle,
        right,
        left_range,
        right_range,
    } = seen;
    match (left, middle, right) {
        // Nothing seen: toward the target.
        (false, false, false) => toward(target_error, half_turn),
        // Left, or left and middle: turn right.
        (true, _, false) => Dir::Right,
        // Right, or middle and right: turn left.
        (false, _, true) => Dir::Left,
        // Only the middle, or all three: keep turning the same way; after going straight turn
        // toward the target; heading at the target, pick a side at random.
        (false, true, false) | (true, true, true) => match previous {
            Dir::Left | Dir::Right => previous,
            Dir::Straight => match toward(target_error, half_turn) {
                Dir::Straight => {
                    if coin() {
                        Dir::Left
                    } else {
                        Dir::Right
                    }
                }
                side => side,
            },
        },
        // Left and right but not the middle (a gap ahead): the paper is silent, so this reading
        // is ours. Steer away from the nearer side, which centres the formation in the gap
        // instead of letting a converging side close on its edge robot; equal ranges (within
        // `RANGE_TIE`) go straight through.
        (true, false, true) => {
            if (left_range - right_range).abs() <= tie {
                Dir::Straight
            } else if left_range < right_range {
                Dir::Right
            } else {
                Dir::Left
            }
        }
    }
}

/// Epsilon-greedy: with probability `epsilon_obstacle` (something seen) or `epsilon_clear`
/// (nothing seen) take the opposite turn. Returns the turn and whether it was flipped.
pub fn epsilon_greedy(
    dir: Dir,
    seen: Seen,
    epsilon_obstacle: f64,
    epsilon_clear: f64,
    rng: &mut impl rand::Rng,
) -> (Dir, bool) {
    if dir == Dir::Straight {
        return (dir, false);
    }
    let eps = if seen.any() {
        epsilon_obstacle
    } else {
        epsilon_clear
    };
    if rand::Rng::random::<f64>(rng) < eps {
        (dir.opposite(), true)
    } else {
        (dir, false)
    }
}
