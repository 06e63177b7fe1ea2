#!/bin/sh
# The gutter (Fig 6) at levels L, (nt, na, nl) = L (2, 9, 15) as `refinement fig6` makes them:
# outer iterations from rest and nested from level L-1 (`ltl_run --init`, paper_notes/nested.md),
# for Newton (solver = "newton") and ALG2 + Anderson, to a force residual of 1e-6
# (stopping = "equilibrium"). Each run prints its console lines and a TIME line (/usr/bin/time).
#
# Usage (from the repository root): experiments/refinement/nested_levels.sh LEVELS VARIANTS
#   e.g. experiments/refinement/nested_levels.sh "1 2 3" "newton-rest newton-nested alg2-nested"
# VARIANTS among newton-rest, newton-nested, alg2-rest, alg2-nested. The nested runs start from
# level L-1's Newton result (newton-L(L-1)-rest.h5, else newton-L(L-1)-nested.h5) in
# ${OUT:-results/nested}; run the levels in increasing order.
set -u
B=${LTL_RUN:-build/experiments/ltl_run}
D=${OUT:-results/nested}
mkdir -p "$D"
run() { # name level solver init
  name=$1 L=$2 solver=$3 init=$4
  set -- --set mesh.parameters.nt=$((2 * L)) --set mesh.parameters.na=$((9 * L)) \
    --set mesh.parameters.nl=$((15 * L)) --set "algorithm.solver=\"$solver\"" \
    --set 'algorithm.stopping="equilibrium"' --set algorithm.force_tol=1e-6 \
    --set algorithm.max_iter=20000
  [ "$solver" = alg2 ] && set -- "$@" --set 'algorithm.acceleration="anderson"'
  [ -n "$init" ] && set -- "$@" --init "$init"
  echo "=== $name start $(date -u +%T) load $(cut -d' ' -f1-3 /proc/loadavg)"
  /usr/bin/time -f "TIME wall %e s user %U s maxrss %M KB" \
    "$B" experiments/fig6/fig6.toml -o "$D/$name.h5" "$@" 2>&1
  echo "=== end $name rc $? $(date -u +%T) load $(cut -d' ' -f1-3 /proc/loadavg)"
}
source_of() { # the level-L Newton result
  if [ -f "$D/newton-L$1-rest.h5" ]; then echo "$D/newton-L$1-rest.h5"; else echo "$D/newton-L$1-nested.h5"; fi
}
for L in $1; do
  for v in $2; do
    case $v in
      newton-rest) run "newton-L$L-rest" "$L" newton "" ;;
      newton-nested) run "newton-L$L-nested" "$L" newton "$(source_of $((L - 1)))" ;;
      alg2-rest) run "alg2-L$L-rest" "$L" alg2 "" ;;
      alg2-nested) run "alg2-L$L-nested" "$L" alg2 "$(source_of $((L - 1)))" ;;
      *) echo "unknown variant $v" >&2; exit 2 ;;
    esac
  done
done
