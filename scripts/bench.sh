#!/usr/bin/env bash
# Builds (scripts/setup.sh build), then runs the end-to-end benchmark on the
# standard capture and the stability study, niced so that a shared machine
# stays usable. Results go to bench_results/.
# Usage: scripts/bench.sh [--quick]   (--quick: fewer stability points)
# Environment: BENCH_OUT (scratch folder, default /tmp/svbrdf_bench), BENCH_PRESET (default standard).
set -euo pipefail
cd "$(dirname "$0")/.."
QUICK=()
if [ "${1:-}" = "--quick" ]; then QUICK=(--quick); fi
OUT=${BENCH_OUT:-/tmp/svbrdf_bench}
PRESET=${BENCH_PRESET:-standard}
PY=/usr/bin/python3

scripts/setup.sh build
nice -n 5 "$PY" scripts/bench.py --preset "$PRESET" --out-dir "$OUT"
nice -n 5 "$PY" scripts/stability.py --out-dir "$OUT" "${QUICK[@]}"
if [ -x build/tests/bench/relight_bench ]; then
  nice -n 5 build/tests/bench/relight_bench --benchmark_min_time=2 | tee bench_results/relight_bench.txt
fi

echo
echo "results in $(pwd)/bench_results/:"
ls -1 bench_results/
echo "scratch data (captures, materials, logs) in $OUT"
