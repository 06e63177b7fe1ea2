"""Shared pieces of the dolfinx 0.5 peer: gmsh .geo -> dolfinx mesh, a Newton solver with a
backtracking line search and MUMPS, and a sampler that evaluates P2/Q2 displacement fields at
reference points of boundary facets (numpy only, no JIT).

Written against DOLFINx 0.5.2 / basix 0.5.1 / gmsh 4.8 / petsc4py 3.18 (Debian 12).
"""
import logging
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
logging.getLogger().setLevel(logging.WARNING)
logging.getLogger("UFL").setLevel(logging.WARNING)
logging.getLogger("FFCX").setLevel(logging.WARNING)

import numpy as np  # noqa: E402
import gmsh  # noqa: E402
import basix  # noqa: E402
import ufl  # noqa: E402
from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402
import dolfinx  # noqa: E402
import dolfinx.fem as fem  # noqa: E402
import dolfinx.fem.petsc as fpetsc  # noqa: E402
import dolfinx.io.gmshio as gmshio  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))


def load_geo(path, parameters, geom_order=2):
    """Mesh a .geo the way lib/mesh.cpp does (onelab::clear, onelab::setNumber("Parameters/<name>"),
    gmsh::open, mesh::generate(dim)); then, for geom_order = 2, mesh::setOrder(2) (the project does
    this in 2-D only). Returns (mesh, cell_tags, facet_tags, {group name: tag})."""
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.Verbosity", 1)
        gmsh.onelab.clear()
        for name, value in parameters.items():
            gmsh.onelab.setNumber("Parameters/" + name, [float(value)])
        gmsh.open(path)
        dim = gmsh.model.getDimension()
        gmsh.model.mesh.generate(dim)
        if geom_order == 2:
            gmsh.model.mesh.setOrder(2)
        groups = {gmsh.model.getPhysicalName(d, t): t for d, t in gmsh.model.getPhysicalGroups()}
        mesh, ct, ft = gmshio.model_to_mesh(gmsh.model, MPI.COMM_WORLD, 0, gdim=dim)
    finally:
        gmsh.finalize()
    return mesh, ct, ft, groups


def facet_ref_points(cell_type, local_facet, pts):
    """Map points given on the reference facet (interval [0,1] or square [0,1]^2) to reference
    cell coordinates of local facet `local_facet` (basix numbering)."""
    geo = basix.geometry(cell_type)
    tdim = geo.shape[1]
    verts = basix.topology(cell_type)[tdim - 1][local_facet]
    v = geo[verts]
    pts = np.atleast_2d(pts)
    X = np.tile(v[0], (pts.shape[0], 1))
    X += np.outer(pts[:, 0], v[1] - v[0])
    if tdim == 3:
        X += np.outer(pts[:, 1], v[2] - v[0])
    return X


class FacetSampler:
    """Evaluates reference coordinates x and the displacement u (in the collapsed degree-2
    Lagrange space V) at given reference-facet points of every facet with tag `tag`.
    Uses the isoparametric identity x(X) = sum_i phi_i(X) x_i with x_i = dof coordinates of V
    (exact for P2/Q2 geometry; for order-1 geometry the P2 midpoints lie on straight edges, so
    it is exact as well)."""

    def __init__(self, V, ft, tag, facet_pts):
        mesh = V.mesh
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        mesh.topology.create_connectivity(tdim, tdim - 1)
        f2c = mesh.topology.connectivity(tdim - 1, tdim)
        c2f = mesh.topology.connectivity(tdim, tdim - 1)
        ctype = basix.CellType.triangle if tdim == 2 else basix.CellType.hexahedron
        if mesh.topology.cell_type == dolfinx.mesh.CellType.quadrilateral:
            ctype = basix.CellType.quadrilateral
        elem = basix.create_element(basix.ElementFamily.P, ctype, 2, basix.LagrangeVariant.gll_warped)
        nfac = len(basix.topology(ctype)[tdim - 1])
        self.tab = []
        for lf in range(nfac):
            X = facet_ref_points(ctype, lf, facet_pts)
            self.tab.append(elem.tabulate(0, X)[0, :, :, 0])  # (npts, ndofs)
        facets = ft.indices[ft.values == tag]
        self.cells, self.lfs = [], []
        for f in facets:
            c = f2c.links(f)[0]
            self.cells.append(c)
            self.lfs.append(int(np.where(c2f.links(c) == f)[0][0]))
        self.V = V
        self.xdof = V.tabulate_dof_coordinates()[:, : mesh.geometry.dim]
        self.gdim = mesh.geometry.dim
        self.npts = len(np.atleast_2d(facet_pts))

    def __call__(self, u):
        """Returns (X, U): arrays (nfacets*npts, gdim) of reference positions and displacements."""
        ua = u.x.array.reshape(-1, self.gdim)
        Xs, Us = [], []
        for c, lf in zip(self.cells, self.lfs):
            d = self.V.dofmap.cell_dofs(c)
            phi = self.tab[lf]
            Xs.append(phi @ self.xdof[d])
            Us.append(phi @ ua[d])
        return np.vstack(Xs), np.vstack(Us)


class NewtonSolver:
    """Newton on R(w) = 0 with Jacobian J, homogeneous Dirichlet bcs (the initial w satisfies
    them), MUMPS LU, and a backtracking line search on ||R||_2."""

    def __init__(self, R, Jform, w, bcs, quad_log=None):
        self.R = fem.form(R)
        self.J = fem.form(Jform)
        self.w = w
        self.bcs = bcs
        self.A = fpetsc.create_matrix(self.J)
        self.b = fpetsc.create_vector(self.R)
        self.dw = self.A.createVecRight()
        self.ksp = PETSc.KSP().create(MPI.COMM_WORLD)
        self.ksp.setOperators(self.A)
        self.ksp.setType("preonly")
        pc = self.ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        self.total_iterations = 0
        self.log = quad_log
        self.is_u = np.zeros(0, dtype=bool)

    def set_scales(self, u_dofs, u_scale, q_scale):
        """Increment test: a full Newton step with max|du| <= 1e-10 u_scale on the displacement
        dofs and max|dq| <= 1e-8 q_scale on the pressure dofs is converged (this test takes over
        when a large penalty puts the residual's round-off floor above rtol * ref_norm)."""
        self.is_u = np.zeros(self.w.x.array.size, dtype=bool)
        self.is_u[np.asarray(u_dofs)] = True
        self.u_scale, self.q_scale = u_scale, q_scale

    def residual(self):
        with self.b.localForm() as loc:
            loc.set(0.0)
        fpetsc.assemble_vector(self.b, self.R)
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fpetsc.set_bc(self.b, self.bcs)  # bc values are 0 and w satisfies them: zero the rows
        return self.b.norm()

    def step(self, verbose=False):
        """One Newton iteration from the current w (residual assembled here), with the same
        backtracking line search as solve(). Returns False on a linear-solver failure."""
        w = self.w
        r0 = self.residual()
        self.A.zeroEntries()
        fpetsc.assemble_matrix(self.A, self.J, bcs=self.bcs)
        self.A.assemble()
        self.b.scale(-1.0)
        self.ksp.solve(self.b, self.dw)
        if self.ksp.getConvergedReason() < 0:
            return False
        self.total_iterations += 1
        dw = self.dw.array.copy()
        if not np.all(np.isfinite(dw)):
            return False
        w0 = w.x.array.copy()
        alpha = 1.0
        while True:
            w.x.array[:] = w0 + alpha * dw
            w.x.scatter_forward()
            r = self.residual()
            if (np.isfinite(r) and r <= (1 - 1e-4 * alpha) * r0) or alpha < 1e-2:
                break
            alpha *= 0.5
        if verbose:
            print(f"      step: |R| {r0:.3e} -> {r:.3e}, alpha = {alpha:.3g}", flush=True)
        return bool(np.isfinite(r))

    def solve(self, ref_norm, rtol=1e-10, stol=1e-12, max_it=40, verbose=False):
        """Returns (converged, iterations). ref_norm scales the residual test
        ||R|| <= rtol * ref_norm; also converged when the full-step increment is below
        stol (max norm) and the residual is below 1e3 * rtol * ref_norm."""
        w = self.w
        r = self.residual()
        if not np.isfinite(r):
            return False, 0
        for it in range(1, max_it + 1):
            if r <= rtol * ref_norm:
                return True, it - 1
            self.A.zeroEntries()
            fpetsc.assemble_matrix(self.A, self.J, bcs=self.bcs)
            self.A.assemble()
            self.b.scale(-1.0)
            self.ksp.solve(self.b, self.dw)
            if self.ksp.getConvergedReason() < 0:
                return False, it
            if verbose:
                rl = self.A.createVecLeft()
                self.A.mult(self.dw, rl)
                rl.axpy(-1.0, self.b)
                print(f"      linear residual {rl.norm() / self.b.norm():.2e}", flush=True)
            self.total_iterations += 1
            dw = self.dw.array.copy()
            if not np.all(np.isfinite(dw)):
                return False, it
            w0 = w.x.array.copy()
            if self.is_u.size:
                du = np.max(np.abs(dw[self.is_u]), initial=0.0)
                dq = np.max(np.abs(dw[~self.is_u]), initial=0.0)
                if du <= 1e-10 * self.u_scale and dq <= 1e-8 * self.q_scale:
                    w.x.array[:] = w0 + dw
                    w.x.scatter_forward()
                    r = self.residual()
                    if verbose:
                        print(f"      newton {it:2d}: |R| = {r:.3e} (ref {ref_norm:.3e}) increment test: |du| = {du:.2e} |dq| = {dq:.2e}", flush=True)
                    return bool(np.isfinite(r) and r <= 1e-6 * ref_norm), it
            alpha, r0 = 1.0, r
            while True:
                w.x.array[:] = w0 + alpha * dw
                w.x.scatter_forward()
                r = self.residual()
                if np.isfinite(r) and r <= (1 - 1e-4 * alpha) * r0:
                    break
                if alpha < 1e-3:
                    break  # accept the tiny step; the iteration cap will decide
                alpha *= 0.5
            inc = alpha * np.max(np.abs(dw))
            if verbose:
                extra = f" |du| = {alpha * du:.2e} |dq| = {alpha * dq:.2e}" if self.is_u.size else ""
                print(f"      newton {it:2d}: |R| = {r:.3e} (ref {ref_norm:.3e}) alpha = {alpha:.3g} |dw| = {inc:.2e}{extra}", flush=True)
            if not np.isfinite(r):
                return False, it
            if r <= rtol * ref_norm or (alpha == 1.0 and inc < stol and r <= 1e3 * rtol * ref_norm):
                return True, it
        return False, max_it


def assemble(expr):
    return MPI.COMM_WORLD.allreduce(fem.assemble_scalar(fem.form(expr)), op=MPI.SUM)


class Timer:
    def __init__(self):
        self.t0 = time.perf_counter()

    def __call__(self):
        return time.perf_counter() - self.t0
