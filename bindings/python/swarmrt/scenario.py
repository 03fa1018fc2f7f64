"""The scenario helpers a behaviour uses, ported from the Rust `swarmrt_scenario` crate so a
Python robot computes the very same floats as a Rust one.

Bit-identical results need the same operations in the same order: Rust's `%` on `f64` is C's
`fmod` (`math.fmod`, not Python's `%`), `to_radians` is `x * (PI / 180)`, `powi(2)` is `x * x`,
`f64::round` rounds halves away from zero, and `f64::max`/`min`/`clamp` treat NaN differently
from Python's `max`/`min`. `sin`, `cos`, `atan2`, `pow` and `sqrt` come from the same libm in
both languages. Each function names the Rust it mirrors.

`cfg` below is the resolved config as `tomllib` parses it (`Robot.config`). The resolved TOML
leaves out keys whose value is an empty list or absent (`robots.start.groups`,
`robots.lidar.angles_deg`, `robots.aerial`, ...), so those are read with their defaults.
"""

from __future__ import annotations

import math
from typing import Callable, Optional

PI = math.pi
#: `RADS_PER_DEG` of Rust's `f64::to_radians`.
RADS_PER_DEG = PI / 180.0


def to_radians(deg: float) -> float:
    """Rust's `f64::to_radians`."""
    return deg * RADS_PER_DEG


def wrap_angle(a: float) -> float:
    """`swarmrt_scenario::wrap_angle` (scenario/src/angle.rs): into (-pi, pi]."""
    a = math.fmod(a, 2.0 * PI)
    if a <= -PI:
        a += 2.0 * PI
    elif a > PI:
        a -= 2.0 * PI
    return a


def fmax(a: float, b: float) -> float:
    """Rust's `f64::max`: a NaN argument gives the other one."""
    if a != a:
        return b
    if b != b:
        return a
    return b if b > a else a


def fmin(a: float, b: float) -> float:
    """Rust's `f64::min`: a NaN argument gives the other one."""
    if a != a:
        return b
    if b != b:
        return a
    return b if b < a else a


def clamp(x: float, lo: float, hi: float) -> float:
    """Rust's `f64::clamp` (NaN stays NaN)."""
    if x < lo:
        x = lo
    if x > hi:
        x = hi
    return x


def round_half_away(x: float) -> float:
    """Rust's `f64::round`: halves away from zero (Python's `round` goes to even)."""
    if not math.isfinite(x):
        return x
    t = math.floor(abs(x))
    if abs(x) - t >= 0.5:
        t += 1.0
    return math.copysign(t, x)


# --- config.rs -----------------------------------------------------------------------------


def ray_angle(lidar: dict, k: int) -> float:
    """`LidarConfig::ray_angle` (scenario/src/config.rs): ray `k`'s angle from the heading,
    `angles_deg[k]` when given, else evenly over the field of view from `-fov/2`."""
    angles = lidar.get("angles_deg", [])
    if k < len(angles):
        return to_radians(float(angles[k]))
    rays = max(int(lidar.get("rays", 0)), 1)
    if rays == 1:
        return 0.0
    fov_deg = float(lidar["fov_deg"])
    fov = to_radians(fov_deg)
    step = fov / float(rays) if fov_deg >= 360.0 else fov / float(rays - 1)
    return -fov / 2.0 + step * float(k)


# --- layout.rs -----------------------------------------------------------------------------


def start_group(cfg: dict, robot: int) -> int:
    """`Config::start_group`: contiguous blocks of ids, of `start.group_sizes` or else sizes
    differing by at most one."""
    start = cfg["robots"]["start"]
    sizes = start.get("group_sizes", [])
    if sizes:
        end = 0
        for g, size in enumerate(sizes):
            end += int(size)
            if robot < end:
                return g
        return len(sizes) - 1
    n = max(int(cfg["robots"]["count"]), 1)
    g = max(len(start.get("groups", [])), 1)
    return min(robot, n - 1) * g // n


def goal_of(cfg: dict, robot: int) -> tuple[float, float, float]:
    """`Config::goal_of` for ground robots: `(x, y, radius)` of the goal robot `robot` seeks,
    its start group's own `goal` if it has one, else `map.goal`."""
    g = cfg["map"]["goal"]
    groups = cfg["robots"]["start"].get("groups", [])
    k = start_group(cfg, robot)
    own = groups[k].get("goal") if k < len(groups) else None
    if own is not None:
        return (float(own[0]), float(own[1]), float(g["radius"]))
    return (float(g["x"]), float(g["y"]), float(g["radius"]))


def nominal_heading(cfg: dict, robot: int) -> float:
    """`Config::nominal_heading`: the heading robot `robot` is meant to start with (its start
    group's `heading_deg`, else `robots.start.heading_deg`), wrapped. Start paths
    (`robots.start.path`) are not ported."""
    start = cfg["robots"]["start"]
    if start.get("path"):
        raise NotImplementedError("robots.start.path is not supported by the Python helpers")
    groups = start.get("groups", [])
    k = start_group(cfg, robot)
    heading = float(start.get("heading_deg", 0.0))
    if k < len(groups) and groups[k].get("heading_deg") is not None:
        heading = float(groups[k]["heading_deg"])
    return wrap_angle(to_radians(heading))


#: `MAX_GRID_CANDIDATES` of layout.rs.
MAX_GRID_CANDIDATES = 4_000_000


def nearest_grid_points(
    n: int,
    centre: tuple[float, float],
    spacing: float,
    bounds,
    margin: float,
    ok: Callable[[float, float], bool] = lambda x, y: True,
) -> Optional[list[tuple[float, float]]]:
    """`nearest_grid_points` (scenario/src/layout.rs): the `n` points of a square grid of
    `spacing` through `centre` nearest to it, at least `margin` inside `bounds` and accepted
    by `ok`, ordered by grid distance, then row, then column; None if fewer qualify."""
    if n == 0:
        return []
    if not math.isfinite(spacing) or spacing <= 0.0:
        return None
    b = [float(v) for v in bounds]
    lo_i = math.ceil((b[0] + margin - centre[0]) / spacing)
    hi_i = math.floor((b[2] - margin - centre[0]) / spacing)
    lo_j = math.ceil((b[1] + margin - centre[1]) / spacing)
    hi_j = math.floor((b[3] - margin - centre[1]) / spacing)
    if not (hi_i >= lo_i and hi_j >= lo_j) or float(hi_i - lo_i + 1) * float(
        hi_j - lo_j + 1
    ) > float(MAX_GRID_CANDIDATES):
        return None
    cells = sorted((i * i + j * j, j, i) for j in range(lo_j, hi_j + 1) for i in range(lo_i, hi_i + 1))
    out = []
    for _, j, i in cells:
        x, y = centre[0] + spacing * float(i), centre[1] + spacing * float(j)
        if x - margin > b[0] and x + margin < b[2] and y - margin > b[1] and y + margin < b[3] and ok(x, y):
            out.append((x, y))
            if len(out) == n:
                return out
    return None
