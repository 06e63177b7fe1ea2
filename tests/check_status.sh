#!/bin/sh
# What `ltl-results FILE` says of a file whose status is "running" (a CTest): while ltl_run writes
# it, the process of this machine that writes it (the lock on its lock file, read from
# /proc/locks); once that process is killed (SIGKILL leaves the status as it was, as MPI_Abort
# does to rank 0 when another rank fails), that no process of this machine writes it, its steps
# are complete and --resume continues it; and --resume then does. Skipped (exit 77) without
# /proc/locks (not Linux).
# Usage: check_status.sh BUILD_DIR SOURCE_DIR PYTHON
set -u
build=$1
src=$(cd "$2" && pwd)
python=$3
[ -r /proc/locks ] || { echo "SKIPPED: no /proc/locks"; exit 77; }
dir=$(mktemp -d)
run="$build/experiments/ltl_run"
summary="$src/figures/ltl_results.py"
pid=
trap '[ -n "$pid" ] && kill -9 "$pid" 2> /dev/null; rm -rf "$dir"' EXIT
fail() {
  echo "FAIL: $*"
  exit 1
}
# Fig 5 refined, in 20 steps of a ramp (0.2-1 s a step): the file appears with step 1.
set -- "$src/experiments/fig5/fig5.toml" --set time.steps=20 --set mesh.parameters.n=20 \
  --set mesh.parameters.nd=20 --set 'load.ramp="linear"' --set 'load.ramp_time="20 s"' \
  --set 'algorithm.solver="alg2"' -q
"$run" "$@" -o "$dir/r.h5" &
pid=$!
i=0
while [ ! -f "$dir/r.h5" ] && [ $i -lt 6000 ]; do sleep 0.005; i=$((i + 1)); done
[ -f "$dir/r.h5" ] || fail "no results file after 30 s"
"$python" "$summary" "$dir/r.h5" > "$dir/live.txt" || fail "ltl_results.py on a file being written"
head -1 "$dir/live.txt"
grep -q "status: running (written now by process $pid of this machine)" "$dir/live.txt" ||
  fail "a file being written: $(head -1 "$dir/live.txt")"
kill -9 "$pid"
wait "$pid" 2> /dev/null
pid=
"$python" "$summary" "$dir/r.h5" > "$dir/dead.txt" || fail "ltl_results.py on a killed run's file"
head -1 "$dir/dead.txt"
grep -q "status: running -- but no process of this machine writes it" "$dir/dead.txt" ||
  fail "a killed run's file: $(head -1 "$dir/dead.txt")"
"$run" "$@" --resume --stop-after 1 -o "$dir/r.h5" || fail "--resume of a killed run's file"
"$python" "$summary" "$dir/r.h5" > "$dir/after.txt" || fail "ltl_results.py after --resume"
head -1 "$dir/after.txt"
grep -q "status: stopped after step" "$dir/after.txt" || fail "after --resume: $(head -1 "$dir/after.txt")"
echo ok
