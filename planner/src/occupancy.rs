//! Time-dependent occupancy, eq. (1) of Marchenko & Ponomarenko 2024.
//!
//! `Occupancy(cell, t) = 1` for vehicle u when another vehicle's route holds the cell (or a
//! cell within the safe-distance zone, Fig. 1) during `(t_{n-1} - δ, t_n + δ)`. In slots (see
//! [`PlanParams::pad_slots`]): a cell held over slots `[s0, s1]` is occupied for everyone
//! else over `[s0 - pad, s1 + pad]`.
//!
//! Extra kinds of reservation, beyond the paper's routes:
//! - a finished route parks: its last cell stays occupied for ever (a hovering UAV);
//! - a dead vehicle: its cell is occupied at all times;
//! - a hold: a vehicle hovering at a cell over `[from, until]` (prioritised planning uses it
//!   for vehicles not yet planned).
//!
//! Queries are O(reservations at that cell): spans are indexed per cell, never scanned per
//! route.

use std::collections::BTreeMap;

use crate::error::PlanError;
use crate::grid::{Cell, Grid};
use crate::params::PlanParams;
use crate::route::Route;

/// "For ever" as a slot.
const FOREVER: i64 = i64::MAX;

/// One reservation of one cell: occupied for vehicles other than `vehicle` over `[from, to]`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Span {
    from: i64,
    to: i64,
    vehicle: u32,
}

/// What a vehicle is known to do, for the potential (positions over time).
#[derive(Debug, Clone, PartialEq)]
enum Presence {
    Route(Route),
    Hold { cell: Cell, from: u32, until: u32 },
    Dead,
}

/// The fixed plans of other vehicles, indexed per cell for eq. (1) queries.
#[derive(Debug, Clone, PartialEq)]
pub struct Reservations {
    dims: [u16; 3],
    min: [f64; 3],
    d: f64,
    pad: i64,
    /// Cell offsets within `clearance` of a cell (always includes (0,0,0)).
    zone: Vec<[i32; 3]>,
    spans: Vec<Vec<Span>>,
    /// Per vehicle: the cells it has spans in (to remove them), what it does, and the first
    /// slot from which its reservations and position no longer change.
    vehicles: BTreeMap<u32, Known>,
}

/// Everything recorded about one vehicle.
#[derive(Debug, Clone, PartialEq, Default)]
struct Known {
    cells: Vec<u32>,
    presences: Vec<Presence>,
    steady_from: i64,
}

impl Reservations {
    /// An empty table for `grid`, with δ, slot length and clearance from `params`.
    pub fn new(grid: &Grid, params: &PlanParams) -> Result<Reservations, PlanError> {
        params.validate()?;
        let r = (params.clearance / grid.d() + 1e-9).floor() as i32;
        let mut zone = Vec::new();
        for dk in -r..=r {
            for dj in -r..=r {
                for di in -r..=r {
                    let dist = f64::from(di * di + dj * dj + dk * dk).sqrt() * grid.d();
                    if dist <= params.clearance + 1e-9 {
                        zone.push([di, dj, dk]);
                    }
                }
            }
        }
        Ok(Reservations {
            dims: grid.dims(),
            min: grid.min(),
            d: grid.d(),
            pad: i64::from(params.pad_slots()),
            zone,
            spans: vec![Vec::new(); grid.len()],
            vehicles: BTreeMap::new(),
        })
    }

    /// Slots of eq. (1)'s δ either side of a held interval.
    pub fn pad(&self) -> u32 {
        self.pad as u32
    }

    fn centre(&self, c: Cell) -> [f64; 3] {
        [
            self.min[0] + (f64::from(c.i) + 0.5) * self.d,
            self.min[1] + (f64::from(c.j) + 0.5) * self.d,
            self.min[2] + (f64::from(c.k) + 0.5) * self.d,
        ]
    }

    fn known(&mut self, vehicle: u32) -> &mut Known {
        self.vehicles.entry(vehicle).or_insert_with(|| Known {
            steady_from: i64::MIN,
            ..Known::default()
        })
    }

    /// Adds `[from, to]` (already padded) at `c` and every cell of its safe-distance zone.
    fn reserve(&mut self, vehicle: u32, c: Cell, from: i64, to: i64) {
        let [nx, ny, nz] = self.dims.map(i32::from);
        let entry = self.vehicles.entry(vehicle).or_insert_with(|| Known {
            steady_from: i64::MIN,
            ..Known::default()
        });
        if to != FOREVER {
            entry.steady_from = entry.steady_from.max(to + 1);
        }
        for off in &self.zone {
            let (i, j, k) = (
                i32::from(c.i) + off[0],
                i32::from(c.j) + off[1],
                i32::from(c.k) + off[2],
            );
            if i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz {
                continue;
            }
            let idx = (i + nx * (j + ny * k)) as usize;
            self.spans[idx].push(Span { from, to, vehicle });
            entry.cells.push(idx as u32);
        }
    }

    /// Fixes `route` for `vehicle`: each run of equal cells `[s0, s1]` is occupied over
    /// `[s0 - pad, s1 + pad]`, the last cell from `s0 - pad` for ever (parked).
    pub fn add_route(&mut self, vehicle: u32, route: &Route) {
        for (c, s0, s1, parked) in route.runs() {
            let to = if parked { FOREVER } else { s1 + self.pad };
            self.reserve(vehicle, c, s0 - self.pad, to);
        }
        let known = self.known(vehicle);
        known.steady_from = known.steady_from.max(i64::from(route.end_slot()));
        known.presences.push(Presence::Route(route.clone()));
    }

    /// A vehicle hovering at `cell` over slots `[from, until]` (padded by δ).
    pub fn add_hold(&mut self, vehicle: u32, cell: Cell, from: u32, until: u32) {
        self.reserve(
            vehicle,
            cell,
            i64::from(from) - self.pad,
            i64::from(until) + self.pad,
        );
        let known = self.known(vehicle);
        known.steady_from = known.steady_from.max(i64::from(until) + 1);
        known.presences.push(Presence::Hold { cell, from, until });
    }

    /// A dead vehicle at `cell`: occupied at all times. It is an obstacle, not a swarm member,
    /// so it adds no potential.
    pub fn add_dead(&mut self, vehicle: u32, cell: Cell) {
        self.reserve(vehicle, cell, i64::MIN, FOREVER);
        self.known(vehicle).presences.push(Presence::Dead);
    }

    /// Forgets everything about `vehicle`.
    pub fn remove_vehicle(&mut self, vehicle: u32) {
        if let Some(known) = self.vehicles.remove(&vehicle) {
            for idx in known.cells {
                self.spans[idx as usize].retain(|s| s.vehicle != vehicle);
            }
        }
    }

    /// Whether the cell with flat index `idx` has any reservation at all (fast path).
    #[inline]
    pub fn any_at(&self, idx: usize) -> bool {
        !self.spans[idx].is_empty()
    }

    /// Eq. (1): whether the cell with flat index `idx` is occupied at `slot` for vehicle
    /// `asker` (its own reservations do not count).
    #[inline]
    pub fn occupied(&self, idx: usize, slot: i64, asker: u32) -> bool {
        self.spans[idx]
            .iter()
            .any(|s| s.vehicle != asker && s.from <= slot && slot <= s.to)
    }

    /// Eq. (1) by cell; cells outside the grid are never occupied.
    pub fn occupied_cell(&self, grid: &Grid, c: Cell, slot: i64, asker: u32) -> bool {
        grid.contains(c) && self.occupied(grid.index(c), slot, asker)
    }

    /// First slot from which the cell `idx` stays free for `asker` for ever, or
    /// `Err(vehicle)` naming a vehicle that keeps it for ever.
    pub fn free_from(&self, idx: usize, asker: u32) -> Result<i64, u32> {
        let mut first = i64::MIN;
        for s in self.spans[idx].iter().filter(|s| s.vehicle != asker) {
            if s.to == FOREVER {
                return Err(s.vehicle);
            }
            first = first.max(s.to + 1);
        }
        Ok(first)
    }

    /// Planned positions (cell centres) of the live vehicles other than `asker` at `slot`, in
    /// vehicle-id order: a route from its start slot on (parked after its end), a hold over
    /// its interval. Dead vehicles are not included.
    pub fn positions_at(&self, slot: i64, asker: u32, out: &mut Vec<[f64; 3]>) {
        out.clear();
        for (&v, known) in &self.vehicles {
            if v == asker {
                continue;
            }
            for p in &known.presences {
                let cell = match p {
                    Presence::Route(r) if slot >= i64::from(r.start_slot) => Some(r.cell_at(slot)),
                    Presence::Hold { cell, from, until }
                        if i64::from(*from) <= slot && slot <= i64::from(*until) =>
                    {
                        Some(*cell)
                    }
                    _ => None,
                };
                if let Some(c) = cell {
                    out.push(self.centre(c));
                    break;
                }
            }
        }
    }

    /// First slot from which nothing `asker` can see changes any more: every reservation of
    /// the others is either over or lasts for ever, and their positions are fixed. From
    /// then on the problem is static, which lets the search merge states of one cell.
    pub fn steady_from(&self, asker: u32) -> i64 {
        self.vehicles
            .iter()
            .filter(|(v, _)| **v != asker)
            .map(|(_, k)| k.steady_from)
            .max()
            .unwrap_or(i64::MIN)
    }

    /// Vehicles with any reservation, in id order.
    pub fn vehicles(&self) -> impl Iterator<Item = u32> + '_ {
        self.vehicles.keys().copied()
    }
}
