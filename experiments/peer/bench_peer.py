#!/usr/bin/python3
"""Time to the same accuracy: the package (ALG2, plain and Anderson) against the dolfinx Newton
peer (experiments/peer/peer.py) on the meshes and observables of Figs 5 and 6.

    /usr/bin/python3 experiments/peer/bench_peer.py [--quick | --full] [--threads 1 2] [--json FILE]

Cases (the same discrete problem in both codes):
  fig5 K  half_disc.geo with n = nd = K (K = 7: the paper's 122 P2), P2 with mean-det
          incompressibility and nodal contact; the peer as `--element p2p0` (a DG0 pressure on
          det F, GLL contact quadrature at the P2 nodes, penalty continuation to 1e13 Pa/m).
          Observable: the drop of the top of the cylinder, -u2 at (0, 1).
  fig6 L  gutter.geo with (nt, na, nl) = L (2, 9, 15) (L = 1: the paper's 270 H8), H8 with
          mean-det; the peer as `--element q1p0` (arc-length from rest, penalty to 1e11 Pa/m).
          Observable: the sag, max over nodes of -u2.

Accuracy: an observable is "at 1e-3 / 1e-6" when its relative distance to the reference is at
most that; the reference is each code's own converged answer to its discrete problem (the
peer's final Newton iterate at the final penalty; the package's Anderson run at tol 1e-12, or
1e-11 where that does not converge); the two discretizations differ slightly (the package moves
C2 into C1, exact only where det F = 1 pointwise): the difference is printed. The equilibrium measure is, for both codes,
max nodal force residual / max nodal load (lib/measures.hpp; for the peer max |R_u| / max |f_u|
of its assembled residual at the current penalty, Dirichlet rows zeroed).

Times are of the whole process (CPU: user + system of all its threads, from the kernel's
rusage; wall: from launch), so they include mesh generation, factorization, and for the peer
Python's and dolfinx's start-up and form compilation (cached by FFCx after the first run).
  Package: build/experiments/refinement at algorithm.tol = 1e-3, 1e-4, ... (one process per
  tolerance); the time to an accuracy is that of the first (loosest) run that meets it (for
  Fig 5 the Anderson reference run at tol 1e-12 counts as the last run of the sweep).
  Peer: one run; every Newton (or arc-length corrector) iterate is recorded (hooked at the
  Jacobian assembly, the recording time subtracted); the time to an accuracy is the time of the
  first iterate from which on every later iterate meets it.
Threads: OMP_NUM_THREADS = OPENBLAS_NUM_THREADS = n for both (the package's OpenMP loops;
PETSc/MUMPS/BLAS threads of the peer).
"""
import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
PY = "/usr/bin/python3"
TARGETS = (1e-3, 1e-6)
LARGE = ("fig5:56", "fig6:2")  # plain and 2 threads only with --full
REF_TOL = 1e-12  # the package's reference run (Anderson): its own converged discrete answer


# --------------------------------------------------------------------------------------------
# The peer, in a child process (--worker): peer.py with a recorder hooked into its Newton
# --------------------------------------------------------------------------------------------
def worker(fig, level, out):
    t_launch = float(os.environ["BENCH_T0"])
    sys.path.insert(0, HERE)
    import peer_common
    import peer
    from peer_common import fem, fpetsc, np, ufl, PETSc, MPI

    records, pending, state = [], [None], {"overhead_cpu": 0.0, "overhead_wall": 0.0}

    def cpu():
        return sum(getattr(resource.getrusage(who), f) for who in
                   (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN) for f in ("ru_utime", "ru_stime"))

    def setup(solver):
        W = solver.w.function_space
        V, umap = W.sub(0).collapse()
        Xv = V.tabulate_dof_coordinates()
        gdim = V.mesh.geometry.dim
        umap = np.asarray(umap)
        is_u = np.zeros(solver.w.x.array.size, dtype=bool)
        is_u[umap] = True
        state["umap"], state["is_u"], state["gdim"] = umap, is_u, gdim
        if fig == "fig5":
            i = int(np.argmin(np.linalg.norm(Xv[:, :2] - [0.0, 1.0], axis=1)))
            state["top"] = umap[2 * i + 1]
            # the full load f = (0, f2) per unit area, as peer.solve_fig5 (quadrature degree 4)
            v, _ = ufl.split(ufl.TestFunction(W))
            dx = ufl.Measure("dx", domain=V.mesh, metadata={"quadrature_degree": 4})
            fv = fpetsc.assemble_vector(fem.form(ufl.dot(ufl.as_vector([0.0, peer.FIG5["f2"]]), v) * dx))
            fv.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            fpetsc.set_bc(fv, solver.bcs)
            state["fmax"] = float(np.max(np.abs(fv.array[umap])))

    def observable(w):
        if fig == "fig5":
            return float(-w[state["top"]])
        return float(np.max(-w[state["umap"]].reshape(-1, 3)[:, 1]))

    orig_residual = peer_common.NewtonSolver.residual

    def residual(self):
        r = orig_residual(self)
        c0, w0 = cpu(), time.time()
        if "umap" not in state:
            setup(self)
        if "fmax" in state:
            b = self.b.array
            # as lib/measures.cpp: max over displacement components of |R| / max |f|
            eq = float(np.max(np.abs(b[state["umap"]]))) / state["fmax"]
        else:
            eq = float("nan")
        pending[0] = {"cpu": c0 - state["overhead_cpu"], "wall": w0 - t_launch - state["overhead_wall"],
                      "obs": observable(self.w.x.array), "eq": eq}
        state["overhead_cpu"] += cpu() - c0
        state["overhead_wall"] += time.time() - w0
        return r

    peer_common.NewtonSolver.residual = residual
    orig_assemble = fpetsc.assemble_matrix

    def assemble_matrix(*a, **k):
        if pending[0] is not None:
            records.append(pending[0])
            pending[0] = None
        return orig_assemble(*a, **k)

    fpetsc.assemble_matrix = assemble_matrix
    if fig == "fig6":  # the load vector of the gutter: the one arc-length continues in
        orig_arc = peer.arclength

        def arclength(solver, lam, fvec, *a, **k):
            if "umap" not in state:
                setup(solver)
            state["fmax"] = float(np.max(np.abs(fvec.array[state["umap"]])))
            return orig_arc(solver, lam, fvec, *a, **k)

        peer.arclength = arclength
    if fig == "fig5":
        r = peer.solve_fig5(level, 2, [1e8 * 10.0 ** i for i in range(6)], element="p2p0")
    else:
        r = peer.solve_fig6(level, 1, "q1p0", [1e6 * 10.0 ** i for i in range(6)])
    if pending[0] is not None:
        records.append(pending[0])
    final = r["observables"]["drop" if fig == "fig5" else "sag"]
    with open(out, "w") as fh:
        json.dump({"records": records, "final": final, "dofs": r["dofs"], "cells": r["cells"],
                   "newton": r["newton_total"], "cpu_end": cpu() - state["overhead_cpu"],
                   "wall_end": time.time() - t_launch - state["overhead_wall"],
                   "penalty": r["observables"]["penalty"]}, fh)


def run_peer(fig, level, threads):
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), OPENBLAS_NUM_THREADS=str(threads),
               BENCH_T0=repr(time.time()))
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as tf:
        path = tf.name
    with open(os.devnull, "w") as devnull:
        p = subprocess.run([PY, os.path.abspath(__file__), "--worker", fig, str(level), path],
                           env=env, cwd=ROOT, stdout=devnull, stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        print(p.stderr[-3000:], file=sys.stderr)
        raise RuntimeError(f"peer {fig} {level} failed")
    with open(path) as fh:
        data = json.load(fh)
    os.unlink(path)
    return data


def peer_times(data, ref, target):
    """(cpu, wall) of the first record n with eq <= target at n (the residual of the problem
    being solved then: the current load and penalty) and |obs - ref| <= target |ref| at n and at
    every later record (no transient crossing of the reference counts); None if none."""
    recs = data["records"]
    first_obs = len(recs)
    for i in range(len(recs) - 1, -1, -1):
        if abs(recs[i]["obs"] - ref) <= target * abs(ref):
            first_obs = i
        else:
            break
    for r in recs[first_obs:]:
        if r["eq"] <= target:
            return r["cpu"], r["wall"]
    return None


# --------------------------------------------------------------------------------------------
# The package: build/experiments/refinement, one process per tolerance
# --------------------------------------------------------------------------------------------
def run_package(fig, level, tol, variant, threads):
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), OPENBLAS_NUM_THREADS=str(threads))
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as tf:
        path = tf.name
    args = [os.path.join(ROOT, "build", "experiments", "refinement"), fig, f"levels={level}",
            f"json={path}", f"algorithm.tol={tol:g}", "algorithm.max_iter=100000"]
    if variant == "anderson":
        args.append('algorithm.acceleration="anderson"')
    if variant == "newton":  # ALG2 into Newton's method on the same discrete problem
        args.append('algorithm.solver="newton"')
    t0 = time.time()
    p = subprocess.Popen(args, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.time() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    err = p.stderr.read().decode()
    try:
        with open(path) as fh:
            row = json.load(fh)["runs"][0]
    except (OSError, ValueError, IndexError):
        print(f"package {fig} {level} tol {tol:g} {variant}: no result ({err.strip()[-300:]})",
              file=sys.stderr)
        row = None
    os.unlink(path)
    if row is None:
        return None
    return {"tol": tol, "cpu": ru.ru_utime + ru.ru_stime, "wall": wall, "obs": row["drop"],
            "eq": row["force_residual"], "iterations": row["iterations"],
            "converged": row["converged"], "nodes": row["nodes"], "cells": row["cells"]}


def package_sweep(fig, level, variant, threads, ref, tols):
    """Runs at increasing tightness until both targets are met (or the tolerances run out)."""
    runs = []
    for tol in tols:
        r = run_package(fig, level, tol, variant, threads)
        if r is None:
            continue
        runs.append(r)
        print(f"    package {variant:8s} tol {tol:7.0e}: {r['iterations']:6d} it, cpu {r['cpu']:7.2f} s, "
              f"wall {r['wall']:7.2f} s, obs {r['obs']:.9g} (rel. err {abs(r['obs'] - ref) / abs(ref):.1e}), "
              f"eq {r['eq']:.1e}{'' if r['converged'] else ' NOT CONVERGED'}", flush=True)
        if meets(r, ref, TARGETS[-1]):
            break
    return runs


def meets(r, ref, target):
    return (r["converged"] and abs(r["obs"] - ref) <= target * abs(ref) and r["eq"] <= target)


def package_times(runs, ref, target):
    for r in runs:
        if meets(r, ref, target):
            return r["cpu"], r["wall"], r["iterations"]
    return None


# --------------------------------------------------------------------------------------------
def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worker", nargs=3, metavar=("FIG", "LEVEL", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--quick", action="store_true", help="Fig 5 K = 7, 28 and Fig 6 L = 1 only")
    ap.add_argument("--cases", nargs="+", default=None,
                    help="e.g. fig5:7 fig5:28 fig5:56 fig6:1 fig6:2 (the default)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--variants", nargs="+", default=["none", "anderson", "newton"],
                    choices=["none", "anderson", "newton"])
    ap.add_argument("--full", action="store_true",
                    help="every variant and thread count on the large cases too (~45 min idle); "
                         "by default fig5:56 and fig6:2 run Anderson on 1 thread only (~10 min)")
    ap.add_argument("--tols", type=float, nargs="+", default=[10.0 ** -e for e in range(3, 12)],
                    help="the package's tolerances, loosest first (default 1e-3 ... 1e-11)")
    ap.add_argument("--package-ref", nargs=2, action="append", metavar=("FIG", "SOURCE"), default=[],
                    help="the package's reference: 'own' (its Anderson run at tol 1e-12; fig5's "
                         "default) or 'peer' (the peer's final value: the same discrete problem, "
                         "fig6's default; 1.7e-9 apart on the paper's mesh)")
    ap.add_argument("--json", default=None, help="write every measurement to this file")
    a = ap.parse_args()
    if a.worker:
        worker(a.worker[0], int(a.worker[1]), a.worker[2])
        return
    if a.cases is None:
        a.cases = (["fig5:7", "fig5:28", "fig6:1"] if a.quick
                   else ["fig5:7", "fig5:28", "fig5:56", "fig6:1", "fig6:2"])
    tols = a.tols
    a.package_ref = dict({"fig5": "own", "fig6": "peer"}, **dict(a.package_ref))
    pkg_ref = {}
    load = os.getloadavg()
    print(f"bench-peer: load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} at start, "
          f"{os.cpu_count()} cores", flush=True)
    # fill the FFCx form cache (the forms do not depend on the mesh) with an untimed small run
    for fig in sorted({c.split(":")[0] for c in a.cases}):
        run_peer(fig, 7 if fig == "fig5" else 1, 1)
    results = []
    for case in a.cases:
        fig, level = case.split(":")
        level = int(level)
        large = case in LARGE and not a.full
        for th in (a.threads[:1] if large else a.threads):
            variants = ([v for v in ("anderson", "newton") if v in a.variants] if large
                        else a.variants)
            print(f"== {fig} level {level}, {th} thread(s)", flush=True)
            pd = run_peer(fig, level, th)
            ref = pd["final"]
            print(f"    peer: {pd['dofs']} unknowns, {pd['newton']} Newton/corrector iterations, "
                  f"cpu {pd['cpu_end']:.2f} s, wall {pd['wall_end']:.2f} s, final {ref:.9g}, "
                  f"penalty {pd['penalty']:.0e}", flush=True)
            if a.package_ref[fig] == "peer":  # the same discrete problem: the peer's answer
                pkg_ref.setdefault(fig, {})[level] = {"obs": ref, "tol": None, "source": "peer"}
            if fig not in pkg_ref or level not in pkg_ref[fig]:  # the package's own reference
                rr = run_package(fig, level, REF_TOL, "anderson", th)
                if rr is None or not rr["converged"]:  # a round-off floor: one decade looser
                    rr = run_package(fig, level, 10 * REF_TOL, "anderson", th)
                if rr is None or not rr["converged"]:
                    raise RuntimeError(f"package reference run {case} failed")
                rr["threads"] = th
                pkg_ref.setdefault(fig, {})[level] = rr
                print(f"    package reference (anderson, tol {rr['tol']:g}): {rr['iterations']} it, "
                      f"{rr['obs']:.9g}, eq {rr['eq']:.1e}; relative difference to the peer "
                      f"{abs(rr['obs'] - ref) / abs(ref):.1e} (the discretizations differ by that)",
                      flush=True)
            pref = pkg_ref[fig][level]["obs"]
            pk = {v: package_sweep(fig, level, v, th, pref, tols) for v in variants}
            rr = pkg_ref[fig][level]
            if ("anderson" in pk and rr.get("tol") and rr.get("threads") == th
                    and not any(meets(x, pref, TARGETS[-1]) for x in pk["anderson"])):
                pk["anderson"].append(rr)  # the reference run is the tightest Anderson run
            row = {"case": case, "threads": th, "peer_dofs": pd["dofs"], "cells": pd["cells"],
                   "peer_final": ref, "peer_newton": pd["newton"],
                   "peer_total_cpu": pd["cpu_end"], "peer_total_wall": pd["wall_end"],
                   "package_runs": pk, "package_reference": pkg_ref[fig][level], "load": os.getloadavg(), "targets": {}}
            anyrun = next((rs[0] for rs in pk.values() if rs), None)
            if anyrun:
                row["nodes"] = anyrun["nodes"]
                row["package_unknowns"] = anyrun["nodes"] * (2 if fig == "fig5" else 3)
            for t in TARGETS:
                e = {"peer": peer_times(pd, ref, t)}
                for v, rs in pk.items():
                    e[v] = package_times(rs, pref, t)
                row["targets"][f"{t:g}"] = e
            results.append(row)
            if a.json:
                with open(a.json, "w") as fh:
                    json.dump(results, fh, indent=1)
    print_table(results, a.variants)


def print_table(results, variants):
    print("\nTime to the same accuracy (observable within the target of its reference, and "
          "the equilibrium measure below it); whole-process CPU s (wall s); ratio = package CPU / peer CPU")
    head = f"{'case':>8} {'thr':>3} {'pkg nodes':>9} {'peer dofs':>9} {'acc':>6} {'peer':>15}"
    for v in variants:
        head += f" {('pkg ' + v):>22} {'ratio':>6}"
    print(head)
    for row in results:
        for t, e in row["targets"].items():
            p = e["peer"]
            line = (f"{row['case']:>8} {row['threads']:>3} {row.get('nodes', 0):>9} {row['peer_dofs']:>9} "
                    f"{t:>6} " + (f"{p[0]:6.2f} ({p[1]:6.2f})" if p else f"{'-':>15}"))
            for v in variants:
                q = e.get(v, False)
                if q is False:
                    line += f" {'not run':>22} {'-':>6}"
                elif q:
                    line += f" {q[0]:7.2f} ({q[1]:6.2f}) {q[2]:5d}it"
                    line += f" {q[0] / p[0]:6.2f}" if p else f" {'-':>6}"
                else:
                    line += f" {'not reached':>22} {'-':>6}"
            print(line)
    print("\nload average at the end of each case: " + ", ".join(
        f"{r['case']}/{r['threads']}: {r['load'][0]:.1f}" for r in results))


if __name__ == "__main__":
    main()
