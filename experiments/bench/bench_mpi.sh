#!/bin/sh
# make bench-mpi: bench_mpi (experiments/bench/bench_mpi.cpp) on refined Fig 6 gutters, one run
# at a time, each printing one "MPI ..." line (times, bytes, memory per rank, load average).
#   strong scaling: the same gutter on 1 rank (serial solver, and the distributed one), 2 ranks
#                   and 4 ranks (oversubscribed: 2 cores), with MUMPS and with CG + GAMG;
#   weak scaling:   25 600 cells per rank on 1 and 2 ranks (MUMPS); 4 ranks is the strong
#                   row of the 102 400-cell gutter;
#   Newton:         bench_mpi_newton's step on the 102 400-cell gutter, 1, 2 and 4 ranks, with
#                   every rank's peak memory (not with --quick);
#   partition:      the facets cut by slabs and by PT-Scotch's graph partition into 2 to 256
#                   parts, on the 102 400-cell gutter and a cube of 46^3 H8 ("CUT ..." lines),
#                   then ALG2 with CG + GAMG on the cube, 2 and 4 ranks, graph and slabs
#                   (-ltl_mpi_slabs) (not with --quick);
#   Newton, cube:   bench_mpi_newton on a cube of 30^3 H8, 2 and 4 ranks, graph and slabs: the
#                   tangent's entries sent to other ranks' rows per assembly (not with --quick);
#   Newton, whole:  bench_mpi_newton's step from rest to convergence on the 800- and 3 200-cell
#                   gutters, 2 ranks, GMRES + GAMG: the messages per Newton iteration of the
#                   model of paper_notes/mpi_model.md (its third gutter, 14 400 cells, takes 9
#                   minutes: mesh.parameters.nt=8 na=30 nl=60 by hand) (not with --quick).
# 20 timed iterations after 3 (1 080 and 9 900 cells), 8 after 2 (the larger gutters).
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
    # stdin from /dev/null: mpirun would read the loop's input.
    mpirun -n "$p" --oversubscribe "$bench" "$nt" "$na" "$nl" --solver "$solver" \
      --label "$label" "$@" < /dev/null
  fi
}
strong="2 18 30 20 3
3 30 110 20 3"
[ "$quick" = "--quick" ] || strong="$strong
8 80 160 8 2"
echo "$strong" | while read -r nt na nl it warm; do
  run 1 strong "$nt" "$na" "$nl" mumps --iters "$it" --warm "$warm"
  for solver in mumps cg-amg; do
    run 1 strong "$nt" "$na" "$nl" "$solver" --distribute 1 --iters "$it" --warm "$warm"
    run 2 strong "$nt" "$na" "$nl" "$solver" --iters "$it" --warm "$warm"
    run 4 strong-oversubscribed "$nt" "$na" "$nl" "$solver" --iters "$it" --warm "$warm"
  done
done
[ "$quick" = "--quick" ] && exit 0
run 1 weak 8 80 40 mumps --distribute 1 --iters 8 --warm 2
run 2 weak 8 80 80 mumps --iters 8 --warm 2
# The Newton phase's memory per rank (paper_notes/mpi.md, "Memory per rank with the Newton
# phase"): the 102 400-cell gutter, Newton entered at once and capped at 2 iterations, with
# ALG2's global step on MUMPS and on CG + GAMG, 1, 2 and 4 (oversubscribed) ranks.
newton=$build/experiments/bench_mpi_newton
for gs in cholesky cg-amg; do
  for p in 1 2 4; do
    echo "newton: global_solver $gs, $p rank(s)"
    mpirun -n "$p" --oversubscribe "$newton" "$(dirname "$0")/../fig6/fig6.toml" \
      mesh.parameters.nt=8 mesh.parameters.na=80 mesh.parameters.nl=160 \
      algorithm.newton_switch=1e9 algorithm.newton_max_iter=2 algorithm.max_iter=3 \
      "algorithm.global_solver=\"$gs\"" < /dev/null
  done
done
# The partition of the cells (paper_notes/mpi.md, "The ranks' cells: a graph partition").
"$bench" 8 80 160 --cuts 2,4,8,16,64,256 --label cuts
"$bench" --body cube 46 --cuts 2,4,8,16,64,256 --label cuts
# ALG2 on the cube of 46^3, and the Newton phase on one of 30^3, with either partition ("The
# Newton phase and the contact points on the cells' partition").
for p in 2 4; do
  for part in graph slabs; do
    if [ "$part" = slabs ]; then options=-ltl_mpi_slabs; else options=; fi
    PETSC_OPTIONS=$options mpirun -n "$p" --oversubscribe -x PETSC_OPTIONS "$bench" --body cube 46 \
      --solver cg-amg --iters 8 --warm 2 --label "$part" < /dev/null
    echo "newton: cube 30^3, $part, $p ranks"
    PETSC_OPTIONS=$options mpirun -n "$p" --oversubscribe -x PETSC_OPTIONS "$newton" \
      "$(dirname "$0")/cube.toml" mesh.parameters.n=30 algorithm.newton_switch=1e9 \
      algorithm.newton_max_iter=2 algorithm.max_iter=3 < /dev/null
  done
done
# The Newton phase's messages and GMRES iterations per Newton iteration, a whole step each
# (paper_notes/mpi_model.md, "The Newton phase at 64-1024 ranks").
for size in "4 10 20" "4 20 40"; do
  set -- $size
  echo "newton: whole step, gutter $1 x $2 x $3, 2 ranks, cg-amg"
  mpirun -n 2 --oversubscribe "$newton" "$(dirname "$0")/../fig6/fig6.toml" \
    mesh.parameters.nt="$1" mesh.parameters.na="$2" mesh.parameters.nl="$3" \
    'algorithm.global_solver="cg-amg"' < /dev/null
done
