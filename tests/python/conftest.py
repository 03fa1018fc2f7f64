"""Shared by the package's tests (run by tests/tests/e2e/python_package.rs with the venv's
Python, from a directory outside the source tree): where the configs are, and the
installed binaries."""

import os
import sys
from pathlib import Path

import pytest

WORKSPACE = Path(os.environ["SWARMRT_WORKSPACE"])
CONFIGS = WORKSPACE / "configs"
SWARM = Path(sys.executable).parent / "swarm"


@pytest.fixture
def configs() -> Path:
    return CONFIGS
