#!/bin/sh
# Smoke test of the benchmarks (`make bench`, `make bench-peer`), so that they cannot break
# silently: bench on its smallest case, bench_accel on Fig 5 K = 7 (plain, Anderson, Newton),
# and bench_peer.py's argument parsing. Timings are not checked (speed is measured in `make
# bench`, never in tests). Usage: check_bench.sh BUILD_DIR SOURCE_DIR PYTHON
set -eu
build=$1 src=$2 py=$3
cd "$src"
out=$("$build/experiments/bench" --case 0 --iters 2 --warm 1)
echo "$out" | grep -q "^RESULT name=" || { echo "bench printed no RESULT line: $out"; exit 1; }
out=$("$build/experiments/bench_accel" --trace "fig5 K=7" --cap-seconds 60)
echo "$out"
echo "$out" | grep -q "^fig5 K=7 " || { echo "bench_accel printed no row for fig5 K=7"; exit 1; }
if echo "$out" | grep -qE "^ +Newton: "; then echo "bench_accel: the Newton run did not converge"; exit 1; fi
out=$("$build/experiments/bench_amg" --iters 2 --case gutter-270 cholesky)
echo "$out" | grep -q "^RESULT gutter-270 cholesky " || { echo "bench_amg printed no RESULT line: $out"; exit 1; }
"$py" experiments/peer/bench_peer.py --help > /dev/null
echo "benchmarks: smoke test passed"
