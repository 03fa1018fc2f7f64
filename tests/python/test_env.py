"""The learning environments: PettingZoo's and Gymnasium's own checkers, determinism,
the vector env against single worlds, bad actions, reward callables."""

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test, parallel_seed_test

from conftest import CONFIGS
from swarmrt import env

GOTO = CONFIGS / "goto_simple.toml"
FLOCK = CONFIGS / "flocking_crossing.toml"
SHORT = {"scenario.ticks": 40}
LOSSY = {"scenario.ticks": 40, "radio.loss": 0.3, "radio.delay_ticks": 2}


@pytest.mark.parametrize("config,set,payload", [(GOTO, SHORT, 0), (FLOCK, LOSSY, 8)])
def test_pettingzoos_parallel_api_and_seed_tests_pass(config, set, payload):
    parallel_api_test(env.parallel_env(config, set=set, payload=payload), num_cycles=60)
    parallel_seed_test(lambda: env.parallel_env(config, set=set, payload=payload))


def test_gymnasiums_checker_passes_on_the_joint_env():
    check_env(env.gym_env(FLOCK, set=LOSSY, payload=4), skip_render_check=True)


def rollout(e, steps, seed):
    e.reset(seed=seed)
    rng = np.random.default_rng(seed)
    seen = []
    for _ in range(steps):
        actions = {a: e.action_space(a).sample() for a in e.agents}
        for a in actions:
            actions[a] = rng.uniform(-1, 1, 2) * [e.limits["max_speed"], e.limits["max_turn_rate"]]
        obs, rewards, *_ = e.step(actions)
        seen.append((obs, rewards))
    return seen


def test_the_same_seed_gives_the_same_observations_bit_for_bit_over_a_lossy_radio():
    a = rollout(env.parallel_env(FLOCK, set=LOSSY), 30, seed=7)
    b = rollout(env.parallel_env(FLOCK, set=LOSSY), 30, seed=7)
    c = rollout(env.parallel_env(FLOCK, set=LOSSY), 30, seed=8)
    for (oa, ra), (ob, rb) in zip(a, b):
        assert ra == rb
        for agent in oa:
            for key in oa[agent]:
                assert oa[agent][key].tobytes() == ob[agent][key].tobytes(), (agent, key)
    assert any(c[t][0]["robot_0"]["pose"].tobytes() != a[t][0]["robot_0"]["pose"].tobytes()
               for t in range(30)), "another seed starts elsewhere"


def test_a_policys_bytes_cross_the_lossy_radio():
    e = env.parallel_env(FLOCK, set={"scenario.ticks": 40}, payload=4)
    e.reset(seed=1)
    heard = 0
    for _ in range(10):
        act = {a: {"move": np.zeros(2), "say": np.array([1, 2, 3], dtype=np.uint8),
                   "say_len": 3} for a in e.agents}
        obs, *_ = e.step(act)
        for o in obs.values():
            for j in np.flatnonzero(o["inbox_mask"]):
                assert o["inbox"][j][:3].tolist() == [1, 2, 3]
                assert o["inbox_meta"][j][1] == 3
                heard += 1
    assert heard > 0


def test_the_vector_env_steps_k_worlds_as_k_single_worlds_would():
    k = 3
    vec = env.vector_env(FLOCK, num_envs=k, set=SHORT)
    singles = [env.gym_env(FLOCK, set=SHORT) for _ in range(k)]
    vo, _ = vec.reset(seed=11)
    so = [s.reset(seed=11 + i)[0] for i, s in enumerate(singles)]
    rng = np.random.default_rng(0)
    for _ in range(25):
        act = vec.action_space.sample()
        act = np.clip(rng.normal(size=act.shape), -0.05, 0.05)
        vo, vr, vt, vtr, info = vec.step(act)
        for i, s in enumerate(singles):
            o, r, t, tr, sinfo = s.step(act[i])
            for key in o:
                assert vo[key][i].tobytes() == o[key].tobytes(), key
            assert np.array_equal(info["rewards"][i], sinfo["rewards"])
    assert vo["lidar"].shape == (k, 10, 8)


def test_the_vector_env_resets_an_ended_world_at_the_next_step():
    vec = env.vector_env(GOTO, num_envs=2, set={"scenario.ticks": 5})
    vec.reset(seed=1)
    zero = np.zeros((2, 9, 2))
    for t in range(5):
        _, _, _, truncated, _ = vec.step(zero)
    assert truncated.all()
    obs, rewards, _, truncated, _ = vec.step(zero)
    assert not truncated.any() and (rewards == 0).all()
    first, _ = env.gym_env(GOTO, set={"scenario.ticks": 5}).reset(seed=3)
    assert obs["pose"][0].tobytes() == first["pose"].tobytes(), "world 0 restarted on seed 3"


def test_bad_actions_raise_value_error_naming_the_agent_and_the_bound():
    e = env.parallel_env(GOTO, set=SHORT)
    e.reset(seed=1)
    acts = {a: np.zeros(2) for a in e.agents}
    with pytest.raises(ValueError, match=r"robot_4.*shape \(2,\)"):
        e.step({**acts, "robot_4": np.zeros(3)})
    with pytest.raises(ValueError, match=r"robot_2: v = NaN is not a finite"):
        e.step({**acts, "robot_2": np.array([np.nan, 0.0])})
    with pytest.raises(ValueError, match=r"robot_0: omega = 99 is out of range \[-"):
        e.step({**acts, "robot_0": np.array([0.0, 99.0])})
    assert e.state()["x"].tolist() == env.parallel_env(GOTO, set=SHORT).state()["x"].tolist()
    clipped = env.parallel_env(GOTO, set=SHORT, clip_actions=True)
    clipped.reset(seed=1)
    *_, infos = clipped.step({**acts, "robot_0": np.array([0.0, 99.0])})
    assert infos["robot_0"]["clipped"] == 1 and infos["robot_1"]["clipped"] == 0


def test_a_reward_callable_gets_the_worlds_truth_and_its_exception_surfaces():
    calls = []

    def reward(state, events):
        calls.append(state)
        if len(calls) == 2:
            raise KeyError("from the user's reward")
        return -state["x"]

    e = env.parallel_env(GOTO, set=SHORT, reward=reward)
    obs, _ = e.reset(seed=1)
    _, rewards, *_ = e.step({a: np.array([0.1, 0.0]) for a in e.agents})
    assert rewards["robot_0"] == -calls[0]["x"][0]
    with pytest.raises(KeyError, match="from the user's reward"):
        e.step({a: np.array([0.1, 0.0]) for a in e.agents})
    obs, _ = e.reset(seed=1)
    assert len(obs) == 9
    e.step({a: np.zeros(2) for a in e.agents})


def test_a_robot_killed_by_the_configs_faults_leaves_the_agents():
    kill = {"scenario.ticks": 30, "faults.kill": [{"tick": 5, "robot": 3}]}
    e = env.parallel_env(GOTO, set=kill)
    e.reset(seed=1)
    for t in range(10):
        _, _, terminated, _, _ = e.step({a: np.zeros(2) for a in e.agents})
        if "robot_3" in terminated and terminated["robot_3"]:
            break
    assert "robot_3" not in e.agents and len(e.agents) == 8


def test_a_bad_config_or_size_is_refused_with_its_key_and_bound():
    import swarmrt

    with pytest.raises(swarmrt.ConfigError, match=r"goto_simple.toml: key `radio.losss`"):
        env.parallel_env(GOTO, set={"radio.losss": 0.1})
    with pytest.raises(ValueError, match=r"neighbours = 99 is out of range: at most 32"):
        env.parallel_env(GOTO, neighbours=99)
    with pytest.raises(swarmrt.ConfigError, match=r"robots.aerial"):
        env.parallel_env(CONFIGS / "planner_uav3.toml")
    with pytest.raises(ValueError, match=r"num_envs = 0 is out of range"):
        env.vector_env(GOTO, num_envs=0)


def test_the_flock_reward_rewards_alignment_and_closeness():
    e = env.parallel_env(FLOCK, set=SHORT, reward="flock")
    e.reset(seed=1)
    _, rewards, *_ = e.step({a: np.zeros(2) for a in e.agents})
    state = e.state()
    expected = env.flock_reward(state, [])
    assert [rewards[f"robot_{i}"] for i in range(10)] == pytest.approx(expected.tolist())
    aligned = {"x": np.zeros(3), "y": np.zeros(3), "theta": np.full(3, 0.5),
               "state": np.zeros(3, dtype=np.uint8)}
    assert env.flock_reward(aligned, []).tolist() == pytest.approx([1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="expected \"goal\", \"flock\" or a callable"):
        env.vector_env(FLOCK, num_envs=2, set=SHORT, reward="nope")
