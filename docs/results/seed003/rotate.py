#!/usr/bin/env python3
"""Push-Pull-Rotate's two rotations compared: the master's trail (`behaviour.rotate =
"trail"`, the default) against Appendix A's random shake of the colliding point ("shake"),
on the MobotSim corridor (16 robot processes, seeds 1-5) and the 140-robot snake (in-process,
which writes the same records as processes, seeds 1-3).

usage: rotate.py SWARM OUT_DIR > rotate.md
"""
import json
import subprocess
import sys

SWARM, TMP = sys.argv[1], sys.argv[2]
CASES = [("chain_corridor", "processes", range(1, 6)), ("chain_snake_140", "in-process", range(1, 4))]
ROTATES = ["trail", "shake"]


def run(config, mode, rotate, seed):
    d = f"{TMP}/{config}-{rotate}-{seed}"
    args = [SWARM, "run", f"configs/{config}.toml", "--out", d, "--force",
            "--set", f"scenario.seed={seed}", "--set", f'behaviour.rotate="{rotate}"']
    if mode == "in-process":
        args.append("--in-process")
    out = subprocess.run(args, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"{config} {rotate} {seed}: {out.stderr}")
    m = json.load(open(f"{d}/metrics.json"))
    return m


print("| config | rotate | seeds | rod violations (of rod-ticks) | angle violations | vetoes | collisions | reached | tail home, s (mean) | head progress, m (mean) |")
print("|---|---|---|---|---|---|---|---|---|---|")
for config, mode, seeds in CASES:
    for rotate in ROTATES:
        ms = [run(config, mode, rotate, s) for s in seeds]
        c = [m["chain"] for m in ms]
        n = len(seeds)
        tails = [x["tail_reached_tick"] * 0.1 for x in c if x.get("tail_reached_tick") is not None]
        tail = f"{sum(tails) / len(tails):.1f} ({len(tails)} of {n})" if tails else f"- (0 of {n})"
        print(f"| {config} ({mode}) | {rotate} | {seeds.start}-{seeds.stop - 1} | "
              f"{sum(x['rod_violations'] for x in c)} of {sum(x['rod_ticks'] for x in c)} | "
              f"{sum(x['angle_violations'] for x in c)} | {sum(x['vetoes'] for x in c)} | "
              f"{sum(x['collisions'] for x in c)} | {sum(x['reached'] for x in c) / n:.1f} | {tail} | "
              f"{sum(x['head_progress'] for x in c) / n:.2f} |")
