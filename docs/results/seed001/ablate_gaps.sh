#!/usr/bin/env bash
# Ablations behind the gaps of Tables II-IV (docs/results/seed001.md, "Where the gaps come
# from"): S2, S31 and S4 rerun with one config key changed at a time, 5 seeds each, in-process
# (the same bytes as processes). Run from the repository root after `cargo build --release`;
# writes ablation.md next to this script. Scratch output goes to $OUT (default /tmp/seed001_abl).
set -euo pipefail
OUT=${OUT:-/tmp/seed001_abl}
HERE=docs/results/seed001
SWARM=target/release/swarm
JOBS=${JOBS:-1}
SEEDS=${SEEDS:-5}
mkdir -p "$OUT"

run() { # run <scenario file> <label> [--set key=value ...]
  local cfg=$1 label=$2
  shift 2
  rm -rf "$OUT/$label"
  "$SWARM" sweep "$cfg" --vary robots.count="${COUNT:-11}" --seeds "$SEEDS" --start-seed 1 --jobs "$JOBS" \
    --in-process --out "$OUT/$label" --metric grouping.t_nav "$@" > /dev/null
}

for sc in s2 s3; do
  cfg=configs/grouping_$sc.toml
  run "$cfg" "$sc-base"
  # The formation's centre at 0.45 m/s instead of 0.35: the paper's S3 groups average
  # 33 m in 70 s, 0.47 m/s.
  run "$cfg" "$sc-speed0.45" --set behaviour.group_speed=0.45
  # Wheels without inertia, then with three times the default's.
  run "$cfg" "$sc-turnacc10" --set behaviour.turn_accel=10
  run "$cfg" "$sc-turnacc1" --set behaviour.turn_accel=1
  # Another circle (S2 draws 1.0 m, S3 1.8 m) and a shorter repulsion range.
  if [ $sc = s2 ]; then r=1.5; else r=1.0; fi
  run "$cfg" "$sc-radius" --set behaviour.radius=$r
  run "$cfg" "$sc-rep0.4" --set behaviour.rep_range=0.4
  # A shorter range finder (less of the corridor's clutter sensed).
  run "$cfg" "$sc-lidar2.5" --set robots.lidar.range=2.5 --set robots.range_bearing.range=2.5
done
# S2 only: every leader explores until it sees the goal itself (no leader tells the others),
# which is how the paper's Table II reads: its three groups explore 13.0, 0.7 and 14.3 s.
run configs/grouping_s2.toml s2-noshare --set behaviour.share_goal=false
# S3 only: the three groups start side by side at the first group's distance (x = 16 m),
# each 33-34 m from its goal, as the paper's Table III distances suggest, instead of one
# behind the other; alone and with the faster formation centre.
SIDE='robots.start.groups=[{x=16.0,y=10.0,goal=[49.0,10.0]},{x=16.0,y=3.5,goal=[50.0,4.5]},{x=16.0,y=16.5,goal=[50.0,15.5]}]'
run configs/grouping_s3.toml s3-side --set "$SIDE"
run configs/grouping_s3.toml s3-side-speed0.45 --set "$SIDE" --set behaviour.group_speed=0.45
# S3 only: groups 2 and 3 aim at goals 2 m either side of the corridor's axis (y 8 and 12)
# instead of 4.5 and 15.5 m, which lie beyond its walls (y 6-14): their circles stop rubbing on
# the walls.
run configs/grouping_s3.toml s3-goalsinline --set 'robots.start.groups=[{x=16.0,y=10.0,goal=[49.0,10.0]},{x=9.5,y=10.0,goal=[50.0,8.0]},{x=3.0,y=10.0,goal=[50.0,12.0]}]'
# S4 (9 robots): the faster centre, and the S1-S3 leader (straight with detours, no map).
COUNT=9 run configs/grouping_s4.toml s4-base
COUNT=9 run configs/grouping_s4.toml s4-speed0.45 --set behaviour.group_speed=0.45
COUNT=9 run configs/grouping_s4.toml s4-detour --set behaviour.leader_nav=detour
# S4 without the two caps that make group 1's dead-end pockets (its walls and doors kept).
NOPOCKETS=$(python3 -c "
import tomllib
c = tomllib.load(open('configs/grouping_s4.toml', 'rb'))
rs = [r for r in c['map']['rectangles'] if not (r['y_min'] == 8.0 and r['y_max'] == 9.0)]
print('map.rectangles=[' + ','.join('{x_min=%s,y_min=%s,x_max=%s,y_max=%s}'
      % (r['x_min'], r['y_min'], r['x_max'], r['y_max']) for r in rs) + ']')")
COUNT=9 run configs/grouping_s4.toml s4-nopockets --set "$NOPOCKETS"
# S4 over a hostile radio: the formations and members' reports lost or late.
COUNT=9 run configs/grouping_s4.toml s4-loss0.4 --set radio.loss=0.4
COUNT=9 run configs/grouping_s4.toml s4-delay5 --set radio.delay_ticks=5

# Table III's first group grows from 4 to 6 robots (S31-S33): its ΔΩ, with the default wheels,
# without their inertia, with a shorter repulsion range and with the faster centre.
for n in "11 [4,4,3]" "12 [5,4,3]" "13 [6,4,3]"; do
  set -- $n
  for v in "base" "turnacc10 behaviour.turn_accel=10" "rep0.4 behaviour.rep_range=0.4" \
           "speed0.45 behaviour.group_speed=0.45"; do
    set -- $1 $2 $v
    extra=()
    if [ $# -eq 4 ]; then extra=(--set "$4"); fi
    rm -rf "$OUT/g1-$1-$3"
    "$SWARM" sweep configs/grouping_s3.toml --vary behaviour.radius=1.8 --set robots.count=$1 --seeds "$SEEDS" --start-seed 1 \
      --jobs "$JOBS" --in-process --set "robots.start.group_sizes=$2" "${extra[@]}" \
      --out "$OUT/g1-$1-$3" --metric grouping.t_nav > /dev/null
  done
done

python3 "$HERE/ablate_gaps.py" "$OUT" > "$HERE/ablation.md"
echo "ablation: $HERE/ablation.md"
