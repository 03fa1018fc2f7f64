#!/usr/bin/env bash
# Reproduces docs/results/seed001.md's tables: run from the repository root after
# `cargo build --release`. Scratch output goes to $OUT (default /tmp/seed001); tables.md and
# the figures the doc cites are written next to this script.
set -euo pipefail
OUT=${OUT:-/tmp/seed001}
HERE=docs/results/seed001
SWARM=target/release/swarm
JOBS=${JOBS:-2}
SEEDS=${SEEDS:-5}
mkdir -p "$OUT"
M=(--metric grouping.t_s --metric grouping.t_nav --metric grouping.d_m
   --metric grouping.delta_omega --metric grouping.reached --metric collisions
   --metric grouping.groups --metric grouping.leaders --metric grouping.precision)

# The paper's experiments, each sub-scenario 5 times (seeds 1-5: random start positions and
# headings), every robot a process.
"$SWARM" sweep configs/grouping_s1.toml --vary robots.count=4,5,6,7,8 --seeds "$SEEDS" \
  --start-seed 1 --jobs "$JOBS" --out "$OUT/s1" "${M[@]}"
"$SWARM" sweep configs/grouping_s2.toml --vary robots.count=11 --seeds "$SEEDS" \
  --start-seed 1 --jobs "$JOBS" --out "$OUT/s2" "${M[@]}"
for s in "31 11 [4,4,3]" "32 12 [5,4,3]" "33 13 [6,4,3]"; do
  set -- $s
  "$SWARM" sweep configs/grouping_s3.toml --vary behaviour.radius=1.8 --seeds "$SEEDS" \
    --start-seed 1 --jobs "$JOBS" --set robots.count=$2 --set "robots.start.group_sizes=$3" \
    --out "$OUT/s$1" "${M[@]}"
done
"$SWARM" sweep configs/grouping_s4.toml --vary robots.count=9 --seeds "$SEEDS" \
  --start-seed 1 --jobs "$JOBS" --out "$OUT/s4" "${M[@]}"

# Beyond the paper, in-process (the same bytes as processes, see tests/tests/e2e/grouping.rs):
# radio loss 0-50 % and delay 0-10 ticks on S1 (8 robots) and S2, 3 seeds each.
for sc in s1 s2; do
  "$SWARM" sweep configs/grouping_$sc.toml --vary radio.loss=0,0.1,0.2,0.3,0.4,0.5 \
    --vary radio.delay_ticks=0,2,5,10 --seeds 3 --start-seed 1 --jobs "$JOBS" --in-process \
    --out "$OUT/${sc}_radio" "${M[@]}"
done

# Beyond the paper: one group of 8 to 30 robots (S1's field), the circle's radius grown so
# neighbours on it stay 0.75 m apart, the start disc so the robots fit, and the goal so the
# circle fits in it.
for n in 8 12 16 20 25 30; do
  r=$(python3 -c "import math; print(round(max(1.0, $n * 0.75 / (2 * math.pi)), 2))")
  d=$(python3 -c "import math; print(round(max(2.2, 1.1 * math.sqrt($n)), 2))")
  "$SWARM" sweep configs/grouping_s1.toml --vary robots.count=$n --seeds 3 --start-seed 1 \
    --jobs "$JOBS" --in-process --set behaviour.radius=$r --set robots.start.scatter=$d \
    --set "map.goal.radius=$(python3 -c "print($r + 0.6)")" --set scenario.ticks=4000 \
    --set "robots.start.x=$(python3 -c "print(max(5.0, $d + 1.0))")" \
    --out "$OUT/scale_$n" "${M[@]}"
done

# The classifier's precision p_v (eq. 17) with and without lidar noise: S1, 8 robots.
"$SWARM" sweep configs/grouping_s1.toml --vary robots.noise.lidar=0,0.01,0.02,0.05 --seeds 3 \
  --start-seed 1 --jobs "$JOBS" --in-process --out "$OUT/noise" "${M[@]}"

python3 "$HERE/tables.py" "$OUT" > "$HERE/tables.md"
cp "$OUT/s1/runs/robots.count=8_s1/trajectory.png" "$HERE/s1_8_robots.png"
cp "$OUT/s2/runs/robots.count=11_s1/trajectory.png" "$HERE/s2.png"
cp "$OUT/s31/runs/behaviour.radius=1.8_s1/trajectory.png" "$HERE/s31.png"
cp "$OUT/s4/runs/robots.count=9_s1/trajectory.png" "$HERE/s4.png"
cp "$OUT/scale_30/runs/robots.count=30_s1/trajectory.png" "$HERE/scale_30.png"
echo "tables: $HERE/tables.md"

# The ablations behind Tables II-III's gaps (ablation.md; in-process, one job).
OUT="$OUT/ablation" JOBS=1 bash "$HERE/ablate_gaps.sh"

# Why S3's group 1 keeps its ΔΩ as it grows (domega.md; in-process, one job).
OUT="$OUT/domega" JOBS=1 bash "$HERE/domega.sh"
