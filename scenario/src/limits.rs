//! How big a config may be: every bound on a size (the file, `--set` values, names, command
//! lines, obstacles, vertices) in one place, so the loader checks and `docs/config.md` states
//! the same numbers. Each bound is far above what any config of `configs/` needs and low
//! enough that loading, building the map and a short run stay quick.

/// Most bytes of a config file, of config text and of one `--set` argument: 1 MiB, about 350
/// times the largest config of `configs/` (3 KB).
pub const MAX_CONFIG_BYTES: u64 = 1 << 20;

/// Most bytes of `scenario.name`. The default run directory is
/// `runs/<name>-s<seed>-<YYYYMMDD-hhmmss>[-k]/`: 64 bytes of name plus at most 20 digits of
/// seed, the time and a suffix stay well under the 255 bytes a file name may have.
pub const MAX_NAME_BYTES: usize = 64;

/// Most vertices of one polygon obstacle. The world keeps their convex hull, and every
/// clearance query near a polygon walks its vertices.
pub const MAX_POLYGON_POINTS: usize = 256;

/// Least area in m² of a polygon obstacle's convex hull: a millimetre square, as circles'
/// radii and rectangles' sides are at least a millimetre. Below it the hull is a segment or a
/// point for the geometry library (which panics on some of those).
pub const MIN_POLYGON_AREA: f64 = 1e-6;

/// Most obstacles of each kind (`map.circles`, `map.rectangles`, `map.polygons`).
pub const MAX_OBSTACLES: usize = 10_000;

/// Most words of a robot's command line (`robots.program`, `robots.programs[i].program`).
pub const MAX_ARGS: usize = 256;

/// Most bytes of one word of a robot's command line: a path of at most `PATH_MAX`.
pub const MAX_ARG_BYTES: usize = 4096;

/// Most `[[robots.programs]]` entries.
pub const MAX_PROGRAMS: usize = 1024;
