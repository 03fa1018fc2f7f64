#!/usr/bin/env python3
"""Seed 002's autonomy, compared: behaviour.on_leader_loss = "continue" (the paper) against
"hover" (wait for a leader's plan), under a leader kill, the leader cut off in a minority, a
5 s blackout mid-flight and radio loss, 10 seeds each, as robot processes (release build).

usage: autonomy.py SWARM OUT_DIR [COUNT] > autonomy.md
"""
import concurrent.futures
import json
import subprocess
import sys

SWARM, TMP = sys.argv[1], sys.argv[2]
COUNT = int(sys.argv[3]) if len(sys.argv) > 3 else 3
CONFIG = "configs/planner_uav3.toml"
SEEDS = range(1, 11)
KILL = 'faults.kill=[{tick=120,robot="leader"}]'
SCENARIOS = [
    ("leader killed at tick 120", [KILL]),
    ("leader killed, 30 % loss, 2-tick delay", [KILL, "radio.loss=0.3", "radio.delay_ticks=2"]),
    ("leader cut off alone, ticks 120-900", ["PARTITION"]),
    ("blackout 5 s, ticks 150-200", ["faults.blackout=[{from=150,to=200}]"]),
    ("10 % loss, 2-tick delay", ["radio.loss=0.1", "radio.delay_ticks=2"]),
    ("30 % loss, 2-tick delay", ["radio.loss=0.3", "radio.delay_ticks=2"]),
]
POLICIES = ["continue", "hover"]


def run(args):
    out = subprocess.run([SWARM, "run", CONFIG, *args], capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"{args}: {out.stderr}")
    return out.stdout.strip().splitlines()[-1]


def leader_at_120(seed):
    """The leader at tick 119 of this seed (the same in both modes and policies)."""
    d = f"{TMP}/leader-{COUNT}-{seed}"
    run(["--in-process", "--ticks", "119", "--out", d, "--force",
         "--set", f"scenario.seed={seed}", "--set", f"robots.count={COUNT}"])
    leader = None
    for line in open(f"{d}/events.jsonl"):
        e = json.loads(line)
        state = e.get("note", {}) if isinstance(e.get("note"), dict) else {}
        state = state.get("consensus", {}).get("state") if isinstance(state.get("consensus"), dict) else None
        if state and state.get("role") == "leader":
            leader = e["robot"]
    return leader


def one(job):
    name, sets, policy, seed, leader = job
    args = []
    for s in sets:
        if s == "PARTITION":
            s = f"faults.partition=[{{from=120,to=900,groups=[[{leader}]]}}]"
        args += ["--set", s]
    d = f"{TMP}/{COUNT}-{SCENARIOS.index((name, sets))}-{policy}-{seed}"
    run(["--out", d, "--force", "--set", f"scenario.seed={seed}", "--set", f"robots.count={COUNT}",
         "--set", f'behaviour.on_leader_loss="{policy}"', *args])
    m = json.load(open(f"{d}/metrics.json"))
    p = m["planner"]
    alive = COUNT - m["dead"]
    return (name, policy, {
        "reached": p["reached"], "alive": alive, "conflicts": p["conflicts"],
        "collisions": p["collisions"], "replans": p["replans"], "detours": p["detours"],
        "hovers": p["hovers"], "stalled": "stalled" in m,
        "last": m.get("steps_to_target") if p["reached"] == alive else None,
    })


def main():
    leaders = {seed: leader_at_120(seed) for seed in SEEDS}
    jobs = [(n, s, pol, seed, leaders[seed]) for (n, s) in SCENARIOS for pol in POLICIES for seed in SEEDS]
    with concurrent.futures.ThreadPoolExecutor(2) as ex:
        results = list(ex.map(one, jobs))
    print(f"{COUNT} UAVs (`{CONFIG}`{'' if COUNT == 3 else f' --set robots.count={COUNT}'}), "
          f"seeds 1-10 each, robot processes. Leaders at tick 120 by seed: "
          + ", ".join(f"{s}: {l}" for s, l in leaders.items()) + ".\n")
    print("| scenario | on_leader_loss | survivors home | conflicts | collisions | last arrival, s (mean, all home) | re-plans | detours | hovers | stalled runs |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for (name, _) in SCENARIOS:
        for pol in POLICIES:
            rs = [r for (n, p, r) in results if n == name and p == pol]
            home = sum(r["reached"] for r in rs)
            alive = sum(r["alive"] for r in rs)
            lasts = [r["last"] for r in rs if r["last"] is not None]
            last = f"{sum(lasts) / len(lasts) * 0.1:.1f} ({len(lasts)} runs)" if lasts else "-"
            print(f"| {name} | {pol} | {home} of {alive} | {sum(r['conflicts'] for r in rs)} | "
                  f"{sum(r['collisions'] for r in rs)} | {last} | {sum(r['replans'] for r in rs)} | "
                  f"{sum(r['detours'] for r in rs)} | {sum(r['hovers'] for r in rs)} | "
                  f"{sum(r['stalled'] for r in rs)} |")


main()
