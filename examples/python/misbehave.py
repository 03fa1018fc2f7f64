#!/usr/bin/env python3
"""Test robots: the Python go-to robot (goto.py) made to misbehave on purpose, for tests of
what the world and the orchestrator do with a broken foreign robot.

    program = [".venv/bin/python", "examples/python/misbehave.py", "<mode>"]

The mode is the first argument (the orchestrator appends the robot's own arguments after it):

* `nan`            every command has a NaN speed
* `wrong-tick`     every command answers the next tick instead of this one
* `garbage-frame`  every command carries a frame that is no radio message and not opaque
* `impersonate`    every command claims to be from the next robot
* `garbage`        the four above in turn, one per tick
* `crash:N`        raises an exception at tick N (Python exits with code 1)
* `slow:MS`        sleeps MS milliseconds before answering each tick (a correct robot)

Every other field is what goto.py decides, so the robot is otherwise sane. Refused commands
are counted by the world in `rejected`; the robot stands still and the others go on.
"""

from __future__ import annotations

import math
import os
import sys
import time

sys.dont_write_bytecode = True  # no __pycache__ beside the examples
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from goto import Goto  # noqa: E402

from swarmrt import BROADCAST, STATE_ACTIVE, Robot, radio  # noqa: E402

GARBAGE = ["nan", "wrong-tick", "garbage-frame", "impersonate"]


def corrupt(mode: str, cmd, robot: Robot) -> None:
    """Breaks `cmd` the way `mode` says."""
    if mode == "nan":
        cmd.v = math.nan
    elif mode == "wrong-tick":
        cmd.tick += 1
    elif mode == "garbage-frame":
        # RadioMsg::Goto's tag and a beacon cut short: neither a message nor opaque.
        cmd.outbox_len = 0
        radio.push_frame(cmd, BROADCAST, bytes([radio.GOTO, 1, 2, 3]))
    elif mode == "impersonate":
        cmd.robot = (robot.id + 1) % int(robot.config["robots"]["count"])
    else:
        raise ValueError(f"unknown garbage mode {mode!r}")


def main() -> int:
    spec = sys.argv[1] if len(sys.argv) > 1 else ""
    mode, _, arg = spec.partition(":")
    if mode not in GARBAGE + ["garbage", "crash", "slow"]:
        print(f"misbehave.py: unknown mode {spec!r} (see the file's docstring)", file=sys.stderr)
        return 2
    robot = Robot.from_env()
    goto = Goto(robot.config, robot.id)
    answered = 0
    for obs in robot.observations():
        if mode == "crash" and obs.tick >= int(arg):
            raise RuntimeError(f"test robot {robot.id} crashes at tick {obs.tick}")
        if mode == "slow":
            time.sleep(int(arg) / 1000.0)
        cmd = robot.command(obs)
        if obs.state == STATE_ACTIVE:
            goto.step(obs, cmd)
        if mode == "garbage":
            corrupt(GARBAGE[answered % len(GARBAGE)], cmd, robot)
        elif mode in GARBAGE:
            corrupt(mode, cmd, robot)
        answered += 1
        robot.send(cmd)
    return robot.exit_code


if __name__ == "__main__":
    sys.exit(main())
