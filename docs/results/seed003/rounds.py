"""Appendix A's one-step propagation over the real IPC (`radio.rounds`) against today's one
robot per tick: the corridor (16), the snake (140) and the hairpin chain (451), each as robot
processes without rounds, with a cap of 16 rounds and with a cap above the chain's length.

Usage: python3 rounds.py SWARM OUT_DIR [in-process]
(prints a markdown table; about 10 minutes on 2 cores. With `in-process`, the same runs in one
process instead, for their ticks/s without IPC; they write the same bytes.)
"""
import json
import subprocess
import sys

swarm, out = sys.argv[1], sys.argv[2]
in_process = sys.argv[3:] == ["in-process"]
RUNS = [
    ("corridor", "configs/chain_corridor.toml", 16),
    ("snake", "configs/chain_snake_140.toml", 140),
    ("chain", "configs/chain_450.toml", 451),
]
CAPS = [0, 16, 1024]
MODE = ["--in-process"] if in_process else []

print(f"| chain | robots | radio.rounds | ticks | ticks/s ({'in-process' if in_process else 'processes'}) | head-to-tail lag, ticks (s) | ticks per robot "
      "| rod violations / rod-ticks | angle violations | collisions | rounds per tick (max) | wake-ups per tick | capped ticks |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for name, config, n in RUNS:
    for cap in CAPS:
        d = f"{out}/{name}_{cap}"
        subprocess.run([swarm, "run", config, "--out", d, "--force", "--set", f"radio.rounds={cap}", *MODE],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        m = json.load(open(f"{d}/metrics.json"))
        c = m["chain"]
        r = m.get("rounds")
        dt = 0.1
        lag = c["propagation_ticks"]
        lag_s = "-" if lag is None else f"{lag} ({lag * dt:.1f} s)"
        per = "-" if c["propagation_per_robot"] is None else f'{c["propagation_per_robot"]:.2f}'
        if r:
            t = m["ticks"]
            rounds = f'{r["rounds"] / t:.1f} ({r["max_in_a_tick"]})'
            wake = f'{r["wakeups"] / t:.1f}'
            capped = r["capped_ticks"]
        else:
            rounds, wake, capped = "-", "-", "-"
        print(f'| {name} | {n} | {cap} | {m["ticks"]} | {m["ticks_per_second"]:.0f} | {lag_s} | {per} '
              f'| {c["rod_violations"]} / {c["rod_ticks"]} | {c["angle_violations"]} | {c["collisions"]} '
              f'| {rounds} | {wake} | {capped} |', flush=True)
