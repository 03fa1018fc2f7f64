//! The crate's one error type.
//!
//! Every fallible call of the planner returns [`PlanError`]; a search that runs out of budget
//! is an error too ([`PlanError::NoRoute`]) so the caller can tell "no route exists within
//! the horizon" from a bad input.

use crate::grid::Cell;

/// What went wrong while building a grid, validating parameters or planning a route.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    /// A [`crate::PlanParams`] field is outside its bounds.
    #[error("plan parameter `{field}` = {value} is out of bounds: expected {expected}")]
    InvalidParam {
        /// The field's name, as spelled in `PlanParams`.
        field: &'static str,
        /// The value given (integers are converted to `f64`).
        value: f64,
        /// The accepted range, in words.
        expected: &'static str,
    },
    /// The grid's bounds or cell size do not describe a non-empty box of cubes.
    #[error("invalid grid: {reason}")]
    InvalidGrid {
        /// Why, in words.
        reason: &'static str,
    },
    /// The grid would have more cells than the planner accepts.
    #[error("grid has {cells} cells, more than the maximum {max}")]
    TooManyCells {
        /// Cells the bounds and `d` ask for.
        cells: u64,
        /// The limit ([`crate::grid::MAX_CELLS`]).
        max: u64,
    },
    /// A cell index lies outside the grid.
    #[error("cell {cell:?} is outside the grid")]
    OutOfGrid {
        /// The offending cell.
        cell: Cell,
    },
    /// The goal cell is blocked by a static obstacle (after inflation).
    #[error("goal cell {goal:?} is blocked by an obstacle")]
    GoalBlocked {
        /// The goal cell.
        goal: Cell,
    },
    /// Another vehicle keeps the goal cell occupied for ever (parked there, or dead).
    #[error("goal cell {goal:?} is occupied for ever by vehicle {vehicle}")]
    GoalTaken {
        /// The goal cell.
        goal: Cell,
        /// The vehicle that holds it.
        vehicle: u32,
    },
    /// The search ran out of states (horizon) or of expansions without reaching the goal.
    #[error("no route found after {expansions} expansions")]
    NoRoute {
        /// States expanded before giving up.
        expansions: u64,
    },
    /// A move code in a compact route is not in `0..=26`, or leaves the `u16` cell range.
    #[error("move {index} has invalid code {code}")]
    BadMove {
        /// Position of the move in the sequence.
        index: usize,
        /// The byte found.
        code: u8,
    },
}
