#!/usr/bin/env python3
"""domega.md from the sweeps domega.sh ran (issue 35, part 1): why S3's first group keeps its
ΔΩ (eq. 16) as it grows from 4 to 6 robots while Table III's grows 1.72x. Stdlib only.

ΔΩ is recomputed here from trajectory.csv exactly as metrics.rs `delta_omega` does (true
headings every dt, active rows up to the robot's `reached` tick; checked against metrics.json),
then split by robot role (leader, members) and by phase: forming (before the leader's first
`formed` note), approach (x < 21 m), corridor (21-41 m) and exit (x > 41 m). Also writes
$OUT/domega_robots.csv (one line per robot and run) and $OUT/domega.json (the table cells)."""
import csv
import glob
import json
import math
import os
import sys
from statistics import mean, stdev

from runs import avg, group_of

OUT = sys.argv[1]
DT = 0.1
CORRIDOR = (21.0, 41.0)  # configs/grouping_s3.toml: the walls span x = 21-41 m
PHASES = ["forming", "approach", "corridor", "exit"]
SIZES = [4, 5, 6]
# Table III's ΔΩ (deg/s²) per sub-scenario S31-S33 and group G1-G3 (sizes [n, 4, 3]).
PAPER_S3 = {4: [17.18, 13.75, 10.37], 5: [22.4, 12.9, 9.96], 6: [29.6, 13.07, 9.88]}
PAPER_S1 = {4: 15.87, 5: 24.57, 6: 18.28, 7: 22.34, 8: 18.85}  # Table I
PAPER_S2 = [(4, 44.69), (4, 29.22), (3, 22.45)]  # Table II: (robots, ΔΩ) per group
PAPER_S4 = [(3, 22.69), (3, 59.22), (3, 67.45)]  # Table IV
ROWS = [
    ("base", "the committed config (circle 1.8 m, rho_0 0.7 m, k_att 1, k_turn 3, turn_accel 3)"),
    ("radius-scaled", "behaviour.radius 1.8 / 2.25 / 2.7 m: neighbours stay 2.55 m apart"),
    ("radius1.0", "behaviour.radius 1.0 m: neighbours 1.41 / 1.18 / 1.0 m apart"),
    ("rep0.4", "behaviour.rep_range 0.4 m"),
    ("rep1.5", "behaviour.rep_range 1.5 m"),
    ("rep2.0", "behaviour.rep_range 2.0 m (reaches the neighbours on the circle from 5 robots on)"),
    ("radius1.0-rep1.5", "behaviour.radius 1.0 m and rep_range 1.5 m"),
    ("radius1.2", "behaviour.radius 1.2 m: neighbours 1.70 / 1.41 / 1.2 m apart"),
    ("krep0.1", "behaviour.k_rep 0.1 (5x)"),
    ("rep2.0-krep0.1", "behaviour.rep_range 2.0 m and k_rep 0.1"),
    ("katt0.5", "behaviour.k_att 0.5"),
    ("katt2", "behaviour.k_att 2"),
    ("kturn1.5", "behaviour.k_turn 1.5"),
    ("kturn6", "behaviour.k_turn 6"),
    ("turnacc-raw", "behaviour.turn_accel 1e6 rad/s² (no limit: raw turn rate)"),
    ("turnacc1", "behaviour.turn_accel 1 rad/s²"),
    ("lidar0.05", "robots.noise.lidar 0.05 m"),
    ("heading0.05", "robots.noise.heading 0.05 rad"),
    ("slip0.05", "robots.noise.wheel_slip 0.05"),
    ("speed0.45", "behaviour.group_speed 0.45 m/s"),
]


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi




def fmt(v, d=1):
    return "-" if v is None else f"{v:.{d}f}"


def ratio(a, b):
    return "-" if a is None or not b else f"{a / b:.2f}"


def growth_se(c4, c6):
    """The 6/4 ratio of group 1's mean ΔΩ and its standard error (independent runs)."""
    r = c6["g1"] / c4["g1"]
    rel = [c["g1_sd"] / (c["g1"] * math.sqrt(c["groups"])) for c in (c4, c6)]
    return r, r * math.hypot(*rel)


def run_dirs(name):
    return sorted(glob.glob(os.path.join(OUT, name, "runs", "*", "metrics.json")))


def analyse(mpath):
    """Per robot of one run: its leader, ΔΩ overall and per phase (sum, samples), and the
    share of navigation ticks it spent closer than 1 m to another robot of its group."""
    d = os.path.dirname(mpath)
    with open(mpath) as f:
        m = json.load(f)
    robots = {r["id"]: r for r in m["grouping"]["per_robot"]}
    reached, formed = {}, {}
    with open(os.path.join(d, "events.jsonl")) as f:
        for line in f:
            e = json.loads(line)
            if e.get("event") == "reached":
                reached.setdefault(e["robot"], e["tick"])
            elif e.get("event") == "note" and isinstance(e["note"], dict) and "formed" in e["note"]:
                formed.setdefault(e["robot"], e["tick"])
    rows = {}
    pos = {}
    with open(os.path.join(d, "trajectory.csv")) as f:
        for r in csv.DictReader(f):
            i, t = int(r["id"]), int(r["tick"])
            if i in reached and t > reached[i]:
                continue
            x, y = float(r["x"]), float(r["y"])
            pos.setdefault(t, {})[i] = (x, y)
            if r["state"] == "active":
                rows.setdefault(i, []).append((t, x, float(r["theta"])))
    out = {}
    for i, rob in robots.items():
        ld = rob["leader"]
        f_tick = formed.get(ld) if ld is not None else None
        seq = rows.get(i, [])
        om = [wrap(seq[k][2] - seq[k - 1][2]) / DT for k in range(1, len(seq))]
        acc = {p: [0.0, 0] for p in PHASES}
        total = 0.0
        for k in range(1, len(om)):
            a = abs(om[k] - om[k - 1]) / DT
            total += a
            t, x, _ = seq[k]  # the middle heading of the three this sample uses
            if f_tick is None or t < f_tick:
                p = "forming"
            elif x < CORRIDOR[0]:
                p = "approach"
            elif x <= CORRIDOR[1]:
                p = "corridor"
            else:
                p = "exit"
            acc[p][0] += a
            acc[p][1] += 1
        n = max(len(om) - 1, 0)
        do_all = math.degrees(total / n) if n else 0.0
        assert abs(do_all - rob["delta_omega"]) < 1e-6 * max(1.0, do_all), (mpath, i)
        nav_n = sum(acc[p][1] for p in PHASES[1:])
        nav = math.degrees(sum(acc[p][0] for p in PHASES[1:]) / nav_n) if nav_n else None
        # Closeness to the own group during navigation.
        mates = [j for j, r in robots.items() if r["leader"] == ld and j != i]
        close = ticks = 0
        for t, _, _ in seq:
            if f_tick is None or t < f_tick:
                continue
            here = pos[t].get(i)
            others = [pos[t][j] for j in mates if j in pos[t]]
            if here is None or not others:
                continue
            ticks += 1
            dmin = min(math.hypot(here[0] - o[0], here[1] - o[1]) for o in others)
            close += dmin < 1.0
        out[i] = {
            "leader": ld,
            "is_leader": ld == i,
            "delta_omega": do_all,
            "nav": nav,
            "close1m": close / ticks if ticks else None,
            "reached": i in reached,
            **{p: (math.degrees(acc[p][0] / acc[p][1]) if acc[p][1] else None) for p in PHASES},
            **{f"n_{p}": acc[p][1] for p in PHASES},
        }
    return m, out


# ---- S3 rows -------------------------------------------------------------------------------
csv_rows = []
cells = {}  # (row, size) -> aggregates of group 1
s3_all = {}  # size -> group -> list of (mean, sum) per run, base row only
for label, _ in ROWS:
    for size in SIZES:
        sizes = [size, 4, 3]
        agg = {k: [] for k in ["g1", "g1_sum", "leader", "members", "nav", "nav_members", "close"]
               + PHASES + [f"share_{p}" for p in PHASES]}
        reached = robots = coll = 0
        for mpath in run_dirs(f"{label}-g{size}"):
            m, per = analyse(mpath)
            seed = os.path.basename(os.path.dirname(mpath)).rsplit("_s", 1)[1]
            reached += m["grouping"]["reached"]
            robots += m["agents"]
            coll += m["collisions"]
            for g in m["grouping"]["per_group"]:
                gi = group_of(g["leader"], sizes)
                mem = [r for r in per.values() if r["leader"] == g["leader"]]
                if label == "base":
                    s3_all.setdefault(size, {}).setdefault(gi, []).append(
                        (g["delta_omega"], sum(r["delta_omega"] for r in mem), len(mem)))
                if gi != 0:
                    continue
                agg["g1"].append(g["delta_omega"])
                agg["g1_sum"].append(sum(r["delta_omega"] for r in mem))
                agg["leader"] += [r["delta_omega"] for r in mem if r["is_leader"]]
                agg["members"] += [r["delta_omega"] for r in mem if not r["is_leader"]]
                agg["nav"] += [r["nav"] for r in mem]
                agg["nav_members"] += [r["nav"] for r in mem if not r["is_leader"]]
                agg["close"] += [r["close1m"] for r in mem]
                for p in PHASES:
                    agg[p] += [r[p] for r in mem]
                    tot = [sum(r[f"n_{q}"] for q in PHASES) for r in mem]
                    agg[f"share_{p}"] += [r[f"n_{p}"] / t for r, t in zip(mem, tot) if t]
            for i, r in sorted(per.items()):
                csv_rows.append({"row": label, "g1_size": size, "seed": seed, "robot": i,
                                 "group": group_of(r["leader"], sizes) + 1 if r["leader"] is not None else "",
                                 **{k: (f"{v:.4f}" if isinstance(v, float) else v) for k, v in r.items()}})
        cell = {k: avg(v) for k, v in agg.items()}
        cell.update(reached=reached, robots=robots, collisions=coll, groups=len(agg["g1"]),
                    g1_sd=stdev(agg["g1"]) if len(agg["g1"]) > 1 else None)
        cells[(label, size)] = cell

with open(os.path.join(OUT, "domega_robots.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(csv_rows[0].keys()))
    w.writeheader()
    w.writerows(csv_rows)
with open(os.path.join(OUT, "domega.json"), "w") as f:
    json.dump({f"{k[0]}/g1={k[1]}": v for k, v in cells.items()}, f, indent=1, sort_keys=True)

P = PAPER_S3
print("# Seed 001, S3: why group 1's ΔΩ does not grow with its size (issue 35, part 1)\n")
print("Regenerate from the repository root after `cargo build --release`: "
      "`bash docs/results/seed001/domega.sh` (about 2 min on one core; runs the sweeps into $OUT, "
      "default /tmp/seed001_domega, then `domega.py` writes this file). The rows base, rep0.4 and "
      "speed0.45 give the numbers of ablation.md's last table to the digit. Every "
      "row: S31, S32, S33 (group 1 of 4, 5, 6 robots; groups 2-3 of 4 and 3), seeds 1-5, "
      "in-process, one config key changed with `--set`. ΔΩ as metrics.rs computes it (eq. 16 "
      "per robot, then the group's mean), recomputed from trajectory.csv and checked against "
      "metrics.json. Cells: ours (ours/paper); paper = Table III (17.18, 22.4, 29.6 deg/s²).\n")
print("## 1. Group 1's ΔΩ (deg/s²) as it grows, one knob per row\n")
print("| row | change | G1 of 4 | G1 of 5 | G1 of 6 | 6/4 (paper 1.72) ± s.e. | members only, 6/4 "
      "| navigation only, 6/4 | reached | collisions |")
print("|---|---|---|---|---|---|---|---|---|---|")
for label, change in ROWS:
    c = [cells[(label, s)] for s in SIZES]
    print(f"| {label} | {change} | "
          + " | ".join(f"{fmt(x['g1'])} ({ratio(x['g1'], P[s][0])})" for x, s in zip(c, SIZES))
          + " | **{:.2f}** ± {:.2f}".format(*growth_se(c[0], c[2]))
          + f" | {ratio(c[2]['members'], c[0]['members'])} "
          f"| {ratio(c[2]['nav'], c[0]['nav'])} "
          f"| {sum(x['reached'] for x in c)}/{sum(x['robots'] for x in c)} "
          f"| {sum(x['collisions'] for x in c)} |")
growth = [(label, cells[(label, 6)]["g1"] / cells[(label, 4)]["g1"]) for label, _ in ROWS]
lo, hi = min(growth, key=lambda x: x[1]), max(growth, key=lambda x: x[1])
print(f"\nGrowth from 4 to 6 robots over all {len(ROWS)} rows: {lo[1]:.2f} ({lo[0]}) to "
      f"{hi[1]:.2f} ({hi[0]}); the paper's 1.72 is outside this range.\n")

print("## 2. Leader and members, and the share of time near a group mate (base and the "
      "repulsion rows)\n")
print("ΔΩ per robot (deg/s²), means over the robots of group 1 in 5 runs; `close` = share of "
      "its navigation ticks with another robot of its group nearer than 1 m.\n")
print("Leader and members pool the robots; the group mean averages the groups whose leader "
      "started in group 1 (`groups` of them in 5 runs: more than 5 when a group split), each "
      "group equally, so it can fall outside the two when start groups merged under one leader "
      "(rep2.0-krep0.1, 6 robots, seed 4: 10 robots).\n")
print("| row | G1 size | leader | members | group mean | group mean / leader | close < 1 m | groups |")
print("|---|---|---|---|---|---|---|---|")
for label in ["base", "radius1.2", "radius1.0", "radius1.0-rep1.5", "rep2.0", "krep0.1",
              "rep2.0-krep0.1", "turnacc-raw"]:
    for s in SIZES:
        c = cells[(label, s)]
        print(f"| {label} | {s} | {fmt(c['leader'])} | {fmt(c['members'])} | {fmt(c['g1'])} "
              f"| {ratio(c['g1'], c['leader'])} | {fmt(100 * c['close'], 0) + ' %' if c['close'] is not None else '-'} "
              f"| {c['groups']} |")

print("\n## 3. Phases: ΔΩ per robot of group 1 in each phase, deg/s² (share of its samples)\n")
print("forming = before its leader's first `formed` note (grouping, leader choice, forming); "
      "then by the robot's x: approach < 21 m, corridor 21-41 m, exit > 41 m (until it "
      "reaches the goal).\n")
print("| row | G1 size | " + " | ".join(PHASES) + " | navigation (all but forming) | whole run |")
print("|---|---|---|---|---|---|---|---|")
for label in ["base", "radius1.0-rep1.5", "rep2.0-krep0.1"]:
    for s in SIZES:
        c = cells[(label, s)]
        print(f"| {label} | {s} | "
              + " | ".join(f"{fmt(c[p])} ({100 * c['share_' + p]:.0f} %)" for p in PHASES)
              + f" | {fmt(c['nav'])} | {fmt(c['g1'])} |")
    c4, c6 = cells[(label, 4)], cells[(label, 6)]
    print(f"| {label} | 6/4 | " + " | ".join(ratio(c6[p], c4[p]) if c4[p] and c4[p] >= 0.5
                                            else "- (from ~0)" for p in PHASES)
          + f" | {ratio(c6['nav'], c4['nav'])} | {ratio(c6['g1'], c4['g1'])} |")

# ---- Eq. 16 read as a mean (metrics.rs) and as a sum over the group ------------------------
print("\n## 4. Eq. 16 read as a per-robot mean (ours) and as a sum over the group's robots\n")
print("Eq. 16 is written for one robot (\"the average change in angular velocity ... during the "
      "robot's navigation\"), and section 3.2.1 says \"the average was determined for each "
      "robot\"; metrics.rs takes the robots' mean per group. Read as a sum over the group, our "
      "value becomes N x mean, and the paper's per-robot value becomes paper / N.\n")
print("### 4a. The paper's own tables under both readings\n")
print("| table | row | robots N | printed ΔΩ | printed / N (per robot if a sum) |")
print("|---|---|---|---|---|")
for n, v in PAPER_S1.items():
    print(f"| I (S1) | {n} robots | {n} | {v} | {v / n:.2f} |")
for g, (n, v) in enumerate(PAPER_S2):
    print(f"| II (S2) | G{g + 1} | {n} | {v} | {v / n:.2f} |")
for s in SIZES:
    for g, n in enumerate([s, 4, 3]):
        print(f"| III (S3{s - 3}) | G{g + 1} | {n} | {P[s][g]} | {P[s][g] / n:.2f} |")
for g, (n, v) in enumerate(PAPER_S4):
    print(f"| IV (S4) | G{g + 1} | {n} | {v} | {v / n:.2f} |")
print(f"\nTable III, G1 from 4 to 6: printed {P[6][0] / P[4][0]:.2f}x, per robot if a sum "
      f"{(P[6][0] / 6) / (P[4][0] / 4):.2f}x. G3 (3 robots) / G2 (4 robots): printed "
      + ", ".join(f"{P[s][2] / P[s][1]:.2f}" for s in SIZES)
      + " (S31-S33; 3/4 = 0.75), per robot if a sum "
      + ", ".join(f"{(P[s][2] / 3) / (P[s][1] / 4):.2f}" for s in SIZES)
      + f". Table I from 4 to 8: printed {PAPER_S1[8] / PAPER_S1[4]:.2f}x, per robot if a sum "
      f"{(PAPER_S1[8] / 8) / (PAPER_S1[4] / 4):.2f}x.\n")


def s1_rows():
    rows = {}
    for mpath in run_dirs("s1"):
        with open(mpath) as f:
            m = json.load(f)
        n = m["agents"]
        pr = m["grouping"]["per_robot"]
        rows.setdefault(n, []).append((mean(r["delta_omega"] for r in pr),
                                       sum(r["delta_omega"] for r in pr)))
    return rows


print("### 4b. Ours under both readings (base configs, 5 seeds)\n")
print("| scenario | group | N | ours mean (metrics.rs) | paper | ratio | ours sum (N x mean) "
      "| ratio to paper |")
print("|---|---|---|---|---|---|---|---|")
RAT_MEAN, RAT_SUM = [], []
s1 = s1_rows()
for n in sorted(s1):
    mn, sm = avg(x[0] for x in s1[n]), avg(x[1] for x in s1[n])
    RAT_MEAN.append(mn / PAPER_S1[n])
    RAT_SUM.append(sm / PAPER_S1[n])
    print(f"| S1 | all | {n} | {fmt(mn)} | {PAPER_S1[n]} | {ratio(mn, PAPER_S1[n])} | {fmt(sm)} "
          f"| {ratio(sm, PAPER_S1[n])} |")
s2 = {}
for mpath in run_dirs("s2"):
    with open(mpath) as f:
        m = json.load(f)
    per = {r["id"]: r for r in m["grouping"]["per_robot"]}
    for g in m["grouping"]["per_group"]:
        mem = [r["delta_omega"] for r in per.values() if r["leader"] == g["leader"]]
        s2.setdefault(group_of(g["leader"], [4, 4, 3]), []).append((g["delta_omega"], sum(mem)))
for g in sorted(s2):
    n, pv = PAPER_S2[g]
    mn, sm = avg(x[0] for x in s2[g]), avg(x[1] for x in s2[g])
    RAT_MEAN.append(mn / pv)
    RAT_SUM.append(sm / pv)
    print(f"| S2 | G{g + 1} | {n} | {fmt(mn)} | {pv} | {ratio(mn, pv)} | {fmt(sm)} | {ratio(sm, pv)} |")
for s in SIZES:
    for g in sorted(s3_all[s]):
        n = [s, 4, 3][g]
        mn, sm = avg(x[0] for x in s3_all[s][g]), avg(x[1] for x in s3_all[s][g])
        RAT_MEAN.append(mn / P[s][g])
        RAT_SUM.append(sm / P[s][g])
        print(f"| S3{s - 3} | G{g + 1} | {n} | {fmt(mn)} | {P[s][g]} | {ratio(mn, P[s][g])} "
              f"| {fmt(sm)} | {ratio(sm, P[s][g])} |")


def grow(d, a, b, k):
    return avg(x[k] for x in d[b]) / avg(x[k] for x in d[a])


print("\nGrowth factors (ours mean | ours sum | paper printed):\n")
print(f"- S3 G1 4 -> 6 robots: {grow({s: s3_all[s][0] for s in SIZES}, 4, 6, 0):.2f} | "
      f"{grow({s: s3_all[s][0] for s in SIZES}, 4, 6, 1):.2f} | {P[6][0] / P[4][0]:.2f}")
print(f"- S3 G1 4 -> 5 robots: {grow({s: s3_all[s][0] for s in SIZES}, 4, 5, 0):.2f} | "
      f"{grow({s: s3_all[s][0] for s in SIZES}, 4, 5, 1):.2f} | {P[5][0] / P[4][0]:.2f}")
print(f"- S1 4 -> 8 robots: {grow(s1, 4, 8, 0):.2f} | {grow(s1, 4, 8, 1):.2f} | "
      f"{PAPER_S1[8] / PAPER_S1[4]:.2f}")
g3g2 = [avg(x[0] for x in s3_all[s][2]) / avg(x[0] for x in s3_all[s][1]) for s in SIZES]
g3g2s = [avg(x[1] for x in s3_all[s][2]) / avg(x[1] for x in s3_all[s][1]) for s in SIZES]
print("- S3 G3 (3 robots) / G2 (4 robots), S31-S33: "
      + ", ".join(f"{x:.2f}" for x in g3g2) + " | " + ", ".join(f"{x:.2f}" for x in g3g2s)
      + " | " + ", ".join(f"{P[s][2] / P[s][1]:.2f}" for s in SIZES))

# ---- S1: the same controller where the circle is crowded -----------------------------------
print("\n## 5. S1 (one group, circle 1.0 m for 4-8 robots): ΔΩ against the neighbours' spacing\n")
print("chord = the distance between neighbouring slots, 2 f_r sin(pi/N); `close` as in section 2. "
      "For comparison the base S3 rows (circle 1.8 m) from section 2.\n")
print("| scenario | N | chord (m) | close < 1 m | ours ΔΩ (mean) | paper | ratio |")
print("|---|---|---|---|---|---|---|")
s1c = {}
for mpath in run_dirs("s1"):
    m, per = analyse(mpath)
    s1c.setdefault(m["agents"], []).append(per)
for n in sorted(s1c):
    close = avg(r["close1m"] for per in s1c[n] for r in per.values())
    do = avg(mean(r["delta_omega"] for r in per.values()) for per in s1c[n])
    print(f"| S1 | {n} | {2 * 1.0 * math.sin(math.pi / n):.2f} | {100 * close:.0f} % | {do:.1f} "
          f"| {PAPER_S1[n]} | {do / PAPER_S1[n]:.2f} |")
for s in SIZES:
    c = cells[("base", s)]
    print(f"| S3{s - 3} G1 | {s} | {2 * 1.8 * math.sin(math.pi / s):.2f} | {100 * c['close']:.0f} % "
          f"| {c['g1']:.1f} | {P[s][0]} | {c['g1'] / P[s][0]:.2f} |")

# ---- Conclusion, from the numbers above ----------------------------------------------------
def khatib(k_rep, rho_0, rho):
    """Eq. 11's repulsion magnitude (circle.rs `repulsion`), m/s."""
    return k_rep * (1.0 / rho - 1.0 / rho_0) / rho ** 2 if rho < rho_0 else 0.0


b4, b6 = cells[("base", 4)], cells[("base", 6)]
x4, x6 = cells[("radius1.0-rep1.5", 4)], cells[("radius1.0-rep1.5", 6)]
g_base, se_base = growth_se(b4, b6)
g_x, se_x = growth_se(x4, x6)
knobs = [l for l, _ in ROWS if l not in ("base", "radius1.0-rep1.5", "rep2.0-krep0.1",
                                         "radius-scaled", "radius1.0")]
kg = [growth_se(cells[(l, 4)], cells[(l, 6)])[0] for l in knobs]
s1_close = {n: avg(r["close1m"] for per in s1c[n] for r in per.values()) for n in s1c}
s1_do = {n: avg(mean(r["delta_omega"] for r in per.values()) for per in s1c[n]) for n in s1c}
print("\n## Conclusion (measured)\n")
print(f"**The cause is that our group 1 never crowds at f_r = 1.8 m**: its neighbours sit "
      f"{2 * 1.8 * math.sin(math.pi / 6):.2f}-{2 * 1.8 * math.sin(math.pi / 4):.2f} m apart on the circle, "
      f"closer than 1 m to a group mate only {100 * b4['close']:.0f}-{100 * b6['close']:.0f} % of the "
      f"navigation ticks, so nothing in a member's turn rate depends on the group's size. A robot's "
      f"ΔΩ is its own slot tracking around the corridor's cones, the same in every phase at 4 and 6 "
      f"robots (base, section 3: forming {ratio(b6['forming'], b4['forming'])}, approach "
      f"{ratio(b6['approach'], b4['approach'])}, corridor {ratio(b6['corridor'], b4['corridor'])}; "
      f"group growth {g_base:.2f} ± {se_base:.2f}). None of the other knobs (k_att, k_turn, "
      f"turn_accel incl. raw, rho_0 or k_rep alone, a 1.2 m circle, lidar/heading/wheel noise, "
      f"speed) changes that ({min(kg):.2f}-{max(kg):.2f}, section 1): they move the level, not "
      f"the growth; a 1.0 m circle alone gives "
      + "{:.2f} ± {:.2f}".format(*growth_se(cells[("radius1.0", 4)], cells[("radius1.0", 6)]))
      + f". Rows radius1.0-rep1.5 and S1 show the same controller does grow ΔΩ once the "
      f"circle is crowded: a 1.0 m circle with rho_0 = 1.5 m gives {g_x:.2f} ± {se_x:.2f} from 4 "
      f"to 6 (close < 1 m {100 * x4['close']:.0f} -> {100 * x6['close']:.0f} %), and the growth is "
      f"in the corridor ({ratio(x6['corridor'], x4['corridor'])}x there), as the paper's text "
      f"says; S1's committed 1.0 m circle grows {s1_do[8] / s1_do[4]:.2f}x from 4 to 8 robots "
      f"(close < 1 m {100 * s1_close[4]:.0f} -> {100 * s1_close[8]:.0f} %). A longer range alone "
      f"(rep1.5, rep2.0) does nothing: eq. 11's push per lidar hit on a neighbour's surface "
      f"1.6 m away (6 robots on 1.8 m) with rho_0 = 2.0 m and k_rep = 0.02 is "
      f"{khatib(0.02, 2.0, 1.6) * 1000:.1f} mm/s (computed), against "
      f"{khatib(0.02, 1.5, 0.8) * 1000:.0f} mm/s at 0.8 m (6 robots on 1.0 m) with rho_0 = 1.5 m "
      f"and a formation speed of 350 mm/s; with k_rep = 0.1 too (rep2.0-krep0.1) it grows "
      f"{growth_se(cells[('rep2.0-krep0.1', 4)], cells[('rep2.0-krep0.1', 6)])[0]:.2f}x but noisily "
      f"(± {growth_se(cells[('rep2.0-krep0.1', 4)], cells[('rep2.0-krep0.1', 6)])[1]:.2f}) and loses "
      f"robots ({sum(cells[('rep2.0-krep0.1', s)]['reached'] for s in SIZES)}/"
      f"{sum(cells[('rep2.0-krep0.1', s)]['robots'] for s in SIZES)} reached). Scaling the circle "
      f"with N (radius-scaled) shrinks ΔΩ and loses robots in the 8 m corridor.\n")
print(f"**The paper's side: Table III reads like a group sum.** Its 3-robot group 3 has "
      + ", ".join(f"{P[s][2] / P[s][1]:.2f}" for s in SIZES)
      + " of the 4-robot group 2's ΔΩ in S31-S33, i.e. 3/4 (the per-robot values "
      + ", ".join(f"{(P[s][2] / 3) / (P[s][1] / 4):.2f}" for s in SIZES)
      + f"), and read as a sum group 1's per-robot ΔΩ grows only "
      f"{(P[6][0] / 6) / (P[4][0] / 4):.2f}x from 4 to 6 robots, about one standard error from our "
      f"{g_base:.2f} ± {se_base:.2f}; our sum grows {grow({s: s3_all[s][0] for s in SIZES}, 4, 6, 1):.2f}x "
      f"(paper 1.72). But the sum reading does not fit Table I (per robot it would fall "
      f"{(PAPER_S1[8] / 8) / (PAPER_S1[4] / 4):.2f}x from 4 to 8 robots) nor the magnitudes (our sums "
      f"are {min(RAT_SUM):.1f}-{max(RAT_SUM):.1f}x the paper's values on S1-S3, our means "
      f"{min(RAT_MEAN):.1f}-{max(RAT_MEAN):.1f}x), and eq. 16 and section 3.2.1 define a "
      f"per-robot average, so metrics.rs is left as it is. Either way the 1.72x is **not met** with "
      f"the committed config (measured cause above); it is met in shape only by a crowded circle "
      f"(radius1.0-rep1.5), which departs from the paper's stated 1.8 m.\n")
