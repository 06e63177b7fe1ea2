#!/bin/sh
# ltl_run under mpirun -n 2 (an MPI build): the glued Fig 3 problem, two steps, gives the serial
# run's iteration counts, rank 0 alone prints them and writes the results file, and a failing
# run (an unreadable configuration) ends every rank with a non-zero status; the last line gives
# the peak memory of the ranks (serially, of the process). Resume across rank
# counts: one step on 2 ranks (--stop-after 1), resumed on 3 ranks (oversubscribed) and, from the
# same first step, on 1 rank: step 2 takes the serial iteration count and ends within 1e-8 of the
# serial u (relative), in both files. --init (the nested start) under mpirun -n 2, with plain
# ALG2 and with the Newton phase, ends within 1e-8 of one process, and resumed on 2 ranks from
# inside its step 1, within 1e-8 of the same resumed on one process. --checkpoint: a serial
# run stopped in its step resumes on 2 ranks from its checkpoint, and a run of 2 ranks on one
# process, the counts adding up. A step
# that diverges under mpirun leaves its last iterate in the file (rank 0 writes it, with the
# fields every rank made on its cells: E, sigma, det F, the nodal stress). A geometry script that
# calls `Exit;` ends the job at once with rank 0's message. SIGTERM to rank 1 alone stops every
# rank at the same iteration: status 143, one message, the file marked interrupted. An error of
# rank 1 alone, in a step or once set up, ends the job at once (status 1, its message), not a hang.
# An error of every rank (a divergence, a broken configuration, bad usage) is said once, by rank 0.
# Usage: check_mpi_run.sh BUILD_DIR SOURCE_DIR MPIEXEC
set -u
build=$1 src=$2 mpiexec=$3
run=$build/experiments/ltl_run
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
# The pid of rank 1 of the job writing the results file $1 (none: empty).
rank1_of() {
  for pid in $(pgrep -x ltl_run); do
    r=$( (tr '\0' '\n' < "/proc/$pid/environ") 2> /dev/null | sed -n 's/^OMPI_COMM_WORLD_RANK=//p')
    [ "$r" = 1 ] && grep -q "$1" "/proc/$pid/cmdline" 2> /dev/null && echo "$pid"
  done
}
"$run" "$src/experiments/fig3/fig3.toml" --set time.steps=2 -o "$tmp/serial.h5" > "$tmp/serial.txt" ||
  fail "serial run"
"$mpiexec" -n 2 --oversubscribe "$run" "$src/experiments/fig3/fig3.toml" --set time.steps=2 \
  -o "$tmp/ranks.h5" > "$tmp/ranks.txt" || fail "mpirun -n 2 ltl_run"
serial=$(grep '^step' "$tmp/serial.txt" | sed 's/.*s \+\([0-9]\+\) iterations.*/\1/' | tr '\n' ' ')
ranks=$(grep '^step' "$tmp/ranks.txt" | sed 's/.*s \+\([0-9]\+\) iterations.*/\1/' | tr '\n' ' ')
echo "iterations per step: serial $serial, 2 ranks $ranks"
[ -n "$serial" ] && [ "$serial" = "$ranks" ] || fail "iteration counts differ"
[ "$(grep -c '^step' "$tmp/ranks.txt")" = 2 ] || fail "the step lines are not printed once each"
# The last line gives the ranks' smallest and largest peak memory (VmHWM), 0 < smallest <= largest.
mem=$(sed -n 's/.*peak memory per rank \([0-9]\+\)-\([0-9]\+\) MB over 2 ranks.*/\1 \2/p' "$tmp/ranks.txt")
echo "peak memory per rank (MB): $mem"
[ -n "$mem" ] && [ "${mem% *}" -gt 0 ] && [ "${mem% *}" -le "${mem#* }" ] ||
  fail "no peak memory per rank in the run's last line"
grep -q 'peak memory [0-9]\+ MB (.*code.*), wrote' "$tmp/serial.txt" || fail "no peak memory in the serial run's line"
[ -f "$tmp/ranks.h5" ] || fail "no results file"
[ "$(ls "$tmp" | grep -c '\.h5$')" = 2 ] || fail "more than one results file per run"
cfg="$src/experiments/fig3/fig3.toml"
"$mpiexec" -n 2 --oversubscribe "$run" "$cfg" --set time.steps=2 --stop-after 1 -o "$tmp/r.h5" \
  > /dev/null || fail "mpirun -n 2 ltl_run --stop-after 1"
cp "$tmp/r.h5" "$tmp/r1.h5"
"$mpiexec" -n 3 --oversubscribe "$run" "$cfg" --set time.steps=2 --resume -o "$tmp/r.h5" \
  > "$tmp/r3.txt" || fail "mpirun -n 3 ltl_run --resume of a 2-rank file"
"$run" "$cfg" --set time.steps=2 --resume -o "$tmp/r1.h5" > "$tmp/r1.txt" ||
  fail "ltl_run --resume (one process) of a 2-rank file"
for f in r3 r1; do
  it=$(grep '^step' "$tmp/$f.txt" | sed 's/.*s \+\([0-9]\+\) iterations.*/\1/' | tr '\n' ' ')
  [ "$(grep -c '^step' "$tmp/$f.txt")" = 1 ] || fail "$f: resumed run did not compute step 2 alone"
  [ "$it" = "$(echo "$serial" | cut -d' ' -f2) " ] || fail "$f: step 2 took $it iterations, serial $serial"
done
/usr/bin/python3 - "$tmp" "$src/figures" <<'PY' || fail "resumed u differs from the serial u"
import sys
sys.path.insert(0, sys.argv[2])
import numpy as np
import ltl_results as lr
tmp = sys.argv[1]
ref = lr.load(tmp + "/serial.h5").step(2).fields["u"]
for name in ("r", "r1"):
    res = lr.load(tmp + "/" + name + ".h5")
    assert len(res.steps) == 2, (name, len(res.steps))
    d = np.abs(res.step(2).fields["u"] - ref).max() / np.abs(ref).max()
    print("resumed %s.h5: step 2, relative difference in u %.3g" % (name, d))
    assert d <= 1e-8, d
PY
# --init (the nested start) on 2 ranks: each rank computes E and lambda on its own cells,
# gathered; plain ALG2 and the Newton phase (both on a rank's cells) as one process.
newton='algorithm.solver="newton"'
alg2='algorithm.solver="alg2"'
for solver in "$alg2" "$newton"; do
  "$run" "$cfg" --set time.steps=1 --set "$solver" --init "$tmp/serial.h5" -o "$tmp/n1.h5" \
    > /dev/null || fail "ltl_run --init with $solver"
  "$mpiexec" -n 2 --oversubscribe "$run" "$cfg" --set time.steps=1 --set "$solver" \
    --init "$tmp/serial.h5" -o "$tmp/n2.h5" > /dev/null || fail "mpirun -n 2 ltl_run --init, $solver"
  /usr/bin/python3 - "$tmp" "$src/figures" "$solver" <<'PY' || fail "--init on 2 ranks differs from serial"
import sys
sys.path.insert(0, sys.argv[2])
import numpy as np
import ltl_results as lr
a = lr.load(sys.argv[1] + "/n1.h5").step(1).fields["u"]
b = lr.load(sys.argv[1] + "/n2.h5").step(1).fields["u"]
d = np.abs(a - b).max() / np.abs(a).max()
print("--init with %s, 2 ranks against one process: relative difference in u %.3g" % (sys.argv[3], d))
assert d <= 1e-8, d
PY
  rm -f "$tmp"/n1.* "$tmp"/n2.*
done
# --resume on 2 ranks of a run started with --init whose step 1 diverged (saved as /unconverged):
# step 1 starts again from the --init file on every rank (the nested start on a rank's cells is
# collective), and the two steps end within 1e-8 of the same file resumed on one process.
if "$mpiexec" -n 2 --oversubscribe "$run" "$cfg" --set time.steps=2 --set algorithm.max_iter=1 \
  --init "$tmp/serial.h5" -o "$tmp/i2.h5" > /dev/null 2>&1; then
  fail "--init with algorithm.max_iter = 1 converged"
fi
cp "$tmp/i2.h5" "$tmp/i1.h5"
timeout 120 "$mpiexec" -n 2 --oversubscribe "$run" "$cfg" --set time.steps=2 --resume \
  -o "$tmp/i2.h5" > "$tmp/i2.txt" || fail "mpirun -n 2 --resume of an --init run stopped in step 1"
grep -q "step 1 starts again from" "$tmp/i2.txt" || fail "the resumed step 1 did not start from --init's file"
"$run" "$cfg" --set time.steps=2 --resume -o "$tmp/i1.h5" > /dev/null ||
  fail "--resume (one process) of an --init run stopped in step 1"
/usr/bin/python3 - "$tmp" "$src/figures" <<'PY' || fail "--init resumed on 2 ranks differs from one process"
import sys
sys.path.insert(0, sys.argv[2])
import numpy as np
import ltl_results as lr
a, b = lr.load(sys.argv[1] + "/i1.h5"), lr.load(sys.argv[1] + "/i2.h5")
for p in (1, 2):
    ua, ub = a.step(p).fields["u"], b.step(p).fields["u"]
    d = np.abs(ub - ua).max() / np.abs(ua).max()
    print("--init run resumed in step 1 on 2 ranks: step %d, relative difference in u %.3g" % (p, d))
    assert d <= 1e-8, d
PY
# --checkpoint: a serial run of Fig 5 (plain ALG2) stopped by SIGTERM in the middle of its step,
# resumed on 2 ranks from its checkpoint: the iterations before and after add up to the
# uninterrupted count; and a 2-rank run saving checkpoints (rank 0 writes) takes that count.
f5="$src/experiments/fig5/fig5.toml"
"$run" "$f5" --set "$alg2" -o "$tmp/f5.h5" > "$tmp/f5.txt" || fail "serial Fig 5"
full=$(grep '^step' "$tmp/f5.txt" | sed 's/.*s \+\([0-9]\+\) iterations.*/\1/')
"$mpiexec" -n 2 --oversubscribe "$run" "$f5" --set "$alg2" --checkpoint 0.001 -o "$tmp/f5c.h5" \
  > "$tmp/f5c.txt" || fail "mpirun -n 2 ltl_run --checkpoint"
grep -q "checkpoint: step 1 after" "$tmp/f5c.txt" || fail "no checkpoint saved on 2 ranks"
[ "$(grep '^step' "$tmp/f5c.txt" | sed 's/.*s \+\([0-9]\+\) iterations.*/\1/')" = "$full" ] ||
  fail "2 ranks with --checkpoint: not the serial $full iterations"
# ... and during the Newton phase (the default solver), whose state between steps is on the
# rank's rows: every iteration's checkpoint saved (until 2026-12-03 each was refused: "E is 122 x
# 2, expected 244 x 2", and a signal in the Newton phase kept none).
"$mpiexec" -n 2 --oversubscribe "$run" "$f5" --set "$newton" --checkpoint 0.001 -o "$tmp/f5n.h5" \
  > "$tmp/f5n.txt" || fail "mpirun -n 2 ltl_run --checkpoint with the Newton phase"
! grep -q "not saved" "$tmp/f5n.txt" || fail "Newton phase on 2 ranks: $(grep -m1 'not saved' "$tmp/f5n.txt")"
its=$(grep '^step' "$tmp/f5n.txt" | sed 's/.*s \+\([0-9]\+\) iterations.*/\1/')
grep -q "checkpoint: step 1 after $its iterations saved" "$tmp/f5n.txt" ||
  fail "Newton phase on 2 ranks: no checkpoint at its last iteration ($its)"
echo "checkpoints on 2 ranks through the Newton phase: saved up to iteration $its"
for attempt in 1 2 3; do
  rm -f "$tmp/k.h5"
  "$run" "$f5" --set "$alg2" --checkpoint 0.001 -q -o "$tmp/k.h5" 2> "$tmp/k.err" &
  pid=$!
  i=0
  while [ ! -f "$tmp/k.h5" ] && [ $i -lt 2000 ]; do sleep 0.005; i=$((i + 1)); done
  kill -TERM $pid 2> /dev/null
  wait $pid
  grep -q "is saved (a checkpoint)" "$tmp/k.err" && break
  [ $attempt = 3 ] && fail "the step always finished before SIGTERM"
done
"$mpiexec" -n 2 --oversubscribe "$run" "$f5" --set "$alg2" --resume -o "$tmp/k.h5" \
  > "$tmp/k.txt" || fail "mpirun -n 2 ltl_run --resume from a checkpoint"
before=$(sed -n 's/.*continues from its checkpoint, saved after \([0-9]\+\) iterations.*/\1/p' "$tmp/k.txt")
after=$(grep '^step' "$tmp/k.txt" | sed 's/.*s \+\([0-9]\+\) iterations.*/\1/')
echo "Fig 5 stopped after the checkpoint of iteration $before, resumed on 2 ranks for $after; uninterrupted $full"
[ -n "$before" ] && [ $((before + after)) = "$full" ] || fail "checkpoint resumed on 2 ranks: $before + $after, not $full"
# ... and the other way: a run on 2 ranks saving checkpoints (E and lambda stay on the ranks'
# rows; rank 0 reads them a block at a time) stopped in its step by SIGTERM to rank 1, then
# resumed on one process from its checkpoint: the counts add up to the uninterrupted one.
for attempt in 1 2 3; do
  rm -f "$tmp/k2.h5"
  timeout 120 "$mpiexec" -n 2 --oversubscribe "$run" "$f5" --set "$alg2" --checkpoint 0.001 -q \
    -o "$tmp/k2.h5" 2> "$tmp/k2.err" &
  job=$!
  i=0
  while [ ! -f "$tmp/k2.h5" ] && [ $i -lt 4000 ]; do sleep 0.005; i=$((i + 1)); done
  victim=$(rank1_of "$tmp/k2.h5")
  [ -n "$victim" ] && kill -TERM "$victim"
  wait $job
  grep -q "is saved (a checkpoint)" "$tmp/k2.err" && break
  [ $attempt = 3 ] && fail "2 ranks: the step always finished before SIGTERM"
done
"$run" "$f5" --set "$alg2" --resume -o "$tmp/k2.h5" > "$tmp/k2.txt" ||
  fail "ltl_run --resume (one process) from a checkpoint saved on 2 ranks"
before=$(sed -n 's/.*continues from its checkpoint, saved after \([0-9]\+\) iterations.*/\1/p' "$tmp/k2.txt")
after=$(grep '^step' "$tmp/k2.txt" | sed 's/.*s \+\([0-9]\+\) iterations.*/\1/')
echo "Fig 5 on 2 ranks stopped after the checkpoint of iteration $before, resumed on one process for $after; uninterrupted $full"
[ -n "$before" ] && [ $((before + after)) = "$full" ] ||
  fail "a checkpoint of 2 ranks resumed on one process: $before + $after, not $full"
# A step that diverges under mpirun (the iteration cap): rank 0 saves its last iterate as
# /unconverged/000001 before every rank ends (the ranks wait for it: a failing rank ends them all).
if "$mpiexec" -n 2 --oversubscribe "$run" "$cfg" --set time.steps=1 --set algorithm.max_iter=5 \
  -o "$tmp/d.h5" > /dev/null 2> "$tmp/d.err"; then
  fail "a diverging run under mpirun exited 0"
fi
grep -q "last iterate are saved in" "$tmp/d.err" || fail "a diverging run under mpirun: $(cat "$tmp/d.err")"
# ... said once, by rank 0 (the other ranks wait a second before they would say theirs:
# report_exception, lib/cli.hpp); each rank said it until 2026-12-03 (P lines).
[ "$(grep -c 'ltl_run: error' "$tmp/d.err")" = 1 ] ||
  fail "a diverging run under mpirun: not one message: $(cat "$tmp/d.err")"
/usr/bin/python3 -c 'import sys, h5py; u = h5py.File(sys.argv[1])["unconverged"]; sys.exit(0 if "000001" in u and all(k in u["000001"] for k in ("E", "sigma", "detF", "sigma_node")) else 1)' \
  "$tmp/d.h5" || fail "no /unconverged/000001 with E, sigma, detF and sigma_node in the file of a diverging run under mpirun"
# A geometry script that ends the program (`Exit;`) on rank 0, which alone runs gmsh: the job ends
# at once (not a hang in the mesh's broadcast), non-zero, with rank 0's message and no file.
cp "$src/experiments/fig5/fig5.toml" "$src/experiments/fig5/half_disc.geo" "$tmp/"
{ cat "$src/experiments/fig5/half_disc.geo"; echo "Exit;"; } > "$tmp/exit.geo"
timeout 60 "$mpiexec" -n 2 --oversubscribe "$run" "$tmp/fig5.toml" --set 'mesh.geometry="exit.geo"' \
  -o "$tmp/x.h5" > "$tmp/x.txt" 2>&1
status=$?
[ $status != 0 ] || fail "a geometry script that calls Exit; under mpirun exited 0"
[ $status != 124 ] || fail "a geometry script that calls Exit; under mpirun: no end within 60 s"
echo "Exit; in the geometry script under mpirun -n 2: exit status $status"
grep -q "exit.geo: the geometry script ended the program" "$tmp/x.txt" ||
  fail "Exit; under mpirun: $(head -3 "$tmp/x.txt")"
[ ! -e "$tmp/x.h5" ] || fail "Exit; under mpirun left a results file"
# SIGTERM to rank 1 alone, once step 1 is written (a scheduler's signal reaches the ranks at
# different moments): every rank stops at the same iteration (run_signal, lib/simulation.cpp),
# the job ends with status 143 (no hang, no abort), rank 0 alone says what was kept, and the file
# keeps the steps done with status 'interrupted by SIGTERM during step ...'. With each rank's own
# record deciding, rank 0 waits for rank 1 in the next iteration's sums (a hang).
rm -f "$tmp/t.h5"
timeout 120 "$mpiexec" -n 2 --oversubscribe "$run" "$f5" --set time.steps=10 \
  --set 'load.ramp="linear"' --set 'load.ramp_time="20 s"' --set mesh.parameters.n=20 \
  --set mesh.parameters.nd=20 --set "$alg2" -o "$tmp/t.h5" > /dev/null 2> "$tmp/t.err" &
job=$!
i=0
while [ ! -f "$tmp/t.h5" ] && [ $i -lt 6000 ]; do sleep 0.005; i=$((i + 1)); done
victim=$(rank1_of "$tmp/t.h5")
[ -n "$victim" ] || fail "SIGTERM to rank 1: no rank 1 found (the run ended before step 1?)"
kill -TERM "$victim"
wait $job
status=$?
[ $status = 143 ] || fail "SIGTERM to rank 1: exit status $status, not 143 (124: a hang)"
[ "$(grep -c 'interrupted by SIGTERM during step' "$tmp/t.err")" = 1 ] ||
  fail "SIGTERM to rank 1: not one message: $(cat "$tmp/t.err")"
/usr/bin/python3 -c 'import sys, h5py; f = h5py.File(sys.argv[1]); s = f.attrs["status"]; s = s.decode() if isinstance(s, bytes) else s; print("SIGTERM to rank 1: exit 143,", len(f["steps"]), "step(s) kept, status:", s); sys.exit(0 if s.startswith("interrupted by SIGTERM during step") and len(f["steps"]) >= 1 else 1)' \
  "$tmp/t.h5" || fail "SIGTERM to rank 1: the file is not marked interrupted with its steps"
# An error of one rank alone (LTL_TEST_FAIL_RANK=1: rank 1 throws after step 1, as a rank out of
# memory would): the job ends at once with status 1 and rank 1's message, the file keeping step
# 1. Before, rank 1 waited in the Solver's destruction (MUMPS's is collective) and rank 0 in
# step 2's sums: a silent hang.
rm -f "$tmp/f.h5"
LTL_TEST_FAIL_RANK=1 timeout 60 "$mpiexec" -n 2 --oversubscribe -x LTL_TEST_FAIL_RANK "$run" \
  "$f5" --set time.steps=3 --set 'load.ramp="linear"' --set 'load.ramp_time="20 s"' \
  --set "$alg2" -o "$tmp/f.h5" > /dev/null 2> "$tmp/f.err"
status=$?
[ $status = 1 ] || fail "an error of rank 1 alone: exit status $status, not 1 (124: a hang)"
grep -q "ltl_run: error: rank 1 fails alone after step 1" "$tmp/f.err" ||
  fail "an error of rank 1 alone: no message: $(cat "$tmp/f.err")"
/usr/bin/python3 -c 'import sys, h5py; sys.exit(0 if len(h5py.File(sys.argv[1])["steps"]) == 1 else 1)' \
  "$tmp/f.h5" || fail "an error of rank 1 alone: the file does not keep step 1"
# Rank 0 was ended inside a collective: the file still says "running", and `ltl-results` says
# that no process of this machine writes it (figures/ltl_results.py, status_line).
/usr/bin/python3 "$src/figures/ltl_results.py" "$tmp/f.h5" > "$tmp/f.txt" ||
  fail "ltl_results.py on the file of a job that one rank's error ended"
grep -q "status: running -- but no process of this machine writes it" "$tmp/f.txt" ||
  fail "an error of rank 1 alone: the summary says $(head -1 "$tmp/f.txt")"
echo "an error of rank 1 alone: exit status 1 with its message, step 1 kept, the summary says no process of this machine writes it"
# The same once its solver is set up (LTL_TEST_FAIL_RANK=1:setup), with MUMPS and with the Newton
# phase on CG + GAMG: rank 1 unwinds its PETSc objects without destroying them
# (mpi::collective_teardown), and the job ends with its message. Destroyed, MUMPS's teardown
# waited for rank 0, which waited in step 1's first sums: a hang (CG + GAMG's did not wait).
for gs in cholesky cg-amg; do
  LTL_TEST_FAIL_RANK=1:setup timeout 60 "$mpiexec" -n 2 --oversubscribe -x LTL_TEST_FAIL_RANK \
    "$run" "$f5" --set time.steps=2 --set "$newton" --set "algorithm.global_solver=\"$gs\"" \
    -o "$tmp/g.h5" > /dev/null 2> "$tmp/g.err"
  status=$?
  [ $status = 1 ] || fail "rank 1 failing once set up ($gs): exit status $status, not 1 (124: a hang)"
  grep -q "ltl_run: error: rank 1 fails alone once set up" "$tmp/g.err" ||
    fail "rank 1 failing once set up ($gs): no message: $(cat "$tmp/g.err")"
done
echo "an error of rank 1 alone once set up: exit status 1 with its message (MUMPS, CG + GAMG)"
echo 'name = "broken"' > "$tmp/broken.toml"
if "$mpiexec" -n 3 --oversubscribe "$run" "$tmp/broken.toml" -o "$tmp/b.h5" > /dev/null 2> "$tmp/b.err"; then
  fail "a broken configuration under mpirun exited 0"
fi
[ "$(grep -c 'ltl_run: error' "$tmp/b.err")" = 1 ] ||
  fail "a broken configuration on 3 ranks: not one message: $(cat "$tmp/b.err")"
# Bad usage: status 2 and one message, rank 0's (every rank parses the same command line).
"$mpiexec" -n 3 --oversubscribe "$run" "$cfg" --bogus > /dev/null 2> "$tmp/u.err"
status=$?
[ $status = 2 ] || fail "an unknown option on 3 ranks: exit status $status, not 2"
[ "$(grep -c "ltl_run: unknown option '--bogus'" "$tmp/u.err")" = 1 ] ||
  fail "an unknown option on 3 ranks: not one message: $(cat "$tmp/u.err")"
echo "a divergence, a broken configuration and bad usage under mpirun: one message each"
echo "ok"
