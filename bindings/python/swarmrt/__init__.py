"""swarmrt from Python: runs, learning environments and robot programs.

* `swarmrt.run(config, ...)` -> `Run` (records as pandas DataFrames, `.plot()`, `.view()`),
  `swarmrt.sweep(...)`, `swarmrt.tune(...)`: the notebook API (`swarmrt._run`).
* `swarmrt.env`: PettingZoo and Gymnasium environments over the world core
  (`pip install 'swarmrt[env]'`).
* `swarmrt.robot`: a robot process in Python: `Robot.from_env()`, `Robot.observations()`,
  `Robot.send()`, and `run_policy(policy)` for a policy trained in `swarmrt.env`.
* `swarmrt._messages` (re-exported here): ctypes mirrors of the Rust messages and every
  protocol constant, GENERATED from protocol/src/layout.rs, so the layout cannot drift.
* `swarmrt.radio`: postcard encoding of the Rust robots' radio messages, and opaque frames;
  its wire tags (`radio.GOTO`, ..., `radio.CONSENSUS`) come from `swarmrt._tags`, GENERATED
  from the agent's behaviour registry (agent/src/wire.rs), so they cannot drift either.

`swarmrt.robot` (and iceoryx2) is imported on first use, so a notebook that only runs and
reads records never loads the shared-memory client. See bindings/python/README.md.
"""

from . import radio
from ._messages import *  # noqa: F401,F403 (the generated protocol: structs and constants)
from ._messages import LAYOUT, Command, Frame, Neighbour, Observation, ObservationHeader
from ._native import ConfigError, SwarmrtError
from ._run import Run, run, sweep, tune

_ROBOT = ("EXIT_SHUTDOWN", "EXIT_TERMINATED", "ProtocolError", "Robot", "main", "run_policy")


def __getattr__(name):
    if name in _ROBOT:
        from . import robot

        return getattr(robot, name)
    raise AttributeError(f"module 'swarmrt' has no attribute {name!r}")


__all__ = [
    "Command",
    "ConfigError",
    "EXIT_SHUTDOWN",
    "EXIT_TERMINATED",
    "Frame",
    "LAYOUT",
    "Neighbour",
    "Observation",
    "ObservationHeader",
    "ProtocolError",
    "Robot",
    "Run",
    "SwarmrtError",
    "main",
    "radio",
    "run",
    "run_policy",
    "sweep",
    "tune",
]
