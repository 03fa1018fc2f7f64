"""Where the `swarm` binary is: the one this package installed into the environment's
`bin/`, else `SWARMRT_BIN_DIR`, else `PATH`."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path


def binary(name: str = "swarm") -> str:
    """The path of `name` (`swarm`, `swarm-world`, ...); FileNotFoundError saying where it
    looked when there is none."""
    places = []
    given = os.environ.get("SWARMRT_BIN_DIR")
    if given:
        places.append(Path(given))
    places.append(Path(sys.executable).parent)
    for place in places:
        candidate = place / name
        if candidate.is_file() and os.access(candidate, os.X_OK):
            return str(candidate)
    found = shutil.which(name)
    if found:
        return found
    raise FileNotFoundError(
        f"no {name} in {', '.join(map(str, places))} or on PATH: install the swarmrt wheel "
        "(pip install ./bindings/python) or set SWARMRT_BIN_DIR to a directory of built binaries"
    )
