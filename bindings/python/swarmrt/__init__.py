"""swarmrt robots in Python: the shared-memory messages, the robot runtime and radio helpers.

* `swarmrt._messages` (re-exported here): ctypes mirrors of the Rust messages and every
  protocol constant, GENERATED from protocol/src/layout.rs, so the layout cannot drift.
* `swarmrt.robot`: `Robot.from_env()` joins the run the orchestrator started this process
  for; `Robot.observations()` yields the ticks to answer; `Robot.send()` answers.
* `swarmrt.radio`: postcard encoding of the Rust robots' radio messages, and opaque frames;
  its wire tags (`radio.GOTO`, ..., `radio.CONSENSUS`) come from `swarmrt._tags`, GENERATED
  from the agent's behaviour registry (agent/src/wire.rs), so they cannot drift either.

See bindings/python/README.md and examples/python/.
"""

from . import radio
from ._messages import *  # noqa: F401,F403 (the generated protocol: structs and constants)
from ._messages import LAYOUT, Command, Frame, Neighbour, Observation, ObservationHeader
from .robot import EXIT_SHUTDOWN, EXIT_TERMINATED, ProtocolError, Robot, main

__all__ = [
    "Command",
    "EXIT_SHUTDOWN",
    "EXIT_TERMINATED",
    "Frame",
    "LAYOUT",
    "Neighbour",
    "Observation",
    "ObservationHeader",
    "ProtocolError",
    "Robot",
    "main",
    "radio",
]
