#!/bin/bash
# Alternates `swarm-bench swarm` of two builds at N robots, PAIRS times, and prints each run's
# runtime and iceoryx2-floor median tick (ms), the world's publish wall and CPU, and the robot
# turns: the way to compare a new runtime with an old build's floor on a drifting machine.
#
#   benchmarks/scripts/alternate_bench.sh OLD_DIR NEW_DIR [N] [PAIRS]
#
# Each DIR holds a swarm-bench with swarm, swarm-world and swarm-agent beside it.
set -euo pipefail
old=$1 new=$2 n=${3:-1000} pairs=${4:-4}
cd "$(dirname "$0")/../.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for i in $(seq 1 "$pairs"); do
  for b in "$old" "$new"; do
    out=$tmp/run
    rm -rf "$out"
    "$b/swarm-bench" swarm --agents "$n" --ticks 100 --rounds 1 --peers iox2 \
      --in-process-agents 100 --in-process-ticks 1 --json --out "$out" > "$tmp/r.json" 2>/dev/null
    python3 - "$tmp/r.json" "$i" "$b" <<'PY'
import json, sys
v = json.load(open(sys.argv[1]))
r, f = v["runtime"][0], v["floor"][0]
turn = lambda x: (x.get("cpu") or {}).get("robot_turn_us")
print(sys.argv[2], sys.argv[3],
      "runtime %.2f floor %.2f publish %.2f publish_cpu %s turn_runtime %s turn_floor %s" % (
          r["tick_ms_median"], f["result"]["tick_ns"]["median"] / 1e6,
          r["phases_ms"]["publish"], r["phases_ms"].get("publish_cpu"), turn(r), turn(f)))
PY
  done
done
