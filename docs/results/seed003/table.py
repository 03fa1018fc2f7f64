"""Prints one markdown row per run directory: the chain metrics seed003.md quotes.

Usage: python3 table.py LABEL=RUN_DIR ...
"""
import json
import sys

COLS = [
    ("mode", lambda m: m["mode"]),
    ("ticks", lambda m: m["ticks"]),
    ("ticks/s", lambda m: f'{m["ticks_per_second"]:.0f}'),
    ("collisions", lambda m: m["chain"]["collisions"]),
    ("reached", lambda m: f'{m["chain"]["reached"]}/{m["agents"]}'),
    ("tail reached (tick)", lambda m: m["chain"]["tail_reached_tick"]),
    ("rod violations / rod-ticks", lambda m: f'{m["chain"]["rod_violations"]} / {m["chain"]["rod_ticks"]}'),
    ("longest, shortest rod (m)", lambda m: f'{m["chain"]["rod_longest"]:.3f}, {m["chain"]["rod_shortest"]:.3f}'),
    ("angle violations", lambda m: m["chain"]["angle_violations"]),
    ("sharpest angle (deg)", lambda m: f'{m["chain"]["angle_sharpest_deg"]:.0f}'),
    ("vetoes (depth)", lambda m: f'{m["chain"]["vetoes"]} ({m["chain"]["veto_depth"]})'),
    ("propagation ticks (per robot)", lambda m: f'{m["chain"]["propagation_ticks"]} ({m["chain"]["propagation_per_robot"]:.2f})' if m["chain"]["propagation_ticks"] is not None else "-"),
    ("head progress (m)", lambda m: f'{m["chain"]["head_progress"]:.1f}'),
]

print("| run | " + " | ".join(c for c, _ in COLS) + " |")
print("|---|" + "---:|" * len(COLS))
for arg in sys.argv[1:]:
    label, run = arg.rsplit("=", 1)
    m = json.load(open(f"{run}/metrics.json"))
    print(f"| {label} | " + " | ".join(str(f(m)) for _, f in COLS) + " |")
