//! Observer selection (seed 000, section 5.2, eq. 4-5): which three robots turn their lidar
//! on, chosen in a frame centred on the virtual leader with x' along the swarm's heading.

/// A robot's observer role. Only observers turn their lidar on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum ObserverRole {
    /// Lidar off: follows its neighbours.
    None = 0,
    /// The leading robot; its lidar looks straight ahead.
    Middle = 1,
    /// The leftmost robot; its lidar points slightly left.
    Left = 2,
    /// The rightmost robot; its lidar points slightly right.
    Right = 3,
}

impl ObserverRole {
    /// Decodes the wire value; anything unknown is `None`.
    pub fn from_u8(v: u8) -> ObserverRole {
        match v {
            1 => ObserverRole::Middle,
            2 => ObserverRole::Left,
            3 => ObserverRole::Right,
            _ => ObserverRole::None,
        }
    }
}

/// A robot's position in the leader frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placed {
    /// Robot id.
    pub id: u32,
    /// Along the swarm's heading (eq. 4).
    pub x: f64,
    /// To the left of the swarm's heading (eq. 5).
    pub y: f64,
}

/// The chosen observers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Observers {
    /// The middle observer.
    pub middle: Option<u32>,
    /// The left observer.
    pub left: Option<u32>,
    /// The right observer.
    pub right: Option<u32>,
}

impl Observers {
    /// The role of robot `id`.
    pub fn role_of(&self, id: u32) -> ObserverRole {
        if self.middle == Some(id) {
            ObserverRole::Middle
        } else if self.left == Some(id) {
            ObserverRole::Left
        } else if self.right == Some(id) {
            ObserverRole::Right
        } else {
            ObserverRole::None
        }
    }
}

/// Eq. 4-5: `(x, y)` relative to the virtual leader `leader`, x' along heading `omega`.
pub fn to_leader_frame(x: f64, y: f64, leader: (f64, f64), omega: f64) -> (f64, f64) {
    let (dx, dy) = (x - leader.0, y - leader.1);
    let (s, c) = omega.sin_cos();
    (dx * c + dy * s, dy * c - dx * s)
}

/// Chooses the observers among `robots` (leader-frame positions). Differences under `tol`
/// (half a robot width) count as equal; remaining ties go to the lower id, so every robot
/// that knows the same positions picks the same observers.
pub fn select(robots: &[Placed], tol: f64) -> Observers {
    match robots.len() {
        0 => Observers::default(),
        // "If there are no other agents remaining, the last remaining agent will act as the
        // middle observer."
        1 => Observers {
            middle: Some(robots[0].id),
            ..Observers::default()
        },
        // "If there are two agents remaining, they will act as the left and right observers."
        2 => {
            let left = best_left(robots, tol).expect("two robots");
            let right = robots.iter().find(|r| r.id != left).map(|r| r.id);
            Observers {
                middle: None,
                left: Some(left),
                right,
            }
        }
        _ => {
            let left = best_left(robots, tol).expect("non-empty");
            let rest: Vec<Placed> = robots.iter().copied().filter(|r| r.id != left).collect();
            let right = best_right(&rest, tol).expect("non-empty");
            // A robot meeting the middle and a side criterion takes the side role; the next
            // one meeting the middle criterion becomes the middle observer (Fig. 6).
            let others: Vec<Placed> = rest.iter().copied().filter(|r| r.id != right).collect();
            Observers {
                middle: best_middle(&others, tol),
                left: Some(left),
                right: Some(right),
            }
        }
    }
}

/// Middle: the largest x'; among equals the smallest |y'|; then the largest x'.
fn best_middle(robots: &[Placed], tol: f64) -> Option<u32> {
    let top = robots.iter().map(|r| r.x).fold(f64::NEG_INFINITY, f64::max);
    let front: Vec<&Placed> = robots.iter().filter(|r| r.x >= top - tol).collect();
    let centre = front
        .iter()
        .map(|r| r.y.abs())
        .fold(f64::INFINITY, f64::min);
    front
        .into_iter()
        .filter(|r| r.y.abs() <= centre + tol)
        .max_by(|a, b| a.x.total_cmp(&b.x).then(b.id.cmp(&a.id)))
        .map(|r| r.id)
}

/// Left: the largest y'; among equals the largest x'.
fn best_left(robots: &[Placed], tol: f64) -> Option<u32> {
    let top = robots.iter().map(|r| r.y).fold(f64::NEG_INFINITY, f64::max);
    robots
        .iter()
        .filter(|r| r.y >= top - tol)
        .max_by(|a, b| {
            a.x.total_cmp(&b.x)
                .then(a.y.total_cmp(&b.y))
                .then(b.id.cmp(&a.id))
        })
        .map(|r| r.id)
}

/// Right: the smallest y'; among equals the largest x'.
fn best_right(robots: &[Placed], tol: f64) -> Option<u32> {
    let bottom = robots.iter().map(|r| r.y).fold(f64::INFINITY, f64::min);
    robots
        .iter()
        .filter(|r| r.y <= bottom + tol)
        .max_by(|a, b| {
            a.x.total_cmp(&b.x)
                .then(b.y.total_cmp(&a.y))
                .then(b.id.cmp(&a.id))
        })
        .map(|r| r.id)
}
