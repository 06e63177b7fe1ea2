#!/usr/bin/python3
"""Time per distributed ALG2 iteration at 64-1024 ranks: a model (paper_notes/mpi.md, "A model
at 64-1024 ranks").

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
    """Ghost values per rank (summed over the SOLVES component solves) and neighbours, for 2-D
    blocks of the (na, nl) surface (the wall is 8 cells thick): four faces. They stand for
    PT-Scotch's graph partition, the ranks' cells since 2026-12-02 (check() compares the facets
    cut). Until then the cells were slabs across the length: two faces of the cross-section,
    3 x 2 (nt+1)(na+1) ghosts and 2 neighbours, up to nl/2 ranks."""
    if P == 1:
        return 0, 0
    side = math.sqrt(g["na"] * g["nl"] / P)
    return SOLVES * 4 * (g["nt"] + 1) * (side + 1), 8


def iteration(g, P, net, design):
    """Seconds per ALG2 iteration on P ranks, split as compute / PETSc / ours."""
    alpha, bw = net
    beta = RANKS_PER_NODE / bw if P > 1 else 0.0  # every rank of a node on the port at once
    cells, nodes, points = g["cells"], g["nodes"], g["points"]
    k = K0 + K1 * math.log2(P)
    compute = C_LOCAL * cells / P + C_KRYLOV * k * cells / P
    ghost, nb = ghosts(g, P)
    # The component solves one after the other (today), or as one block system (a KSP with block
    # size 3: the same bytes in a third of the messages and reductions; not built).
    solves = 1 if design == "ghost layer, one block solve" else SOLVES
    petsc = solves * k * (MSG_PER_ITER * nb * alpha + RED_PER_ITER * allreduce(8, P, alpha, beta))
    petsc += k * B_PER_GHOST * ghost * beta
    if design == "as built":  # since 2026-11-28 the right-hand side and u on the ghost
        # layer, an assembly and a scatter per component (paper_notes/mpi.md); E and lambda stay
        # on their ranks; since 2026-12-02 the contact points' fields too (gathered once per
        # ALG2 phase, not per iteration: not in the time of an iteration)
        ours = 2 * SOLVES * nb * alpha + 2 * 8 * ghost * beta
        ours += 2 * allreduce(8 * 4, P, alpha, beta)  # residual parts with finiteness, failures
    else:  # a ghost layer: right-hand side and u exchanged on the ghosts only
        ours = 2 * (nb * alpha + 8 * D * ghost / SOLVES * beta)
        ours += 2 * allreduce(8 * 4, P, alpha, beta)
    return compute, petsc, ours


def table(cells_total=None, cells_per_rank=None, file=sys.stdout):
    ranks = [1, 64, 128, 256, 512, 1024]
    for name, net in NETWORKS.items():
        for design in ("as built", "ghost layer", "ghost layer, one block solve"):
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


if __name__ == "__main__":
    if "--check" in sys.argv:
        failures = check()
        for f in failures:
            print("FAIL:", f)
        sys.exit(1 if failures else 0)
    table(cells_total=998400)
    table(cells_per_rank=100000)
