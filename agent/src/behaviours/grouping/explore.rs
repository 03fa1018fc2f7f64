//! Exploration for three or more groups (section 2.4, eq. 12-13): each leader knows the other
//! groups' COGs over the radio, finds its left- and right-hand neighbour groups around the
//! COG of all groups X, takes the partial COGs with them (eq. 12), and searches random points
//! in the sector between them (eq. 13).
//!
//! Our reading: alpha is the angle of X -> partial COG with the right-hand (clockwise)
//! neighbour and beta of X -> partial COG with the left-hand (counter-clockwise) one, so the
//! sectors between them split the plane around X among the groups (Fig. 10's yellow area
//! fans out from the large cross). The search position is X + rho (cos t, sin t) with
//! t = rand(alpha, beta) swept counter-clockwise from alpha and rho = r sqrt(rand(0, 1)),
//! uniform over the sector's area (rand(0, r) as printed puts half the points within r/2 of
//! X, where the groups' sectors meet). Drawn from each group's own COG instead, the sectors
//! point outward and the groups end in the corners (we tried it). With one group the sector
//! is the full circle about its COG; with two, the half-plane facing away from the other.

use std::f64::consts::{PI, TAU};

use super::force::V2;

/// A search sector: apex and the angles alpha (start) and beta (end), counter-clockwise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sector {
    /// Where the sector fans out from: X, the COG of all groups.
    pub apex: V2,
    /// Start angle, radians.
    pub alpha: f64,
    /// Counter-clockwise extent, radians in (0, 2 pi].
    pub span: f64,
}

impl Sector {
    /// The end angle beta (wrapped to (-pi, pi]).
    pub fn beta(&self) -> f64 {
        wrap(self.alpha + self.span)
    }

    /// Eq. 13 for draws `u_angle`, `u_radius` in [0, 1), uniform over the sector's area.
    pub fn point(&self, r: f64, u_angle: f64, u_radius: f64) -> V2 {
        let t = self.alpha + u_angle * self.span;
        self.apex + V2::new(t.cos(), t.sin()) * (u_radius.sqrt() * r)
    }

    /// True when direction `a` (radians) lies inside the sector.
    pub fn contains(&self, a: f64) -> bool {
        (a - self.alpha).rem_euclid(TAU) <= self.span
    }
}

fn wrap(a: f64) -> f64 {
    let a = a.rem_euclid(TAU);
    if a > PI { a - TAU } else { a }
}

fn angle(v: V2) -> f64 {
    v.y.atan2(v.x)
}

/// Eq. 12: the partial COG of a group and its neighbour.
pub fn partial(own: V2, neighbour: V2) -> V2 {
    (own + neighbour) / 2.0
}

/// The sector of the group whose COG is `own`, given the other groups' COGs.
pub fn sector(own: V2, others: &[V2]) -> Sector {
    match others.len() {
        0 => Sector {
            apex: own,
            alpha: -PI,
            span: TAU,
        },
        1 => {
            let x = (own + others[0]) / 2.0;
            let away = angle(own - x);
            Sector {
                apex: x,
                alpha: wrap(away - PI / 2.0),
                span: PI,
            }
        }
        _ => {
            let n = others.len() as f64 + 1.0;
            let x = (own + others.iter().sum::<V2>()) / n;
            let mine = angle(own - x);
            // Counter-clockwise offsets of the other groups from this one, about X.
            let offsets: Vec<(f64, V2)> = others
                .iter()
                .map(|&c| ((angle(c - x) - mine).rem_euclid(TAU), c))
                .collect();
            let left = offsets
                .iter()
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|o| o.1)
                .unwrap_or(own);
            let right = offsets
                .iter()
                .max_by(|a, b| a.0.total_cmp(&b.0))
                .map(|o| o.1)
                .unwrap_or(own);
            let alpha = angle(partial(own, right) - x);
            let beta = angle(partial(own, left) - x);
            let mut span = (beta - alpha).rem_euclid(TAU);
            if span < 1e-9 {
                span = TAU;
            }
            Sector {
                apex: x,
                alpha,
                span,
            }
        }
    }
}
