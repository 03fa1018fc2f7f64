//! Wall-following for a leader whose way to the goal is blocked (our addition, opt-in with
//! `behaviour.leader_nav = "wall-follow"`): the paper's leaders avoid obstacles locally
//! (eq. 10-11) and by the COG shift (Fig. 8) and print no planner, yet cross S4's maze
//! (section 3.2.4); a bug algorithm over the leader's own lidar leaves dead ends without a map.

use std::f64::consts::TAU;

/// How the leader steers toward a known goal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LeaderNav {
    /// Straight for the goal, sideways detours after a stall (`unstick` in mod.rs).
    #[default]
    Detour,
    /// Bug-style: follow the wall from the moment it blocks the goal's heading until the
    /// heading is free again and the group is closer than where it began following.
    WallFollow,
}

impl LeaderNav {
    /// True for the default (serde's `skip_serializing_if`).
    pub fn is_default(&self) -> bool {
        *self == LeaderNav::Detour
    }
}

/// Ray `k` of `scan` and its two neighbours read nothing within `range`.
pub fn free(scan: &[(f64, f64)], range: f64, k: usize) -> bool {
    let n = scan.len();
    [k + n - 1, k, k + 1]
        .iter()
        .all(|&j| scan[j % n].1 >= range - 1e-6)
}

/// The direction (world frame, radians) that follows the nearest wall in `scan`
/// ((world angle, range) per ray): the first free direction turning from the wall
/// counter-clockwise (`side` = +1, the wall stays on the right) or clockwise (`side` = -1).
/// None when the scan sees nothing, or nothing is free.
pub fn follow_dir(scan: &[(f64, f64)], range: f64, side: f64) -> Option<f64> {
    let wall = scan
        .iter()
        .filter(|&&(_, r)| r < range - 1e-6)
        .min_by(|a, b| a.1.total_cmp(&b.1))?
        .0;
    (0..scan.len())
        .filter(|&k| free(scan, range, k))
        .map(|k| scan[k].0)
        .min_by(|a, b| {
            let ka = (side * (a - wall)).rem_euclid(TAU);
            let kb = (side * (b - wall)).rem_euclid(TAU);
            ka.total_cmp(&kb)
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A 360° scan of 64 rays from the origin with a wall x = 1 spanning y in [-5, 5].
    fn wall_ahead() -> Vec<(f64, f64)> {
        (0..64)
            .map(|k| {
                let a = -PI + TAU * k as f64 / 64.0;
                let r = if a.cos() > 1e-9 { 1.0 / a.cos() } else { f64::INFINITY };
                let hit = r <= 4.0 && (r * a.sin()).abs() <= 5.0;
                (a, if hit { r } else { 4.0 })
            })
            .collect()
    }

    #[test]
    fn a_wall_between_leader_and_goal_is_followed_not_entered() {
        // Goal at (10, 0), behind the wall: straight ahead (0 rad) is blocked.
        let scan = wall_ahead();
        let left = follow_dir(&scan, 4.0, 1.0).unwrap();
        let right = follow_dir(&scan, 4.0, -1.0).unwrap();
        // Along the wall (near ±90°), never into it (|a| < 60° would hit it).
        assert!(left > 1.2 && left < 2.2, "left {left}");
        assert!(right < -1.2 && right > -2.2, "right {right}");
    }

    #[test]
    fn nothing_seen_means_nothing_to_follow() {
        let scan: Vec<(f64, f64)> = (0..64).map(|k| (TAU * k as f64 / 64.0, 4.0)).collect();
        assert_eq!(follow_dir(&scan, 4.0, 1.0), None);
    }
}
