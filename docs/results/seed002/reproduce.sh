#!/usr/bin/env bash
# Regenerates every number and figure of docs/results/seed002.md (about 4 minutes on 2 cores).
set -euo pipefail
cd "$(dirname "$0")/../../.."
out=docs/results/seed002
tmp=$(mktemp -d)
cargo build --release
swarm=target/release/swarm

# The paper's experiment, planned without flying, then flown by three UAV processes.
$swarm plan configs/planner_uav3.toml > $out/plan.txt
$swarm run configs/planner_uav3.toml --out $tmp/potential --force
$swarm run configs/planner_uav3.toml --out $tmp/no_potential --force --set behaviour.a=0 --set behaviour.b=0
cp $tmp/potential/trajectory.png $out/uav3_top.png
cp $tmp/potential/trajectory_side.png $out/uav3_side.png
python3 $out/pairs.py $tmp/potential $tmp/no_potential > $out/potential.md

# The leader killed mid-flight.
$swarm run configs/planner_uav3_leader_dies.toml --out $tmp/leader_dies --force
cp $tmp/leader_dies/trajectory.png $out/leader_dies_top.png
cp $tmp/leader_dies/trajectory_side.png $out/leader_dies_side.png

# Robustness: loss and delay, 10 seeds each, as processes.
metrics="--metric planner.reached --metric planner.conflicts --metric planner.collisions --metric planner.min_separation --metric planner.replans --metric steps_to_target"
$swarm sweep configs/planner_uav3.toml --vary radio.loss=0,0.1,0.2,0.3 --vary radio.delay_ticks=0,2 \
  --seeds 10 --jobs 2 --out $tmp/sweep_uav3 $metrics
$swarm sweep configs/planner_uav3_leader_dies.toml --vary radio.loss=0,0.2,0.3 --vary radio.delay_ticks=0,2 \
  --seeds 10 --jobs 2 --out $tmp/sweep_leader_dies $metrics
sed -n '/^| radio.loss/,/^$/p' $tmp/sweep_uav3/summary.md > $out/sweep_uav3.md
sed -n '/^| radio.loss/,/^$/p' $tmp/sweep_leader_dies/summary.md > $out/sweep_leader_dies.md

# On leader loss: the paper's autonomy ("continue") against hovering for a new plan, 10 seeds
# per scenario, 3 and 10 UAVs, as processes (about 2 minutes).
python3 $out/autonomy.py $swarm $tmp 3 > $out/autonomy_3.md
python3 $out/autonomy.py $swarm $tmp 10 > $out/autonomy_10.md

# Planner speed, one run, every row against the paper's 30 ms.
cargo run --release -p swarmrt-planner --example compare > $out/compare.txt
echo "wrote $out"
