#!/usr/bin/env bash
# Per-tick cost of a run split over emulated hosts (issues 16 and 32), for docs/benchmarks.md.
#
# Builds three emulated hosts (network namespaces on a bridge, each with a private /dev/shm,
# as tests/src/lab.rs does), then runs configs/goto_simple.toml at 100 and 500 robots:
# all on one host, half on a second host, a third on each of three hosts, and every robot on
# one remote host (the world alone on its own). Every split runs twice, back to back: over
# the default link (QUIC with mutual TLS, certificates from `swarm certs`) and over plain TCP
# (`--insecure-link`), so the TLS column's ratio is read within one run. Prints a markdown
# table. Needs root.
#
#   bash docs/benchmarks/multihost.sh [ticks_100] [ticks_500]
set -euo pipefail
cd "$(dirname "$0")/../.."
T100=${1:-300}
T500=${2:-200}
cargo build --release -q
SWARM=$PWD/target/release/swarm
TAG=mhb$$
OUT=$(mktemp -d /tmp/swarmrt-multihost.XXXX)
HOLDERS=()

cleanup() {
  for p in "${HOLDERS[@]}"; do kill -9 "$p" 2>/dev/null || true; done
  for i in 0 1 2; do ip netns del "${TAG}h$i" 2>/dev/null || true; done
  ip netns del "${TAG}br" 2>/dev/null || true
}
trap cleanup EXIT

ip netns add "${TAG}br"
ip -n "${TAG}br" link add br0 type bridge
ip -n "${TAG}br" link set br0 up
for i in 0 1 2; do
  ns=${TAG}h$i
  ip netns add "$ns"
  ip link add "h$i" netns "$ns" type veth peer name "b$i" netns "${TAG}br"
  ip -n "$ns" addr add "10.77.0.$((i + 1))/24" dev "h$i"
  ip -n "$ns" link set "h$i" up
  ip -n "$ns" link set lo up
  ip -n "${TAG}br" link set "b$i" master br0 up
  ip netns exec "$ns" unshare --mount --propagation private \
    sh -c 'mount -t tmpfs swlab /dev/shm && exec sleep 100000' &
  HOLDERS+=($!)
done
sleep 0.5
launcher() { echo "\"nsenter\", \"-t\", \"${HOLDERS[$1]}\", \"-n\", \"-m\", \"--\""; }

# hosts.toml (link: quic or tcp) with robots counts for hosts 1, 2 (an empty count: that
# host is unused); a quic file gets its certificates in certs/ beside it.
hosts_file() {
  local link=$1
  shift
  mkdir -p "$OUT/hosts-$link-$1-$2"
  local f=$OUT/hosts-$link-$1-$2/hosts.toml
  printf '[world]\nlisten = "%s/10.77.0.1:7447"\n' "$link" >"$f"
  local i=1
  for c in "$2" "$3"; do
    if [ -n "$c" ]; then
      printf '\n[[host]]\nname = "h%s"\nlauncher = [%s]\nrobots = %s\n' "$i" "$(launcher $i)" "$c" >>"$f"
    fi
    i=$((i + 1))
  done
  if [ "$link" = quic ]; then
    "$SWARM" certs "$f" >/dev/null
  fi
  echo "$f"
}

# The same map sizing as `swarm bench swarm` (benchmarks/src/swarm.rs, `scenario`).
sets() {
  python3 - "$1" "$2" <<'EOF'
import math, sys
n, ticks = int(sys.argv[1]), int(sys.argv[2])
r = math.sqrt(n / math.pi) * 0.7 + 1.0
side = math.ceil(max(2 * r + 6.0, 12.0))
c, g = side / 2, side / 2 + r / 2
for s in [f"robots.count={n}", f"scenario.ticks={ticks}", "scenario.stop_when_done=false",
          f"map.bounds=[0.0, 0.0, {side:.1f}, {side:.1f}]", f"robots.start.x={c:.1f}",
          f"robots.start.y={c:.1f}", f"map.goal.x={g:.1f}", f"map.goal.y={g:.1f}"]:
    print("--set"); print(s)
EOF
}

run() { # name n ticks [link hosts-file]
  local dir=$OUT/$1-$2-${4:-local}
  dir=${dir// /_}
  mapfile -t S < <(sets "$2" "$3")
  local extra=()
  if [ -n "${5:-}" ]; then
    extra=(--hosts "$5")
    [ "$4" = tcp ] && extra+=(--insecure-link)
  fi
  nsenter -t "${HOLDERS[0]}" -n -m --wd="$PWD" -- \
    "$SWARM" run configs/goto_simple.toml "${S[@]}" "${extra[@]}" --out "$dir" >/dev/null
  python3 - "$dir" "$1" "$2" <<'EOF'
import json, sys
d, name, n = sys.argv[1], sys.argv[2], sys.argv[3]
m = json.load(open(d + "/metrics.json"))
link_kind = m.get("link", "-")
t = m["shell"]["timing"]
ticks = max(t["ticks"], 1)
tick = 1000 * t["seconds"] / ticks
link = m["shell"].get("link", [])
per_host = ", ".join(
    f'{h["host"]} {h["bytes_down"] / ticks / 1024:.0f} KiB down / {h["bytes_up"] / ticks / 1024:.0f} KiB up'
    for h in link) or "-"
print(f'| {n} | {name} | {link_kind} | {tick:.2f} | {t["tick_ms_median"]:.2f} | {t["publish_ms_mean"]:.2f} | '
      f'{t["wait_ms_mean"]:.2f} | {t["step_ms_mean"]:.2f} | {per_host} | {m["reproducible"]} |')
EOF
}

echo "| robots | split | link | tick ms (mean) | tick ms (median) | publish ms | wait ms | step ms | bytes per tick per host | reproducible |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for n in 100 500; do
  ticks=$T100
  [ "$n" = 500 ] && ticks=$T500
  half=$((n / 2))
  third=$((n / 3))
  run "one host" "$n" "$ticks"
  for link in quic tcp; do
    run "2 hosts (half remote)" "$n" "$ticks" $link "$(hosts_file $link 2 "$half" "")"
  done
  for link in quic tcp; do
    run "3 hosts (thirds)" "$n" "$ticks" $link "$(hosts_file $link 3 "$third" "$third")"
  done
  for link in quic tcp; do
    run "all on 1 remote host" "$n" "$ticks" $link "$(hosts_file $link r "$n" "")"
  done
done
echo
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); run dirs in $OUT"
