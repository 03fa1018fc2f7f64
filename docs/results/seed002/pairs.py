#!/usr/bin/env python3
"""Per run directory given: the planner metrics and, from trajectory.csv, each UAV's flown
path length and the mean and largest distance between UAVs over the flight (the cluster the
potential of eq. 2 is meant to keep). Prints one Markdown row per run."""
import collections, csv, json, math, sys

print("| run | route cost | expansions | min separation (m) | mean pair distance (m) | largest (m) | flown (m, per UAV) | ticks |")
print("|---|---:|---:|---:|---:|---:|---|---:|")
for d in sys.argv[1:]:
    m = json.load(open(f"{d}/metrics.json"))["planner"]
    by = collections.defaultdict(dict)
    for r in csv.DictReader(open(f"{d}/trajectory.csv")):
        by[int(r["tick"])][int(r["id"])] = (float(r["x"]), float(r["y"]), float(r["z"]))
    flown, prev, pairs = collections.Counter(), {}, []
    for t in sorted(by):
        p = by[t]
        ids = sorted(p)
        for i in ids:
            if i in prev:
                flown[i] += math.dist(prev[i], p[i])
            prev[i] = p[i]
        ds = [math.dist(p[a], p[b]) for k, a in enumerate(ids) for b in ids[k + 1:]]
        pairs.append(sum(ds) / len(ds))
    print(f"| {d.rstrip('/').split('/')[-1]} | {m['route_cost']:.2f} | {m['expansions']:.0f} | "
          f"{m['min_separation']:.2f} | {sum(pairs) / len(pairs):.2f} | {max(pairs):.2f} | "
          f"{', '.join(f'{flown[i]:.2f}' for i in sorted(flown))} | {max(by)} |")
