"""A policy rolled out in the environment, then deployed as one Python process per robot
over iceoryx2: the same seed gives the same records, byte for byte."""

import importlib.util
import subprocess
import sys

import numpy as np

from conftest import CONFIGS, SWARM, WORKSPACE
from swarmrt import env

EXAMPLE = WORKSPACE / "examples" / "python" / "policy.py"


def load_example():
    spec = importlib.util.spec_from_file_location("policy_example", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_deployed_policy_writes_its_rollouts_records(tmp_path):
    example = load_example()
    ticks, seed = 80, 3
    config = CONFIGS / "goto_simple.toml"
    e = env.parallel_env(config, set={"scenario.ticks": ticks}, record=tmp_path / "env",
                         **example.LAYOUT)
    obs, _ = e.reset(seed=seed)
    moved = False
    while e.agents:
        actions = {a: example.policy(obs[a]) for a in e.agents}
        moved |= any(abs(a[0]) > 0 for a in actions.values())
        obs, *_ = e.step(actions)
    assert moved
    program = f'robots.program=["{sys.executable}", "{EXAMPLE}"]'
    subprocess.run([str(SWARM), "run", str(config), "--ticks", str(ticks), "--seed", str(seed),
                    "--set", program, "--out", str(tmp_path / "processes")],
                   check=True, capture_output=True)
    for name in ("trajectory.csv", "events.jsonl"):
        rolled = (tmp_path / "env" / name).read_bytes()
        deployed = (tmp_path / "processes" / name).read_bytes()
        assert rolled == deployed, name
    rows = rolled = (tmp_path / "env" / "trajectory.csv").read_text().splitlines()
    assert len(rows) == 1 + 9 * (ticks + 1)
    last = [r.split(",") for r in rows[-9:]]
    assert len({(r[2], r[3]) for r in last}) == 9, "the robots went their own ways"
