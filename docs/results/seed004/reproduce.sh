#!/usr/bin/env bash
# Reproduces docs/results/seed004.md's numbers (except the PSO, see tune.sh): run from the
# repository root after `cargo build --release`. Scratch output goes to $OUT (default
# /tmp/seed004); the summaries, tables and figures the doc cites are copied next to this
# script.
set -euo pipefail
OUT=${OUT:-/tmp/seed004}
HERE=docs/results/seed004
SWARM=target/release/swarm
JOBS=${JOBS:-2}
mkdir -p "$OUT"

keep() { # keep <sweep dir> <name>: summary, table and plots under $HERE/<name>*
  cp "$1/summary.md" "$HERE/$2_summary.md"
  cp "$1/sweep.csv" "$HERE/$2_sweep.csv"
}

# Environments 1 and 2, hand-crafted weights, compass vs odometry (both with 5 % wheel slip,
# so the world moves the same way and only the heading source differs), 10 seeds, robot
# processes. Seeds move each robot up to 2 cm off its start point.
for env in obstacles crossing; do
  "$SWARM" sweep configs/flocking_$env.toml --vary behaviour.heading=compass,odometry \
    --set robots.noise.wheel_slip=0.05 --set robots.start.jitter=0.02 \
    --seeds 10 --jobs "$JOBS" --out "$OUT/$env" \
    --metric flocking.performance --metric flocking.order --metric flocking.cohesion \
    --metric flocking.velocity --metric flocking.fitness --metric collisions
  keep "$OUT/$env" "$env"
done

# Environment 3, the calibrated e-pucks, 10 seeds, robot processes.
"$SWARM" sweep configs/flocking_calibrated.toml --vary behaviour.heading=odometry \
  --set robots.start.jitter=0.01 --seeds 10 --jobs "$JOBS" --out "$OUT/calibrated" \
  --metric flocking.performance --metric flocking.order --metric flocking.cohesion \
  --metric flocking.velocity --metric flocking.fitness --metric collisions
keep "$OUT/calibrated" calibrated

# Beyond the paper: p̄ against radio loss and delay, environment 1, 3 seeds each (in-process:
# the same bytes as processes, see tests/tests/e2e/flocking.rs).
"$SWARM" sweep configs/flocking_obstacles.toml --vary radio.loss=0,0.1,0.2,0.3,0.4,0.5 \
  --vary radio.delay_ticks=0,2,5,10 --set robots.start.jitter=0.02 --seeds 3 --jobs "$JOBS" \
  --in-process --out "$OUT/radio" \
  --metric flocking.performance --metric flocking.cohesion --metric flocking.order --metric collisions
keep "$OUT/radio" radio
cp "$OUT/radio/plots/flocking.performance.png" "$HERE/radio_performance.png" 2>/dev/null ||
  cp "$(ls "$OUT"/radio/plots/*performance*.png | head -1)" "$HERE/radio_performance.png"

# Beyond the paper: flocks of 5, 50 and 200 robot processes in a larger field, with the
# paper's D = 0.1 m and with D grown with the flock, D = 0.1 sqrt(N / 5).
scale() { # scale <n> <D> <tag>
  "$SWARM" run configs/flocking_obstacles.toml --set robots.count=$1 --set behaviour.desired_distance=$2 \
    --set 'map.bounds=[0.0, 0.0, 8.0, 4.0]' --set 'map.goal={ x = 7.7, y = 2.0, radius = 0.2 }' \
    --set 'map.circles=[{ x = 3.0, y = 1.6, r = 0.06 }, { x = 3.6, y = 2.4, r = 0.06 }, { x = 4.2, y = 1.8, r = 0.06 }, { x = 4.8, y = 2.2, r = 0.06 }]' \
    --set robots.start.x=1.0 --set robots.start.y=2.0 --set scenario.name=flocking_scale_$1 \
    --out "$OUT/scale_$3"
  cp "$OUT/scale_$3/trajectory.png" "$HERE/scale_$3_trajectory.png"
  cp "$OUT/scale_$3/flocking.png" "$HERE/scale_$3_flocking.png"
  cp "$OUT/scale_$3/metrics.json" "$HERE/scale_$3_metrics.json"
}
if true; then
  for n in 5 50 200; do
    scale $n 0.1 ${n}
    scale $n "$(python3 -c "print(round(0.1 * ($n / 5) ** 0.5, 3))")" ${n}_scaled_d
  done
fi

# Figures like the paper's Fig. 4-8: one run each, seed 1.
fig() { # fig <name> <config> <args...>
  local name=$1 cfg=$2; shift 2
  "$SWARM" run "$cfg" --out "$OUT/fig_$name" "$@"
  cp "$OUT/fig_$name/flocking.png" "$HERE/${name}_performance.png"
  cp "$OUT/fig_$name/trajectory.png" "$HERE/${name}_trajectory.png"
}
fig env1_odometry configs/flocking_obstacles.toml --set behaviour.heading=odometry --set robots.noise.wheel_slip=0.05
fig env2_odometry configs/flocking_crossing.toml --set behaviour.heading=odometry --set robots.noise.wheel_slip=0.05
fig env1_compass configs/flocking_obstacles.toml --set robots.noise.wheel_slip=0.05
fig env2_compass configs/flocking_crossing.toml --set robots.noise.wheel_slip=0.05
fig env3_calibrated configs/flocking_calibrated.toml

# Where the radio does start to matter: loss up to 100 %, delay up to 30 ticks (1.9 s).
"$SWARM" sweep configs/flocking_obstacles.toml --vary radio.loss=0.8,0.9,0.95,0.99,1 \
  --vary radio.delay_ticks=0,10,30 --set robots.start.jitter=0.02 --seeds 3 --jobs "$JOBS" \
  --in-process --out "$OUT/radio_harsh" \
  --metric flocking.performance --metric flocking.cohesion --metric flocking.order --metric collisions
keep "$OUT/radio_harsh" radio_harsh
