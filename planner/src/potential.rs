//! The attraction/repulsion potential of eq. (2), Marchenko & Ponomarenko 2024.
//!
//! Eq. (2) reads `Potential(y) = -y·(a/‖y‖² - b/‖y‖⁴) - min Potential`. Taken as a scalar of
//! the distance `r = ‖y‖` between the cell centre and another vehicle's planned position at
//! that time: `P(r) = -r·(a/r² - b/r⁴) - P_min = -a/r + b/r³ - P_min`.
//!
//! Minimum: `P'(r) = a/r² - 3b/r⁴ = 0` gives `r* = sqrt(3b/a)`, and
//! `P_min = -a/r* + b/r*³ = (b - a·r*²)/r*³ = -2b/r*³`. So `P ≥ 0`, `P(r*) = 0`: a vehicle
//! at r* costs nothing, a closer one repels (`b/r³` grows fast), a farther one attracts
//! gently (P rises towards `2b/r*³` as r → ∞). With the paper's a = 10, b = 50: r* = √15 ≈
//! 3.87 m and the far-field value ≈ 1.72.
//!
//! Several vehicles: their potentials add (superposition, as the paper's Fig. 2 field is
//! per pair). Only vehicles within `range` (default 2·r*) count: a vehicle far away would add
//! its near-constant far-field value to *every* step, which inflates route cost in proportion
//! to route length in slots and so pushes the search towards shorter-in-time rather than
//! better routes, without steering anything. Reading: the potential is a local swarm-keeping
//! term, not a global pull. The cut-off makes `P` jump by `P(range)` at the range (≈ 0.54 at
//! 2·r*), which is harmless because every cost term stays ≥ 0.

/// Smallest distance used in eq. (2): guards r → 0 (the vehicles' own cells are excluded by
/// occupancy anyway, so this only caps a degenerate input).
pub const R_MIN: f64 = 1e-2;

/// Eq. (2) with its parameters resolved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Potential {
    a: f64,
    b: f64,
    r_star: f64,
    p_min: f64,
    range: f64,
}

impl Potential {
    /// The potential for weights `a`, `b` (both > 0, or both 0 for "off") and a cut-off
    /// `range` (`None` = 2·r*).
    pub fn new(a: f64, b: f64, range: Option<f64>) -> Potential {
        if a <= 0.0 || b <= 0.0 {
            return Potential {
                a: 0.0,
                b: 0.0,
                r_star: f64::INFINITY,
                p_min: 0.0,
                range: 0.0,
            };
        }
        let r_star = (3.0 * b / a).sqrt();
        let p_min = -2.0 * b / (r_star * r_star * r_star);
        Potential {
            a,
            b,
            r_star,
            p_min,
            range: range.unwrap_or(2.0 * r_star),
        }
    }

    /// Whether the potential is switched off (`a = b = 0`): every value is 0.
    pub fn is_off(&self) -> bool {
        self.range <= 0.0
    }

    /// Distance of the minimum, `sqrt(3b/a)` (infinite when off).
    pub fn r_star(&self) -> f64 {
        self.r_star
    }

    /// Cut-off radius: vehicles farther than this add nothing.
    pub fn range(&self) -> f64 {
        self.range
    }

    /// `P(r) = -a/r + b/r³ - P_min ≥ 0`, without the cut-off.
    #[inline]
    pub fn value(&self, r: f64) -> f64 {
        if self.is_off() {
            return 0.0;
        }
        let r = r.max(R_MIN);
        (-self.a / r + self.b / (r * r * r) - self.p_min).max(0.0)
    }

    /// Sum of `P` over the vehicles at `others` within `range` of `p`.
    #[inline]
    pub fn sum(&self, p: [f64; 3], others: &[[f64; 3]]) -> f64 {
        if self.is_off() {
            return 0.0;
        }
        let r2max = self.range * self.range;
        let mut s = 0.0;
        for q in others {
            let d2 = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2);
            if d2 <= r2max {
                s += self.value(d2.sqrt());
            }
        }
        s
    }
}
