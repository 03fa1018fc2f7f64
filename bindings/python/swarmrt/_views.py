"""A batch of robots' views as numpy arrays, from the native module's flat bytes (one array
per field, robot after robot). The environment and a policy deployed as a robot process both
read their views through `arrays`, so a policy gets the same numbers in both."""

from __future__ import annotations

import numpy as np

#: Each field of a view: its dtype and its shape for one robot, given the layout
#: (rays, neighbours, inbox frames, payload bytes).
FIELDS = {
    "pose": (np.float32, lambda r, k, m, p: (3,)),
    "goal": (np.float32, lambda r, k, m, p: (3,)),
    "lidar": (np.float32, lambda r, k, m, p: (r,)),
    "neighbours": (np.float32, lambda r, k, m, p: (k, 2)),
    "neighbours_mask": (np.uint8, lambda r, k, m, p: (k,)),
    "inbox": (np.uint8, lambda r, k, m, p: (m, p)),
    "inbox_meta": (np.int32, lambda r, k, m, p: (m, 2)),
    "inbox_mask": (np.uint8, lambda r, k, m, p: (m,)),
}


def arrays(raw: dict, batch: tuple, layout: tuple) -> dict:
    """The fields of `raw` (bytes) as arrays of shape `batch + field shape`."""
    out = {}
    for name, (dtype, shape) in FIELDS.items():
        out[name] = np.frombuffer(raw[name], dtype=dtype).reshape(batch + shape(*layout))
    return out
