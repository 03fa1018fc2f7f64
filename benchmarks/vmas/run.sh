#!/usr/bin/env bash
# swarmrt's vector environment against VMAS on this CPU, alternated in one run.
#
#   benchmarks/vmas/run.sh WHEEL [RESULTS_DIR] [bench.py options...]
#   SWARMRT_WHEEL=/path/swarmrt-*.whl benchmarks/vmas/run.sh [RESULTS_DIR] [options...]
#
# Makes two venvs under target/vmas-bench/ (VMAS_BENCH_DIR overrides): venv-vmas with vmas,
# the torch PyPI gives and matplotlib (it also runs the driver and draws the plot), and
# venv-swarmrt with the swarmrt wheel (a release build for numbers worth quoting) and its
# `env` extra. Each measurement runs in a fresh child process of its own venv.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
bench_dir=${VMAS_BENCH_DIR:-$root/target/vmas-bench}
python=${PYTHON:-python3.11}

wheel=${SWARMRT_WHEEL:-}
if [[ -z "$wheel" ]]; then
    if [[ $# -lt 1 || "$1" != *.whl ]]; then
        echo "usage: $0 WHEEL [RESULTS_DIR] [bench.py options]  (or set SWARMRT_WHEEL)" >&2
        exit 2
    fi
    wheel=$1
    shift
fi
[[ -f "$wheel" ]] || { echo "no wheel at $wheel" >&2; exit 2; }
wheel=$(cd "$(dirname "$wheel")" && pwd)/$(basename "$wheel")

results=$bench_dir/results
if [[ $# -ge 1 && "$1" != -* ]]; then
    results=$1
    shift
fi

mkdir -p "$bench_dir"

vmas_venv=$bench_dir/venv-vmas
if [[ ! -f "$vmas_venv/.ready" ]]; then
    echo "== venv for vmas + torch at $vmas_venv (torch from PyPI: large download)"
    "$python" -m venv "$vmas_venv"
    "$vmas_venv/bin/pip" install --quiet --upgrade pip
    "$vmas_venv/bin/pip" install vmas matplotlib
    "$vmas_venv/bin/python" -c "import vmas, torch; print('vmas', vmas.__version__, 'torch', torch.__version__)"
    touch "$vmas_venv/.ready"
fi

ours_venv=$bench_dir/venv-swarmrt
if [[ ! -f "$ours_venv/.ready" ]]; then
    echo "== venv for swarmrt at $ours_venv"
    "$python" -m venv "$ours_venv"
    "$ours_venv/bin/pip" install --quiet --upgrade pip
    "$ours_venv/bin/pip" install "$wheel[env]"
    touch "$ours_venv/.ready"
fi
# The wheel given this time, whatever was installed before (same version number).
if [[ "$(cat "$ours_venv/.wheel" 2>/dev/null || true)" != "$wheel $(stat -c %Y "$wheel")" ]]; then
    "$ours_venv/bin/pip" install --quiet --force-reinstall --no-deps "$wheel"
    echo "$wheel $(stat -c %Y "$wheel")" > "$ours_venv/.wheel"
fi

echo "== sizes: $(du -sh "$vmas_venv" | cut -f1) venv-vmas, $(du -sh "$ours_venv" | cut -f1) venv-swarmrt"

exec "$vmas_venv/bin/python" "$here/bench.py" \
    --ours-python "$ours_venv/bin/python" \
    --vmas-python "$vmas_venv/bin/python" \
    --wheel "$wheel" \
    --results "$results" "$@"
