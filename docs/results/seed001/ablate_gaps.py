#!/usr/bin/env python3
"""The ablation table of docs/results/seed001.md from the sweeps ablate_gaps.sh ran: per
variant and group, t_nav, d_m and ΔΩ over 5 seeds with ours/paper (Tables II, III's S31, IV)."""
import csv
import glob
import json
import math
import os
import sys
from statistics import mean

from runs import avg, group_of

OUT = sys.argv[1]
SIZES = {"s2": [4, 4, 3], "s3": [4, 4, 3], "s4": [3, 3, 3]}
# The paper's t_s, d_m, ΔΩ, exploration per group (Table II for S2, Table III's S31 for S3).
PAPER = {
    "s2": [(28.01, 12.7, 44.69, 12.99), (16.64, 9.1, 29.22, 0.68), (26.4, 11.87, 22.45, 14.32)],
    "s3": [(71.06, 33.21, 17.18, None), (68.12, 32.7, 13.75, None), (71.48, 33.39, 10.37, None)],
    "s4": [(131.0, 58.9, 22.69, None), (184.0, 81.2, 59.22, None), (223.0, 102.7, 67.45, None)],
}
VARIANTS = [
    ("base", "the committed config"),
    ("speed0.45", "behaviour.group_speed 0.35 -> 0.45 m/s"),
    ("turnacc10", "behaviour.turn_accel 3 -> 10 rad/s²"),
    ("turnacc1", "behaviour.turn_accel 3 -> 1 rad/s²"),
    ("radius", "behaviour.radius 1.0 -> 1.5 m (S2), 1.8 -> 1.0 m (S3)"),
    ("rep0.4", "behaviour.rep_range 0.7 -> 0.4 m"),
    ("lidar2.5", "range finder and range-and-bearing 4 -> 2.5 m"),
    ("noshare", "behaviour.share_goal false: each leader must see the goal itself"),
    ("side", "groups start side by side at x = 16 m (33-34 m from their goals)"),
    ("side-speed0.45", "side by side and group_speed 0.45 m/s"),
    ("goalsinline", "groups 2 and 3 aim at y = 8 and 12 m, inside the corridor (not 4.5 and 15.5)"),
    ("detour", "behaviour.leader_nav map -> detour (S1-S3's leader: no map)"),
    ("nopockets", "S4 without the caps of group 1's two dead-end pockets"),
    ("loss0.4", "radio.loss 0 -> 0.4"),
    ("delay5", "radio.delay_ticks 0 -> 5"),
]




def cell(ours, paper):
    if ours is None:
        return "-"
    if paper is None:
        return f"{ours:.1f}"
    return f"{ours:.1f} ({ours / paper:.2f})"


for sc, title in [("s2", "S2 (Table II)"), ("s3", "S31 (Table III)"), ("s4", "S4 (Table IV)")]:
    print(f"\n{title}: each cell ours (ours/paper), mean of 5 seeds, in-process\n")
    keys = ["t_nav", "d_m", "delta_omega"] + (["explore_time"] if sc == "s2" else [])
    names = ["t_nav", "d_m", "ΔΩ", "explore"][: len(keys)]
    print("| variant | change | " + " | ".join(f"G{g} {n}" for n in names for g in (1, 2, 3))
          + " | reached | collisions |")
    print("|---|---|" + "---|" * (3 * len(keys) + 2))
    for v, change in VARIANTS:
        paths = sorted(glob.glob(os.path.join(OUT, f"{sc}-{v}", "runs", "*", "metrics.json")))
        if not paths:
            continue
        rows = {}
        reached = robots = coll = 0
        for p in paths:
            with open(p) as f:
                m = json.load(f)
            reached += m["grouping"]["reached"]
            robots += m["agents"]
            coll += m["collisions"]
            for g in m["grouping"]["per_group"]:
                rows.setdefault(group_of(g["leader"], SIZES[sc]), []).append(g)
        cells = []
        for i, key in enumerate(keys):
            for g in range(3):
                cells.append(cell(avg([x[key] for x in rows.get(g, [])]), PAPER[sc][g][i]))
        print(f"| {v} | {change} | " + " | ".join(cells) + f" | {reached}/{robots} | {coll} |")

print("\nTable III's first group as it grows (S31-S33): its ΔΩ in deg/s² (ours/paper), 5 seeds, "
      "in-process\n")
G1 = {11: (4, 17.18), 12: (5, 22.4), 13: (6, 29.6)}
print("| variant | G1 of 4 | G1 of 5 | G1 of 6 | G1 of 6 / G1 of 4 (paper 1.72) |")
print("|---|---|---|---|---|")
for v in ["base", "turnacc10", "rep0.4", "speed0.45"]:
    vals = []
    for n, (size, paper) in G1.items():
        dos = []
        for p in sorted(glob.glob(os.path.join(OUT, f"g1-{n}-{v}", "runs", "*", "metrics.json"))):
            with open(p) as f:
                m = json.load(f)
            dos += [g["delta_omega"] for g in m["grouping"]["per_group"] if g["leader"] < size]
        vals.append((avg(dos), paper))
    grow = f"{vals[2][0] / vals[0][0]:.2f}" if vals[0][0] and vals[2][0] else "-"
    print(f"| {v} | " + " | ".join(cell(o, p) for o, p in vals) + f" | {grow} |")

# S2's finder: the smallest explore time of each run (the leader that saw the goal itself).
finder = []
for p in sorted(glob.glob(os.path.join(OUT, "s2-base", "runs", "*", "metrics.json"))):
    with open(p) as f:
        m = json.load(f)
    finder.append(min(g["explore_time"] for g in m["grouping"]["per_group"]))
print("\nS2 (base): the finder's explore time per seed (s): "
      + ", ".join(f"{x:.1f}" for x in finder))


def delta_omega(headings, dt):
    """Eq. 16 as metrics.rs computes it: mean |Ω(i) - Ω(i-1)| / dt, deg/s²."""
    wrap = lambda a: (a + math.pi) % (2 * math.pi) - math.pi
    om = [wrap(b - a) / dt for a, b in zip(headings, headings[1:])]
    if len(om) < 2:
        return None
    return math.degrees(sum(abs(b - a) / dt for a, b in zip(om, om[1:])) / (len(om) - 1))


def navigations(sc):
    """Per robot of the base runs of `sc` that reached the goal: its group, its active rows
    (tick, heading, x), the tick of its leader's first formation and the tick it arrived."""
    dt = 0.1
    for p in sorted(glob.glob(os.path.join(OUT, f"{sc}-base", "runs", "*", "metrics.json"))):
        with open(p) as f:
            m = json.load(f)
        rows = {}
        with open(os.path.join(os.path.dirname(p), "trajectory.csv")) as f:
            for row in csv.DictReader(f):
                if row["state"] == "active":
                    rows.setdefault(int(row["id"]), []).append(
                        (int(row["tick"]), float(row["theta"]), float(row["x"])))
        for r in m["grouping"]["per_robot"]:
            if r["t_s"] is None or r["t_nav"] is None:
                continue
            start, end = round((r["t_s"] - r["t_nav"]) / dt), round(r["t_s"] / dt)
            yield group_of(r["leader"], SIZES[sc]), rows[r["id"]], start, end


def phase_table(sc, parts):
    """Per group, the mean over robots of ΔΩ over each part ((tick, x, start, end) -> kept)."""
    by_group = {}
    for g, rows, start, end in navigations(sc):
        by_group.setdefault(g, []).append([
            delta_omega([t for k, t, x in rows if keep(k, x, start, end)], 0.1)
            for keep in parts])
    for g in range(3):
        cols = [avg([x[i] for x in by_group.get(g, [])]) for i in range(len(parts))]
        print(f"| G{g + 1} | " + " | ".join(f"{c:.1f}" if c is not None else "-" for c in cols)
              + f" | {PAPER[sc][g][2]} |")


# S4 (base): where group 1's ΔΩ comes from. Each robot's headings until it reached the goal,
# split at its leader's first formation (t_s - t_nav): grouping, leader choice and forming
# before, the maze after.
print("\nS4 (base): ΔΩ (deg/s²) per group before and after the first formation, 5 seeds\n")
print("| group | whole run | grouping and forming | navigating | paper |")
print("|---|---|---|---|---|")
phase_table("s4", [lambda k, x, s, e: k <= e, lambda k, x, s, e: k <= s,
                   lambda k, x, s, e: s <= k <= e])

# S3 (base): where groups 2 and 3 turn. Each robot's headings while navigating (from its
# leader's first formation until it reached the goal), split by its x: before the corridor
# (x < 21 m) and in it (21-41 m).
print("\nS31 (base): ΔΩ (deg/s²) per group while navigating, before and in the corridor, 5 seeds\n")
print("| group | before the corridor | in the corridor | paper (whole run) |")
print("|---|---|---|---|")
phase_table("s3", [lambda k, x, s, e: s <= k <= e and x < 21.0,
                   lambda k, x, s, e: s <= k <= e and 21.0 <= x <= 41.0])
