"""Reads a `swarm export --mcap` file with the PyPI `mcap` package and prints what the
end-to-end test (tests/tests/e2e/export_mcap.rs) checks, as one JSON object:

- channels: topic, schema name, schema encoding, message encoding (in channel id order);
- counts: messages per topic, and the summary's statistics' total;
- metadata: the `swarmrt` metadata record (scenario, seed, dt, ...);
- attachments: attachment names;
- pose: robot ROBOT's transform at tick TICK from `/tf` (time TICK * dt from the metadata),
  with its heading (yaw) recovered from the quaternion;
- robot_entity: robot ROBOT's entity of `/scene/robots` at that tick (id, state, colour);
- events: log messages per level, and the first warning.

Usage: read_mcap.py FILE ROBOT TICK
"""

import json
import math
import sys
from collections import Counter

from mcap.reader import make_reader


def main() -> None:
    path, robot, tick = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    with open(path, "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
        channels = [
            {
                "topic": ch.topic,
                "schema": summary.schemas[ch.schema_id].name,
                "schema_encoding": summary.schemas[ch.schema_id].encoding,
                "message_encoding": ch.message_encoding,
            }
            for _, ch in sorted(summary.channels.items())
        ]
        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        attachments = [a.name for a in reader.iter_attachments()]
        dt_ns = round(float(metadata["swarmrt"]["dt"]) * 1e9)
        want_ns = tick * dt_ns
        frame = f"robot_{robot}"

        counts = Counter()
        levels = Counter()
        first_warning = None
        pose = None
        entity = None
        last_time = -1
        in_order = True
        for _schema, channel, message in reader.iter_messages(log_time_order=False):
            counts[channel.topic] += 1
            if message.log_time < last_time:
                in_order = False
            last_time = message.log_time
            if channel.topic == "/events":
                log = json.loads(message.data)
                levels[str(log["level"])] += 1
                if log["level"] == 3 and first_warning is None:
                    first_warning = log
            elif message.log_time != want_ns:
                continue
            elif channel.topic == "/tf":
                for tf in json.loads(message.data)["transforms"]:
                    if tf["child_frame_id"] == frame:
                        q = tf["rotation"]
                        pose = {
                            "tick": tick,
                            "robot": robot,
                            "log_time_ns": message.log_time,
                            "parent": tf["parent_frame_id"],
                            "x": tf["translation"]["x"],
                            "y": tf["translation"]["y"],
                            "z": tf["translation"]["z"],
                            "yaw": 2.0 * math.atan2(q["z"], q["w"]),
                        }
            elif channel.topic == "/scene/robots":
                for e in json.loads(message.data)["entities"]:
                    if e["id"] == frame:
                        entity = {
                            "id": e["id"],
                            "state": {m["key"]: m["value"] for m in e["metadata"]}["state"],
                            "color": e["cylinders"][0]["color"],
                            "x": e["cylinders"][0]["pose"]["position"]["x"],
                        }

    print(
        json.dumps(
            {
                "profile": header.profile,
                "library": header.library,
                "channels": channels,
                "counts": dict(sorted(counts.items())),
                "statistics_messages": summary.statistics.message_count,
                "in_time_order": in_order,
                "metadata": metadata,
                "attachments": attachments,
                "pose": pose,
                "robot_entity": entity,
                "events": {
                    "levels": dict(sorted(levels.items())),
                    "first_warning": first_warning,
                },
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main()
