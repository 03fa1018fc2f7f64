#!/usr/bin/env bash
# Beyond the paper: the corridor against radio loss and delay, with the slaves locating their
# masters by range-and-bearing (falling back on the radio) or by the radio alone. Sensor noise
# (1 cm lidar, 5 mm position, 0.01 rad heading) makes the seeds differ.
set -euo pipefail
cd "$(dirname "$0")/../../.."
out=${1:-/tmp/seed003_sweep}
rm -rf "$out"
target/release/swarm sweep configs/chain_corridor.toml \
  --vary radio.loss=0,0.1,0.3,0.5 --vary radio.delay_ticks=0,2,5,10 \
  --vary behaviour.master_from='"both"','"radio"' \
  --set robots.noise.pose=0.005 --set robots.noise.heading=0.01 --set robots.noise.lidar=0.01 \
  --seeds 3 --jobs 2 --out "$out" \
  --metric chain.tail_reached --metric chain.tail_reached_tick --metric chain.collisions \
  --metric chain.rod_violations --metric chain.rod_ticks --metric chain.propagation_ticks \
  --metric chain.vetoes
