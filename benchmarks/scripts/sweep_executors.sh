#!/bin/sh
# Sweep throughput by executor (issue 36): the same 200-run goto sweep on this machine with
# --jobs 2, through Slurm (one run per task, then 10), and over two emulated hosts with the
# ssh executor (network + mount namespaces with their own /dev/shm, `nsenter` as the
# launcher, one run at a time each; needs root), back to back; prints wall seconds, runs per minute and whether
# the two sweep.csv agree (wall-clock columns left out).
# Usage: SLURM_CONF=/path/slurm.conf benchmarks/scripts/sweep_executors.sh [SWARM] [OUT]
# (a Slurm cluster must answer; tests/src/slurm.rs shows a one-node one on this machine).
set -e
SWARM=${1:-target/release/swarm}
OUT=${2:-/tmp/sweep_executors}
SWEEP="configs/goto_simple.toml --vary radio.loss=0,0.1,0.2,0.3 --seeds 50"
mkdir -p "$OUT"
# Two emulated hosts for the ssh executor, as tests/src/lab.rs makes them.
HOLDERS=
printf '' > "$OUT/hosts.toml"
for h in 0 1; do
  ip netns add "swexec$h"
  ip netns exec "swexec$h" unshare --mount --propagation private \
    sh -c 'mount -t tmpfs swexec /dev/shm && exec sleep 100000' &
  HOLDERS="$HOLDERS $!"
done
sleep 1
h=0
for pid in $HOLDERS; do
  # The holder's child (sleep) has the namespaces; `ip netns exec` forked it.
  inner=$(pgrep -P "$pid" || echo "$pid")
  printf '[[host]]\nname = "h%s"\nlauncher = ["nsenter", "-t", "%s", "-n", "-m", "--"]\n' "$h" "$inner" >> "$OUT/hosts.toml"
  h=$((h + 1))
done
cleanup() {
  for pid in $HOLDERS; do pkill -P "$pid" 2>/dev/null; kill "$pid" 2>/dev/null; done
  ip netns del swexec0 2>/dev/null; ip netns del swexec1 2>/dev/null
}
trap cleanup EXIT
for ex in local slurm slurm10 ssh; do
  rm -rf "$OUT/$ex"
  start=$(date +%s.%N)
  if [ "$ex" = local ]; then
    $SWARM sweep $SWEEP --jobs 2 --out "$OUT/$ex" > /dev/null
  elif [ "$ex" = slurm ]; then
    $SWARM sweep $SWEEP --executor slurm --out "$OUT/$ex" > /dev/null
  elif [ "$ex" = slurm10 ]; then
    $SWARM sweep $SWEEP --executor slurm --runs-per-task 10 --out "$OUT/$ex" > /dev/null
  else
    $SWARM sweep $SWEEP --executor ssh --hosts "$OUT/hosts.toml" --out "$OUT/$ex" > /dev/null
  fi
  end=$(date +%s.%N)
  echo "$ex $start $end" >> "$OUT/times.txt"
done
python3 - "$OUT" <<'PY'
import csv, statistics, sys
out = sys.argv[1]
times = {l.split()[0]: float(l.split()[2]) - float(l.split()[1]) for l in open(f"{out}/times.txt")}
wall = lambda c: c in ("wall_seconds", "ticks_per_second", "startup_ms") or c.startswith("shell.timing.")
rows = {}
print("| executor | runs | wall s | runs/min | median run s | overhead per run s |")
print("|---|---:|---:|---:|---:|---:|")
for ex in ("local", "slurm", "slurm10", "ssh"):
    r = list(csv.DictReader(open(f"{out}/{ex}/sweep.csv")))
    rows[ex] = {(x["radio.loss"], x["seed"]): {k: v for k, v in x.items() if not wall(k)} for x in r}
    med = statistics.median(float(x["wall_seconds"]) for x in r)
    t = times[ex]
    # Two runs at a time either way: each slot spends t / (runs / 2) per run.
    print(f"| {ex} | {len(r)} | {t:.1f} | {60 * len(r) / t:.0f} | {med:.2f} | {t / (len(r) / 2) - med:.2f} |")
print("rows equal (wall-clock columns left out):", all(rows["local"] == rows[ex] for ex in rows))
PY
rm -f "$OUT/times.txt"
