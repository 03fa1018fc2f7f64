#!/usr/bin/env python3
"""Seed 000, complex map, w = 1 deg: why robots go down at low speed (issue 35, part 3).

Runs `swarm run configs/formation_complex.toml` at v = 0.1 / 0.2 / 0.5 m/s, w = 1 deg, seeds
1-5 (the seeds `swarm sweep --seeds 5` uses), and traces every collision in the run records
(events.jsonl, trajectory.csv) to:

- the robot and its slot: the desired offset from the virtual leader (world frame, fixed: the
  paper's x_ides, y_ides) and where that slot was in the leader frame at the collision
  (x' along the swarm heading, y' to its left, eq. 4-5): front / mid / rear, left / centre /
  right;
- what it hit: the obstacle (or robot, or the map's edge) nearest the robot at the collision;
- what the formation was doing: the swarm turn (majority of the robots' own turns, from their
  `turn` notes) and why: "avoiding" if an observer's cone saw an obstacle within detect_range
  in the last verdict_ticks ticks (recomputed by ray casting the map from the observers'
  poses, roles from `role` notes, cones around each robot's swarm heading, which is rebuilt
  from the `turn` notes the way mod.rs averages it), "returning" if nothing was seen and the
  turn is toward the target, "straight" otherwise;
- whether any observer's cone ever had the point that was hit within detect_range in the
  300 ticks before (ray cast: the first obstacle on the ray, so occlusion counts);
- the gap: the free width between the hit obstacle and the nearest other obstacle (or map
  edge), against the formation's width across its heading at that moment.

Usage: complex_collisions.py [--swarm target/release/swarm] [--work DIR] [--sweeps] [--gap-tie M]
With --gap-tie 1000 the traced runs go straight on whenever only the side observers see
something (the rule before issue 35).
Prints markdown tables. With --sweeps it also runs the w = 1, 5 deg sweeps on both maps with
the paper's speeds, 10 seeds each, and prints the reached-target tables, then the complex map
at w = 5 deg, 0.1 m/s with twice the tick budget, and at w = 1 deg below 1 m/s with the
observers reaching 3, 3.5 and 4 m, and the open case's tie (behaviour.gap_tie) at 0.05, 0.45
and 1000 m (always straight on, the rule before issue 35).
"""

import argparse
import collections
import csv
import json
import math
import os
import subprocess
import sys
import tomllib

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
CONFIG = os.path.join(ROOT, "configs", "formation_complex.toml")
SPEEDS = ["0.1", "0.2", "0.5"]
SEEDS = [1, 2, 3, 4, 5]
PAPER_SPEEDS = "0.1,0.2,0.5,1,1.5,2,2.5,3,3.5,4,4.5,5,5.5"
LOOKBACK = 300


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


class Map:
    def __init__(self, cfg):
        m = cfg["map"]
        self.bounds = m["bounds"]
        self.goal = (m["goal"]["x"], m["goal"]["y"])
        self.shapes = []  # (name, kind, data)
        for c in m.get("circles", []):
            self.shapes.append((f"circle ({c['x']:g},{c['y']:g}) r {c['r']:g}", "c", c))
        for r in m.get("rectangles", []):
            pts = [(r["x_min"], r["y_min"]), (r["x_max"], r["y_min"]),
                   (r["x_max"], r["y_max"]), (r["x_min"], r["y_max"])]
            self.shapes.append((f"bar x {r['x_min']:g}-{r['x_max']:g} y {r['y_min']:g}-{r['y_max']:g}", "p", pts))
        for p in m.get("polygons", []):
            pts = [tuple(q) for q in p["points"]]
            name = "triangle " + " ".join(f"({x:g},{y:g})" for x, y in pts)
            self.shapes.append((name, "p", pts))
        x0, y0, x1, y1 = self.bounds
        self.edges = [((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))]

    @staticmethod
    def seg_closest(p, a, b):
        ax, ay = a
        dx, dy = b[0] - ax, b[1] - ay
        t = ((p[0] - ax) * dx + (p[1] - ay) * dy) / (dx * dx + dy * dy)
        t = max(0.0, min(1.0, t))
        return (ax + t * dx, ay + t * dy)

    def closest(self, shape, p):
        _, kind, d = shape
        if kind == "c":
            ang = math.atan2(p[1] - d["y"], p[0] - d["x"])
            q = (d["x"] + d["r"] * math.cos(ang), d["y"] + d["r"] * math.sin(ang))
            return q, max(0.0, math.hypot(p[0] - d["x"], p[1] - d["y"]) - d["r"])
        pts = d
        best = None
        for i in range(len(pts)):
            q = self.seg_closest(p, pts[i], pts[(i + 1) % len(pts)])
            dist = math.hypot(p[0] - q[0], p[1] - q[1])
            if best is None or dist < best[1]:
                best = (q, dist)
        return best

    def nearest(self, p):
        """(name, closest point, distance) of the nearest obstacle or map edge."""
        best = None
        for s in self.shapes:
            q, dist = self.closest(s, p)
            if best is None or dist < best[2]:
                best = (s[0], q, dist)
        for a, b in self.edges:
            q = self.seg_closest(p, a, b)
            dist = math.hypot(p[0] - q[0], p[1] - q[1])
            if dist < best[2]:
                best = ("map edge", q, dist)
        return best

    def gap(self, name, q):
        """Free width from point q on obstacle `name` to the nearest other obstacle or edge."""
        best = math.inf
        for s in self.shapes:
            if s[0] == name:
                continue
            best = min(best, self.closest(s, q)[1])
        for a, b in self.edges:
            r = self.seg_closest(q, a, b)
            best = min(best, math.hypot(q[0] - r[0], q[1] - r[1]))
        return best

    @staticmethod
    def ray_seg(o, d, a, b):
        ex, ey = b[0] - a[0], b[1] - a[1]
        den = d[0] * ey - d[1] * ex
        if abs(den) < 1e-12:
            return math.inf
        wx, wy = a[0] - o[0], a[1] - o[1]
        t = (wx * ey - wy * ex) / den
        u = (wx * d[1] - wy * d[0]) / den
        return t if t >= 0 and 0 <= u <= 1 else math.inf

    def ray(self, o, ang, rng):
        return self.ray_hit(o, ang, rng)[0]

    def ray_hit(self, o, ang, rng):
        """Distance along the ray to the first obstacle (or edge), and its name."""
        d = (math.cos(ang), math.sin(ang))
        best, what = rng, None
        for name, kind, s in self.shapes:
            before = best
            if kind == "c":
                fx, fy = o[0] - s["x"], o[1] - s["y"]
                b = fx * d[0] + fy * d[1]
                c = fx * fx + fy * fy - s["r"] ** 2
                disc = b * b - c
                if disc >= 0:
                    t = -b - math.sqrt(disc)
                    if t < 0:
                        t = -b + math.sqrt(disc)
                    if 0 <= t < best:
                        best = t
            else:
                for i in range(len(s)):
                    best = min(best, self.ray_seg(o, d, s[i], s[(i + 1) % len(s)]))
            if best < before:
                what = name
        for a, b in self.edges:
            t = self.ray_seg(o, d, a, b)
            if t < best:
                best, what = t, "map edge"
        return best, what


def run(swarm, speed, seed, out, tie=None):
    if not os.path.exists(os.path.join(out, "metrics.json")):
        extra = [] if tie is None else ["--set", f"behaviour.gap_tie={tie}"]
        subprocess.run(
            [swarm, "run", CONFIG, "--set", f"behaviour.speed={speed}", "--set", "behaviour.turn_deg=1",
             "--set", f"scenario.seed={seed}", "--out", out, "--force", "--in-process"] + extra,
            check=True, stdout=subprocess.DEVNULL)
    return out


def load(out):
    traj = collections.defaultdict(dict)  # tick -> id -> row
    with open(os.path.join(out, "trajectory.csv")) as f:
        for r in csv.DictReader(f):
            traj[int(r["tick"])][int(r["id"])] = (float(r["x"]), float(r["y"]), float(r["theta"]), r["state"])
    events = [json.loads(line) for line in open(os.path.join(out, "events.jsonl"))]
    metrics = json.load(open(os.path.join(out, "metrics.json")))
    return traj, events, metrics


def analyse(cfg, out, speed, seed):
    m = Map(cfg)
    b = cfg["behaviour"]
    turn = math.radians(1.0)
    side_off = math.radians(b["side_offset_deg"])
    cone = math.radians(b["cone_deg"])
    detect = b["detect_range"]
    lid = cfg["robots"]["lidar"]
    rays = [math.radians(-lid["fov_deg"] / 2 + k * lid["fov_deg"] / (lid["rays"] - 1)) for k in range(lid["rays"])]
    radius = cfg["robots"]["radius"]
    traj, events, metrics = load(out)
    n = cfg["robots"]["count"]
    start = traj[0]
    cx = sum(start[i][0] for i in range(n)) / n
    cy = sum(start[i][1] for i in range(n)) / n
    off = {i: (start[i][0] - cx, start[i][1] - cy) for i in range(n)}
    last_tick = max(traj)
    # Turn and role per robot per tick, from notes.
    dirs = collections.defaultdict(dict)
    roles = collections.defaultdict(dict)
    for e in events:
        if e["event"] == "note" and isinstance(e["note"], dict):
            if "turn" in e["note"]:
                dirs[e["robot"]][e["tick"]] = e["note"]["turn"]["dir"]
            if "role" in e["note"]:
                roles[e["robot"]][e["tick"]] = e["note"]["role"]["role"]
    # Rebuild each robot's swarm heading (mod.rs step 1-2): circular mean of its own and the
    # headings its neighbours sent last tick, then its own turn.
    psi = {i: 0.0 for i in range(n)}
    sent = {i: 0 for i in range(n)}
    cur_dir = {i: 0 for i in range(n)}
    cur_role = {i: 0 for i in range(n)}
    hist = {}  # tick -> (psi_before per robot, dir per robot, role used per robot)
    for t in range(0, last_tick + 1):
        rows = traj[t]
        before, d_t, r_t = {}, {}, {}
        new = {}
        for i in range(n):
            if rows.get(i, (0, 0, 0, "down"))[3] != "active":
                continue
            s, c = math.sin(psi[i]), math.cos(psi[i])
            for j in range(n):
                if j != i and t > 0 and t - 1 - sent[j] <= 20 and sent[j] < t:
                    s += math.sin(psi[j])
                    c += math.cos(psi[j])
            before[i] = math.atan2(s, c)
            r_t[i] = cur_role[i]  # the role its lidar is on for this tick
            cur_dir[i] = dirs[i].get(t, cur_dir[i])
            cur_role[i] = roles[i].get(t, cur_role[i])
            d_t[i] = cur_dir[i]
            new[i] = wrap(before[i] + cur_dir[i] * turn)
        for i, p in new.items():
            psi[i] = p
            sent[i] = t
        hist[t] = (before, d_t, r_t)

    def cone_of(i, t):
        before, _, r_t = hist[t]
        role = r_t.get(i, 0)
        if role == 0 or i not in before:
            return None
        return role, before[i] + {1: 0.0, 2: side_off, 3: -side_off}[role]

    def cone_rays(t):
        """Every lidar ray inside an observer's cone at tick t: (role, origin, angle)."""
        for i in range(n):
            c = cone_of(i, t)
            if c is None:
                continue
            x, y, th, _ = traj[t][i]
            for a in rays:
                ang = th + a
                if abs(wrap(ang - c[1])) <= cone:
                    yield c[0], (x, y), ang

    def verdict(t):
        seen = set()
        for role, origin, ang in cone_rays(t):
            if role not in seen and m.ray(origin, ang, detect) < detect:
                seen.add(role)
        return seen

    def leader(t):
        act = [i for i in range(n) if traj[t][i][3] == "active"]
        if not act:
            return None
        return (sum(traj[t][i][0] - off[i][0] for i in act) / len(act),
                sum(traj[t][i][1] - off[i][1] for i in act) / len(act))

    rows = []
    for e in events:
        if e["event"] != "collision":
            continue
        t, i = e["tick"], e["robot"]
        x, y, th, _ = traj[t][i]
        name, q, dist = m.nearest((x, y))
        others = [(j, math.hypot(traj[t][j][0] - x, traj[t][j][1] - y)) for j in range(n) if j != i]
        j, dj = min(others, key=lambda p: p[1])
        if dj < 2 * radius + 0.02 and dj - 2 * radius < dist - radius:
            hit = f"robot {j}"
        else:
            hit = name
        before, d_t, _ = hist[t]
        sw = before.get(i, next(iter(before.values())))
        ld0 = leader(t)
        off_slot = math.hypot(x - ld0[0] - off[i][0], y - ld0[1] - off[i][1])
        # Slot in the leader frame (eq. 4-5) at the collision.
        ox, oy = off[i]
        xp = ox * math.cos(sw) + oy * math.sin(sw)
        yp = oy * math.cos(sw) - ox * math.sin(sw)
        fr = "front" if xp > 0.4 else ("rear" if xp < -0.4 else "mid")
        lr = "left" if yp > 0.4 else ("right" if yp < -0.4 else "centre")
        # Swarm turn over the last 10 ticks: majority of the robots' own turns.
        votes = collections.Counter()
        for u in range(max(0, t - 9), t + 1):
            votes.update(hist[u][1].values())
        maj = votes.most_common(1)[0][0]
        turning = {1: "left", -1: "right", 0: "straight"}[maj]
        seen_recent = set()
        for u in range(max(0, t - b.get("verdict_ticks", 3)), t + 1):
            seen_recent |= verdict(u)
        ld = leader(t)
        to_goal = math.atan2(m.goal[1] - ld[1], m.goal[0] - ld[0])
        err = wrap(to_goal - sw)
        toward = 1 if err > turn / 2 else (-1 if err < -turn / 2 else 0)
        if seen_recent:
            doing = "avoiding (" + "+".join({1: "M", 2: "L", 3: "R"}[r] for r in sorted(seen_recent)) + " seen)"
        elif maj != 0 and maj == toward:
            doing = "returning to target"
        else:
            doing = f"{turning}, nothing seen"
        # How long before the collision the point hit was in an observer's cone, within
        # detect_range and the first obstacle on that ray (gaps of up to 5 ticks bridged).
        def visible(u):
            """The role and distance at which an observer's cone saw the obstacle hit."""
            best = None
            for role, origin, ang in cone_rays(u):
                dist2, what = m.ray_hit(origin, ang, detect)
                if what == name and dist2 < detect and (best is None or dist2 < best[1]):
                    best = ({1: "M", 2: "L", 3: "R"}[role], dist2)
            return best
        seen_txt = "-"
        if not hit.startswith("robot"):
            first, miss, u = None, 0, t
            while u >= max(0, t - LOOKBACK) and miss <= 5:
                v = visible(u)
                if v:
                    first, miss = (u, v), 0
                else:
                    miss += 1
                u -= 1
            seen_txt = "never" if first is None else (
                f"{first[1][0]}, {'>= ' if t - first[0] >= LOOKBACK else ''}{t - first[0]} ticks, from {first[1][1]:.1f} m")
        else:
            j_down = next((e2["tick"] for e2 in events if e2["event"] == "collision" and e2["robot"] == j and e2["tick"] < t), None)
            if j_down is not None:
                hit += f" (down since tick {j_down})"
        # Ticks, of the 150 before, in which the left and right observers saw something and the
        # middle did not: section 5.2 is silent there; direction.rs steers away from the nearer side.
        gap_rule = sum(1 for u in range(max(0, t - 150), t + 1) if verdict(u) == {2, 3})
        # Formation width across the heading, against the free gap beside the hit point.
        ys = [oy2 * math.cos(sw) - ox2 * math.sin(sw) for ox2, oy2 in off.values()]
        width = max(ys) - min(ys) + 2 * radius
        gap = m.gap(name, q) if not hit.startswith("robot") else math.nan
        # Heading change of the swarm in the 50 ticks before.
        dpsi = math.degrees(wrap(sw - hist[max(0, t - 50)][0].get(i, sw)))
        rows.append(dict(speed=speed, seed=seed, tick=t, robot=i, slot=f"({ox:+.1f},{oy:+.1f})",
                         where=f"{fr}-{lr}", hit=hit, turning=turning, doing=doing,
                         heading=round(math.degrees(sw)), dpsi50=round(dpsi),
                         seen=seen_txt, gap_rule=gap_rule, off_slot=off_slot,
                         gap=gap, width=width))
    return rows, metrics


def sweep(swarm, config, out):
    if not os.path.exists(os.path.join(out, "sweep.csv")):
        subprocess.run([swarm, "sweep", config, "--vary", f"behaviour.speed={PAPER_SPEEDS}",
                        "--vary", "behaviour.turn_deg=1,5", "--seeds", "10", "--jobs", "1",
                        "--in-process", "--out", out], check=True, stdout=subprocess.DEVNULL)
    table = collections.defaultdict(list)
    with open(os.path.join(out, "sweep.csv")) as f:
        for r in csv.DictReader(f):
            table[(r["behaviour.turn_deg"], r["behaviour.speed"])].append(float(r["reached_target"]))
    speeds = PAPER_SPEEDS.split(",")
    print(f"\n`swarm sweep {os.path.relpath(config, ROOT)} --vary behaviour.speed={PAPER_SPEEDS} "
          "--vary behaviour.turn_deg=1,5 --seeds 10 --jobs 1 --in-process`\n")
    print("| w \\ v (m/s) | " + " | ".join(speeds) + " |")
    print("|---" * (len(speeds) + 1) + "|")
    for w in ["1", "5"]:
        cells = []
        for s in speeds:
            v = table.get((w, s)) or table.get((w + ".0", s)) or []
            mean = sum(v) / len(v) if v else math.nan
            cells.append(f"{mean:g}" if mean in (0, 9) else f"{mean:.1f}")
        print(f"| {w}° | " + " | ".join(cells) + " |")


def long_budget(swarm, out):
    """w = 5 deg at 0.1 m/s with twice the tick budget: out of time or lost?"""
    if not os.path.exists(os.path.join(out, "sweep.csv")):
        subprocess.run([swarm, "sweep", os.path.join(ROOT, "configs", "formation_complex.toml"),
                        "--vary", "behaviour.speed=0.1", "--vary", "behaviour.turn_deg=5", "--seeds", "10",
                        "--jobs", "1", "--in-process", "--set", "scenario.ticks=12000", "--out", out],
                       check=True, stdout=subprocess.DEVNULL)
    rows = list(csv.DictReader(open(os.path.join(out, "sweep.csv"))))
    print("\n`swarm sweep configs/formation_complex.toml --vary behaviour.speed=0.1 --vary behaviour.turn_deg=5 "
          "--seeds 10 --jobs 1 --in-process --set scenario.ticks=12000` (twice the config's budget)\n")
    print("| seed | reached | down | steps to target |")
    print("|---|---|---|---|")
    for r in rows:
        print(f"| {r['seed']} | {r['reached_target']} | {r['down']} | {r['steps_to_target'] or '-'} |")
    reached = [float(r["reached_target"]) for r in rows]
    print(f"\nMean reached: {sum(reached) / len(reached):.1f} of 9")


def detect_ablation(swarm, out):
    """w = 1 deg below 1 m/s with the observers reaching 3 (the config), 3.5 and 4 m."""
    if not os.path.exists(os.path.join(out, "sweep.csv")):
        subprocess.run([swarm, "sweep", os.path.join(ROOT, "configs", "formation_complex.toml"),
                        "--vary", "behaviour.speed=0.1,0.2,0.5", "--vary", "behaviour.detect_range=3,3.5,4",
                        "--set", "behaviour.turn_deg=1", "--seeds", "10", "--jobs", "1", "--in-process",
                        "--out", out], check=True, stdout=subprocess.DEVNULL)
    table = collections.defaultdict(list)
    for r in csv.DictReader(open(os.path.join(out, "sweep.csv"))):
        table[(float(r["behaviour.detect_range"]), float(r["behaviour.speed"]))].append(float(r["reached_target"]))
    print("\n`swarm sweep configs/formation_complex.toml --vary behaviour.speed=0.1,0.2,0.5 "
          "--vary behaviour.detect_range=3,3.5,4 --set behaviour.turn_deg=1 --seeds 10 --jobs 1 --in-process`\n")
    speeds = [0.1, 0.2, 0.5]
    print("| detect range (m) \\ v (m/s) | " + " | ".join(f"{v:g}" for v in speeds) + " |")
    print("|---" * (len(speeds) + 1) + "|")
    for d in [3.0, 3.5, 4.0]:
        cells = []
        for v in speeds:
            xs = table[(d, v)]
            mean = sum(xs) / len(xs)
            cells.append(f"{mean:g}" if mean in (0, 9) else f"{mean:.1f}")
        print(f"| {d:g} | " + " | ".join(cells) + " |")


def tie_ablation(swarm, work):
    """The open case's tie (behaviour.gap_tie): 0.05 m (ours), 0.45 m, and 1000 m, which is
    always "straight on", the rule before issue 35. Complex map at w = 1, 5 deg up to 1 m/s and
    simple map at w = 20 deg, 10 seeds."""
    runs = [("formation_complex", "0.1,0.2,0.5,1", "1,5"), ("formation_simple", PAPER_SPEEDS, "20")]
    for name, speeds, ws in runs:
        out = os.path.join(work, f"tie-{name}")
        if not os.path.exists(os.path.join(out, "sweep.csv")):
            subprocess.run([swarm, "sweep", os.path.join(ROOT, "configs", f"{name}.toml"),
                            "--vary", f"behaviour.speed={speeds}", "--vary", "behaviour.gap_tie=0.05,0.45,1000",
                            "--vary", f"behaviour.turn_deg={ws}", "--seeds", "10", "--jobs", "1", "--in-process",
                            "--out", out], check=True, stdout=subprocess.DEVNULL)
        table = collections.defaultdict(list)
        for r in csv.DictReader(open(os.path.join(out, "sweep.csv"))):
            key = (float(r["behaviour.turn_deg"]), float(r["behaviour.gap_tie"]), float(r["behaviour.speed"]))
            table[key].append(float(r["reached_target"]))
        print(f"\n`swarm sweep configs/{name}.toml --vary behaviour.speed={speeds} "
              f"--vary behaviour.gap_tie=0.05,0.45,1000 --vary behaviour.turn_deg={ws} --seeds 10 --jobs 1 --in-process`\n")
        sp = [float(v) for v in speeds.split(",")]
        print("| w, gap_tie (m) \\ v (m/s) | " + " | ".join(f"{v:g}" for v in sp) + " | robots home |")
        print("|---" * (len(sp) + 2) + "|")
        for w in [float(x) for x in ws.split(",")]:
            for tie in [0.05, 0.45, 1000.0]:
                cells = []
                for v in sp:
                    xs = table[(w, tie, v)]
                    mean = sum(xs) / len(xs)
                    cells.append(f"{mean:g}" if mean in (0, 9) else f"{mean:.1f}")
                total = sum(sum(table[(w, tie, v)]) for v in sp)
                print(f"| {w:g}°, {tie:g} | " + " | ".join(cells) + f" | {total:g} |")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--swarm", default=os.path.join(ROOT, "target", "release", "swarm"))
    ap.add_argument("--work", default=os.path.join(ROOT, "target", "seed000_complex_collisions"))
    ap.add_argument("--sweeps", action="store_true")
    ap.add_argument("--gap-tie", help="behaviour.gap_tie for the traced runs (1000: always straight on)")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    with open(CONFIG, "rb") as f:
        cfg = tomllib.load(f)
    allrows = []
    reached = collections.defaultdict(list)
    downs = collections.defaultdict(list)
    for speed in SPEEDS:
        for seed in SEEDS:
            tag = "" if a.gap_tie is None else f"-tie{a.gap_tie}"
            out = run(a.swarm, speed, seed, os.path.join(a.work, f"v{speed}-s{seed}{tag}"), a.gap_tie)
            rows, met = analyse(cfg, out, speed, seed)
            reached[speed].append(met["reached_target"])
            downs[speed].append(met["down"])
            allrows.extend(rows)
    tie = "" if a.gap_tie is None else f" --set behaviour.gap_tie={a.gap_tie}"
    print("Runs: `swarm run configs/formation_complex.toml --set behaviour.speed=V "
          f"--set behaviour.turn_deg=1 --set scenario.seed=S --in-process{tie}`, S = 1..5\n")
    print("| v (m/s) | reached per seed | mean | down per seed | out of time | collisions |")
    print("|---|---|---|---|---|---|")
    for s in SPEEDS:
        k = sum(1 for r in allrows if r["speed"] == s)
        late = sum(cfg["robots"]["count"] - r - d for r, d in zip(reached[s], downs[s]))
        print(f"| {s} | {' '.join(str(x) for x in reached[s])} | {sum(reached[s]) / len(reached[s]):.1f} "
              f"| {' '.join(str(x) for x in downs[s])} | {late} | {k} |")
    print("\n| v | seed | tick | robot | slot (offset) | slot in leader frame | off its slot (m) | hit | swarm turn (10 ticks) "
          "| formation doing | heading ° | heading change, last 50 ticks ° | obstacle hit in a cone (role, for, from) "
          "| L+R-only ticks of last 150 | free gap there (m) | formation width across heading (m) |")
    print("|---" * 16 + "|")
    for r in allrows:
        gap = "-" if math.isnan(r["gap"]) else f"{r['gap']:.2f}"
        print(f"| {r['speed']} | {r['seed']} | {r['tick']} | {r['robot']} | {r['slot']} | {r['where']} | {r['off_slot']:.2f} | {r['hit']} "
              f"| {r['turning']} | {r['doing']} | {r['heading']} | {r['dpsi50']} | {r['seen']} | {r['gap_rule']} | {gap} | {r['width']:.2f} |")
    # Tallies.
    def tally(key):
        c = collections.Counter(key(r) for r in allrows)
        return ", ".join(f"{k}: {v}" for k, v in c.most_common())
    print("\nTurn radius of the virtual leader at w = 1 deg, v dt / w (m): "
          + ", ".join(f"{sp} m/s: {float(sp) * cfg['scenario']['dt'] / math.radians(1):.2f}" for sp in SPEEDS)
          + f"; observers report obstacles within {cfg['behaviour']['detect_range']:g} m")
    print(f"\nCollisions: {len(allrows)}")
    print(f"- slot in leader frame: {tally(lambda r: r['where'])}")
    print(f"- hit: {tally(lambda r: r['hit'].split(' (down')[0])}")
    print(f"- hit robot off its slot by more than 0.2 m: {tally(lambda r: 'yes' if r['off_slot'] > 0.2 else 'no')}")
    print(f"- swarm turn: {tally(lambda r: r['turning'])}")
    print(f"- formation doing: {tally(lambda r: r['doing'].split(' (')[0])}")
    print(f"- obstacle hit seen by a cone before: {tally(lambda r: 'robot' if r['seen'] == '-' else ('never' if r['seen'] == 'never' else 'yes'))}")
    print(f"- robot hit was already down: {tally(lambda r: 'obstacle' if not r['hit'].startswith('robot') else ('yes' if 'down since' in r['hit'] else 'no'))}")
    print(f"- left and right seen, middle not, for >= 20 of the last 150 ticks: "
          f"{tally(lambda r: 'yes' if r['gap_rule'] >= 20 else 'no')}")
    print(f"- free gap narrower than the formation: "
          f"{tally(lambda r: 'robot' if math.isnan(r['gap']) else ('narrower' if r['gap'] < r['width'] else 'wider'))}")
    tot = sum(sum(v) for v in reached.values())
    print(f"- robots home over these runs: {tot} of {cfg['robots']['count'] * len(SPEEDS) * len(SEEDS)} "
          f"({100 * tot / (cfg['robots']['count'] * len(SPEEDS) * len(SEEDS)):.0f} %)")
    obst = [r for r in allrows if not r["hit"].startswith("robot")]
    print(f"- largest distance of a hit robot from its slot: {max(r['off_slot'] for r in allrows):.2f} m")
    print(f"- obstacle hits: free gap {min(r['gap'] for r in obst):.2f}-{max(r['gap'] for r in obst):.2f} m, "
          f"formation width {min(r['width'] for r in obst):.2f}-{max(r['width'] for r in obst):.2f} m, "
          f"gap minus width {min(r['gap'] - r['width'] for r in obst):.2f}-{max(r['gap'] - r['width'] for r in obst):.2f} m")
    for sp in SPEEDS:
        seen = [r["seen"] for r in obst if r["speed"] == sp and r["seen"] != "never"]
        lr = [r["gap_rule"] for r in obst if r["speed"] == sp and r["gap_rule"] >= 20]
        print(f"- {sp} m/s: obstacle in a cone before the hit: " + "; ".join(seen)
              + (f"; L+R-only ticks {min(lr)}-{max(lr)} of 150" if lr else ""))
    lag = [r["tick"] - int(r["hit"].split("since tick ")[1].rstrip(")")) for r in allrows if "down since" in r["hit"]]
    if lag:
        print(f"- a teammate already down was hit {min(lag)}-{max(lag)} ticks after it went down")
    # One cause per collision, checked in this order.
    def cause(r):
        if "down since" in r["hit"]:
            return "hit a teammate already down"
        if r["hit"].startswith("robot"):
            return "hit a moving teammate"
        if r["seen"] == "never":
            return "obstacle never in a cone"
        if r["gap_rule"] >= 20:
            return "L+R seen, M not (>= 20 of 150 ticks)"
        return "seen, turning away at w: too slow"
    causes = ["L+R seen, M not (>= 20 of 150 ticks)", "seen, turning away at w: too slow",
              "obstacle never in a cone", "hit a teammate already down", "hit a moving teammate"]
    print("\n| cause | " + " | ".join(f"{sp} m/s" for sp in SPEEDS) + " |")
    print("|---" * (len(SPEEDS) + 1) + "|")
    for c in causes:
        print(f"| {c} | " + " | ".join(str(sum(1 for r in allrows if r["speed"] == sp and cause(r) == c)) for sp in SPEEDS) + " |")
    if a.sweeps:
        for name in ["formation_complex", "formation_simple"]:
            sweep(a.swarm, os.path.join(ROOT, "configs", f"{name}.toml"), os.path.join(a.work, f"sweep-{name}"))
        long_budget(a.swarm, os.path.join(a.work, "long-budget"))
        detect_ablation(a.swarm, os.path.join(a.work, "detect-range"))
        tie_ablation(a.swarm, a.work)


if __name__ == "__main__":
    sys.exit(main())
