"""Learning environments over the world core: what a robot process observes and sends.

* `parallel_env(config, ...)`: a PettingZoo `ParallelEnv`, one agent per robot.
* `gym_env(config, ...)`: the same world as one Gymnasium `Env` whose observation and action
  hold every robot (arrays of shape (N, ...)), the team reward the sum of the robots'.
* `vector_env(config, num_envs=K, ...)`: K of those worlds stepped together on Rust threads
  with the GIL released, as a Gymnasium `VectorEnv` (arrays (K, N, ...), next-step autoreset).

A robot's observation is its observation as a robot process gets it (`swarmrt._views`):
`pose` (x, y, theta estimated), `goal` (seen, range, bearing), `lidar` (rays, metres; the
maximum range where nothing was hit), `neighbours` (the nearest K: range, bearing) with
`neighbours_mask`, and the opaque radio frames that reached it, `inbox` (M frames of P
bytes) with `inbox_meta` (sender, length) and `inbox_mask`. Its action is (v, omega) within
`robots.max_speed` and `robots.max_turn_rate`; with `payload=P > 0` it is a dict of `move`
(those two), `say` (P bytes) and `say_len` (how many of them to broadcast as one frame),
which the world's radio carries with its range, loss, bursts, delay, jitter, capacity and
partitions from the config. An action out of bounds, not finite or of the wrong shape raises
ValueError naming the agent and the bound (with `clip_actions=True` it is clipped instead,
and counted in `infos[agent]["clipped"]`).

Rewards: `reward="goal"` (the default), a robot's progress towards its goal this step
(metres, by the world's truth), +1 on entering it, -1 on a collision that takes it down;
`reward="flock"`, its alignment with the swarm's heading minus a tenth of its distance to the
swarm's centre (`flock_reward`). `reward=f` replaces them:
`f(state, events) -> N rewards`, with `state` the world's truth (x, y, theta, v, omega, state
per robot) and `events` the step's events as dicts (the `events.jsonl` vocabulary). A robot
that goes down or is killed by the config's faults is terminated and leaves `agents`; every
robot is truncated when the run's ticks are over. The same seed gives the same observations,
bit for bit.
"""

from __future__ import annotations

import json
from typing import Any, Callable, Mapping, Optional

import numpy as np

from . import _native
from ._views import arrays

try:
    import gymnasium
    from gymnasium import spaces
    from pettingzoo import ParallelEnv
except ImportError as e:  # pragma: no cover - the message is the point
    raise ImportError(
        "swarmrt.env needs pettingzoo and gymnasium: pip install 'swarmrt[env]'"
    ) from e

__all__ = ["SwarmParallelEnv", "SwarmGymEnv", "SwarmVectorEnv", "parallel_env", "gym_env",
           "vector_env"]

Reward = Callable[[dict, list], Any]


def _set_words(set: Optional[Mapping[str, Any]]) -> list[str]:
    from ._run import _toml

    return [f"{k}={_toml(v)}" for k, v in (set or {}).items()]


class _Worlds:
    """K worlds of the native `VecEnv`, in numpy."""

    def __init__(self, config, num_envs, seed, neighbours, inbox, payload, set):
        self.core = _native.VecEnv(str(config), _set_words(set), num_envs, seed, neighbours,
                                   inbox, payload)
        self.k = self.core.num_envs
        self.n = self.core.num_agents
        self.layout = self.core.layout
        self.limits = self.core.limits
        self.payload = self.layout[3]

    def views(self) -> dict:
        return arrays(self.core.observe(), (self.k, self.n), self.layout)

    def state(self) -> dict:
        raw = self.core.state()
        out = {key: np.frombuffer(raw[key], dtype=np.float64).reshape(self.k, self.n)
               for key in ("x", "y", "theta", "v", "omega")}
        out["state"] = np.frombuffer(raw["state"], dtype=np.uint8).reshape(self.k, self.n)
        out["tick"] = np.asarray(raw["tick"])
        return out

    def step(self, v, omega, say, say_len):
        rewards, terminated, truncated = self.core.step(
            np.ascontiguousarray(v, dtype=np.float64).tobytes(),
            np.ascontiguousarray(omega, dtype=np.float64).tobytes(),
            np.ascontiguousarray(say, dtype=np.uint8).tobytes(),
            np.ascontiguousarray(say_len, dtype=np.uint8).tobytes(),
        )
        return (np.frombuffer(rewards, dtype=np.float64).reshape(self.k, self.n).copy(),
                np.frombuffer(terminated, dtype=np.uint8).reshape(self.k, self.n).astype(bool),
                np.frombuffer(truncated, dtype=np.uint8).astype(bool))

    def events(self, k: int) -> list:
        return [json.loads(e) for e in self.core.events(k)]


def _observation_space(layout, batch=()) -> "spaces.Dict":
    rays, k, m, p = layout
    f32 = dict(low=-np.inf, high=np.inf, dtype=np.float32)
    return spaces.Dict({
        "pose": spaces.Box(shape=batch + (3,), **f32),
        "goal": spaces.Box(shape=batch + (3,), **f32),
        "lidar": spaces.Box(shape=batch + (rays,), **f32),
        "neighbours": spaces.Box(shape=batch + (k, 2), **f32),
        "neighbours_mask": spaces.Box(0, 1, shape=batch + (k,), dtype=np.uint8),
        "inbox": spaces.Box(0, 255, shape=batch + (m, p), dtype=np.uint8),
        "inbox_meta": spaces.Box(0, np.iinfo(np.int32).max, shape=batch + (m, 2), dtype=np.int32),
        "inbox_mask": spaces.Box(0, 1, shape=batch + (m,), dtype=np.uint8),
    })


def _move_space(limits, batch=()) -> "spaces.Box":
    high = np.broadcast_to(np.array([limits["max_speed"], limits["max_turn_rate"]]),
                           batch + (2,)).astype(np.float64)
    return spaces.Box(-high, high, dtype=np.float64)


def _action_space(limits, payload, batch=()) -> "spaces.Space":
    move = _move_space(limits, batch)
    if payload == 0:
        return move
    return spaces.Dict({
        "move": move,
        "say": spaces.Box(0, 255, shape=batch + (payload,), dtype=np.uint8),
        "say_len": spaces.Box(0, payload, shape=batch, dtype=np.uint8),
    })


def _split(action, agent: str, payload: int, limits, clip: bool):
    """(v, omega, say bytes, say_len, clipped) of one agent's action; ValueError naming the
    agent when its shape is wrong (its values are checked by the world's rules)."""
    if payload and not isinstance(action, Mapping):
        raise ValueError(f"agent {agent}: with payload={payload} an action is a dict of "
                         "move, say and say_len")
    move = action["move"] if payload else action
    move = np.asarray(move, dtype=np.float64)
    if move.shape != (2,):
        raise ValueError(f"agent {agent}: an action's move is (v, omega), shape (2,), "
                         f"not {move.shape}")
    clipped = 0
    if clip:
        high = np.array([limits["max_speed"], limits["max_turn_rate"]])
        safe = np.clip(np.nan_to_num(move, nan=0.0), -high, high)
        clipped = int(np.any(safe != move))
        move = safe
    say = np.zeros(payload, dtype=np.uint8)
    say_len = 0
    if payload:
        raw = np.asarray(action.get("say", say), dtype=np.uint8).reshape(-1)
        if raw.shape[0] > payload:
            raise ValueError(f"agent {agent}: say holds {raw.shape[0]} bytes; a frame holds "
                             f"at most {payload}")
        say[: raw.shape[0]] = raw
        say_len = int(action.get("say_len", raw.shape[0]))
        if not 0 <= say_len <= payload:
            raise ValueError(f"agent {agent}: say_len = {say_len} is out of range [0, {payload}]")
    return move[0], move[1], say, say_len, clipped


def flock_reward(state: dict, events: list) -> np.ndarray:
    """The built-in `reward="flock"`: each robot's alignment with the swarm's mean heading
    (cos of the difference, in [-1, 1]) minus a tenth of its distance to the swarm's centre
    (metres), over the robots still up; 0 for a robot that is down or dead."""
    up = state["state"] <= 1  # active or frozen
    if not up.any():
        return np.zeros_like(state["x"])
    heading = np.arctan2(np.sin(state["theta"][up]).mean(), np.cos(state["theta"][up]).mean())
    cx, cy = state["x"][up].mean(), state["y"][up].mean()
    spread = np.hypot(state["x"] - cx, state["y"] - cy)
    return np.where(up, np.cos(state["theta"] - heading) - 0.1 * spread, 0.0)


def _reward_fn(reward) -> Optional[Reward]:
    """None for the built-in goal reward, else the callable that computes the rewards."""
    if reward is None or reward == "goal":
        return None
    if reward == "flock":
        return flock_reward
    if callable(reward):
        return reward
    raise ValueError(f"reward = {reward!r}: expected \"goal\", \"flock\" or a callable")


def _builtin_or(reward: Optional[Reward], worlds: _Worlds, k: int, builtin: np.ndarray):
    if reward is None:
        return builtin
    state = {key: value[k] for key, value in worlds.state().items() if key != "tick"}
    out = np.asarray(reward(state, worlds.events(k)), dtype=np.float64)
    if out.shape != (worlds.n,):
        raise ValueError(f"the reward callable returned shape {out.shape}, not ({worlds.n},)")
    return out


class SwarmParallelEnv(ParallelEnv):
    """One world, one PettingZoo agent (`robot_<i>`) per robot. See the module's doc."""

    metadata = {"name": "swarmrt_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, config, *, seed: Optional[int] = None, neighbours: int = 8,
                 inbox: int = 4, payload: int = 0, reward: Optional[Reward] = None,
                 clip_actions: bool = False, record=None, set: Optional[Mapping[str, Any]] = None):
        self._worlds = _Worlds(config, 1, seed, neighbours, inbox, payload, set)
        self._record = record
        self._next_seed = seed if seed is not None else self._worlds.limits["seed"]
        self._reward = _reward_fn(reward)
        self._clip = clip_actions
        self.possible_agents = [f"robot_{i}" for i in range(self._worlds.n)]
        self.agents = list(self.possible_agents)
        self._obs_space = _observation_space(self._worlds.layout)
        self._act_space = _action_space(self._worlds.limits, self._worlds.payload)
        self._resets = 0

    def observation_space(self, agent):
        return self._obs_space

    def action_space(self, agent):
        return self._act_space

    @property
    def limits(self) -> dict:
        """Speed and turn limits, the lidar's range, the map's bounds, the run's ticks."""
        return dict(self._worlds.limits)

    def _observations(self) -> dict:
        views = self._worlds.views()
        return {a: {key: views[key][0, i] for key in views}
                for i, a in enumerate(self.possible_agents) if a in self.agents}

    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None):
        """A new episode: seeded `seed`, else the config's seed first and the next one at
        each later reset. With `record`, the first episode is recorded there."""
        if seed is not None:
            self._next_seed = seed
        record = None if self._record is None or self._resets else str(self._record)
        self._worlds.core.reset_one(0, self._next_seed, record)
        self._resets += 1
        self._next_seed += 1
        self.agents = list(self.possible_agents)
        obs = self._observations()
        return obs, {a: {} for a in self.agents}

    def step(self, actions: dict):
        worlds, n, p = self._worlds, self._worlds.n, self._worlds.payload
        v, omega = np.zeros((1, n)), np.zeros((1, n))
        say, say_len = np.zeros((1, n, p), dtype=np.uint8), np.zeros((1, n), dtype=np.uint8)
        clipped = {}
        for i, agent in enumerate(self.possible_agents):
            if agent in self.agents and agent in actions:
                v[0, i], omega[0, i], say[0, i], say_len[0, i], clipped[agent] = _split(
                    actions[agent], agent, p, worlds.limits, self._clip)
        try:
            builtin, terminated, truncated = worlds.step(v, omega, say, say_len)
        except ValueError as e:
            raise ValueError(str(e).replace("world 0: ", "")) from None
        rewards = _builtin_or(self._reward, worlds, 0, builtin[0])
        live = list(self.agents)
        obs = {a: o for a, o in self._observations().items()}
        out_rewards = {a: float(rewards[self.possible_agents.index(a)]) for a in live}
        terms = {a: bool(terminated[0, self.possible_agents.index(a)]) for a in live}
        truncs = {a: bool(truncated[0]) for a in live}
        infos = {a: ({"clipped": clipped.get(a, 0)} if self._clip else {}) for a in live}
        self.agents = [a for a in live if not (terms[a] or truncs[a])]
        return obs, out_rewards, terms, truncs, infos

    def state(self) -> dict:
        """The world's truth per robot (x, y, theta, v, omega, state)."""
        return {k: v[0] for k, v in self._worlds.state().items() if k != "tick"}

    def close(self):
        pass


class SwarmGymEnv(gymnasium.Env):
    """One world as a single Gymnasium `Env`: observation and action of every robot at once
    (arrays of shape (N, ...)), the team reward the sum of the robots' rewards, terminated
    once every robot is, truncated when the run's ticks are over. `vector_env` batches it."""

    metadata = {"render_modes": []}

    def __init__(self, config, *, seed: Optional[int] = None, neighbours: int = 8,
                 inbox: int = 4, payload: int = 0, reward: Optional[Reward] = None,
                 set: Optional[Mapping[str, Any]] = None):
        self._worlds = _Worlds(config, 1, seed, neighbours, inbox, payload, set)
        self._reward = _reward_fn(reward)
        n = self._worlds.n
        self.observation_space = _observation_space(self._worlds.layout, (n,))
        self.action_space = _action_space(self._worlds.limits, self._worlds.payload, (n,))
        self._next_seed = seed if seed is not None else self._worlds.limits["seed"]

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        super().reset(seed=seed)
        if seed is not None:
            self._next_seed = seed
        self._worlds.core.reset_one(0, self._next_seed)
        self._next_seed += 1
        return {k: v[0].copy() for k, v in self._worlds.views().items()}, {}

    def step(self, action):
        w = self._worlds
        v, omega, say, say_len = _batched(action, w, 1)
        builtin, terminated, truncated = w.step(v, omega, say, say_len)
        rewards = _builtin_or(self._reward, w, 0, builtin[0])
        obs = {k: v[0].copy() for k, v in w.views().items()}
        return (obs, float(rewards.sum()), bool(terminated[0].all()), bool(truncated[0]),
                {"rewards": rewards, "terminated": terminated[0]})


def _batched(action, worlds: _Worlds, k: int):
    """(v, omega, say, say_len) arrays of shape (k, N, ...) from a batched action."""
    n, p = worlds.n, worlds.payload
    if p:
        move = np.asarray(action["move"], dtype=np.float64).reshape(k, n, 2)
        say = np.asarray(action["say"], dtype=np.uint8).reshape(k, n, p)
        say_len = np.asarray(action["say_len"], dtype=np.uint8).reshape(k, n)
    else:
        move = np.asarray(action, dtype=np.float64)
        if move.size != k * n * 2:
            raise ValueError(f"an action is (v, omega) per robot: shape {(k, n, 2)}, "
                             f"not {move.shape}")
        move = move.reshape(k, n, 2)
        say, say_len = np.zeros((k, n, 0), dtype=np.uint8), np.zeros((k, n), dtype=np.uint8)
    return move[..., 0], move[..., 1], say, say_len


class SwarmVectorEnv(gymnasium.vector.VectorEnv):
    """K worlds of `SwarmGymEnv`, stepped together on Rust threads with the GIL released:
    observations (K, N, ...), rewards, terminations and truncations (K,) with the robots' own
    in `infos["rewards"]` and `infos["terminated"]` (K, N); a world that ended is reset at the
    next step (Gymnasium's next-step autoreset), its seed the next unused one."""

    metadata = {"autoreset_mode": gymnasium.vector.AutoresetMode.NEXT_STEP}

    def __init__(self, config, num_envs: int, *, seed: Optional[int] = None,
                 neighbours: int = 8, inbox: int = 4, payload: int = 0,
                 reward: Optional[Reward] = None, set: Optional[Mapping[str, Any]] = None):
        self._worlds = _Worlds(config, num_envs, seed, neighbours, inbox, payload, set)
        self._reward = _reward_fn(reward)
        w = self._worlds
        self.num_envs = num_envs
        self.single_observation_space = _observation_space(w.layout, (w.n,))
        self.single_action_space = _action_space(w.limits, w.payload, (w.n,))
        self.observation_space = _observation_space(w.layout, (num_envs, w.n))
        self.action_space = _action_space(w.limits, w.payload, (num_envs, w.n))
        self._seed = seed if seed is not None else w.limits["seed"]
        self._next_seed = self._seed + num_envs
        self._ended = np.zeros(num_envs, dtype=bool)

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        if seed is not None:
            self._seed = seed
        for k in range(self.num_envs):
            self._worlds.core.reset_one(k, self._seed + k)
        self._next_seed = self._seed + self.num_envs
        self._ended[:] = False
        return {k: v.copy() for k, v in self._worlds.views().items()}, {}

    def step(self, actions):
        w = self._worlds
        v, omega, say, say_len = _batched(actions, w, self.num_envs)
        # Worlds that ended last step restart now and ignore this step's actions.
        for k in np.flatnonzero(self._ended):
            w.core.reset_one(int(k), self._next_seed)
            self._next_seed += 1
            v[k], omega[k], say_len[k] = 0.0, 0.0, 0
        builtin, terminated, truncated = w.step(v, omega, say, say_len)
        rewards = builtin if self._reward is None else np.stack(
            [_builtin_or(self._reward, w, k, builtin[k]) for k in range(self.num_envs)])
        restarted = self._ended.copy()
        rewards[restarted] = 0.0
        terminated[restarted] = False
        truncated[restarted] = False
        team_done = terminated.all(axis=1)
        self._ended = team_done | truncated
        obs = {k: v.copy() for k, v in w.views().items()}
        return (obs, rewards.sum(axis=1), team_done, truncated.copy(),
                {"rewards": rewards, "terminated": terminated})


def parallel_env(config, **kwargs) -> SwarmParallelEnv:
    """A PettingZoo `ParallelEnv` over `config` (a path to a TOML scenario)."""
    return SwarmParallelEnv(config, **kwargs)


def gym_env(config, **kwargs) -> SwarmGymEnv:
    """A Gymnasium `Env` of one world, every robot at once."""
    return SwarmGymEnv(config, **kwargs)


def vector_env(config, num_envs: int = 16, **kwargs) -> SwarmVectorEnv:
    """A Gymnasium `VectorEnv` of `num_envs` worlds."""
    return SwarmVectorEnv(config, num_envs, **kwargs)
