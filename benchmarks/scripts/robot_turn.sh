#!/bin/bash
# CPU per turn of one robot process: `perf stat -e task-clock` on PID for 4 s, divided by the
# voluntary context switches in that window (a robot sleeps once per tick, in the bell's
# futex or, for a floor robot, in its listener). Needs perf and root (or perf_event_paranoid
# <= 1). Usage: benchmarks/scripts/robot_turn.sh PID
# docs/benchmarks.md, issue 34, shows how it was used on a runtime robot and a floor robot.
set -euo pipefail
p=$1
v0=$(awk '/^voluntary_ctxt_switches/ {print $2}' /proc/$p/status)
ms=$(perf stat -e task-clock -p "$p" -- sleep 4 2>&1 | awk '/task-clock/ {print $1}')
v1=$(awk '/^voluntary_ctxt_switches/ {print $2}' /proc/$p/status)
python3 -c "ms=float('$ms'.replace(',','')); n=$v1-$v0; print(f'cpu {ms:.1f} ms, sleeps {n}, {ms*1000/max(n,1):.1f} us per sleep')"
