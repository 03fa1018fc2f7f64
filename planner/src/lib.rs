//! Collision-free routes for a UAV swarm on a time-dependent 3D occupancy grid, after
//! Marchenko & Ponomarenko 2024, "Improved algorithm for constructing collision-free route
//! for multi-agent swarm robotic systems" (RADAP 98, doi 10.20535/RADAP.2024.98.5-12).
//!
//! A pure library: no I/O, no clock, no randomness. Map of the code:
//! - [`grid`]: the d × d × d occupancy grid and obstacle inflation (section 2.1);
//! - [`occupancy`]: eq. (1), cells occupied by other vehicles' routes in time;
//! - [`potential`]: eq. (2), the attraction/repulsion potential;
//! - [`astar`]: the search of the pseudo code over (cell, slot) with eq. (3)'s cost;
//! - [`prioritised`]: plan a swarm vehicle by vehicle, and check the result;
//! - [`route`]: timed routes and their one-byte-per-step radio form;
//! - [`spline`]: the smoothed trajectory a vehicle follows (section 2.2);
//! - [`scenes`]: the paper's scene and a 100-vehicle one, for examples and benchmarks;
//! - [`params`], [`error`]: tunables with the paper's defaults, the one error type.
//!
//! The paper's experiment: 3 UAVs in a 10 × 15 × 5 m space, d = 1 m, a = 10, b = 50, δ = 1 s.
//!
//! ```
//! use swarmrt_planner::{conflicts, plan_all, Cell, Grid, Job, PlanParams, Reservations, Trajectory};
//!
//! let mut grid = Grid::new([0.0; 3], [10.0, 15.0, 5.0], 1.0).unwrap();
//! // A wall across the middle with a gap, inflated by a 0.3 m vehicle radius.
//! grid.block_box([0.0, 7.0, 0.0], [6.0, 8.0, 5.0], 0.3);
//! grid.block_cylinder([8.0, 11.0], 0.5, 0.0, 5.0, 0.3);
//! let params = PlanParams::default();
//! let jobs: Vec<Job> = (0..3u16)
//!     .map(|v| Job {
//!         vehicle: u32::from(v),
//!         start: Cell::new(1 + 3 * v, 1, 2),
//!         goal: Cell::new(7 - 3 * v, 13, 2),
//!         start_slot: 0,
//!     })
//!     .collect();
//! let fixed = Reservations::new(&grid, &params).unwrap();
//! let routes: Vec<(u32, _)> = plan_all(&grid, &jobs, fixed, &params)
//!     .into_iter()
//!     .zip(&jobs)
//!     .map(|(r, j)| (j.vehicle, r.unwrap()))
//!     .collect();
//! assert_eq!(conflicts(&grid, &routes, &params), 0);
//! for ((_, route), job) in routes.iter().zip(&jobs) {
//!     assert_eq!(route.cells.last(), Some(&job.goal));
//!     // The smoothed trajectory, sampled 5 points per segment and every d/10, stays free.
//!     let traj = Trajectory::new(&grid, route, params.slot, None, 5);
//!     assert_eq!(traj.check(&grid, 5), None);
//! }
//! ```
#![warn(missing_docs)]

pub mod astar;
pub mod error;
pub mod grid;
pub mod occupancy;
pub mod params;
pub mod potential;
pub mod prioritised;
pub mod route;
pub mod scenes;
pub mod spline;

pub use astar::{Job, Planner, plan};
pub use error::PlanError;
pub use grid::{Cell, Grid};
pub use occupancy::Reservations;
pub use params::PlanParams;
pub use potential::Potential;
pub use prioritised::{conflicts, min_separation, plan_all};
pub use route::Route;
pub use spline::{Spline, Trajectory};
