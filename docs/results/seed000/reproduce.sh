#!/usr/bin/env bash
# Reproduces docs/results/seed000.md's tables and figures: run from the repository root after
# `cargo build --release`. Scratch output goes to $OUT (default /tmp/seed000); the summaries,
# figures and complex_collisions.md the doc cites are written next to this script.
set -euo pipefail
OUT=${OUT:-/tmp/seed000}
HERE=docs/results/seed000
SWARM=target/release/swarm
JOBS=${JOBS:-1}
SPEEDS=0.1,0.2,0.5,1,1.5,2,2.5,3,3.5,4,4.5,5,5.5
M=(--metric reached_target --metric down --metric steps_to_target --metric energy_saving
   --metric formation_error_rms --metric loops_detected --metric epsilon_flips)
mkdir -p "$OUT"

# sweep NAME CONFIG ARGS...: one sweep, its summary and figures copied here.
sweep() {
  local name=$1 config=$2
  shift 2
  rm -rf "${OUT:?}/$name"
  "$SWARM" sweep "$config" "$@" --jobs "$JOBS" --out "$OUT/$name" "${M[@]}" >/dev/null
  cp "$OUT/$name/summary.md" "$HERE/summary_$name.md"
}

# Fig. 11-12: both maps, the paper's speeds and turn angles, 5 seeds (in-process: the same
# bytes as processes, see tests/tests/e2e/formation.rs).
for map in simple complex; do
  sweep $map configs/formation_$map.toml --vary behaviour.speed=$SPEEDS \
    --vary behaviour.turn_deg=1,5,10,20 --seeds 5 --in-process
  for fig in reached_target down steps_to_target; do
    cp "$OUT/$map/plots/$fig.png" "$HERE/${map}_$fig.png"
  done
done
# Fig. 7: lidar energy against the robot count.
sweep energy configs/formation_simple.toml --vary robots.count=4,5,6,7,8,9,10 --seeds 3 --in-process
cp "$OUT/energy/plots/energy_saving.png" "$HERE/energy_saving.png"
# Fig. 8-9: epsilon-greedy on and off on the deadlock map.
sweep deadlock configs/formation_deadlock.toml --vary behaviour.epsilon_clear=0,0.01 \
  --vary behaviour.epsilon_obstacle=0,0.001 --seeds 20 --in-process
cp "$OUT/deadlock/plots/reached_target.png" "$HERE/deadlock_reached_target.png"
# Beyond the paper: radio loss and delay, verdicts living 3 and 12 ticks, and robot processes.
sweep radio configs/formation_simple.toml --vary radio.loss=0,0.1,0.2,0.3,0.4,0.5 \
  --vary radio.delay_ticks=0,2,5,10 --seeds 5 --in-process
cp "$OUT/radio/plots/reached_target.png" "$HERE/radio_reached_target.png"
sweep radio_v12 configs/formation_simple.toml --vary radio.loss=0,0.1,0.2,0.3,0.4,0.5 \
  --vary radio.delay_ticks=0,2,5,10 --seeds 5 --in-process --set behaviour.verdict_ticks=12
cp "$OUT/radio_v12/plots/reached_target.png" "$HERE/radio_v12_reached_target.png"
sweep radio_processes configs/formation_simple.toml --vary radio.loss=0,0.2,0.4 \
  --vary radio.delay_ticks=0,5 --seeds 2

# The complex map's collisions at w = 1 deg below 1 m/s, traced, and the w = 1, 5 deg sweeps
# on both maps with 10 seeds, then the ablations (tick budget, detect range, gap_tie).
python3 "$HERE/complex_collisions.py" --work "$OUT/collisions" --sweeps > "$HERE/complex_collisions.md"
# The same trace with the rule before issue 35 (straight on when only the side observers see).
python3 "$HERE/complex_collisions.py" --work "$OUT/collisions" --gap-tie 1000 > "$HERE/complex_collisions_straight.md"

# Steps to the target on the deadlock map, from each run's metrics.json (sweep.csv leaves the
# column out when the first run it reads never reached).
python3 - "$OUT/deadlock/runs" > "$HERE/deadlock_steps.md" <<'PY'
import collections, json, os, statistics, sys
runs = sys.argv[1]
steps = collections.defaultdict(list)
for d in sorted(os.listdir(runs)):
    key = tuple(p.split("=")[1] for p in d.rsplit("_s", 1)[0].split("_behaviour.")[0:2])
    m = json.load(open(os.path.join(runs, d, "metrics.json")))
    if m.get("steps_to_target") is not None:
        steps[key].append(m["steps_to_target"])
print("| epsilon_clear | epsilon_obstacle | runs that reached | steps to target (mean ± sd) |")
print("|---|---|---|---|")
for key in sorted(steps):
    s = steps[key]
    print(f"| {key[0]} | {key[1]} | {len(s)} | {statistics.mean(s):.0f} ± {statistics.stdev(s):.0f} |")
PY

# Two runs the doc describes: the simple map's zigzag through the wall's gap at w = 20 deg,
# 1.5 m/s (seed 2), and the complex map's detour at w = 5 deg, 0.1 m/s (seed 1).
cp "$OUT/simple/runs/behaviour.speed=1.5_behaviour.turn_deg=20_s2/trajectory.png" \
  "$HERE/simple_w20_v1.5_s2_trajectory.png"
cp "$OUT/complex/runs/behaviour.speed=0.1_behaviour.turn_deg=5_s1/trajectory.png" \
  "$HERE/complex_w5_v0.1_s1_trajectory.png"
