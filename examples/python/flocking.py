#!/usr/bin/env python3
"""The flocking robot in Python: a port of agent/src/behaviours/flocking/ (seed 004, after
Turgut et al. 2008) that flies in one flock with the Rust robots.

    swarm run configs/flocking_obstacles.toml \\
        --set 'robots.program=[".venv/bin/python", "examples/python/flocking.py"]'

Every tick a robot broadcasts its flock and heading (`RadioMsg::Flocking`, the same postcard
bytes as the Rust robots, or the one-byte e-puck message with `behaviour.encoding = "byte"`),
remembers the flock-mates it heard (forgotten after `time_out`), and steers toward the desired
heading of eq. 1: heading alignment with a migratory bias (eq. 5-6), proximal repulsion from
its eight IR rays (eq. 2, 7-8), cohesion toward the mates it located by range-and-bearing
(eq. 3-4, 9). The wheels follow eq. 10-13.

The vector algebra is written out by component in the order nalgebra evaluates it (a sum
folds from zero, `norm` is `sqrt(x*x + y*y)`, a rotation times a vector is
`m00*x + m01*y`), so the floats are the Rust robots' floats bit for bit.
"""

from __future__ import annotations

import math
import sys

from swarmrt import BROADCAST, STATE_ACTIVE, Command, Observation, Robot, radio
from swarmrt.scenario import (
    clamp,
    fmax,
    nominal_heading,
    ray_angle,
    round_half_away,
    start_group,
    to_radians,
    wrap_angle,
)

#: Highest proximity level O_k.
LEVEL_MAX = 7.0


# --- desired.rs: eq. 1-9 in the robot frame (x ahead, y to the left) -----------------------


def norm(v):
    """nalgebra's `norm` of a 2-vector: `sqrt(0 + (x*x + y*y))`."""
    return math.sqrt(v[0] * v[0] + v[1] * v[1])


def normalised(v):
    """`v / |v|`, or None when it has (almost) no length."""
    n = norm(v)
    if n > 1e-12:
        return (v[0] / n, v[1] / n)
    return None


def unit(angle):
    """e^{i angle}."""
    return (math.cos(angle), math.sin(angle))


def alignment(rel_headings):
    """Eq. 6: the mean heading of the mates heard and the robot itself (sum folded from 0)."""
    sx, sy = 0.0, 0.0
    for t in rel_headings:
        ux, uy = unit(t)
        sx, sy = sx + ux, sy + uy
    sx, sy = sx + 1.0, sy + 0.0
    n = float(len(rel_headings) + 1)
    return (sx / n, sy / n)


def heading_alignment(mb, migration_rel, l):
    """Eq. 5: h = (M_b m + (1 - M_b) l) / ||.||; e_1 when they cancel out."""
    m = unit(migration_rel)
    k = 1.0 - mb
    v = (m[0] * mb + l[0] * k, m[1] * mb + l[1] * k)
    return normalised(v) or (1.0, 0.0)


def level(distance, radius, rng):
    """O_k: a proximity level, linear from 0 at the sensor range to 7 at contact."""
    if rng <= radius:
        return LEVEL_MAX if distance < rng else 0.0
    return clamp(LEVEL_MAX * (rng - distance) / (rng - radius), 0.0, LEVEL_MAX)


def repulsion(o):
    """Eq. 8."""
    return -(o * o) / (LEVEL_MAX * LEVEL_MAX)


def proximal(levels, angles):
    """Eq. 7: sum_k f_k e^{i phi_k}, normalised; zero when nothing is sensed."""
    sx, sy = 0.0, 0.0
    for o, phi in zip(levels, angles):
        ux, uy = unit(phi)
        f = repulsion(o)
        sx, sy = sx + ux * f, sy + uy * f
    return normalised((sx, sy)) or (0.0, 0.0)


def strongest(levels):
    """s(t) of eq. 2."""
    s = 0.0
    for o in levels:
        s = fmax(s, o)
    return s / LEVEL_MAX


def cohesion(rel_positions):
    """Eq. 9: the centre of mass of the mates located, relative to the robot."""
    if not rel_positions:
        return (0.0, 0.0)
    sx, sy = 0.0, 0.0
    for px, py in rel_positions:
        sx, sy = sx + px, sy + py
    n = float(len(rel_positions))
    return (sx / n, sy / n)


def cohesion_weight(delta, zeta, d, desired_distance):
    """Eq. 3-4."""
    return math.pow(delta, zeta + d) if d > desired_distance else 0.0


def desired(alpha, h, gamma, p, delta_w, c):
    """Eq. 1: a = (alpha h + Gamma p + Delta c) / ||.||; e_1 when everything cancels out."""
    v = (
        h[0] * alpha + p[0] * gamma + c[0] * delta_w,
        h[1] * alpha + p[1] * gamma + c[1] * delta_w,
    )
    return normalised(v) or (1.0, 0.0)


# --- wheels.rs: eq. 10-13 ------------------------------------------------------------------


def forward_speed(top, a_x, dot_ch):
    """Eq. 10."""
    slow = math.sqrt(fmax(1.0 - abs(dot_ch), 0.0))
    if a_x > 0.0 and dot_ch < 0.0:
        return top * a_x * slow
    if a_x > 0.0:
        return top * a_x
    if a_x < 0.0 and dot_ch < 0.0:
        return top * abs(a_x) * slow
    return 0.0


def turn_rate(kappa, theta_a, wheel_radius, axle):
    """Eq. 11."""
    return kappa * theta_a * 8.0 * wheel_radius / axle


def unicycle(u, omega, axle, top):
    """Eq. 12-13 and back, each wheel limited to `top`."""
    left = clamp(u - omega * axle / 2.0, -top, top)
    right = clamp(u + omega * axle / 2.0, -top, top)
    return ((left + right) / 2.0, (right - left) / axle)


# --- mod.rs --------------------------------------------------------------------------------


class Flocking:
    """One robot's flocking state (`Flocking` of flocking/mod.rs)."""

    def __init__(self, cfg: dict, robot: int) -> None:
        p = cfg["behaviour"]
        self.id = robot
        self.alpha = float(p["alpha"])
        self.beta = float(p["beta"])
        self.delta = float(p["delta"])
        self.iota = float(p["iota"])
        self.zeta = float(p["zeta"])
        self.kappa = float(p["kappa"])
        self.mb = float(p["mb"])
        self.desired_distance = float(p["desired_distance"])
        self.heading_source = p["heading"]
        self.encoding = p["encoding"]
        self.wheel_radius = float(p["wheel_radius"])
        self.axle = float(p["axle"])
        self.flock = start_group(cfg, robot)
        migration = [float(m) for m in p["migration_deg"]]
        m = migration[self.flock] if self.flock < len(migration) else (migration[0] if migration else 0.0)
        self.migration = to_radians(m)
        r = cfg["robots"]
        self.dt = float(cfg["scenario"]["dt"])
        self.top = float(r["max_speed"])
        self.max_turn = float(r["max_turn_rate"])
        self.radius = float(r["radius"])
        lidar = r["lidar"]
        self.sensor_range = float(lidar["range"])
        self.sensor_angles = [ray_angle(lidar, k) for k in range(int(lidar["rays"]))]
        # Rust: `(time_out / dt).round() as u64` (saturating at 0).
        self.time_out_ticks = max(int(round_half_away(float(p["time_out"]) / self.dt)), 0)
        # Mates by id: (heading, position or None, tick heard).
        self.mates = [None] * int(r["count"])
        self.x = 0.0
        self.y = 0.0
        self.theta = nominal_heading(cfg, robot)
        self.last = (0.0, 0.0)

    def update_pose(self, obs: Observation) -> None:
        """Heading estimate and dead-reckoned position from last tick's command."""
        v, omega = self.last
        if self.heading_source == "compass":
            self.theta = obs.theta
        else:
            self.theta = wrap_angle(self.theta + omega * self.dt)
        self.x += v * self.dt * math.cos(self.theta)
        self.y += v * self.dt * math.sin(self.theta)

    def listen(self, obs: Observation, heard) -> None:
        """Remembers each flock-mate heard this tick, located by range-and-bearing if seen."""
        neighbours = [obs.neighbours[k] for k in range(min(int(obs.neighbours_len), 32))]
        for h in heard:
            msg = radio.decode_flock(h.payload)
            if msg is None:
                continue
            if isinstance(msg, radio.FlockHeading):
                mid, flock, heading, byte = h.src, msg.flock, msg.heading, False
            else:
                mid, heading = radio.decode_byte(msg.byte)
                flock, byte = self.flock, True
            if flock != self.flock or mid == self.id:
                continue
            position = None
            for n in neighbours:
                if (n.id & 7 == mid) if byte else (n.id == mid):
                    a = self.theta + n.bearing
                    position = (self.x + n.range * math.cos(a), self.y + n.range * math.sin(a))
                    break
            if mid < len(self.mates):
                self.mates[mid] = (heading, position, obs.tick)
        for i, m in enumerate(self.mates):
            if m is not None and max(obs.tick - m[2], 0) > self.time_out_ticks:
                self.mates[i] = None

    def step(self, obs: Observation, heard, cmd: Command) -> None:
        """This tick's decision for an ACTIVE robot, written into `cmd`."""
        self.update_pose(obs)
        self.listen(obs, heard)
        # Rotation2::new(-theta) = [[c, -s], [s, c]] with (s, c) = sin_cos(-theta).
        s, c = math.sin(-self.theta), math.cos(-self.theta)
        headings = []
        positions = []
        for m in self.mates:
            if m is None:
                continue
            headings.append(wrap_angle(m[0] - self.theta))
        for m in self.mates:
            if m is None or m[1] is None:
                continue
            dx, dy = m[1][0] - self.x, m[1][1] - self.y
            positions.append((c * dx + -s * dy, s * dx + c * dy))
        h = heading_alignment(self.mb, wrap_angle(self.migration - self.theta), alignment(headings))
        n = min(int(obs.lidar_len), 64)
        levels = [level(obs.lidar[k], self.radius, self.sensor_range) for k in range(n)]
        prox = proximal(levels, self.sensor_angles)
        gamma = math.pow(self.beta, self.iota + strongest(levels))
        coh = cohesion(positions)
        d = norm(coh)
        delta_w = cohesion_weight(self.delta, self.zeta, d, self.desired_distance)
        a = desired(self.alpha, h, gamma, prox, delta_w, coh)
        if d > self.desired_distance:
            dot_ch = h[0] * (coh[0] / d) + h[1] * (coh[1] / d)
        else:
            dot_ch = 0.0
        u = forward_speed(self.top, a[0], dot_ch)
        omega = turn_rate(self.kappa, math.atan2(a[1], a[0]), self.wheel_radius, self.axle)
        v, omega = unicycle(u, omega, self.axle, self.top)
        v, omega = clamp(v, 0.0, self.top), clamp(omega, -self.max_turn, self.max_turn)
        cmd.v = v
        cmd.omega = omega
        cmd.lidar_on = 1
        if self.encoding == "byte":
            payload = radio.encode_flock_byte(radio.encode_byte(self.id, self.theta))
        else:
            payload = radio.encode_flock_heading(self.flock, self.theta)
        radio.push_frame(cmd, BROADCAST, payload)
        self.last = (v, omega)


def main() -> int:
    robot = Robot.from_env()
    flocking = Flocking(robot.config, robot.id)
    for obs in robot.observations():
        cmd = robot.command(obs)
        if obs.state == STATE_ACTIVE:
            flocking.step(obs, radio.inbox(obs, robot.id), cmd)
        robot.send(cmd)
    return robot.exit_code


if __name__ == "__main__":
    sys.exit(main())
