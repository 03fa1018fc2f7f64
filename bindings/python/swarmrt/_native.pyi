"""Type stubs of the native module (bindings/python/src): what editors and type checkers see."""

from typing import Callable, Optional

OBSERVATION_SIZE: int
COMMAND_SIZE: int

class ConfigError(ValueError):
    """A config or its overrides are invalid: the CLI's one line (file, key, expected)."""

class SwarmrtError(RuntimeError):
    """A run failed for a reason that is not the config's."""

def run(argv: list[str], progress: Optional[Callable[[int], None]] = None) -> str:
    """`swarm <argv>` for a `run` command, in this process; returns the run directory."""

def check_config(config: str, set: list[str] = ...) -> tuple[str, int, int, int]:
    """The scenario's name, seed, ticks and robot count; ConfigError when invalid."""

def features(observation: bytes, rays: int, neighbours: int, inbox: int, payload: int,
             lidar_range: float) -> dict[str, bytes]:
    """One robot's view of its observation's bytes, as the environment computes it."""

def command(robot: int, tick: int, v: float, omega: float, say: list[int]) -> bytes:
    """The command bytes a robot sends for an action, as the environment applies it."""

class VecEnv:
    def __init__(self, config: str, set: list[str], num_envs: int, seed: Optional[int] = None,
                 neighbours: int = 8, inbox: int = 4, payload: int = 0) -> None: ...
    @property
    def num_envs(self) -> int: ...
    @property
    def num_agents(self) -> int: ...
    @property
    def layout(self) -> tuple[int, int, int, int]: ...
    @property
    def limits(self) -> dict: ...
    def reset_one(self, k: int, seed: int, record: Optional[str] = None) -> None: ...
    def observe(self) -> dict[str, bytes]: ...
    def state(self) -> dict: ...
    def expects(self) -> bytes: ...
    def step(self, v: bytes, omega: bytes, say: bytes, say_len: bytes) -> tuple[bytes, bytes, bytes]: ...
    def events(self, k: int) -> list[str]: ...
