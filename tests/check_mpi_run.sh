#!/bin/sh
# ltl_run under mpirun -n 2 (an MPI build): the glued Fig 3 problem, two steps, gives the serial
# run's iteration counts, rank 0 alone prints them and writes the results file, and a failing
# run (an unreadable configuration) ends every rank with a non-zero status.
# Usage: check_mpi_run.sh BUILD_DIR SOURCE_DIR MPIEXEC
set -u
build=$1 src=$2 mpiexec=$3
run=$build/experiments/ltl_run
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
"$run" "$src/experiments/fig3/fig3.toml" --set time.steps=2 -o "$tmp/serial.h5" > "$tmp/serial.txt" ||
  fail "serial run"
"$mpiexec" -n 2 --oversubscribe "$run" "$src/experiments/fig3/fig3.toml" --set time.steps=2 \
  -o "$tmp/ranks.h5" > "$tmp/ranks.txt" || fail "mpirun -n 2 ltl_run"
serial=$(grep '^step' "$tmp/serial.txt" | sed 's/.*s \+\([0-9]\+\) iterations.*/\1/' | tr '\n' ' ')
ranks=$(grep '^step' "$tmp/ranks.txt" | sed 's/.*s \+\([0-9]\+\) iterations.*/\1/' | tr '\n' ' ')
echo "iterations per step: serial $serial, 2 ranks $ranks"
[ -n "$serial" ] && [ "$serial" = "$ranks" ] || fail "iteration counts differ"
[ "$(grep -c '^step' "$tmp/ranks.txt")" = 2 ] || fail "the step lines are not printed once each"
[ -f "$tmp/ranks.h5" ] || fail "no results file"
[ "$(ls "$tmp" | grep -c '\.h5$')" = 2 ] || fail "more than one results file per run"
echo 'name = "broken"' > "$tmp/broken.toml"
if "$mpiexec" -n 2 --oversubscribe "$run" "$tmp/broken.toml" -o "$tmp/b.h5" > /dev/null 2>&1; then
  fail "a broken configuration under mpirun exited 0"
fi
echo "ok"
