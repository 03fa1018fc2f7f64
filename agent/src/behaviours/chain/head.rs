//! The initiator's wall following with target seeking: the subsumption layers of Table 2
//! (section 3, "Exploratory behaviour"), evaluated from the highest (6, KEEP-MOVING) to the
//! lowest (1, CLOSE-LEFT); a lower layer that triggers overrides the ones above it, so
//! collision avoidance has the last word.
//!
//! Readings of the paper we chose:
//! - FAR-RIGHT and FAR-LEFT trigger on any reading above `wall_max`, nothing seen included
//!   (a wall that ends is one the head is leaving). FAR-LEFT: leaving the left wall but not
//!   the right one (Table 2's wording; the text's "and above the right reading" is the same
//!   whenever the right wall is still there).
//! - CLOSE-LEFT: close to the left wall and not close to the right one, or closer to the left
//!   when both are close (the text's optimisation of 2.6): in a corridor narrower than twice
//!   `wall_min` the head turns away from the nearer wall instead of always to the left.
//! - FAR-RIGHT and FAR-LEFT stay silent while the target is in sight (the goal sensor, which
//!   obstacles occlude): walls are followed to find the target, and a head that keeps
//!   hugging a pillar after it sees the target would orbit it for ever (TARGET-CHECK sits
//!   above them in the stack, so read literally they would always override it). CLOSE-RIGHT
//!   and CLOSE-LEFT, the collision avoidance, always apply.
//! - Table 2 lists KEEP-MOVING again after CLOSE-LEFT; we read it as the table's wrap-around
//!   (the stack starts over at the next tick), not as a seventh layer.

use swarmrt_protocol::Observation;
use swarmrt_scenario::LidarConfig;

use super::params::ChainParams;

/// A layer of Table 2, by priority number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layer {
    /// 6: always; both wheels at s.
    KeepMoving,
    /// 5: the target is seen; wheels steer to it (both stop at it with `stop_at_target`).
    TargetCheck,
    /// 4: leaving the right wall; turn right (vl = s, vr = 0).
    FarRight,
    /// 3: leaving the left wall but not the right one; turn left (vl = 0, vr = s).
    FarLeft,
    /// 2: wall close to the right; turn left (vl = 0, vr = s).
    CloseRight,
    /// 1: wall close to the left but not to the right; turn right (vl = s, vr = 0).
    CloseLeft,
}

/// The two side readings of step 1: nearest wall at the left-front and right-front, in
/// metres (the lidar's range when nothing is seen). Robots are not walls: a head must neither
/// follow its own chain curling beside it nor turn away from it (the chain follows the head
/// and keeps its rods; it is not in the way).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sides {
    /// Left-front.
    pub left: f64,
    /// Right-front.
    pub right: f64,
}

/// What TARGET-CHECK knows of the target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// Bearing in the robot frame, radians (positive: left).
    pub bearing: f64,
    /// The head is at the target.
    pub reached: bool,
}

/// Wheel speeds (m/s) as Table 2 writes them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wheels {
    /// Left wheel.
    pub vl: f64,
    /// Right wheel.
    pub vr: f64,
}

/// The nearest lidar hit in the left-front sector `[from, to]` degrees and the right-front
/// one `[-to, -from]`. Hits within `body` metres of a robot that range-and-bearing reports
/// are that robot, not a wall.
pub fn sides(obs: &Observation, lidar: &LidarConfig, sector_deg: [f64; 2], body: f64) -> Sides {
    let (from, to) = (sector_deg[0].to_radians(), sector_deg[1].to_radians());
    let mut s = Sides {
        left: lidar.range,
        right: lidar.range,
    };
    let robots: Vec<(f64, f64)> = obs.neighbours[..obs.neighbours_len as usize]
        .iter()
        .map(|n| (n.range * n.bearing.cos(), n.range * n.bearing.sin()))
        .collect();
    for k in 0..obs.lidar_len as usize {
        let a = swarmrt_scenario::wrap_angle(lidar.ray_angle(k));
        let d = obs.lidar[k];
        let hit = (d * a.cos(), d * a.sin());
        if robots
            .iter()
            .any(|r| (r.0 - hit.0).hypot(r.1 - hit.1) <= body)
        {
            continue;
        }
        if (from..=to).contains(&a) {
            s.left = s.left.min(d);
        } else if (-to..=-from).contains(&a) {
            s.right = s.right.min(d);
        }
    }
    s
}

/// Table 2: the layer whose output drives the head and its wheel speeds.
pub fn subsume(sides: Sides, target: Option<Target>, p: &ChainParams) -> (Layer, Wheels) {
    let s = p.speed;
    let leaving = |d: f64| d > p.wall_max;
    let close = |d: f64| d < p.wall_min;
    let mut out = (Layer::KeepMoving, Wheels { vl: s, vr: s });
    if let Some(t) = target {
        let wheels = if t.reached && p.stop_at_target {
            Wheels { vl: 0.0, vr: 0.0 }
        } else {
            let turn = (p.target_gain * t.bearing).clamp(-1.0, 1.0);
            if turn >= 0.0 {
                Wheels {
                    vl: s * (1.0 - turn),
                    vr: s,
                }
            } else {
                Wheels {
                    vl: s,
                    vr: s * (1.0 + turn),
                }
            }
        };
        out = (Layer::TargetCheck, wheels);
    }
    // Walls are followed to find the target; once it is in sight, leaving a wall is fine.
    let seeking = target.is_none();
    let (left, right) = (sides.left, sides.right);
    if seeking && leaving(right) {
        out = (Layer::FarRight, Wheels { vl: s, vr: 0.0 });
    }
    if seeking && leaving(left) && !leaving(right) {
        out = (Layer::FarLeft, Wheels { vl: 0.0, vr: s });
    }
    if close(right) {
        out = (Layer::CloseRight, Wheels { vl: 0.0, vr: s });
    }
    if close(left) && (!close(right) || left < right) {
        out = (Layer::CloseLeft, Wheels { vl: s, vr: 0.0 });
    }
    out
}

/// A differential drive's `(v, omega)` from its wheel speeds over `axle`, the turn rate
/// limited to `max_turn_rate`.
pub fn unicycle(w: Wheels, axle: f64, max_turn_rate: f64) -> (f64, f64) {
    let v = (w.vl + w.vr) / 2.0;
    let omega = ((w.vr - w.vl) / axle).clamp(-max_turn_rate, max_turn_rate);
    (v, omega)
}
