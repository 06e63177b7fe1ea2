#!/bin/sh
# The gutter (Fig 6) at level 16, (nt, na, nl) = (32, 144, 240): 1 105 920 H8 cells, solved to a
# force residual of 1e-6 with ALG2 + Anderson and the CG + AMG global step (a PETSc build: its
# factor would not fit in 24 GB, paper_notes/performance.md), nested from level 8's Newton result
# (experiments/refinement/nested_levels.sh "2 ... 8"). The step takes hours: the iterate is saved
# every 15 minutes (--checkpoint 900), and running the script again continues the step from the
# last checkpoint (--resume) instead of starting it again.
#
# Usage (from the repository root): experiments/refinement/gutter_1e6.sh
#   LTL_RUN  the runner of a PETSc build (default build-petsc/experiments/ltl_run)
#   OUT      the folder of the nested levels and of this run's file (default results/nested)
set -u
B=${LTL_RUN:-build-petsc/experiments/ltl_run}
D=${OUT:-results/nested}
src="$D/newton-L8-nested.h5"
out="$D/alg2-L16-nested.h5"
set -- experiments/fig6/fig6.toml -o "$out" --checkpoint 900 \
  --set mesh.parameters.nt=32 --set mesh.parameters.na=144 --set mesh.parameters.nl=240 \
  --set 'algorithm.solver="alg2"' --set 'algorithm.acceleration="anderson"' \
  --set 'algorithm.global_solver="cg-amg"' --set 'algorithm.stopping="equilibrium"' \
  --set algorithm.force_tol=1e-6 --set algorithm.max_iter=100000
if [ -f "$out" ]; then
  set -- "$@" --resume
else
  [ -f "$src" ] || { echo "no $src: run experiments/refinement/nested_levels.sh first" >&2; exit 2; }
  set -- "$@" --init "$src"
fi
echo "=== L16 start $(date -u +%T) load $(cut -d' ' -f1-3 /proc/loadavg)"
OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} /usr/bin/time -f "TIME wall %e s user %U s maxrss %M KB" \
  "$B" "$@" 2>&1
echo "=== L16 end rc $? $(date -u +%T) load $(cut -d' ' -f1-3 /proc/loadavg)"
