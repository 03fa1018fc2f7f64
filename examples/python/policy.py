"""A hand-written policy over the learning environment's observation, deployed unchanged as
one robot process per robot (`swarmrt.robot.run_policy`).

Train (or here, just roll out) in `swarmrt.env`, then run the same function as robots:

    swarm run configs/goto_simple.toml \\
        --set 'robots.program=[".venv/bin/python", "examples/python/policy.py"]'

It heads for the goal when its goal sensor sees it, turns on the spot when it does not, and
veers away from the nearest lidar hit; the same observation gives the same action, so the
process run writes the environment rollout's records (tests/python/test_policy.py).
"""

import numpy as np

#: The observation's sizes, the same in the environment and in the robot process.
LAYOUT = {"neighbours": 8, "inbox": 4, "payload": 0}
MAX_SPEED = 0.3
MAX_TURN = 1.0


def policy(obs: dict) -> np.ndarray:
    """(v, omega) from one robot's observation."""
    seen, _, bearing = obs["goal"]
    lidar = obs["lidar"]
    if lidar.size and lidar.min() < 0.4:
        # Veer away from the side the nearest hit is on.
        side = 1.0 if np.argmin(lidar) < lidar.size / 2 else -1.0
        return np.array([0.05, side * MAX_TURN])
    if seen:
        return np.array([MAX_SPEED, float(np.clip(2.0 * bearing, -MAX_TURN, MAX_TURN))])
    return np.array([0.0, 0.5])


if __name__ == "__main__":
    from swarmrt.robot import run_policy

    run_policy(policy, **LAYOUT)
