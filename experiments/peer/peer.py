#!/usr/bin/python3
"""Independent dolfinx 0.5 peer for the contact problems of Le Tallec & Lotfi (1987), Figs 5 and 6.

Incompressible Mooney-Rivlin, mixed displacement/pressure (Taylor-Hood P2/P1 on triangles,
Q2/Q1 on hexahedra; optionally Q1/P0 in 3-D), full Newton (MUMPS LU, backtracking line search),
frictionless contact with a rigid plane by a quadratic penalty on the gap at facet quadrature
points, with load stepping at a moderate penalty and then penalty continuation at full load.
Fig 6 (the gutter falling onto the plane): arc-length continuation in the load from rest with
the plane in place (a smoothed penalty), then the penalty continuation; or (--strategy nested)
Newton at full load from the converged state of another mesh, interpolated (--save / --init).
Fig 6 elements: Q2/Q1 Taylor-Hood on the quadratic geometry (the reference), or --element q1p0
(mean dilatation: a DG0 pressure, int_e (det F - 1) q = 0, 2x2x2 Gauss) with nodal contact on
the trilinear geometry, i.e. the package's H8 discrete problem with mean-det incompressibility.

Usage (from the repository root):
  OMP_NUM_THREADS=1 /usr/bin/python3 experiments/peer/peer.py fig5 --levels 7 14 28 56 --out results/peer/fig5.json
  OMP_NUM_THREADS=1 /usr/bin/python3 experiments/peer/peer.py fig6 --levels 1 --save results/peer/q2 --out results/peer/fig6.json
  OMP_NUM_THREADS=1 /usr/bin/python3 experiments/peer/peer.py fig6 --levels 2 --strategy nested --init results/peer/q2_L1.npz --out results/peer/fig6.json
  /usr/bin/python3 experiments/peer/peer.py table results/peer/fig5.json
"""
import argparse
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_common import (  # noqa: E402
    ROOT, MPI, PETSc, Timer, FacetSampler, NewtonSolver, assemble, basix, fem, fpetsc, load_geo, np,
    ufl)


def mooney_rivlin_psi(Fm, q, C1, C2):
    """W(F) - q (det F - 1) for the 3x3 deformation gradient Fm."""
    C = Fm.T * Fm
    I1 = ufl.tr(C)
    I2 = 0.5 * (I1 ** 2 - ufl.tr(C * C))
    return C1 * (I1 - 3) + C2 * (I2 - 3) - q * (ufl.det(Fm) - 1)


def mixed_space(mesh, element):
    cell = mesh.ufl_cell()
    if element == "taylor-hood":  # P2/P1 (triangles) or Q2/Q1 (hexahedra)
        Ue = ufl.VectorElement("Lagrange", cell, 2)
        Pe = ufl.FiniteElement("Lagrange", cell, 1)
    elif element == "p2p0":  # mean-det: (1/|O_e|) integral det F = 1 per cell
        Ue = ufl.VectorElement("Lagrange", cell, 2)
        Pe = ufl.FiniteElement("DG", cell, 0)
    elif element == "q1p0":
        Ue = ufl.VectorElement("Lagrange", cell, 1)
        Pe = ufl.FiniteElement("DG", cell, 0)
    else:
        raise ValueError(element)
    return fem.FunctionSpace(mesh, ufl.MixedElement([Ue, Pe]))


def pos(x):
    return ufl.max_value(x, 0.0)


def smooth_pos(x, delta):
    """C1 (Huber-like) regularisation of max(x, 0): x - delta/2 for x > delta, x^2/(2 delta) on
    [0, delta], 0 below; equals max(x, 0) when delta = 0."""
    return ufl.conditional(ufl.gt(x, delta), x - delta / 2,
                           ufl.conditional(ufl.gt(x, 0.0), x * x / (2 * ufl.max_value(delta, 1e-300)), 0.0))


class Damping:
    """Pseudo-transient continuation: the residual carries + c (u - u_old) . v dx; c = 0 except
    inside ptc(). Used to pass limit points (snap-through) of the load/obstacle path: a damped
    (gradient-flow-like) sequence of solves at a fixed load that ends in a stable equilibrium,
    after which c is set to 0 and the undamped problem is solved (the result carries no damping)."""

    def __init__(self, mesh, W, c0):
        self.c = fem.Constant(mesh, PETSc.ScalarType(0.0))
        self.w_old = fem.Function(W)
        self.c0 = c0

    def term(self, u, v):
        u_old, _ = ufl.split(self.w_old)
        return self.c * ufl.dot(u - u_old, v)


def ptc(solver, damp, ref_norm, log, verbose=False, max_steps=3000, rtol=1e-10):
    """Pseudo-transient continuation (Kelley & Keyes' Psi-tc with the switched evolution
    relaxation rule): w <- w + dw with (J(w) + c M) dw = -R(w), M = the u-mass matrix, and
    c <- c * |R_new| / |R_old|. Each pseudo-step is one linear solve; when c has become small
    it is plain Newton. Ends when the undamped residual |R| <= rtol * ref_norm."""
    w = solver.w
    c = damp.c0
    damp.w_old.x.array[:] = w.x.array
    damp.c.value = c
    r_prev = solver.residual()
    for n in range(1, max_steps + 1):
        if r_prev <= rtol * ref_norm:
            damp.c.value = 0.0
            print(f"      ptc: converged after {n - 1} pseudo-steps", flush=True)
            log.append({"ptc_steps": n - 1, "ok": True})
            return True
        damp.c.value = c
        damp.w_old.x.array[:] = w.x.array
        w_save = w.x.array.copy()
        ok = solver.step(verbose=verbose)
        damp.w_old.x.array[:] = w.x.array  # R(w; w_old = w) is the undamped residual
        r = solver.residual() if ok else float("inf")
        if not np.isfinite(r) or r > 1e3 * r_prev:
            w.x.array[:] = w_save
            w.x.scatter_forward()
            damp.w_old.x.array[:] = w.x.array
            c = max(10.0 * c, damp.c0)
            if verbose:
                print(f"      ptc step {n}: rejected, c -> {c:.2e}", flush=True)
            continue
        if verbose or n % 25 == 0:
            print(f"      ptc step {n}: c = {c:.2e}, |R| = {r:.3e} (ref {ref_norm:.3e})", flush=True)
        c = min(c * r / r_prev, 1e3 * damp.c0)
        if c < 1e-12 * damp.c0:
            c = 0.0
        r_prev = r
    damp.c.value = 0.0
    log.append({"ptc_steps": max_steps, "ok": False})
    return False


def ramp(solver, const, start, end, step0, name, ref_norm_fn, log, first_guess=None, verbose=False,
         rtol=1e-10, max_it=25, min_step=1e-5, damp=None, ptc_below=2e-3):
    """Adaptive continuation of the fem.Constant `const` from start to end (Newton at each value;
    halve the step on failure, grow it by 1.5 after an easy solve). With `damp`, a step that
    still fails when shorter than ptc_below * (end - start) is done by pseudo-transient
    continuation instead (a limit point has been met)."""
    w = solver.w
    cur, step = start, step0 * (end - start)
    total = end - start
    while (end - cur) / total > 1e-12:
        trial = end if (end - (cur + step)) / total < 1e-12 else cur + step
        w_save = w.x.array.copy()
        const.value = trial
        if cur == start and first_guess is not None:
            first_guess(trial)
        ok, its = solver.solve(ref_norm_fn(trial), rtol=rtol, verbose=verbose, max_it=max_it)
        print(f"    {name} {trial:.5g}: {'ok' if ok else 'FAILED'} in {its} Newton", flush=True)
        log.append({name: trial, "ok": ok, "newton": its})
        if ok:
            cur = trial
            if its <= 6:
                step *= 1.5
        else:
            w.x.array[:] = w_save
            w.x.scatter_forward()
            if damp is not None and abs(step / total) < ptc_below:
                print(f"    {name} {trial:.5g}: limit point? pseudo-transient continuation", flush=True)
                ok = ptc(solver, damp, ref_norm_fn(trial), log, verbose=verbose, rtol=rtol)
                if not ok:
                    raise RuntimeError(f"pseudo-transient continuation in {name} failed at {trial}")
                log.append({name: trial, "ok": True, "ptc": True})
                cur = trial
                step = max(step, 0.05 * total)
                continue
            step *= 0.5
            if abs(step / total) < min_step:
                raise RuntimeError(f"continuation in {name} failed at {cur}")
    const.value = end


def negative_eigenvalues(solver):
    """Number of negative eigenvalues of the Jacobian at the current state (MUMPS LDL^T inertia;
    the Jacobian of a hyperelastic energy with dead loads and a penalty is symmetric). A stable
    equilibrium of the mixed u-p problem has exactly as many as there are pressure dofs."""
    solver.A.zeroEntries()
    fpetsc.assemble_matrix(solver.A, solver.J, bcs=solver.bcs)
    solver.A.assemble()
    solver.A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    ksp = PETSc.KSP().create(MPI.COMM_WORLD)
    ksp.setOperators(solver.A)
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("cholesky")
    pc.setFactorSolverType("mumps")
    pc.setFactorSetUpSolverType()
    pc.getFactorMatrix().setMumpsIcntl(13, 1)  # inertia over the whole matrix (no ScaLAPACK root)
    pc.getFactorMatrix().setMumpsIcntl(24, 1)  # null pivot detection (MatGetInertia requires it)
    pc.setUp()
    neg, _, _ = pc.getFactorMatrix().getInertia()
    ksp.destroy()
    return int(neg)


def arclength(solver, lam, fvec, ref_norm, log, dlam0=0.05, lam_end=1.0, rtol=1e-9, max_it=10,
              max_steps=400, verbose=False, history_cb=None, grow=4.0, path_rtol=1e-6, control=None,
              inertia=False):
    """Arc-length continuation of the equilibrium path R(w) - lam f = 0 from rest to lam = lam_end
    through limit points of the load (the gutter's snap-through onto the plane): unknowns (w, lam)
    with the cylindrical constraint |u - u_n|^2 = ds^2 on the displacement dofs (Crisfield),
    linearized consistently, so each corrector is K a = -R, K b = f (one factorization, two
    solves), dlam = (-(|du|^2 - ds^2)/2 - du.a) / (du.b), dw = a + dlam b. Secant predictor
    (the previous increment scaled to ds), which follows the path through a limit point; ds
    grows after easy steps and halves on failure. At the first step that crosses lam_end, the
    state is interpolated to lam_end and solved by plain Newton at fixed load. Path points are
    solved to |R| <= path_rtol |f|, the end point to rtol. A corrector that lands behind the
    previous point (du_new . du_prev <= 0: the constraint's second intersection with the path,
    met near a limit point) is rejected and ds halved. Returns True at lam = lam_end.

    control = (dof, sign, stop): displacement control instead, the constraint
    sign (w[dof] - w_n[dof]) = ds (the controlled displacement grows by ds per step, dlam =
    (-g - sign a[dof]) / (sign b[dof])); returns "stop" as soon as stop() is True after a step
    (the caller goes on by load stepping)."""
    w = solver.w
    isu = solver.is_u
    f = fvec.array.copy()

    def factorize():
        solver.A.zeroEntries()
        fpetsc.assemble_matrix(solver.A, solver.J, bcs=solver.bcs)
        solver.A.assemble()

    def solve(rhs):
        b = solver.A.createVecLeft()
        b.array[:] = rhs
        x = solver.A.createVecRight()
        solver.ksp.solve(b, x)
        if solver.ksp.getConvergedReason() < 0:
            return None
        return x.array.copy()

    lam.value = 0.0
    wn, ln = w.x.array.copy(), 0.0
    factorize()
    t = solve(f)
    solver.total_iterations += 1
    dW, dL = dlam0 * t, dlam0
    dW_prev = dW.copy()
    ds = math.sqrt(np.dot(dW[isu], dW[isu])) if control is None else control[1] * dW[control[0]]
    ds_max = grow * ds

    def constraint(dw_full):
        """(g, dg/dw) of the step constraint."""
        if control is None:
            du = np.zeros_like(dw_full)
            du[isu] = dw_full[isu]
            return np.dot(du, du) - ds * ds, 2 * du
        c = np.zeros_like(dw_full)
        c[control[0]] = control[1]
        return control[1] * dw_full[control[0]] - ds, c
    for step in range(1, max_steps + 1):
        # predictor
        w.x.array[:] = wn + dW
        w.x.scatter_forward()
        lcur = ln + dL
        ok = False
        for it in range(1, max_it + 1):
            lam.value = lcur
            r = solver.residual()
            if not np.isfinite(r):
                break
            du = w.x.array[isu] - wn[isu]
            g, cg = constraint(w.x.array - wn)
            if it > 1 and r <= path_rtol * ref_norm and abs(g) <= 1e-6 * ds * ds:
                ok = step == 1 or np.dot(du, dW_prev[isu]) > 0.0 or control is not None
                break
            factorize()
            a = solve(-solver.b.array)
            b = solve(f)
            solver.total_iterations += 1
            if a is None or b is None or not np.all(np.isfinite(a)):
                break
            den = np.dot(cg, b)
            if den == 0.0:
                break
            dl = (-g - np.dot(cg, a)) / den
            w.x.array[:] += a + dl * b
            w.x.scatter_forward()
            lcur += dl
        if verbose:
            print(f"      arc step {step}: ds = {ds:.3e}, lam = {lcur:.5f}, "
                  f"{'ok' if ok else 'FAILED'} in {it} iterations", flush=True)
        if not ok:
            w.x.array[:] = wn
            w.x.scatter_forward()
            print(f"      arc step {step}: rejected (residual {r:.2e}, lam {lcur:.5g}, ds {ds:.3g})",
                  flush=True)
            ds *= 0.5
            dW, dL = 0.5 * dW, 0.5 * dL
            if ds < 1e-8 * ds_max:
                log.append({"step": step, "ok": False, "lam": ln})
                return False
            continue
        entry = {"step": step, "lam": lcur, "ds": ds, "iterations": it - 1}
        if inertia:  # negative eigenvalues of the (symmetric) Jacobian at the new point
            entry["negative_eigenvalues"] = negative_eigenvalues(solver)
        if history_cb is not None:
            entry.update(history_cb())
        log.append(entry)
        print("      arc step " + ", ".join(f"{k} {v:.5g}" if isinstance(v, float) else f"{k} {v}"
                                            for k, v in entry.items()), flush=True)
        if control is not None and lcur < lam_end and control[2]():
            return "stop"
        if lcur >= lam_end:  # crossed: interpolate to lam_end, Newton at fixed load
            s = (lam_end - ln) / (lcur - ln)
            w.x.array[:] = wn + s * (w.x.array - wn)
            w.x.scatter_forward()
            lam.value = lam_end
            okn, its = solver.solve(ref_norm, rtol=rtol, verbose=verbose)
            print(f"    arc-length: lam = {lam_end} reached after {step} steps, "
                  f"Newton at fixed load {'ok' if okn else 'FAILED'} in {its}", flush=True)
            if okn:
                log.append({"final_newton": its, "ok": True})
                return True
            w.x.array[:] = wn  # retry the step shorter
            w.x.scatter_forward()
            ds *= 0.5
            dW, dL = 0.5 * dW, 0.5 * dL
            continue
        dW, dL = w.x.array - wn, lcur - ln
        dW_prev = dW.copy()
        wn, ln = w.x.array.copy(), lcur
        fac = 1.5 if it - 1 <= 4 else (0.7 if it - 1 >= 8 else 1.0)
        fac = min(fac, ds_max / ds)
        ds *= fac
        dW, dL = fac * dW, fac * dL
    log.append({"ok": False, "lam": ln, "max_steps": max_steps})
    return False


def run_continuation(solver, lam, kpen, k_list, ref_norm, first_guess=None, dl0=0.25, verbose=False,
                     rtol=1e-10, history_cb=None, plane=None, damp=None, smooth=None, strategy="ramp",
                     fvec=None, control=None, lam_pre=0.04, inertia=False):
    """Load stepping lam: 0 -> 1 at penalty k_list[0] (adaptive step); optionally (plane =
    (Constant, start, end)) move the obstacle from start to end at full load; then penalty
    continuation through k_list at lam = 1. Returns a log dict."""
    log = {"load_steps": [], "plane_steps": [], "penalty_steps": []}
    kpen.value = k_list[0]
    if plane is not None:
        plane[0].value = plane[1]
    if strategy in ("nested", "nested-ptc"):  # full load from an interpolated converged state
        lam.value = 1.0
        if plane is not None:
            plane[0].value = plane[2]
        first_guess(1.0)
        if strategy == "nested-ptc":  # damped (pseudo-transient) Newton from there
            log["ptc"] = []
            ok = ptc(solver, damp, ref_norm, log["ptc"], verbose=verbose, rtol=rtol)
            its = sum(e.get("ptc_steps", 0) for e in log["ptc"])
        else:
            ok, its = solver.solve(ref_norm, rtol=rtol, verbose=verbose, max_it=60)
        print(f"    nested start at full load: {'ok' if ok else 'FAILED'} in {its} Newton", flush=True)
        log["nested_newton"] = {"ok": ok, "newton": its}
        if not ok:
            raise RuntimeError("Newton from the interpolated state failed")
        plane = None
    elif strategy == "control":  # displacement control until the controlled node touches, then load
        if plane is not None:
            plane[0].value = plane[2]
        log["control_steps"] = []
        res = arclength(solver, lam, fvec, ref_norm, log["control_steps"], rtol=rtol, verbose=verbose,
                        history_cb=history_cb, control=control)
        if res is False:
            raise RuntimeError("displacement control failed")
        if res == "stop":
            lam0 = float(lam.value)
            print(f"    displacement control: the node touches at lam = {lam0:.5g}; load stepping", flush=True)
            log["load_steps"] = []
            ramp(solver, lam, lam0, 1.0, 0.1, "load", lambda t: ref_norm, log["load_steps"],
                 verbose=verbose, rtol=rtol)
        plane = None
    elif strategy == "arc-ptc":  # arc-length to lam_pre, then pseudo-transient continuation at full load
        if plane is not None:
            plane[0].value = plane[2]
        log["arc_steps"], log["ptc"] = [], []
        if arclength(solver, lam, fvec, ref_norm, log["arc_steps"], rtol=rtol, verbose=verbose,
                     history_cb=history_cb, lam_end=lam_pre) is not True:
            raise RuntimeError("arc-length continuation failed")
        lam.value = 1.0
        if not ptc(solver, damp, ref_norm, log["ptc"], verbose=verbose, rtol=rtol):
            raise RuntimeError("pseudo-transient continuation failed")
        plane = None
    elif strategy == "arclength":  # full obstacle from the start, arc-length in the load
        if plane is not None:
            plane[0].value = plane[2]
        log["arc_steps"] = []
        if not arclength(solver, lam, fvec, ref_norm, log["arc_steps"], rtol=rtol, verbose=verbose,
                         history_cb=history_cb, inertia=inertia):
            raise RuntimeError("arc-length continuation failed")
        plane = None
    elif strategy == "ptc":  # full load, obstacle in place, pseudo-transient continuation from w
        lam.value = 1.0
        if plane is not None:
            plane[0].value = plane[2]
        log["ptc"] = []
        if not ptc(solver, damp, ref_norm, log["ptc"], verbose=verbose, rtol=rtol):
            raise RuntimeError("pseudo-transient continuation failed")
        plane = None
    else:
        ramp(solver, lam, 0.0, 1.0, dl0, "load", lambda t: ref_norm * t, log["load_steps"],
             first_guess=first_guess, verbose=verbose, rtol=rtol, damp=damp)
    if plane is not None:
        ramp(solver, plane[0], plane[1], plane[2], 0.1, "plane", lambda t: ref_norm,
             log["plane_steps"], verbose=verbose, rtol=rtol, damp=damp)
    w = solver.w
    for kk in k_list[1:]:
        w_save = w.x.array.copy()
        kprev = float(kpen.value)
        kpen.value = kk
        if smooth is not None:  # shrink the smoothing width like 1/k^2
            smooth[0].value = smooth[1] * (k_list[0] / kk) ** 2
        ok, its = solver.solve(ref_norm, rtol=rtol, verbose=verbose)
        if not ok:  # retry with an intermediate penalty
            w.x.array[:] = w_save
            w.x.scatter_forward()
            kpen.value = math.sqrt(kprev * kk)
            ok1, its1 = solver.solve(ref_norm, rtol=rtol, verbose=verbose)
            kpen.value = kk
            ok, its2 = solver.solve(ref_norm, rtol=rtol, verbose=verbose)
            its = its1 + its2
            ok = ok1 and ok
        print(f"    penalty k = {kk:.1e}: {'ok' if ok else 'FAILED'} in {its} Newton", flush=True)
        entry = {"k": kk, "ok": ok, "newton": its}
        if history_cb is not None:
            entry.update(history_cb())
        log["penalty_steps"].append(entry)
        if not ok:
            raise RuntimeError(f"Newton failed at penalty {kk}")
    if smooth is not None:  # final solve with the exact max(0, -g)
        smooth[0].value = 0.0
        ok, its = solver.solve(ref_norm, rtol=rtol, verbose=verbose)
        print(f"    penalty k = {float(kpen.value):.1e}, no smoothing: {'ok' if ok else 'FAILED'} in {its} Newton", flush=True)
        entry = {"k": float(kpen.value), "ok": ok, "newton": its, "smoothing": 0.0}
        if history_cb is not None:
            entry.update(history_cb())
        log["penalty_steps"].append(entry)
        if not ok:
            raise RuntimeError("Newton failed without smoothing")
    # The penalty error is O(1/k): estimate v(k_final) - v(inf) ~ (v(k_final/10) - v(k_final)) / 9
    ps = log["penalty_steps"]
    prev = [e for e in ps if e["k"] < ps[-1]["k"]] if ps else []
    if prev:
        log["penalty_error_estimate"] = {
            key: abs(prev[-1][key] - ps[-1][key]) / 9.0 for key in ps[-1]
            if key not in ("k", "ok", "newton", "smoothing") and isinstance(ps[-1][key], float)
            and key in prev[-1]}
    return log


# --------------------------------------------------------------------------------------------
# Fig 5: plane-strain half cylinder on the plane x2 = -1 under its own weight
# --------------------------------------------------------------------------------------------
FIG5 = dict(Rc=1.0, C1=435e3, C2=65e3, f2=-400e3, plane=-1.0)


def contact_rule(rule, facet_cell, cdeg):
    """(ufl metadata, reference-facet points) of the contact quadrature. 'gll' with degree 3 is
    nodal collocation for P2/Q2 (3 points per edge, 3x3 per face); 'gauss' with degree 3 is the
    2-point (2x2) Gauss rule."""
    name = {"gll": "GLL", "gauss": "GL"}[rule]
    qt = {"gll": basix.QuadratureType.gll, "gauss": basix.QuadratureType.gauss_jacobi}[rule]
    pts, _ = basix.make_quadrature(qt, facet_cell, cdeg)
    return {"quadrature_degree": cdeg, "quadrature_rule": name}, pts


def solve_fig5(K, geom_order=2, k_list=None, verbose=False, qdeg=4, cdeg=3, rule="gll",
               element="taylor-hood"):
    """element: "taylor-hood" (P2/P1, the reference), "p2p0" (P2 with a DG0 pressure: the cell
    mean of det F is 1), or "p2p0-detmean" (the paper's det-mean constraint det(mean F) = 1 with
    the C2 term as (C1 + C2)|F|^2, i.e. the package's discretization.incompressibility =
    "det-mean": a three-field form with the cell-mean gradient Fb as a DG0 tensor unknown)."""
    T = Timer()
    P = FIG5
    geo = os.path.join(ROOT, "experiments", "fig5", "half_disc.geo")
    mesh, ct, ft, groups = load_geo(geo, {"Rc": P["Rc"], "n": K, "nd": K}, geom_order)
    t_mesh = T()
    detmean = element == "p2p0-detmean"
    if detmean:
        cell = mesh.ufl_cell()
        W = fem.FunctionSpace(mesh, ufl.MixedElement([
            ufl.VectorElement("Lagrange", cell, 2), ufl.FiniteElement("DG", cell, 0),
            ufl.TensorElement("DG", cell, 0, shape=(2, 2))]))
        w = fem.Function(W)
        u, q, Fb = ufl.split(w)
        wt = ufl.TestFunction(W)
        v, rq, tau = ufl.split(wt)
    else:
        W = mixed_space(mesh, element)
        w = fem.Function(W)
        u, q = ufl.split(w)
        wt = ufl.TestFunction(W)
        v, _ = ufl.split(wt)
    dw = ufl.TrialFunction(W)
    x = ufl.SpatialCoordinate(mesh)
    lam = fem.Constant(mesh, PETSc.ScalarType(0.0))
    kpen = fem.Constant(mesh, PETSc.ScalarType(1.0))
    f = ufl.as_vector([0.0, P["f2"]])
    dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": qdeg})
    cmeta, qpts = contact_rule(rule, basix.CellType.interval, cdeg)
    dsc = ufl.Measure("ds", domain=mesh, subdomain_data=ft, subdomain_id=groups["contact"],
                      metadata=cmeta)
    dsc_hi = ufl.Measure("ds", domain=mesh, subdomain_data=ft, subdomain_id=groups["contact"],
                         metadata={"quadrature_degree": 20})
    F2 = ufl.Identity(2) + ufl.grad(u)
    F3 = ufl.as_matrix([[F2[0, 0], F2[0, 1], 0.0], [F2[1, 0], F2[1, 1], 0.0], [0.0, 0.0, 1.0]])
    psi = mooney_rivlin_psi(F3, q, P["C1"], P["C2"])
    gap = x[1] + u[1] - P["plane"]  # >= 0
    pc = kpen * pos(-gap)  # penalty contact pressure (nominal, per reference length)
    R = ufl.derivative(psi * dx, w, wt) - lam * ufl.dot(f, v) * dx - pc * v[1] * dsc
    if detmean:  # stationarity of (C1 + C2)|F|^2 - q (det Fbar - 1) with Fbar = mean F per cell
        Fbar = ufl.Identity(2) + Fb
        cofb = ufl.as_matrix([[Fbar[1, 1], -Fbar[1, 0]], [-Fbar[0, 1], Fbar[0, 0]]])
        R = (ufl.inner(2 * (P["C1"] + P["C2"]) * F2 - q * cofb, ufl.grad(v)) * dx
             - (ufl.det(Fbar) - 1) * rq * dx + ufl.inner(Fb - ufl.grad(u), tau) * dx
             - lam * ufl.dot(f, v) * dx - pc * v[1] * dsc)
    Jf = ufl.derivative(R, w, dw)

    tdim = mesh.topology.dim
    symf = ft.indices[ft.values == groups["symmetry_x"]]
    dofs = fem.locate_dofs_topological(W.sub(0).sub(0), tdim - 1, symf)
    bcs = [fem.dirichletbc(PETSc.ScalarType(0.0), dofs, W.sub(0).sub(0))]

    solver = NewtonSolver(R, Jf, w, bcs)
    solver.set_scales(W.sub(0).collapse()[1], P["Rc"], P["C1"] + P["C2"])
    # Reference residual norm: the full external load vector.
    bl = fem.petsc.assemble_vector(fem.form(ufl.dot(f, v) * dx))
    bl.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    fem.petsc.set_bc(bl, bcs)
    ref_norm = bl.norm()

    area = assemble(fem.Constant(mesh, 1.0) * dx)
    weight = abs(P["f2"]) * area
    _, u2map = W.sub(0).sub(1).collapse()
    k0 = k_list[0]

    def first_guess(lmb):
        # rigid translation for which a rigid disc with penalty k0 would carry lmb * weight:
        # force = k0 * (2/3) * delta * sqrt(2 R delta)
        delta = (3 * lmb * weight / (2 * k0 * math.sqrt(2 * P["Rc"]))) ** (2.0 / 3.0)
        w.x.array[:] = 0.0
        w.x.array[np.asarray(u2map)] = -delta
        w.x.scatter_forward()

    V, umap = W.sub(0).collapse()
    umap = np.asarray(umap)
    uh = fem.Function(V)
    Xv = V.tabulate_dof_coordinates()[:, :2]
    cdofs = fem.locate_dofs_topological(V, tdim - 1, ft.indices[ft.values == groups["contact"]])
    top = int(np.argmin(np.linalg.norm(Xv - [0.0, P["Rc"]], axis=1)))
    bot = int(np.argmin(np.linalg.norm(Xv - [0.0, -P["Rc"]], axis=1)))
    assert np.linalg.norm(Xv[top] - [0, P["Rc"]]) < 1e-12 and np.linalg.norm(Xv[bot] - [0, -P["Rc"]]) < 1e-12
    samp_qp = FacetSampler(V, ft, groups["contact"], qpts)
    ndense = 65
    samp_dense = FacetSampler(V, ft, groups["contact"], np.linspace(0, 1, ndense)[:, None])
    M0f = fem.form(pc * dsc)
    M2f = fem.form(pc * (x[0] + u[0]) ** 2 * dsc)
    Lc = fem.form(ufl.conditional(ufl.lt(gap, 0.0), 1.0, 0.0) * dsc_hi)

    def observables():
        uh.x.array[:] = w.x.array[umap]
        ua = uh.x.array.reshape(-1, 2)
        k = float(kpen.value)
        M0 = MPI.COMM_WORLD.allreduce(fem.assemble_scalar(M0f), op=MPI.SUM)
        M2 = MPI.COMM_WORLD.allreduce(fem.assemble_scalar(M2f), op=MPI.SUM)
        Xq, Uq = samp_qp(uh)
        gq = Xq[:, 1] + Uq[:, 1] - P["plane"]
        pq = k * np.maximum(-gq, 0.0)
        pmax = float(pq.max())
        x1q = Xq[:, 0] + Uq[:, 0]
        act = pq > 1e-6 * pmax
        Xd, Ud = samp_dense(uh)
        gd = Xd[:, 1] + Ud[:, 1] - P["plane"]
        pd = k * np.maximum(-gd, 0.0)
        x1d = Xd[:, 0] + Ud[:, 0]
        actd = pd > 1e-6 * pmax
        gn = Xv[cdofs, 1] + ua[cdofs, 1] - P["plane"]
        i0 = int(np.argmin(Xq[:, 0]))
        return {
            "drop": float(-ua[top, 1]),
            "M0": M0, "M2": M2,
            "a_moment": float(2 * math.sqrt(M2 / M0)) if M0 > 0 else 0.0,
            "a_edge": float(x1q[act].max()),
            "a_edge_dense": float(x1d[actd].max()),
            "p_max": pmax,
            "p_max_x1": float(x1q[int(np.argmax(pq))]),
            "p_x1_0": float(k * max(-(Xv[bot, 1] + ua[bot, 1] - P["plane"]), 0.0)),
            "p_first_qp": float(pq[i0]),
            "first_qp_x1": float(x1q[i0]),
            "force_ratio": M0 / weight,
            "contact_length_ref": MPI.COMM_WORLD.allreduce(fem.assemble_scalar(Lc), op=MPI.SUM),
            "penetration": float(max((-gn).max(), 0.0)),
            "penetration_dense": float(max((-gd).max(), 0.0)),
            "penalty": k,
            # integral (det F - 1): the area the discrete solution loses (0 for an exact
            # incompressible motion; the det-mean constraint leaves it O(1e-3) on every mesh)
            "area_change": assemble(ufl.det(F2) * dx) - area,
        }

    log = run_continuation(solver, lam, kpen, k_list, ref_norm, first_guess=first_guess,
                           verbose=verbose, history_cb=lambda: {
                               kk: vv for kk, vv in observables().items()
                               if kk in ("drop", "a_moment", "p_max", "penetration", "force_ratio")})
    obs = observables()
    ncells = mesh.topology.index_map(tdim).size_global
    return {
        "level": K, "n": K, "nd": K, "geom_order": geom_order, "element": element,
        "cells": ncells,
        "dofs": W.dofmap.index_map.size_global * W.dofmap.index_map_bs,
        "dofs_u": V.dofmap.index_map.size_global * V.dofmap.index_map_bs,
        "contact_facets": int(np.sum(ft.values == groups["contact"])),
        "area": area, "area_exact": math.pi * P["Rc"] ** 2 / 2,
        "observables": obs,
        "newton_total": solver.total_iterations,
        "time_mesh_s": t_mesh, "time_s": T(),
        "log": log,
        "quadrature": {"bulk": qdeg, "contact": cdeg, "contact_rule": rule,
                       "contact_points_per_facet": len(qpts),
                       "dense_samples_per_facet": ndense},
    }


# --------------------------------------------------------------------------------------------
# Fig 6: the gutter over the plane x2 = -3
# --------------------------------------------------------------------------------------------
FIG6 = dict(Ri=1.0, t=0.2, L=20.0, nt=2, na=9, nl=15, C1=50e3, C2=0.0, traction=-500.0, plane=-3.0)


def gutter_coordinates(X):
    """Normalized structured coordinates of points of the gutter: (rho, theta, s) in [0, 1]^3 with
    r = Ri + rho t, theta the angle from the bottom (x2 = -r, x3 = 0) to the rim (x2 = 0), and
    x1 = s L/2 (the coordinates in which gutter.geo's transfinite mesh is a regular grid)."""
    P = FIG6
    r = np.hypot(X[:, 1], X[:, 2])
    return np.column_stack([(r - P["Ri"]) / P["t"], np.arctan2(X[:, 2], -X[:, 1]) / (math.pi / 2),
                            X[:, 0] / (P["L"] / 2)])


def grid_sampler(C, vals, n, centred):
    """Trilinear interpolant, in gutter_coordinates, of nodal values `vals` (npts x m) given at
    points C (npts x 3) of a regular grid with n = (n_rho, n_theta, n_s) intervals: at the grid
    vertices, or (centred) at the cell centres (a DG0 field). Extrapolates linearly."""
    from scipy.interpolate import RegularGridInterpolator
    n = np.asarray(n)
    if centred:
        idx = np.clip(np.floor(C * n).astype(int), 0, n - 1)
        axes = [(np.arange(k) + 0.5) / k for k in n]
        shape = tuple(n)
    else:
        idx = np.clip(np.rint(C * n).astype(int), 0, n)
        axes = [np.arange(k + 1) / k for k in n]
        shape = tuple(n + 1)
    arr = np.full(shape + (vals.shape[1],), np.nan)
    arr[idx[:, 0], idx[:, 1], idx[:, 2]] = vals
    if np.isnan(arr).any():
        raise RuntimeError("grid_sampler: the coarse points do not fill the structured grid")
    return RegularGridInterpolator(axes, arr, bounds_error=False, fill_value=None)


def solve_fig6(level, geom_order=2, element="taylor-hood", k_list=None, verbose=False, cdeg=3, rule="gll",
               gap0=0.02, c0=5e4, delta0=1e-3, strategy="arclength", init=None, save=None,
               inertia=False):
    """init: an .npz written with `save` by a run on another mesh (either element): its converged
    (u, p), interpolated onto this mesh, starts Newton at full load (nested iteration; strategy
    "nested"), instead of the arc-length path from rest."""
    T = Timer()
    P = FIG6
    geo = os.path.join(ROOT, "experiments", "fig6", "gutter.geo")
    prm = {"Ri": P["Ri"], "t": P["t"], "L": P["L"],
           "nt": P["nt"] * level, "na": P["na"] * level, "nl": P["nl"] * level}
    mesh, ct, ft, groups = load_geo(geo, prm, geom_order)
    t_mesh = T()
    W = mixed_space(mesh, element)
    qdeg = 4 if element == "taylor-hood" else 2
    w = fem.Function(W)
    u, q = ufl.split(w)
    wt = ufl.TestFunction(W)
    v, _ = ufl.split(wt)
    dw = ufl.TrialFunction(W)
    x = ufl.SpatialCoordinate(mesh)
    lam = fem.Constant(mesh, PETSc.ScalarType(0.0))
    kpen = fem.Constant(mesh, PETSc.ScalarType(1.0))
    tr = ufl.as_vector([0.0, P["traction"], 0.0])
    dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": qdeg})
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=ft, metadata={"quadrature_degree": qdeg})
    if element == "q1p0" and rule == "gll":
        cdeg = 1  # nodal for Q1
    cmeta, qpts = contact_rule(rule, basix.CellType.quadrilateral, cdeg)
    dsc = ufl.Measure("ds", domain=mesh, subdomain_data=ft, subdomain_id=groups["outer"],
                      metadata=cmeta)
    dsc_hi = ufl.Measure("ds", domain=mesh, subdomain_data=ft, subdomain_id=groups["outer"],
                         metadata={"quadrature_degree": 11})
    F = ufl.Identity(3) + ufl.grad(u)
    psi = mooney_rivlin_psi(F, q, P["C1"], P["C2"])
    plane = fem.Constant(mesh, PETSc.ScalarType(P["plane"]))
    gap = x[1] + u[1] - plane
    delta = fem.Constant(mesh, PETSc.ScalarType(delta0))
    pc = kpen * smooth_pos(-gap, delta)
    damp = Damping(mesh, W, c0)
    R = (ufl.derivative(psi * dx, w, wt) - lam * ufl.dot(tr, v) * ds(groups["inner"])
         - pc * v[1] * dsc + damp.term(u, v) * dx)
    Jf = ufl.derivative(R, w, dw)

    tdim = 3
    bcs = []
    for grp, comps in (("symmetry_x", [0]), ("symmetry_z", [2]), ("clamped", [0, 1, 2])):
        facets = ft.indices[ft.values == groups[grp]]
        for c in comps:
            dofs = fem.locate_dofs_topological(W.sub(0).sub(c), tdim - 1, facets)
            bcs.append(fem.dirichletbc(PETSc.ScalarType(0.0), dofs, W.sub(0).sub(c)))
    solver = NewtonSolver(R, Jf, w, bcs)
    solver.set_scales(W.sub(0).collapse()[1], P["Ri"], P["C1"] + P["C2"])
    bl = fem.petsc.assemble_vector(fem.form(ufl.dot(tr, v) * ds(groups["inner"])))
    bl.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    fem.petsc.set_bc(bl, bcs)
    ref_norm = bl.norm()
    area_inner = assemble(fem.Constant(mesh, 1.0) * ds(groups["inner"]))
    load = abs(P["traction"]) * area_inner

    V, umap = W.sub(0).collapse()
    umap = np.asarray(umap)
    uh = fem.Function(V)
    Xv = V.tabulate_dof_coordinates()
    cdofs = fem.locate_dofs_topological(V, tdim - 1, ft.indices[ft.values == groups["outer"]])
    # mesh vertices (the H8 nodes) among the V dofs on the outer face
    vert = mesh.geometry.x[:mesh.topology.index_map(0).size_local]
    vset = {tuple(np.round(p, 10)) for p in vert}
    cvert = np.array([d for d in cdofs if tuple(np.round(Xv[d], 10)) in vset])
    samp_qp = FacetSampler(V, ft, groups["outer"], qpts) if element == "taylor-hood" else None
    M0f = fem.form(pc * dsc)
    Af = fem.form(ufl.conditional(ufl.lt(gap, 0.0), 1.0, 0.0) * dsc_hi)
    # nodal weights int_{outer} phi_a (the package's contact-point areas), per V node
    wv = fem.petsc.assemble_vector(fem.form(ufl.TestFunction(V)[1] * ds(groups["outer"])))
    wv.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    wnode = wv.array.reshape(-1, 3)[:, 1].copy()

    def observables():
        uh.x.array[:] = w.x.array[umap]
        ua = uh.x.array.reshape(-1, 3)
        k = float(kpen.value)
        M0 = MPI.COMM_WORLD.allreduce(fem.assemble_scalar(M0f), op=MPI.SUM)
        i = int(np.argmax(-ua[:, 1]))
        gn = Xv[cdofs, 1] + ua[cdofs, 1] - P["plane"]
        gv = Xv[cvert, 1] + ua[cvert, 1] - P["plane"]
        out = {
            "sag": float(-ua[i, 1]),
            "sag_at": [float(c) for c in Xv[i]],
            "contact_force": M0,
            "load": load,
            "force_ratio": M0 / load,
            "contact_area_ref": MPI.COMM_WORLD.allreduce(fem.assemble_scalar(Af), op=MPI.SUM),
            "contact_nodes": int(np.sum(gn < 0.0)),
            "contact_nodes_1e-6": int(np.sum(gn < 1e-6)),
            "contact_vertices": int(np.sum(gv < 0.0)),
            "outer_nodes": int(len(cdofs)), "outer_vertices": int(len(cvert)),
            "penetration": float(max((-gn).max(), 0.0)),
            "penalty": k,
            # nodal contact pressure at the H8 vertices of the outer face (nominal, Pa)
            "p_max_vertex": float(k * max((-gv).max(), 0.0)),
        }
        # as lib/measures.cpp: the reference area (sum of nodal weights) of the contact nodes
        # whose pressure exceeds 1e-6 of the largest
        pn = k * np.maximum(-gn, 0.0)
        out["contact_area_nodal"] = float(np.sum(wnode[cdofs][pn > 1e-6 * pn.max()])) if pn.max() > 0 else 0.0
        if samp_qp is not None:
            Xq, Uq = samp_qp(uh)
            gq = Xq[:, 1] + Uq[:, 1] - P["plane"]
            pq = k * np.maximum(-gq, 0.0)
            out["p_max"] = float(pq.max())
            out["p_max_at"] = [float(c) for c in Xq[int(np.argmax(pq))]]
            out["penetration_qp"] = float(max((-gq).max(), 0.0))
        return out

    # strategy "arclength" (default): the path from rest with the plane at x2 = -3 (smoothed
    # penalty k_list[0]), then penalty continuation; "nested": Newton at full load from `init`;
    # "ramp" / "ptc" (stall on this problem, kept for the record): load stepping with the plane
    # just below the gutter (x2 = -(Ri+t) - gap0) and then moved down, or pseudo-transient
    # continuation at full load from rest.
    plane_start = -(P["Ri"] + P["t"]) - gap0
    Q, pmap = W.sub(1).collapse()
    pmap = np.asarray(pmap)
    Xp = Q.tabulate_dof_coordinates()
    deg_u = 2 if element == "taylor-hood" else 1
    n_cells = np.array([prm["nt"], prm["na"], prm["nl"]])
    first_guess = None
    if strategy in ("nested", "nested-ptc"):
        if init is None:
            raise ValueError("strategy 'nested' needs an initial state (--init FILE.npz)")
        src = np.load(init)

        def first_guess(_):
            su = grid_sampler(src["Cu"], src["u"], src["n_u"], False)
            sp = grid_sampler(src["Cp"], src["p"][:, None], src["n_p"], bool(src["p_centred"]))
            w.x.array[:] = 0.0
            w.x.array[umap] = su(gutter_coordinates(Xv)).reshape(-1)
            w.x.array[pmap] = sp(gutter_coordinates(Xp))[:, 0]
            # the Dirichlet bcs hold exactly (the interpolant is exact on the grid planes x1 = L/2,
            # x1 = 0, x3 = 0 only up to round-off): enforce them
            fem.set_bc(w.x.array, bcs)
            w.x.scatter_forward()
    # displacement control: -u2 of the outer bottom node at x1 = 0, (0, -(Ri + t), 0), until its
    # gap is below 1 mm
    ib = int(np.argmin(np.linalg.norm(Xv - [0.0, -(P["Ri"] + P["t"]), 0.0], axis=1)))
    cdof = int(umap[3 * ib + 1])

    def touching():
        return w.x.array[cdof] + Xv[ib, 1] - P["plane"] < 1e-3

    log = run_continuation(solver, lam, kpen, k_list, ref_norm, verbose=verbose, dl0=0.1,
                           first_guess=first_guess, control=(cdof, -1.0, touching), inertia=inertia,
                           plane=(plane, plane_start, P["plane"]), damp=damp, smooth=(delta, delta0),
                           strategy=strategy, fvec=bl,
                           history_cb=lambda: {
                               kk: vv for kk, vv in observables().items()
                               if kk in ("sag", "force_ratio", "penetration", "contact_area_ref")})
    obs = observables()
    if save is not None:  # the converged state, for a nested-iteration start on another mesh
        np.savez(save, Cu=gutter_coordinates(Xv), u=w.x.array[umap].reshape(-1, 3), n_u=deg_u * n_cells,
                 Cp=gutter_coordinates(Xp), p=w.x.array[pmap], n_p=n_cells,
                 p_centred=element == "q1p0")
    return {
        "level": level, **{kk: prm[kk] for kk in ("nt", "na", "nl")},
        "strategy": strategy, "init": os.path.relpath(init, ROOT) if init else None,
        "geom_order": geom_order, "element": element,
        "cells": mesh.topology.index_map(tdim).size_global,
        "dofs": W.dofmap.index_map.size_global * W.dofmap.index_map_bs,
        "dofs_u": V.dofmap.index_map.size_global * V.dofmap.index_map_bs,
        "area_inner": area_inner, "area_inner_exact": math.pi / 2 * P["Ri"] * P["L"] / 2,
        "observables": obs,
        "newton_total": solver.total_iterations,
        "time_mesh_s": t_mesh, "time_s": T(),
        "log": log,
        "quadrature": {"bulk": qdeg, "contact": cdeg, "contact_rule": rule,
                       "contact_points_per_facet": len(qpts)},
    }


# --------------------------------------------------------------------------------------------
# Tables
# --------------------------------------------------------------------------------------------
def observed_order(h, v):
    """Order p from three (h, value) pairs, h decreasing: (v2-v1)/(v3-v2) = (h1^p-h2^p)/(h2^p-h3^p).
    Equals log2(d_{i-1}/d_i) when the ratio of successive h is 2. None if not monotone."""
    d1, d2 = v[1] - v[0], v[2] - v[1]
    if d1 == 0 or d2 == 0 or d1 * d2 < 0:
        return None
    ratio = d1 / d2

    def fn(p):
        return (h[0] ** p - h[1] ** p) / (h[1] ** p - h[2] ** p) - ratio

    lo, hi = 1e-3, 20.0
    if fn(lo) * fn(hi) > 0:
        return None
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if fn(lo) * fn(mid) <= 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


SCALARS = {
    "fig5": ["drop", "a_moment", "a_edge", "a_edge_dense", "p_max", "p_x1_0", "force_ratio",
             "contact_length_ref", "penetration"],
    "fig6": ["sag", "contact_force", "force_ratio", "contact_area_ref", "contact_area_nodal",
             "contact_nodes", "contact_vertices", "p_max", "p_max_vertex", "penetration"],
}


def print_table(data):
    fig = data["figure"]
    runs = sorted(data["runs"], key=lambda r: r["level"])
    h = [1.0 / r["level"] for r in runs]
    print(f"\n{fig}: geometry order {runs[0]['geom_order']}, element {runs[0].get('element', 'taylor-hood')}")
    print(f"{'level':>6} {'cells':>7} {'dofs':>8} {'newton':>6} {'time[s]':>8} {'k_final':>8}")
    for r in runs:
        print(f"{r['level']:>6} {r['cells']:>7} {r['dofs']:>8} {r['newton_total']:>6} {r['time_s']:>8.1f} "
              f"{r['observables']['penalty']:>8.1e}")
    for key in SCALARS[fig]:
        vals = [r["observables"].get(key) for r in runs]
        if any(v is None for v in vals):
            continue
        print(f"\n  {key}")
        print(f"  {'level':>6} {'value':>16} {'diff':>12} {'order':>7}")
        for i, r in enumerate(runs):
            d = "" if i == 0 else f"{vals[i] - vals[i - 1]:12.4e}"
            o = ""
            if i >= 2:
                p = observed_order(h[i - 2:i + 1], vals[i - 2:i + 1])
                o = "  n/a" if p is None else f"{p:7.2f}"
            print(f"  {r['level']:>6} {vals[i]:16.8g} {d:>12} {o:>7}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    for fig in ("fig5", "fig6"):
        s = sub.add_parser(fig)
        s.add_argument("--levels", type=int, nargs="+", required=True,
                       help="fig5: K = n = nd; fig6: refinement factor of (nt, na, nl) = (2, 9, 15)")
        s.add_argument("--out", required=True)
        s.add_argument("--geom-order", type=int, default=None, choices=[1, 2],
                       help="geometry order of the gmsh mesh (default 2; fig6 --element q1p0: 1, the "
                            "package's trilinear H8 geometry)")
        s.add_argument("--kmin", type=float, default=1e8 if fig == "fig5" else 1e6,
                       help="penalty during load stepping [Pa/m]")
        s.add_argument("--kmax", type=float, default=1e13 if fig == "fig5" else 1e11,
                       help="final penalty [Pa/m] (continuation by factors of 10)")
        s.add_argument("--contact-rule", default="gll", choices=["gll", "gauss"],
                       help="gll: nodal collocation (default); gauss: 2-point Gauss per edge direction")
        s.add_argument("--verbose", action="store_true")
        if fig == "fig5":
            s.add_argument("--element", default="taylor-hood",
                           choices=["taylor-hood", "p2p0", "p2p0-detmean"])
        if fig == "fig6":
            s.add_argument("--element", default="taylor-hood", choices=["taylor-hood", "q1p0"])
            s.add_argument("--strategy", default="arclength", choices=["arclength", "arc-ptc", "control", "nested", "nested-ptc", "ptc", "ramp"],
                           help="ptc: pseudo-transient continuation at full load from u = 0; ramp: load "
                                "stepping with the plane just below the gutter, then the plane moved down")
            s.add_argument("--c0", type=float, default=5e4, help="initial pseudo-time damping [N/m^4]")
            s.add_argument("--init", default=None,
                           help="nested: start from this .npz (written by --save on another mesh)")
            s.add_argument("--inertia", action="store_true",
                           help="arclength: count the negative eigenvalues of the Jacobian at every step")
            s.add_argument("--save", default=None,
                           help="write the converged state to SAVE_L<level>.npz (for --init)")
    t = sub.add_parser("table")
    t.add_argument("json")
    a = ap.parse_args()
    if a.cmd == "table":
        with open(a.json) as fh:
            print_table(json.load(fh))
        return
    if a.geom_order is None:
        a.geom_order = 1 if getattr(a, "element", "") == "q1p0" else 2
    nk = int(round(math.log10(a.kmax / a.kmin)))
    k_list = [a.kmin * 10.0 ** i for i in range(nk + 1)]
    out = os.path.abspath(a.out)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    data = {"figure": a.cmd, "runs": []}
    if os.path.exists(out):  # keep other levels already in the file (same settings assumed)
        with open(out) as fh:
            old = json.load(fh)
        if old.get("figure") == a.cmd:
            data["runs"] = [r for r in old["runs"] if r["level"] not in a.levels
                            and r["geom_order"] == a.geom_order
                            and r.get("element", "taylor-hood") == getattr(a, "element", "taylor-hood")]
    for lev in a.levels:
        print(f"== {a.cmd} level {lev}", flush=True)
        if a.cmd == "fig5":
            r = solve_fig5(lev, a.geom_order, k_list, verbose=a.verbose, rule=a.contact_rule,
                           element=a.element)
        else:
            r = solve_fig6(lev, a.geom_order, a.element, k_list, verbose=a.verbose, rule=a.contact_rule,
                           strategy=a.strategy, c0=a.c0, init=a.init and os.path.abspath(a.init),
                           save=a.save and os.path.abspath(f"{a.save}_L{lev}.npz"), inertia=a.inertia)
        r["command"] = "OMP_NUM_THREADS=1 /usr/bin/python3 experiments/peer/peer.py " + " ".join(
            sys.argv[1:])
        print(json.dumps({kk: r[kk] for kk in ("level", "cells", "dofs", "newton_total", "time_s")}))
        print(json.dumps(r["observables"]), flush=True)
        data["runs"] = [x for x in data["runs"] if x["level"] != lev] + [r]
        data["runs"].sort(key=lambda x: x["level"])
        with open(out, "w") as fh:
            json.dump(data, fh, indent=1)
    print_table(data)


if __name__ == "__main__":
    main()
