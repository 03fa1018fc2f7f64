#!/usr/bin/env python3
"""Alternates runs of two or more builds of swarmrt on the bench scenario and prints each run
and the medians: the way to compare a change on a machine whose speed drifts by a third
between minutes (docs/benchmarks.md, "Issue 19, second pass").

    python3 benchmarks/scripts/alternate.py N TICKS ROUNDS DIR_A DIR_B [...]

Each DIR holds a `swarm` with its `swarm-world` and `swarm-agent` beside it (copy them out of
target/release/ before and after the change). A run is `swarm run configs/goto_simple.toml`
with N robot processes on the map `swarm bench swarm` uses for N. Per run it prints the median
and mean tick, the CPU of all processes per tick (from the children's rusage) and the world's
mean phase times (from metrics.json), all in microseconds.
"""
import json
import math
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "goto_simple.toml"


def scenario(n):
    """The overrides of benchmarks/src/swarm.rs `scenario` for n robots."""
    r_start = math.sqrt(n / math.pi) * 0.7 + 1.0
    side = float(math.ceil(max(2.0 * r_start + 6.0, 12.0)))
    centre, goal = side / 2.0, side / 2.0 + r_start / 2.0
    sets = [f"robots.count={n}", "scenario.stop_when_done=false",
            f"map.bounds=[0.0,0.0,{side},{side}]", f"robots.start.x={centre}",
            f"robots.start.y={centre}", f"map.goal.x={goal}", f"map.goal.y={goal}"]
    return [a for s in sets for a in ("--set", s)]


def run(build, n, ticks, out):
    shutil.rmtree(out, ignore_errors=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([str(Path(build) / "swarm"), "run", str(CONFIG), "--out", str(out),
                    "--ticks", str(ticks), *scenario(n)],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    t = json.loads((out / "metrics.json").read_text())["shell"]["timing"]
    return {"median": t["tick_ms_median"] * 1e3, "mean": t["seconds"] / t["ticks"] * 1e6,
            "cpu": cpu / t["ticks"] * 1e6, "observe": t["observe_ms_mean"] * 1e3,
            "publish": t["publish_ms_mean"] * 1e3, "wait": t["wait_ms_mean"] * 1e3,
            "step": t["step_ms_mean"] * 1e3, "record": t["record_ms_mean"] * 1e3}


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    n, ticks, rounds = (int(a) for a in sys.argv[1:4])
    builds = sys.argv[4:]
    rows = {b: [] for b in builds}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(rounds):
            for b in builds:
                row = run(b, n, ticks, Path(tmp) / "run")
                rows[b].append(row)
                print(b, " ".join(f"{k}={v:.0f}" for k, v in row.items()), flush=True)
    for b in builds:
        med = {k: statistics.median(r[k] for r in rows[b]) for k in rows[b][0]}
        print("median of runs", b, " ".join(f"{k}={v:.0f}" for k, v in med.items()))


if __name__ == "__main__":
    main()
