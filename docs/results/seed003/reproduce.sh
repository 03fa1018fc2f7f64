#!/usr/bin/env bash
# Regenerates every number and figure of docs/results/seed003.md (about 15 minutes on 2
# cores, most of it the loss-and-delay sweep and the 451-process runs).
set -euo pipefail
cd "$(dirname "$0")/../../.."
out=docs/results/seed003
tmp=$(mktemp -d)
cargo build --release
swarm=target/release/swarm
run() { local dir=$tmp/$1; shift; $swarm run "$@" --out "$dir" > /dev/null; echo "$dir"; }

# The paper's experiments, as robot processes.
corridor=$(run corridor configs/chain_corridor.toml)
stationary=$(run stationary configs/chain_stationary.toml)
middle=$(run middle configs/chain_middle.toml)
snake=$(run snake configs/chain_snake_140.toml)
chain450=$(run chain450 configs/chain_450.toml)
cp $corridor/trajectory.png $out/corridor.png
cp $corridor/chain_rods.png $out/corridor_rods.png
cp $stationary/trajectory.png $out/stationary.png
cp $stationary/chain_vetoes.png $out/stationary_vetoes.png
cp $middle/trajectory.png $out/middle.png
cp $snake/trajectory.png $out/snake_140.png
cp $chain450/trajectory.png $out/chain_450.png
cp $chain450/chain_propagation.png $out/chain_450_propagation.png

# The same in one process (same bytes), for the real-time factor without IPC.
corridor_ip=$(run corridor_ip configs/chain_corridor.toml --in-process)
chain450_ip=$(run chain450_ip configs/chain_450.toml --in-process)
cmp $corridor/trajectory.csv $corridor_ip/trajectory.csv
cmp $chain450/trajectory.csv $chain450_ip/trajectory.csv

python3 $out/table.py corridor=$corridor corridor_in_process=$corridor_ip \
  stationary=$stationary middle=$middle snake_140=$snake chain_450=$chain450 \
  chain_450_in_process=$chain450_ip > $out/experiments.md

# How a motion reaches the tail of 451 robots: range-and-bearing against the radio alone.
prop=()
for how in rab radio; do
  for delay in 0 2; do
    d=$(run "prop_${how}_${delay}" configs/chain_450.toml --in-process --ticks 2500 \
      --set behaviour.master_from="\"$how\"" --set radio.delay_ticks=$delay)
    prop+=("master_from $how, delay $delay=$d")
  done
done
python3 $out/wave.py "${prop[@]}" > $out/propagation.md

# A middle robot (8) killed at tick 600 in the corridor: the chain splits.
killed=$(run killed configs/chain_corridor.toml --set 'faults.kill=[{tick=600,robot=8}]' --ticks 3000)
cp $killed/trajectory.png $out/killed.png
python3 $out/table.py killed=$killed > $out/killed.md

# Appendix A's random shake against the trail (about 2 minutes).
python3 $out/rotate.py $swarm $tmp/rotate > $out/rotate.md

# Appendix A's recursion within one tick (radio.rounds), as processes (about 5 minutes).
python3 $out/rounds.py $swarm $tmp/rounds > $out/rounds.md
python3 $out/rounds.py $swarm $tmp/rounds_ip in-process > $out/rounds_in_process.md

# Beyond the paper: loss and delay.
bash $out/sweep.sh $tmp/sweep
sed -n '/^| radio.loss/,/^$/p' $tmp/sweep/summary.md > $out/sweep.md
echo "wrote $out"
