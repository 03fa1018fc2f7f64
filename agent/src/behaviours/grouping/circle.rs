//! Circle formation (section 2.3, eq. 8-11). The leader finds the group's centre of gravity
//! (COG), numbers the members counter-clockwise from its own direction, and each robot moves
//! to its slot on the circle with the potential field of eq. 10-11.
//!
//! Our reading of the paper's vague parts: c_diff is the angle of the COG-to-leader vector with
//! the x-axis, so the leader holds formation role number (FRN) 0 in the direction where it
//! already stands, and the members follow counter-clockwise in the order of their angle about
//! the COG measured from that direction. Eq. 9 is misprinted (cos for sin); we use sin.

use std::f64::consts::TAU;

use super::force::V2;

/// The centre of gravity of equal masses.
pub fn cog(points: &[V2]) -> V2 {
    if points.is_empty() {
        return V2::zeros();
    }
    points.iter().sum::<V2>() / points.len() as f64
}

/// c_diff: the angle of the COG-to-leader vector with the x-axis.
pub fn c_diff(leader: V2, cog: V2) -> f64 {
    let d = leader - cog;
    if d.norm() < 1e-9 { 0.0 } else { d.y.atan2(d.x) }
}

/// The FRN order: `leader` first, then the members by their angle about `cog`,
/// counter-clockwise from the COG-to-leader direction (ties by id).
pub fn frn_order(leader: (u32, V2), members: &[(u32, V2)], cog: V2) -> Vec<u32> {
    let start = c_diff(leader.1, cog);
    let mut rest: Vec<(f64, u32)> = members
        .iter()
        .filter(|m| m.0 != leader.0)
        .map(|&(id, p)| {
            let d = p - cog;
            let a = if d.norm() < 1e-9 { 0.0 } else { d.y.atan2(d.x) };
            ((a - start).rem_euclid(TAU), id)
        })
        .collect();
    rest.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    std::iter::once(leader.0)
        .chain(rest.into_iter().map(|(_, id)| id))
        .collect()
}

/// Eq. 8-9: slot `frn` of `n` on the circle of radius `fr` about `c`, rotated by `c_diff`.
pub fn slot(c: V2, fr: f64, n: usize, frn: usize, c_diff: f64) -> V2 {
    let a = TAU / n.max(1) as f64 * frn as f64 + c_diff;
    V2::new(c.x + fr * a.cos(), c.y + fr * a.sin())
}

/// Eq. 11 with P_att = k_att |q - goal|^2 / 2: the attractive force -grad P_att.
pub fn attraction(k_att: f64, q: V2, goal: V2) -> V2 {
    (goal - q) * k_att
}

/// Eq. 11 with Khatib's P_rep = k_rep (1/rho - 1/rho_0)^2 / 2 for rho < rho_0: the repulsive
/// force, summed over obstacle points given relative to the robot (pointing away from them).
pub fn repulsion(k_rep: f64, rho_0: f64, obstacles: &[V2]) -> V2 {
    obstacles
        .iter()
        .filter_map(|p| {
            let rho = p.norm();
            (rho > 1e-6 && rho < rho_0)
                .then(|| -p / rho * (k_rep * (1.0 / rho - 1.0 / rho_0) / (rho * rho)))
        })
        .sum()
}

/// Eq. 11's repulsion with a swirl (our addition): an obstacle point that lies ahead, in the
/// direction the robot `wants` to go, also pushes it sideways, toward the side `want` leans
/// to, as hard as it repels. A potential field alone stalls a robot whose slot lies straight
/// behind a cone (its local minimum); the swirl slides it around.
pub fn repulsion_swirl(k_rep: f64, rho_0: f64, obstacles: &[V2], want: V2) -> V2 {
    obstacles
        .iter()
        .filter_map(|p| {
            let rho = p.norm();
            if !(rho > 1e-6 && rho < rho_0) {
                return None;
            }
            let push = -p / rho * (k_rep * (1.0 / rho - 1.0 / rho_0) / (rho * rho));
            if push.dot(&want) >= 0.0 {
                return Some(push);
            }
            let side = V2::new(-push.y, push.x);
            let side = if side.dot(&want) >= 0.0 { side } else { -side };
            Some(push + side)
        })
        .sum()
}

/// The largest distance of a robot from its slot, or 0 for an empty group.
pub fn worst_error(positions: &[(usize, V2)], c: V2, fr: f64, n: usize, c_diff: f64) -> f64 {
    positions
        .iter()
        .map(|&(frn, p)| (p - slot(c, fr, n, frn, c_diff)).norm())
        .fold(0.0, f64::max)
}
