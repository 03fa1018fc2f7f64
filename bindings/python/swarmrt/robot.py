"""The robot side of a swarmrt run, in Python: what runtime/src/robot/shell.rs does for the Rust robot.

The orchestrator starts a robot program with the run's names in its environment
(protocol/src/services.rs, `env`). `Robot.from_env()` opens a node with the run's own iceoryx2
config, opens the four services the world created, makes this robot's ports and says hello;
then `observations()` yields, one per tick, the observation this robot must answer, and the
program answers each with `send()`:

    robot = Robot.from_env()
    for obs in robot.observations():
        cmd = robot.command(obs)      # KIND_ACT for obs.tick: stopped, silent, lidar off
        cmd.v = 0.1
        robot.send(cmd)
    sys.exit(robot.exit_code)         # 0: the world ended the run; 143: SIGTERM/SIGINT

The rules it follows, and why:

* Every sample is copied out (this robot's slot only) and released before the next receive:
  the observation service lets a subscriber borrow one sample at a time, and a held sample
  would make the next `receive` fail.
* Every sample queued is drained after a wake-up; each one is a tick. A tick whose slot says
  FROZEN, RESTARTING or DEAD is skipped (a thawed or fresh process may find one still queued;
  the world expects no answer), a DOWN robot still answers (the world ignores the command).
* A sample with `shutdown != 0` ends the generator with `exit_code` 0; that, and only that,
  is what exit code 0 means to the orchestrator.
* The robot sleeps on the run's tick bell (`_bell.py`, a futex word the world wakes all
  robots with in one call), reading its count before draining so no tick is slept through;
  with a world that has no bell it sleeps in a listener of the observation event instead.
* The wait lasts at most 500 ms: the timeout is a watchdog, not a poll. An interrupted
  wait is a spurious wake (SIGCONT after a scheduled freeze fails the wait with EINTR); only
  SIGTERM/SIGINT ends the generator, with `exit_code` 143. They are noted by a handler of
  this module, not iceoryx2's: that one keeps only the last signal, and the orchestrator
  sends SIGCONT right after SIGTERM, which erased the request.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import tomllib
from typing import Iterator, Optional

import iceoryx2 as iox2

from ._bell import Bell
from ._messages import (
    EVENT_COMMAND,
    KIND_ACT,
    KIND_HELLO,
    PROTOCOL_VERSION,
    STATE_ACTIVE,
    STATE_DOWN,
    Command,
    Observation,
    ObservationHeader,
)

#: How long a robot sleeps before checking for a termination request when no tick comes.
IDLE_CHECK_MS = 500
#: Exit code after SIGTERM/SIGINT (128 + 15, what a shell reports for a SIGTERMed process).
EXIT_TERMINATED = 143
#: Exit code after the world's shutdown sample.
EXIT_SHUTDOWN = 0

_OBS_SIZE = ctypes.sizeof(Observation)


class ProtocolError(RuntimeError):
    """The world speaks another protocol version, or the sample has no slot for this robot."""


def _check_mgmt_segment(prefix: str) -> None:
    """Refuses a run whose iceoryx2 management segment another user could have touched, as
    the Rust robot does (ipc/src/mgmt_segment.rs): the orchestrator makes it 0600 before any
    node exists; iceoryx2 0.10 would otherwise open one that is 0666 or empty, and wait for
    ever on an empty one."""
    import glob
    import stat

    found = glob.glob(f"/dev/shm/{glob.escape(prefix)}*_node.*.global_mgmt")
    if not found:
        raise RuntimeError(
            f"the run's shared-memory segment /dev/shm/{prefix}*_node.*.global_mgmt is missing; "
            "start robots through `swarm run`"
        )
    for path in found:
        st = os.lstat(path)
        why = None
        if not stat.S_ISREG(st.st_mode):
            why = "it is not a regular file"
        elif st.st_uid != os.geteuid():
            why = f"it is owned by uid {st.st_uid}, not by you (uid {os.geteuid()})"
        elif st.st_mode & 0o077:
            why = f"group or others may open it (mode {stat.S_IMODE(st.st_mode):04o})"
        elif st.st_size < 16:
            why = "it is empty"
        if why:
            raise RuntimeError(
                f"refusing the run's shared-memory segment {path}: {why}; another local user "
                "may have planted or changed it (remove the run with `swarm clean` and start "
                "it again)"
            )


def _env(name: str) -> str:
    try:
        return os.environ[name]
    except KeyError:
        raise RuntimeError(
            f"{name} is not set: this program is a swarmrt robot and must be started by "
            "`swarm run` (robots.program in the config)"
        ) from None


_terminated = False
"""Set by SIGTERM or SIGINT once a robot's node exists; never cleared."""


def _on_termination_signal(signum, frame) -> None:
    global _terminated
    _terminated = True


def _note_termination_signals() -> None:
    """Routes SIGTERM and SIGINT to `_terminated`, replacing the handlers iceoryx2 installed
    with the node (it keeps only the last signal, so a SIGCONT after SIGTERM erased the
    request). Python handlers exist only in the main thread; elsewhere iceoryx2's stay."""
    try:
        for s in (signal.SIGTERM, signal.SIGINT):
            signal.signal(s, _on_termination_signal)
    except ValueError:
        pass


class Robot:
    """One robot's ports and identity. Build it with `Robot.from_env()`."""

    def __init__(
        self,
        robot: int,
        incarnation: int,
        slot_offset: int,
        run_id: str,
        config: dict,
        config_path: str,
        storage: str,
        node,
        subscriber,
        listener,
        publisher,
        notifier,
        bell: Optional[Bell] = None,
    ) -> None:
        self.id = robot
        """This robot's id."""
        self.incarnation = incarnation
        """Scheduled restarts of this robot before this process (0 for its first)."""
        self.slot_offset = slot_offset
        """This robot's slot in the observation sample is `id - slot_offset`."""
        self.run_id = run_id
        self.config = config
        """The run's resolved config (every key present, except [ipc] and robots.program*;
        keys whose value is an empty list or no value at all are left out)."""
        self.config_path = config_path
        self.storage = storage
        """A directory for state that must survive a scheduled restart."""
        self.exit_code: Optional[int] = None
        """Set when `observations()` ends: 0 after the world's shutdown, 143 after SIGTERM."""
        self._node = node
        self._subscriber = subscriber
        self._listener = listener
        self._bell = bell
        self._publisher = publisher
        self._notifier = notifier
        self._idle = iox2.Duration.from_millis(IDLE_CHECK_MS)
        self._zero = iox2.Duration.from_millis(0)

    @classmethod
    def from_env(cls, hello: bool = True) -> "Robot":
        """Opens the run's services from the environment the orchestrator set, creates this
        robot's ports and (unless `hello` is False) sends the hello that binds this robot to
        its publisher in the world."""
        robot = int(_env("SWARMRT_ROBOT"))
        config_path = _env("SWARMRT_CONFIG")
        with open(config_path, "rb") as f:
            config = tomllib.load(f)
        # The run's own root directory and shared-memory prefix: without them this node
        # would look for the services in iceoryx2's default location and not find them.
        cfg = iox2.config.from_file(iox2.FilePath.new(_env("SWARMRT_IPC_CONFIG")))
        _check_mgmt_segment(_env("SWARMRT_IPC_PREFIX"))
        node = (
            iox2.NodeBuilder.new()
            .name(iox2.NodeName.new(_env("SWARMRT_NODE_NAME")))
            .config(cfg)
            .create(iox2.ServiceType.Ipc)
        )
        _note_termination_signals()
        obs_name = iox2.ServiceName.new(_env("SWARMRT_OBSERVATIONS"))
        cmd_name = iox2.ServiceName.new(_env("SWARMRT_COMMANDS"))
        # Commands travel in the robot's group service; the world is woken on one event
        # service for the whole run (a world older than the groups used one name for both).
        event_name = iox2.ServiceName.new(
            os.environ.get("SWARMRT_COMMANDS_EVENT") or _env("SWARMRT_COMMANDS")
        )
        observations = (
            node.service_builder(obs_name)
            .publish_subscribe(iox2.Slice[Observation])
            .user_header(ObservationHeader)
            .open()
        )
        observations_event = node.service_builder(obs_name).event().open()
        commands = node.service_builder(cmd_name).publish_subscribe(Command).open()
        commands_event = node.service_builder(event_name).event().open()
        # The bell, else (a world without one) a listener of the observation event: a
        # listener costs the world one notification per tick, the bell nothing.
        try:
            bell: Optional[Bell] = Bell(_env("SWARMRT_IPC_ROOT"))
            listener = None
        except OSError:
            bell = None
            listener = observations_event.listener_builder().create()
        r = cls(
            robot=robot,
            incarnation=int(os.environ.get("SWARMRT_INCARNATION", "0")),
            slot_offset=int(os.environ.get("SWARMRT_SLOT_OFFSET", "0")),
            run_id=_env("SWARMRT_RUN_ID"),
            config=config,
            config_path=config_path,
            storage=os.environ.get("SWARMRT_STORAGE", ""),
            node=node,
            subscriber=observations.subscriber_builder().create(),
            listener=listener,
            publisher=commands.publisher_builder().create(),
            notifier=commands_event.notifier_builder()
            .default_event_id(iox2.EventId.new(EVENT_COMMAND))
            .create(),
            bell=bell,
        )
        if hello:
            r.hello()
        return r

    # --- commands ------------------------------------------------------------------------

    def hello(self) -> None:
        """Says this robot's ports exist: the world binds robot `id` to this publisher."""
        cmd = Command()
        cmd.version = PROTOCOL_VERSION
        cmd.robot = self.id
        cmd.kind = KIND_HELLO
        cmd.pid = os.getpid()
        self.send(cmd)

    def command(self, obs: Observation) -> Command:
        """The answer to `obs` as Rust's `Command::act`: stopped, lidar off, no frames, no
        notes. A DOWN robot sends exactly this."""
        cmd = Command()
        cmd.version = PROTOCOL_VERSION
        cmd.robot = self.id
        cmd.tick = obs.tick
        cmd.kind = KIND_ACT
        return cmd

    def send(self, cmd: Command) -> None:
        """Publishes `cmd` and wakes the world (event `EVENT_COMMAND`)."""
        self._publisher.send_copy(cmd)
        self._notifier.notify()

    # --- the loop ------------------------------------------------------------------------

    def _take(self, sample) -> Optional[Observation]:
        """Copies this robot's slot out of `sample` and releases it. Returns None for the
        world's shutdown (and sets `exit_code`)."""
        try:
            header = sample.user_header().contents
            version, shutdown = int(header.version), int(header.shutdown)
            del header
            if version != PROTOCOL_VERSION:
                raise ProtocolError(
                    f"world speaks protocol {version} but this robot speaks {PROTOCOL_VERSION}"
                )
            if shutdown != 0:
                self.exit_code = EXIT_SHUTDOWN
                return None
            payload = sample.payload()
            slot = self.id - self.slot_offset
            if not 0 <= slot < payload.len():
                raise ProtocolError(f"observation sample has no slot for robot {self.id}")
            obs = Observation()
            ctypes.memmove(ctypes.addressof(obs), payload.as_ptr() + slot * _OBS_SIZE, _OBS_SIZE)
            del payload
            return obs
        finally:
            sample.delete()

    def observations(self) -> Iterator[Observation]:
        """Yields, in tick order, every observation this robot must answer (state ACTIVE or
        DOWN), each a copy the caller may keep. Answer each with `send` before asking for the
        next. Ends when the world shuts the run down (`exit_code` 0) or the process is asked
        to terminate (`exit_code` 143)."""
        while True:
            # Read before draining: a tick published after this read rings past it.
            seen = self._bell.seen() if self._bell is not None else 0
            while True:
                sample = self._subscriber.receive()
                if sample is None:
                    break
                obs = self._take(sample)
                del sample
                if obs is None:
                    return
                if obs.state in (STATE_ACTIVE, STATE_DOWN):
                    yield obs
            try:
                if self._bell is not None:
                    self._bell.wait(seen, IDLE_CHECK_MS)
                else:
                    self._listener.timed_wait(self._idle)
            except iox2.ListenerWaitError as e:
                # A signal interrupted the wait: SIGTERM/SIGINT (checked below) or the
                # SIGCONT ending a scheduled freeze, after which Linux fails it with EINTR.
                if "InterruptSignal" not in str(e):
                    raise
            if _terminated:
                self.exit_code = EXIT_TERMINATED
                return
            try:
                # iceoryx2's own note, for a robot outside the main thread.
                self._node.wait(self._zero)
            except iox2.NodeWaitFailure:
                self.exit_code = EXIT_TERMINATED
                return

    def run(self, step) -> int:
        """Answers every observation with `step(robot, obs) -> Command` and returns the exit
        code; `sys.exit(robot.run(step))` is a whole robot's main loop."""
        for obs in self.observations():
            self.send(step(self, obs))
        return self.exit_code if self.exit_code is not None else 1


def main(step) -> None:
    """`Robot.from_env()`, then `run(step)`, then exit with its code."""
    sys.exit(Robot.from_env().run(step))


def run_policy(policy, *, neighbours: int = 8, inbox: int = 4, payload: int = 0) -> None:
    """This robot process runs `policy`, trained in `swarmrt.env` with the same `neighbours`,
    `inbox` and `payload`: each tick it gets the observation the environment gives it (the
    same numbers, computed by the same native code) and answers with its action, sent as the
    environment applies it. A deterministic policy with the same seed writes the rollout's
    records. `policy(obs) -> (v, omega)`, or a dict of `move`, `say`, `say_len` with a
    payload; then exits with the robot's code.

        # policy_robot.py, run as: swarm run CONFIG --set 'robots.program=["python", "policy_robot.py"]'
        from swarmrt.robot import run_policy
        run_policy(lambda obs: (0.2, 0.0))
    """
    import numpy as np

    from . import _native
    from ._views import arrays

    robot = Robot.from_env()
    lidar = robot.config["robots"]["lidar"]
    layout = (int(lidar.get("rays", 0)), neighbours, inbox, payload)
    for obs in robot.observations():
        view = arrays(_native.features(bytes(obs), *layout, float(lidar["range"])), (), layout)
        action = policy(view)
        if payload:
            move = np.asarray(action["move"], dtype=np.float64)
            say = bytes(np.asarray(action.get("say", b""), dtype=np.uint8).reshape(-1))
            say = say[: int(action.get("say_len", len(say)))]
        else:
            move, say = np.asarray(action, dtype=np.float64), b""
        raw = _native.command(robot.id, obs.tick, float(move[0]), float(move[1]), list(say))
        robot.send(Command.from_buffer_copy(raw))
    sys.exit(robot.exit_code if robot.exit_code is not None else 1)
