"""The package's PEP 517 backend: maturin, after the CLI binaries are put where the wheel's
scripts come from.

maturin builds the native module (`swarmrt._native`) but not the workspace's other
binaries, and a venv with no Rust must still run `swarm run` with robot processes. So before
maturin packs the wheel this builds `swarm`, `swarm-world`, `swarm-agent` and `swarm-host` with
cargo (release, or the profile `SWARMRT_WHEEL_PROFILE` names) and copies them to
`swarmrt.data/scripts/`, which maturin installs into the venv's `bin/`, side by side as
`swarm` expects them. `SWARMRT_WHEEL_BINARIES=<dir>` takes them from a directory already
built instead (the tests pass their own build: no second build of the workspace).
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import maturin
from maturin import (  # noqa: F401 (the hooks pip calls, maturin's own)
    build_sdist,
    get_requires_for_build_sdist,
    get_requires_for_build_wheel,
)

BINARIES = ("swarm", "swarm-world", "swarm-agent", "swarm-host")
HERE = Path(__file__).resolve().parent.parent
WORKSPACE = HERE.parent.parent
SCRIPTS = HERE / "swarmrt.data" / "scripts"


def _profile() -> str:
    return os.environ.get("SWARMRT_WHEEL_PROFILE", "release")


def _binaries_dir() -> Path:
    given = os.environ.get("SWARMRT_WHEEL_BINARIES")
    if given:
        return Path(given)
    profile = _profile()
    subprocess.run(
        ["cargo", "build", "--locked", "--profile", profile,
         "-p", "swarmrt-orchestrator", "-p", "swarmrt-bins"],
        cwd=WORKSPACE, check=True,
    )
    target = Path(os.environ.get("CARGO_TARGET_DIR", WORKSPACE / "target"))
    return target / ("debug" if profile == "dev" else profile)


def _stage_binaries() -> None:
    source = _binaries_dir()
    shutil.rmtree(SCRIPTS, ignore_errors=True)
    SCRIPTS.mkdir(parents=True)
    for name in BINARIES:
        built = source / name
        if not built.is_file():
            raise RuntimeError(f"{built} is missing: build the workspace first")
        shutil.copy2(built, SCRIPTS / name)


def _args(config_settings):
    """maturin's profile follows ours, unless the caller chose one."""
    settings = dict(config_settings or {})
    extra = os.environ.get("MATURIN_PEP517_ARGS", "")
    if "--profile" not in extra and "--release" not in extra:
        os.environ["MATURIN_PEP517_ARGS"] = f"{extra} --profile {_profile()}".strip()
    return settings


def _unstage() -> None:
    """The copies go once the wheel holds them; the (ignored) empty directory stays, as
    maturin wants it to exist when it writes the metadata."""
    shutil.rmtree(SCRIPTS, ignore_errors=True)
    SCRIPTS.mkdir(parents=True, exist_ok=True)


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    SCRIPTS.mkdir(parents=True, exist_ok=True)
    return maturin.prepare_metadata_for_build_wheel(metadata_directory, _args(config_settings))


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    _stage_binaries()
    try:
        return maturin.build_wheel(wheel_directory, _args(config_settings), metadata_directory)
    finally:
        _unstage()


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    _stage_binaries()
    try:
        return maturin.build_editable(wheel_directory, _args(config_settings), metadata_directory)
    finally:
        _unstage()
