"""Prints, per run, the ticks between the initiator's first move and robot k's, for a few k
along the chain, and the ticks per robot (a least-squares slope over every robot that moved).

Usage: python3 wave.py LABEL=RUN_DIR ...   (reads each run's chain_propagation.csv)
"""
import csv
import sys

ROBOTS = [1, 10, 50, 100, 200, 300, 450]

print("| run | " + " | ".join(f"robot {k}" for k in ROBOTS) + " | ticks per robot |")
print("|---|" + "---:|" * (len(ROBOTS) + 1))
for arg in sys.argv[1:]:
    label, run = arg.rsplit("=", 1)
    rows = list(csv.DictReader(open(f"{run}/chain_propagation.csv")))
    first = {int(float(r["robot"])): int(float(r["first_move_tick"])) for r in rows}
    t0 = first[0]
    cells = [str(first[k] - t0) if k in first else "-" for k in ROBOTS]
    pts = [(k, t - t0) for k, t in first.items() if k > 0]
    n = len(pts)
    mx = sum(k for k, _ in pts) / n
    my = sum(t for _, t in pts) / n
    slope = sum((k - mx) * (t - my) for k, t in pts) / sum((k - mx) ** 2 for k, _ in pts)
    print(f"| {label} | " + " | ".join(cells) + f" | {slope:.2f} |")
