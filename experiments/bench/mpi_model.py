#!/usr/bin/python3
"""Time per distributed ALG2 iteration at 64-1024 ranks, and per Newton iteration (GMRES +
GAMG): a model (paper_notes/mpi_model.md).

    /usr/bin/python3 experiments/bench/mpi_model.py            # the tables of the note
    /usr/bin/python3 experiments/bench/mpi_model.py --check    # the model against the measured rows

Built from three kinds of numbers:
  * MEASURED on this machine (`make bench-mpi`, the 102 400-cell gutter nt x na x nl = 8 x 80 x
    160, CG + GAMG, 2 ranks; the table of paper_notes/mpi.md): the compute per cell of the local
    phases and of one Krylov iteration, the Krylov iterations per solve against P, PETSc's bytes
    per Krylov iteration and ghost value, and our collectives' bytes (formula checked against the
    measured counts);
  * PUBLISHED network figures (cited in the note): 200 Gb/s per node port (HDR InfiniBand,
    Slingshot), 100 Gb/s (HDR100) with a 4.7:1 blocking factor between islands (Narval), and an
    MPI latency bracketed by the vendors' sub-microsecond port-to-port figures and the 2-5 us of
    the Red Storm specification;
  * the classic cost models of the collectives (Thakur, Rabenseifner and Gropp 2005; Hockney
    1994): a message of n bytes costs alpha + n beta; allreduce min(recursive doubling,
    Rabenseifner); allgather log2(P) alpha + (P - 1)/P n beta.
Every rank of a node shares the node's port: beta per rank = ranks_per_node / bandwidth.
"""
import math
import sys

# ---- measured (bench_mpi, 102 400 cells, CG + GAMG; see paper_notes/mpi.md) -------------------
CELLS_MEASURED = 102400
# Local phases per cell and ALG2 iteration: strain step + update + right-hand side and Gbar u
# (the global phase without its solve and collectives), 2 ranks: (16.70 + 7.02 + (578.12 -
# 499.12 - 10.50)) ms x 2 ranks / 102 400 cells.
C_LOCAL = (16.70 + 7.02 + (578.12 - 499.12 - 10.50)) * 1e-3 * 2 / CELLS_MEASURED
# One Krylov iteration of the global step's solves (CG + GAMG, every component), per cell:
# 499.12 ms / 18.5 iterations x 2 ranks / 102 400 cells.
C_KRYLOV = 499.12e-3 / 18.5 * 2 / CELLS_MEASURED
# Krylov iterations per solve against P: 16.9, 18.5, 19.3 at P = 1, 2, 4, fitted as
# K0 + K1 log2 P (extrapolated: an assumption, GAMG's iterations grow slowly with P).
K0, K1 = 16.9, 1.2
# PETSc's bytes per Krylov iteration per ghost value (summed over the component solves'
# off-diagonal columns): 2 785 929 B / 18.5 / 2 260 ghosts at 2 ranks.
B_PER_GHOST = 2785929 / 18.5 / 2260
SOLVES = 3  # component solves per ALG2 iteration (one KSP per Dirichlet set, the gutter's 3)
# Messages per Krylov iteration and neighbour, and reductions per Krylov iteration, each per
# component solve: PETSc's counters (petsc_irecv_ct + petsc_recv_ct, petsc_allreduce_ct) in
# bench_mpi on the 9 900-cell gutter (3 x 30 x 110), CG + GAMG: 618 messages and 112 reductions
# per ALG2 iteration on 2 ranks (one neighbour each, 3 solves x 11.4 iterations), 1 266 and 118
# on 4 ranks (two neighbours for the inner slabs, 3 x 12.0): 18 messages per neighbour and 3.3
# reductions per Krylov iteration.
MSG_PER_ITER = 18
RED_PER_ITER = 3.3
# Since the third session of 2026-12-03 the solves are inexact by default (the serial CG + AMG's
# rule, lib/mpi_global.hpp): bench_mpi on 2 ranks of the 102 400-cell gutter, iterations 3-22,
# 3.3 Krylov iterations per solve against 20.6 with -ltl_mpi_rtol 1e-12. Assumed to grow with P as
# the tight count does (INEXACT x (K0 + K1 log2 P)), plus per solve the warm start's residual:
# one product (a message per neighbour) and one reduction of two norms.
INEXACT = 3.3 / 20.6
D = 3  # dimension

# ---- published networks (paper_notes/mpi.md cites each) -----------------------------------------
NETWORKS = {
    # name: (alpha seconds, node bandwidth bytes/s)
    "HDR 200 Gb/s, alpha 1.5 us": (1.5e-6, 25e9),
    "HDR100 across 4.7:1 islands, alpha 5 us": (5e-6, 12.5e9 / 4.7),
}
RANKS_PER_NODE = 64


def gutter(cells):
    """An nt x na x nl gutter in bench_mpi's proportions (nt = 8 cells through the wall, nl = 2 na
    along it; 8 x 80 x 160 is the measured one): cells, nodes and contact points (the outer
    face's nodes)."""
    nt = 8
    na = max(1, round(math.sqrt(cells / nt / 2)))
    nl = 2 * na
    return dict(nt=nt, na=na, nl=nl, cells=nt * na * nl, nodes=(nt + 1) * (na + 1) * (nl + 1),
                points=(na + 1) * (nl + 1))


def allreduce(n, P, alpha, beta):
    """Thakur, Rabenseifner, Gropp (2005): recursive doubling for short vectors, Rabenseifner's
    reduce-scatter + allgather for long ones (the cheaper of the two)."""
    if P == 1:
        return 0.0
    lg = math.ceil(math.log2(P))
    return min(lg * (alpha + n * beta), 2 * lg * alpha + 2 * (P - 1) / P * n * beta)


def allgather(n, P, alpha, beta):
    """n bytes gathered in total (each rank brings n / P)."""
    if P == 1:
        return 0.0
    return math.ceil(math.log2(P)) * alpha + (P - 1) / P * n * beta


def ghosts(g, P):
    """Ghost nodes per rank and neighbours, for 2-D blocks of the (na, nl) surface (the wall is
    8 cells thick): four faces; the global step's ghost values are SOLVES times the nodes. They
    stand for PT-Scotch's graph partition, the ranks' cells since 2026-12-02 (check() compares
    the facets cut). Until then the cells were slabs across the length: two faces of the
    cross-section, 2 (nt+1)(na+1) ghost nodes and 2 neighbours, up to nl/2 ranks."""
    if P == 1:
        return 0, 0
    side = math.sqrt(g["na"] * g["nl"] / P)
    return 4 * (g["nt"] + 1) * (side + 1), 8


def iteration(g, P, net, design):
    """Seconds per ALG2 iteration on P ranks, split as compute / PETSc / ours."""
    alpha, bw = net
    beta = RANKS_PER_NODE / bw if P > 1 else 0.0  # every rank of a node on the port at once
    cells, nodes, points = g["cells"], g["nodes"], g["points"]
    k = K0 + K1 * math.log2(P)
    inexact = design == "as built, inexact solves"
    if inexact:
        k *= INEXACT
    compute = C_LOCAL * cells / P + C_KRYLOV * k * cells / P
    ghost_nodes, nb = ghosts(g, P)
    ghost = SOLVES * ghost_nodes  # the component solves' ghost values
    # The component solves one after the other (today), or as one block system (a KSP with block
    # size 3: the same bytes in a third of the messages and reductions; not built).
    solves = 1 if design == "ghost layer, one block solve" else SOLVES
    petsc = solves * k * (MSG_PER_ITER * nb * alpha + RED_PER_ITER * allreduce(8, P, alpha, beta))
    petsc += k * B_PER_GHOST * ghost * beta
    if inexact:  # the warm start's residual, per component solve
        petsc += solves * (nb * alpha + allreduce(16, P, alpha, beta)) + 8 * ghost * beta
    if design.startswith("as built"):  # since 2026-11-28 the right-hand side and u on the ghost
        # layer, an assembly and a scatter per component (paper_notes/mpi.md); E and lambda stay
        # on their ranks; since 2026-12-02 the contact points' fields too (gathered once per
        # ALG2 phase, not per iteration: not in the time of an iteration)
        ours = 2 * SOLVES * nb * alpha + 2 * 8 * ghost * beta
        ours += 2 * allreduce(8 * 4, P, alpha, beta)  # residual parts with finiteness, failures
        # under ltl_run, since 2026-12-03 (second session), the signal the run stops for, decided
        # over the ranks once an iteration (lib/simulation.cpp, run_signal)
        ours += allreduce(8, P, alpha, beta)
    else:  # a ghost layer: right-hand side and u exchanged on the ghosts only
        ours = 2 * (nb * alpha + 8 * D * ghost_nodes * beta)
        ours += 2 * allreduce(8 * 4, P, alpha, beta)
    return compute, petsc, ours


def table(cells_total=None, cells_per_rank=None, file=sys.stdout):
    ranks = [1, 64, 128, 256, 512, 1024]
    for name, net in NETWORKS.items():
        for design in ("as built", "ghost layer", "ghost layer, one block solve",
                       "as built, inexact solves"):
            what = ("strong, %.3g cells" % cells_total if cells_total else
                    "weak, %.3g cells per rank" % cells_per_rank)
            print("\n%s; %s; %s; %d ranks per node" % (what, design, name, RANKS_PER_NODE),
                  file=file)
            print("| P | cells | ms/it | compute | PETSc | ours | efficiency |", file=file)
            print("|---|---|---|---|---|---|---|", file=file)
            t1 = None
            for P in ranks:
                g = gutter(cells_total if cells_total else cells_per_rank * P)
                r = iteration(g, P, net, design)
                t = sum(r)
                if P == 1:
                    t1 = t
                eff = t1 / (P * t) if cells_total else t1 / t
                print("| %d | %d | %.2f | %.2f | %.2f | %.2f | %.2f |" %
                      (P, g["cells"], 1e3 * t, 1e3 * r[0], 1e3 * r[1], 1e3 * r[2], eff),
                      file=file)


def check():
    """The model's pieces against what bench_mpi measured (the P = 2 rows of the note's table):
    our bytes formula against the measured count, and the compute term against the measured
    1-rank time. Returns the failures."""
    fails = []
    g = gutter(CELLS_MEASURED)
    if (g["nt"], g["na"], g["nl"]) != (8, 80, 160):
        fails.append("gutter(102400) is %s, not 8 x 80 x 160" % g)
    # Our bytes received per rank and iteration on 2 ranks, contact replicated off (d0 = 0), with
    # the ghost layer (the right-hand side and u are PETSc's messages): since 2026-12-02 the two
    # sums of the residual parts with u's finiteness (4 doubles) and of the failures (1), 40 B.
    # Measured (2026-12-02) by bench_mpi on 2 ranks of the 9 900-cell gutter as the difference
    # between 8 and 4 timed iterations (the step's end, once per step, cancels): (918 888 - 918
    # 728) / 4 = 40 B. Until 2026-12-02 also 8 (2d + 1) S / 2 for the contact points' blocks:
    # with the end of bench_mpi's step then, 1 812 806 B measured on 2 ranks of the 102 400-cell
    # gutter (2026-11-28) against 1 814 908 modelled.
    c = g["cells"]
    ours = 8 * (4 + 1)
    measured = (918888 - 918728) / 4
    if ours != measured:
        fails.append("our bytes per iteration: model %.0f, measured %.0f" % (ours, measured))
    # 1 rank, CG + GAMG: strain + update + (global - solve) + solve = 1 205.24 - coll. (0).
    t1 = C_LOCAL * c + C_KRYLOV * K0 * c
    if abs(t1 / 1.20524 - 1) > 0.15:
        fails.append("1-rank compute: model %.3f s, measured 1.205 s" % t1)
    print("bytes ours per iteration: model %.0f, measured %.0f; 1 rank: model %.3f s, measured"
          " 1.205 s" % (ours, measured, t1))
    # The partition: the facets cut between the parts of the best a x b grid of 2-D blocks of the
    # (na, nl) surface (a b = P, each cut nt deep), against PT-Scotch's cut of the 102 400-cell
    # gutter measured by `bench_mpi 8 80 160 --cuts 64,256` (2026-12-02): 14 674 and 35 509.
    # The model's ghosts take the blocks' faces; PT-Scotch's parts have up to a quarter more.
    for P, cut in ((64, 14674), (256, 35509)):
        model = min(g["nt"] * ((a - 1) * g["nl"] + (P // a - 1) * g["na"])
                    for a in range(1, P + 1) if P % a == 0)
        print("facets cut by %d parts: 2-D blocks %d, PT-Scotch %d (%+.1f %%)" %
              (P, model, cut, 100 * (cut / model - 1)))
        if not 1 <= cut / model <= 1.25:
            fails.append("facets cut by %d parts: blocks %d, PT-Scotch %d" % (P, model, cut))
    return fails


# ---- the Newton phase (measured 2026-12-03, bench_mpi_newton, the gutter, 2 ranks, the Newton
# phase's linear systems by GMRES + GAMG over the ranks: algorithm.global_solver = "cg-amg") ----
# Three gutters nt x na x nl, one step each, from rest to convergence: cells, nodes, Newton
# iterations (of the step's iterations, one was ALG2's), GMRES iterations, GMRES seconds, set-up
# seconds (the tangent's assembly and GAMG's set-up, once per Newton iteration), step wall
# seconds, our collectives' bytes received by the largest rank, PETSc's messages, reductions and
# bytes received by the largest rank.
def _run(nt, na, nl, **measured):
    """One measured Newton step of the nt x na x nl gutter: its cells, nodes and the face of the
    cut between the 2 ranks ((nt+1)(na+1) nodes), with what was measured."""
    return dict(cells=nt * na * nl, nodes=(nt + 1) * (na + 1) * (nl + 1), face=(nt + 1) * (na + 1),
                **measured)


NEWTON_RUNS = [
    _run(4, 10, 20, newton=31, iterations=32, gmres=11148, gmres_s=6.62, setup_s=0.72,
         wall=7.392, ours=4411264, msgs=257606, reductions=23824, petsc_bytes=223480588),
    _run(4, 20, 40, newton=31, iterations=32, gmres=4284, gmres_s=12.39, setup_s=3.04,
         wall=15.612, ours=16091600, msgs=143792, reductions=10156, petsc_bytes=172577260),
    _run(8, 30, 60, newton=54, iterations=55, gmres=18728, gmres_s=524.05, setup_s=23.30,
         wall=548.584, ours=102839824, msgs=611772, reductions=39911, petsc_bytes=1874291272),
]
_N = NEWTON_RUNS[2]  # the largest calibrates the model; the others bracket it
# One GMRES iteration (GAMG's V-cycle, the products, GMRES(60)'s orthogonalization), per cell:
# 3.9 us on the 14 400-cell gutter (1.5 and 1.8 us on the smaller two).
C_GMRES = _N["gmres_s"] / _N["gmres"] * 2 / _N["cells"]
# The tangent's assembly and GAMG's set-up, per Newton iteration and cell.
C_NSETUP = _N["setup_s"] / _N["newton"] * 2 / _N["cells"]
# The rest of a Newton iteration (residuals, line search, active set), per cell.
C_NREST = (_N["wall"] - _N["gmres_s"] - _N["setup_s"]) / _N["iterations"] * 2 / _N["cells"]
# GMRES iterations per Newton iteration: 360, 138 and 347 on the three gutters (no trend with
# the mesh; the forcing term takes them to 1e-10 near the solution). The model's least certain
# input: the tables take 350 and, for the sensitivity, 4 x 350.
K_NEWTON = 350
# PETSc's messages per GMRES iteration and neighbour, and reductions per GMRES iteration (2
# ranks: one neighbour): 33 and 2.2 (23-34 and 2.1-2.4 on the three gutters).
N_MSG_PER_ITER = 33
N_RED_PER_ITER = 2.2
# PETSc's bytes per GMRES iteration and node of the cut's face (the face of (nt+1)(na+1) nodes
# between the 2 ranks): 358 and 384 B on the two larger gutters.
N_B_PER_FACE_NODE = 370
# Our collectives per Newton iteration: whole-size sums (the residual R_u and G, the multiplier
# sweeps' right-hand sides, the tangent's diagonal, to_state; lib/newton*.cpp) of about 4.6
# vectors of 8 d N bytes (4.97, 4.87 and 4.58 on the three gutters), in about 12 calls.
N_WHOLE_VECTORS = 4.6
N_CALLS = 12


def newton_iteration(g, P, net, design, k=K_NEWTON):
    """Seconds per Newton iteration on P ranks (compute / PETSc / ours). design "as built": our
    sums are whole-size allreduces; "ghost layer": the same vectors exchanged on the ghosts (not
    built), and the other calls small allreduces."""
    alpha, bw = net
    beta = RANKS_PER_NODE / bw if P > 1 else 0.0
    cells, nodes = g["cells"], g["nodes"]
    compute = (C_GMRES * k + C_NSETUP + C_NREST) * cells / P
    ghost_nodes, nb = ghosts(g, P)
    petsc = k * (N_MSG_PER_ITER * nb * alpha + N_RED_PER_ITER * allreduce(8, P, alpha, beta))
    petsc += k * N_B_PER_FACE_NODE * ghost_nodes * beta
    if design == "as built":
        ours = N_WHOLE_VECTORS * allreduce(8 * D * nodes, P, alpha, beta)
        ours += (N_CALLS - N_WHOLE_VECTORS) * allreduce(8, P, alpha, beta)
    else:
        ours = N_WHOLE_VECTORS * (nb * alpha + 8 * D * ghost_nodes * beta)
        ours += (N_CALLS - N_WHOLE_VECTORS) * allreduce(8, P, alpha, beta)
    return compute, petsc, ours


def newton_table(cells_total, file=sys.stdout):
    net_name = "HDR 200 Gb/s, alpha 1.5 us"
    net = NETWORKS[net_name]
    for k in (K_NEWTON, 4 * K_NEWTON):
        for design in ("as built", "ghost layer"):
            print("\nNewton, strong, %.3g cells; %d GMRES iterations per Newton iteration; %s; %s"
                  % (cells_total, k, design, net_name), file=file)
            print("| P | s/Newton it | compute | PETSc | ours | ours, share | efficiency |",
                  file=file)
            print("|---|---|---|---|---|---|---|", file=file)
            t1 = None
            for P in (1, 64, 128, 256, 512, 1024):
                r = newton_iteration(gutter(cells_total), P, net, design, k)
                t = sum(r)
                t1 = t if P == 1 else t1
                print("| %d | %.3f | %.3f | %.3f | %.3f | %.2f | %.2f |" %
                      (P, t, r[0], r[1], r[2], r[2] / t, t1 / (P * t)), file=file)


def check_newton():
    """The Newton phase's constants against the three measured runs: our whole-size vectors per
    Newton iteration, PETSc's messages and reductions per GMRES iteration and its bytes per face
    node, each within the band the runs span. Returns the failures."""
    fails = []
    for r in NEWTON_RUNS:
        whole = r["ours"] / r["iterations"] / (8 * D * r["nodes"])
        msgs = r["msgs"] / r["gmres"]
        red = r["reductions"] / r["gmres"]
        per_face = r["petsc_bytes"] / r["gmres"] / r["face"]
        print("Newton, %d cells: %.2f whole vectors per iteration (model %.1f), %.1f messages and"
              " %.2f reductions per GMRES iteration (model %d, %.1f), %.0f B per face node (model"
              " %d), %.0f GMRES iterations per Newton iteration" %
              (r["cells"], whole, N_WHOLE_VECTORS, msgs, red, N_MSG_PER_ITER, N_RED_PER_ITER,
               per_face, N_B_PER_FACE_NODE, r["gmres"] / r["newton"]))
        larger = r["cells"] >= 3200  # the smallest gutter has fewer GAMG levels: 23 messages
        for what, value, model, band, applies in (
                ("whole vectors per iteration", whole, N_WHOLE_VECTORS, 0.10, True),
                ("reductions per GMRES iteration", red, N_RED_PER_ITER, 0.15, True),
                ("messages per GMRES iteration", msgs, N_MSG_PER_ITER, 0.10, larger),
                ("B per face node", per_face, N_B_PER_FACE_NODE, 0.10, larger)):
            if applies and abs(value / model - 1) > band:
                fails.append("Newton, %d cells: %.3g %s (model %g)" %
                             (r["cells"], value, what, model))
    return fails


if __name__ == "__main__":
    if "--check" in sys.argv:
        failures = check() + check_newton()
        for f in failures:
            print("FAIL:", f)
        sys.exit(1 if failures else 0)
    table(cells_total=998400)
    table(cells_per_rank=100000)
    newton_table(cells_total=998400)
