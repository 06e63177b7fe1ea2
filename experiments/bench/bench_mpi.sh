#!/bin/sh
# make bench-mpi: bench_mpi (experiments/bench/bench_mpi.cpp) on refined Fig 6 gutters, one run
# at a time, each printing one "MPI ..." line (times, bytes, memory per rank, load average).
#   strong scaling: the same gutter on 1 rank (serial solver, and the distributed one), 2 ranks
#                   and 4 ranks (oversubscribed: 2 cores), with MUMPS and with CG + GAMG;
#   weak scaling:   ~25 000 cells per rank on 1, 2 and 4 ranks (MUMPS).
# Usage: bench_mpi.sh BUILD_DIR [--quick]   (--quick: the gutters of 1 080 and 9 900 cells only)
set -u
build=$1
quick=${2:-}
bench=$build/experiments/bench_mpi
export OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
run() {  # ranks label nt na nl solver [extra]
  p=$1 label=$2 nt=$3 na=$4 nl=$5 solver=$6
  shift 6
  if [ "$p" = 1 ]; then
    "$bench" "$nt" "$na" "$nl" --solver "$solver" --label "$label" "$@"
  else
    mpirun -n "$p" --oversubscribe "$bench" "$nt" "$na" "$nl" --solver "$solver" \
      --label "$label" "$@"
  fi
}
strong="2 18 30
3 30 110"
[ "$quick" = "--quick" ] || strong="$strong
4 50 500"
echo "$strong" | while read -r nt na nl; do
  run 1 strong "$nt" "$na" "$nl" mumps
  for solver in mumps cg-amg; do
    run 1 strong "$nt" "$na" "$nl" "$solver" --distribute 1
    run 2 strong "$nt" "$na" "$nl" "$solver"
    run 4 strong-oversubscribed "$nt" "$na" "$nl" "$solver"
  done
done
[ "$quick" = "--quick" ] && exit 0
run 1 weak 4 25 250 mumps --distribute 1
run 2 weak 4 50 250 mumps
run 4 weak-oversubscribed 4 50 500 mumps
