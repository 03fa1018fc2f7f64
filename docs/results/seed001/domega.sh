#!/usr/bin/env bash
# Issue 35, part 1: why S3's first group keeps its ΔΩ (eq. 16) when it grows from 4 to 6 robots
# (Table III: 17.18 -> 22.4 -> 29.6 deg/s², 1.72x). Each row reruns S31-S33 (group 1 of 4, 5, 6
# robots) with one config key changed, 5 seeds each, in-process (the same bytes as processes);
# S1 (4-8 robots) and S2 run once more with the committed configs for the two readings of eq. 16.
# Run from the repository root after `cargo build --release`; writes domega.md next to this
# script and the per-robot and per-phase numbers (domega_robots.csv, domega.json) to $OUT.
set -euo pipefail
OUT=${OUT:-/tmp/seed001_domega}
HERE=docs/results/seed001
SWARM=${SWARM:-target/release/swarm}
JOBS=${JOBS:-1}
SEEDS=${SEEDS:-5}
mkdir -p "$OUT"

# r <label> "<circle radius for 4, 5, 6 robots>" [--set key=value ...]: S31, S32, S33, where
# group 1 has 4, 5 and 6 robots (13 robots at most, groups 2-3 stay 4 and 3).
r() {
  local label=$1 radii=($2)
  shift 2
  local sizes=(4 5 6) counts=(11 12 13) starts=("[4,4,3]" "[5,4,3]" "[6,4,3]")
  for i in 0 1 2; do
    local out="$OUT/$label-g${sizes[$i]}"
    rm -rf "$out"
    "$SWARM" sweep configs/grouping_s3.toml --vary "behaviour.radius=${radii[$i]}" \
      --set robots.count=${counts[$i]} --set "robots.start.group_sizes=${starts[$i]}" "$@" \
      --seeds "$SEEDS" --start-seed 1 --jobs "$JOBS" --in-process --out "$out" \
      --metric grouping.delta_omega > /dev/null
  done
}

R="1.8 1.8 1.8"
r base "$R"
# The circle: grown with the group so neighbours stay 2.55 m apart (the 4-robot chord), or
# shrunk to 1.0 m so they close from 1.41 to 1.0 m (inside a longer repulsion range).
r radius-scaled "1.8 2.25 2.7"
r radius1.0 "1.0 1.0 1.0"
# Member-member repulsion: rho_0 0.7 m (default) -> 0.4, 1.5, 2.0 m. At 1.8 m the neighbours
# on the circle are 2.55 (4), 2.12 (5) and 1.80 m (6) apart: 2.0 m reaches them only from 5 on.
r rep0.4 "$R" --set behaviour.rep_range=0.4
r rep1.5 "$R" --set behaviour.rep_range=1.5
r rep2.0 "$R" --set behaviour.rep_range=2.0
r radius1.0-rep1.5 "1.0 1.0 1.0" --set behaviour.rep_range=1.5
r radius1.2 "1.2 1.2 1.2"
# The repulsion's strength: k_rep 0.02 (default) -> 0.1 m^3/s, alone and with rho_0 2.0 m (at
# 1.8-2.0 m Khatib's force of the default k_rep is below 0.001 m/s: in range, but too weak).
r krep0.1 "$R" --set behaviour.k_rep=0.1
r rep2.0-krep0.1 "$R" --set behaviour.rep_range=2.0 --set behaviour.k_rep=0.1
# Gains: slot attraction and turn gain, halved and doubled.
r katt0.5 "$R" --set behaviour.k_att=0.5
r katt2 "$R" --set behaviour.k_att=2.0
r kturn1.5 "$R" --set behaviour.k_turn=1.5
r kturn6 "$R" --set behaviour.k_turn=6.0
# The turn-rate limit: raw (no wheel inertia) and three times the default's inertia.
r turnacc-raw "$R" --set behaviour.turn_accel=1000000
r turnacc1 "$R" --set behaviour.turn_accel=1
# Sensor and odometry noise (the paper's Gazebo has some; ours is exact by default).
r lidar0.05 "$R" --set robots.noise.lidar=0.05
r heading0.05 "$R" --set robots.noise.heading=0.05
r slip0.05 "$R" --set robots.noise.wheel_slip=0.05
# The faster formation centre (the paper's S3 groups average 0.47 m/s).
r speed0.45 "$R" --set behaviour.group_speed=0.45

# The committed S1 (Table I, 4-8 robots) and S2 (Table II) for eq. 16 read as a mean and as a sum.
rm -rf "$OUT/s1" "$OUT/s2"
"$SWARM" sweep configs/grouping_s1.toml --vary robots.count=4,5,6,7,8 --seeds "$SEEDS" \
  --start-seed 1 --jobs "$JOBS" --in-process --out "$OUT/s1" --metric grouping.delta_omega > /dev/null
"$SWARM" sweep configs/grouping_s2.toml --vary robots.count=11 --seeds "$SEEDS" \
  --start-seed 1 --jobs "$JOBS" --in-process --out "$OUT/s2" --metric grouping.delta_omega > /dev/null

python3 "$HERE/domega.py" "$OUT" > "$HERE/domega.md"
echo "domega: $HERE/domega.md (rows: $OUT/domega_robots.csv, $OUT/domega.json)"
