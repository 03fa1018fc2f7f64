#!/usr/bin/env python3
"""The go-to robot in Python: a line-for-line port of agent/src/behaviours/goto/, so a run
whose robots run this file writes byte-identical records to the Rust robots' run.

    swarm run configs/goto_simple.toml \\
        --set 'robots.program=[".venv/bin/python", "examples/python/goto.py"]'

Each robot heads for its own slot on a grid around the goal centre, steers proportionally
toward it, and when its lidar sees something closer than `avoid_distance` ahead, turns toward
the more open side (committing to that side until the way is open) and slows down. Every
`beacon_period` ticks it broadcasts its pose as the Rust robots do (`RadioMsg::Goto(Beacon)`),
so Rust and Python robots can be mixed in one run.

`Goto` is the behaviour as a plain state machine (no I/O, no clock); `main` is the shell.
Bit-identical floats need the Rust order of operations: see swarmrt/scenario.py.
"""

from __future__ import annotations

import math
import sys

from swarmrt import BROADCAST, STATE_ACTIVE, Command, Observation, Robot, radio
from swarmrt.scenario import (
    PI,
    clamp,
    fmax,
    fmin,
    goal_of,
    nearest_grid_points,
    ray_angle,
    wrap_angle,
)

#: Distance to the slot under which the robot stops.
ARRIVE = 0.05
#: Half-width of the sector ahead that counts for avoidance (70 degrees).
AHEAD = 70.0 * PI / 180.0


class Goto:
    """Go-to-goal state for one robot (`Goto` of goto/mod.rs), from the resolved config."""

    def __init__(self, cfg: dict, robot: int) -> None:
        p = cfg["behaviour"]
        self.id = robot
        self.speed = float(p["speed"])
        self.avoid_distance = float(p["avoid_distance"])
        self.beacon_period = int(p["beacon_period"])
        self.slot_spacing = float(p["slot_spacing"])
        r = cfg["robots"]
        self.lidar = r["lidar"]
        self.radius = float(r["radius"])
        self.dt = float(cfg["scenario"]["dt"])
        self.max_speed = float(r["max_speed"])
        self.max_turn = float(r["max_turn_rate"])
        self.count = int(r["count"])
        self.bounds = [float(b) for b in cfg["map"]["bounds"]]
        gx, gy, self.goal_radius = goal_of(cfg, robot)
        self.goal = (gx, gy)
        # The side (+1 left, -1 right) committed to while going around an obstacle.
        self.avoid_side = None
        self.angles = [ray_angle(self.lidar, k) for k in range(64)]
        self.slot = self.slot_around(self.goal)

    def slot_around(self, goal: tuple[float, float]) -> tuple[float, float]:
        """This robot's slot: the grid points nearest the goal centre inside the map."""
        slots = nearest_grid_points(
            self.count,
            goal,
            fmax(self.slot_spacing, 2.5 * self.radius),
            self.bounds,
            self.radius,
        )
        if slots is not None and self.id < len(slots):
            return slots[self.id]
        return goal

    def step(self, obs: Observation, cmd: Command) -> None:
        """This tick's decision for an ACTIVE robot, written into `cmd` (which starts
        stopped, silent, lidar off)."""
        cmd.lidar_on = 1
        if self.beacon_period > 0 and (obs.tick + self.id) % self.beacon_period == 0:
            radio.push_frame(cmd, BROADCAST, radio.encode_beacon(obs.x, obs.y, obs.theta))

        x, y, theta = obs.x, obs.y, obs.theta
        dx, dy = self.slot[0] - x, self.slot[1] - y
        dist = math.sqrt(dx * dx + dy * dy)
        if dist < ARRIVE:
            return
        err = wrap_angle(math.atan2(dy, dx) - theta)
        omega = 2.0 * err
        # Slow down when facing away and when close, so the robot does not orbit its slot.
        v = self.speed * fmax(math.cos(err), 0.0) * fmin(dist / (4.0 * self.radius), 1.0)

        # Avoidance: nearest return ahead, which side is more open, and what the ray
        # closest to the slot's direction sees.
        nearest, left, right = math.inf, 0.0, 0.0
        toward_slot, best = math.inf, math.inf
        n = min(int(obs.lidar_len), 64)
        lidar = obs.lidar
        for k in range(n):
            d = lidar[k]
            a = self.angles[k]
            if abs(a) <= AHEAD:
                nearest = fmin(nearest, d)
            if a > 0.0:
                left += d
            elif a < 0.0:
                right += d
            if abs(a - err) < best:
                best = abs(a - err)
                toward_slot = d
        gx, gy = self.goal
        ex, ey = x - gx, y - gy
        in_goal_area = math.sqrt(ex * ex + ey * ey) < self.goal_radius * 0.9
        # Only obstacles closer than the slot matter.
        if nearest < self.avoid_distance and nearest < dist:
            if in_goal_area:
                # Blocked inside the goal area, most likely by a parked robot: park here.
                return
            # Commit to one side until the way to the slot is open.
            if self.avoid_side is None:
                self.avoid_side = 1.0 if left >= right else -1.0
            side = self.avoid_side
            urgency = 1.0 - fmax(nearest - self.radius, 0.0) / fmax(
                self.avoid_distance - self.radius, 1e-6
            )
            omega = side * self.max_turn * clamp(urgency, 0.3, 1.0)
            v = self.speed * clamp(1.0 - urgency, 0.0, 1.0)
            if nearest < self.radius + 0.1:
                v = 0.0
        elif self.avoid_side is not None:
            side = self.avoid_side
            if (
                toward_slot
                < fmax(self.avoid_distance, fmin(dist, 1.5 * self.avoid_distance))
                and best < AHEAD * 2.0
            ):
                # The slot is still behind the obstacle: follow its edge, bending back.
                omega = -side * 0.3 * self.max_turn
                v = self.speed
            else:
                self.avoid_side = None

        # Never overshoot the slot within one tick.
        cmd.v = clamp(fmin(v, dist / self.dt), 0.0, self.max_speed)
        cmd.omega = clamp(omega, -self.max_turn, self.max_turn)


def main() -> int:
    robot = Robot.from_env()
    goto = Goto(robot.config, robot.id)
    for obs in robot.observations():
        cmd = robot.command(obs)
        if obs.state == STATE_ACTIVE:
            goto.step(obs, cmd)
        # A DOWN robot answers with the stopped, silent command (the world ignores it).
        robot.send(cmd)
    return robot.exit_code


if __name__ == "__main__":
    sys.exit(main())
