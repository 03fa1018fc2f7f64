//! Planner parameters, with the paper's values as defaults.
//!
//! Marchenko & Ponomarenko 2024, section 2.2: a = 10, b = 50 for the potential of eq. (2),
//! δ = 1 s for the occupancy of eq. (1), d = 1 m. The rest (slot length, wait cost, budgets)
//! are this crate's choices and are documented per field.

use crate::error::PlanError;

/// Tunables of the time-dependent A* (eqs. (1)–(3)).
#[derive(Debug, Clone, PartialEq)]
pub struct PlanParams {
    /// Attraction weight `a` of eq. (2) (paper: 10). `a = b = 0` switches the potential off.
    pub a: f64,
    /// Repulsion weight `b` of eq. (2) (paper: 50).
    pub b: f64,
    /// Safety interval δ of eq. (1), seconds (paper: 1 s).
    pub delta: f64,
    /// Bounded relaxation ε: fScore = g + (1+ε)·H, route cost ≤ (1+ε)·optimal (paper, 2.2).
    pub epsilon: f64,
    /// Seconds per time slot; one action (move or wait) takes one slot. Pick `d / cruise speed`.
    pub slot: f64,
    /// Cost of waiting one slot, metres; must be > 0 so waiting is never free (default = d = 1).
    pub wait_cost: f64,
    /// Safe-distance zone of eq. (1) / Fig. 1, metres centre to centre; 0 = the same cell only.
    pub clearance: f64,
    /// Cut-off radius of the potential, metres; `None` = 2·r* with r* = sqrt(3b/a).
    pub potential_range: Option<f64>,
    /// Search budget: states expanded before [`PlanError::NoRoute`].
    pub max_expansions: u64,
    /// Search budget: slots after the start slot beyond which no state is generated.
    pub horizon_slots: u32,
    /// Prioritised planning: slots a not-yet-planned vehicle is assumed to hover at its start.
    pub hold_slots: u32,
}

impl Default for PlanParams {
    fn default() -> Self {
        PlanParams {
            a: 10.0,
            b: 50.0,
            delta: 1.0,
            epsilon: 0.0,
            slot: 1.0,
            wait_cost: 1.0,
            clearance: 0.0,
            potential_range: None,
            max_expansions: 200_000,
            horizon_slots: 512,
            hold_slots: 16,
        }
    }
}

/// Largest horizon accepted; keeps `slot` arithmetic far from overflow.
pub const MAX_HORIZON_SLOTS: u32 = 1 << 20;

fn check(
    field: &'static str,
    value: f64,
    ok: bool,
    expected: &'static str,
) -> Result<(), PlanError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(PlanError::InvalidParam {
            field,
            value,
            expected,
        })
    }
}

impl PlanParams {
    /// Checks every field; the error names the first field out of bounds and its range.
    ///
    /// `a` and `b` must be both zero (no potential) or both positive: with `b = 0` eq. (2) is
    /// unbounded below near r = 0, with `a = 0` it has no minimum to subtract.
    pub fn validate(&self) -> Result<(), PlanError> {
        check(
            "a",
            self.a,
            self.a >= 0.0,
            ">= 0, finite; both a and b zero or both positive",
        )?;
        check(
            "b",
            self.b,
            self.b >= 0.0,
            ">= 0, finite; both a and b zero or both positive",
        )?;
        if (self.a > 0.0) != (self.b > 0.0) {
            let (field, value) = if self.a > 0.0 {
                ("b", self.b)
            } else {
                ("a", self.a)
            };
            return Err(PlanError::InvalidParam {
                field,
                value,
                expected: "> 0 when the other of a, b is > 0 (both zero switches the potential off)",
            });
        }
        check(
            "delta",
            self.delta,
            self.delta >= 0.0,
            ">= 0 seconds, finite",
        )?;
        check("epsilon", self.epsilon, self.epsilon >= 0.0, ">= 0, finite")?;
        check("slot", self.slot, self.slot > 0.0, "> 0 seconds, finite")?;
        check(
            "wait_cost",
            self.wait_cost,
            self.wait_cost > 0.0,
            "> 0 metres, finite",
        )?;
        check(
            "clearance",
            self.clearance,
            self.clearance >= 0.0,
            ">= 0 metres, finite",
        )?;
        if let Some(r) = self.potential_range {
            check(
                "potential_range",
                r,
                r > 0.0,
                "> 0 metres, finite, or None for 2·r*",
            )?;
        }
        if self.max_expansions == 0 {
            return Err(PlanError::InvalidParam {
                field: "max_expansions",
                value: 0.0,
                expected: ">= 1",
            });
        }
        if self.horizon_slots == 0 || self.horizon_slots > MAX_HORIZON_SLOTS {
            return Err(PlanError::InvalidParam {
                field: "horizon_slots",
                value: f64::from(self.horizon_slots),
                expected: "1..=1048576",
            });
        }
        if self.hold_slots > MAX_HORIZON_SLOTS {
            return Err(PlanError::InvalidParam {
                field: "hold_slots",
                value: f64::from(self.hold_slots),
                expected: "0..=1048576",
            });
        }
        Ok(())
    }

    /// Eq. (1)'s δ in whole slots: a cell held over slots `[s0, s1]` is occupied for others
    /// over `[s0 - pad, s1 + pad]`.
    ///
    /// Reading: the vehicle is inside the cell from when it leaves the previous centre
    /// (`t_{n-1} = (s0-1)·slot`) until it reaches the next centre (`t_n = (s1+1)·slot`); the
    /// open interval `(t_{n-1} - δ, t_n + δ)` contains slot `s` iff `s0 - ceil(δ/slot) <= s
    /// <= s1 + ceil(δ/slot)`. δ = 0 keeps the same slot only; the paper's δ = 1 s with 1 s
    /// slots keeps one slot either side.
    pub fn pad_slots(&self) -> u32 {
        let w = self.delta / self.slot;
        // A hair of tolerance so δ = 3·0.1 does not become 4 slots of 0.1 s.
        let p = (w - 1e-9).ceil();
        if p <= 0.0 {
            0
        } else {
            p.min(f64::from(MAX_HORIZON_SLOTS)) as u32
        }
    }
}
