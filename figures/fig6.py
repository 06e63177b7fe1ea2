"""Fig 6 of [LTL87]: the three-dimensional gutter hanging over the plane x2 = -3.

    /usr/bin/python3 figures/fig6.py results/fig6.h5 results/fig6.png

Reads only the results file. The quarter x1 in [0, 10], x3 >= 0 is computed; every picture
mirrors it in x1 and x3 to the whole gutter. Panels: (a) 3-D view of the deformed surface
(boundary faces of the H8 cells, true scale, coloured by the vertical displacement) above the
plane; (b) the contact zone on the plane: the facets of the outer face that touch it, coloured
by the contact pressure, over the footprint of the deformed gutter; (c) the mid-span
cross-section x1 = 0, deformed and reference; (d) the vertical displacement of the bottom line
and of the rim along the gutter. Prints the sag, the contact zone, the contact force against
the load, and the contact facets.
"""

import sys

import numpy as np

import style  # noqa: F401  (Agg backend and rc parameters, before pyplot)
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

import ltl_results as lr  # noqa: E402

# Faces of an eight-node hexahedron (gmsh order: 0-3 one face, 4-7 the opposite one).
HEX_FACES = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))
# The four copies of the computed quarter: x1 -> +-x1, x3 -> +-x3.
MIRRORS = [np.array([a, 1.0, b]) for a in (1.0, -1.0) for b in (1.0, -1.0)]


def boundary_faces(X, cells, tol=1e-9):
    """Quadrilateral faces (#faces, 4) that belong to one cell only, without those lying on the
    symmetry planes X1 = 0 and X3 = 0 (interior faces of the whole body)."""
    count = {}
    for c in cells:
        for f in HEX_FACES:
            q = tuple(c[list(f)])
            key = tuple(sorted(q))
            count[key] = (count.get(key, (0, q))[0] + 1, q)
    faces = np.array([q for n, q in count.values() if n == 1])
    on_sym = (np.abs(X[faces, 0]).max(axis=1) < tol) | (np.abs(X[faces, 2]).max(axis=1) < tol)
    return faces[~on_sym]


def quad_area(P):
    """Areas of quadrilaterals P (#quads, 4, 3), as two triangles (0,1,2) and (0,2,3)."""
    a = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    b = np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 0])
    return 0.5 * (np.linalg.norm(a, axis=1) + np.linalg.norm(b, axis=1))


def main(h5, png):
    r = lr.load(h5)
    if not r.steps:
        sys.exit("%s: no time step stored" % h5)
    s = r.steps[-1]
    m = r.mesh
    cfg = lr.config(r)
    X, cells, u = m.X, m.cells, s.fields["u"]
    x = lr.deformed(X, u)
    N = np.array([lr.quantity(v) for v in cfg["contact"]["plane_normal"]])
    N = N / np.linalg.norm(N)
    plane = np.array([lr.quantity(v) for v in cfg["contact"]["plane_point"]])
    y_plane = plane[1]

    p = s.fields["contact_pressure"]       # -lambda_c . N per facet, nominal (per reference area)
    area = m.contact_area
    ms = s.measures                        # the solver's measures (lib/measures.hpp)
    touching = s.in_contact                # the contact set, as stored
    force = ms["contact_force"]
    contact_area = ms["contact_area"]

    # The load: the dead tractions of the configuration on the inner face (faces at radius Ri).
    Ri = lr.quantity(cfg["mesh"]["parameters"]["Ri"])
    faces = boundary_faces(X, cells)
    radius = np.hypot(X[faces, 1], X[faces, 2])
    inner = faces[np.all(np.abs(radius - Ri) < 1e-6, axis=1)]
    inner_area = quad_area(X[inner]).sum()
    load = 0.0
    for t in cfg["load"].get("traction", []):
        if t["group"] == "inner":
            g = np.array([lr.quantity(v) for v in t["value"]])
            load += (g @ N) * inner_area

    sag_node = np.argmax(-u[:, 1])
    sag = -u[sag_node, 1]
    penetration = max(ms["contact_penetration"], 0.0)
    print("maximum sag -u2 = %.4f m at X = (%.3f, %.3f, %.3f)" % (sag, *X[sag_node]))
    print("lowest point of the deformed gutter: x2 = %.4f m (plane at %g m)"
          % (x[:, 1].min(), y_plane))
    what = "nodes" if m.contact_nodes is not None else "facets"
    print("contact points (%s) in contact: %d of %d in the computed quarter"
          % (what, ms["in_contact_count"], ms["contact_points"]))
    print("contact area (reference): %.4f m^2 in the quarter, %.4f m^2 in the whole body"
          % (contact_area, 4 * contact_area))
    print("peak contact pressure: %.4g Pa" % ms["p_max"])
    print("total contact force: %.5g N in the quarter, %.5g N in the whole body"
          % (force, 4 * force))
    print("load on the quarter: %.5g N (inner face %.4f m^2); carried by the plane: %.3f, by the "
          "clamped ends: %.3f" % (load, inner_area, force / load, 1 - force / load))
    print("largest penetration of an outer-face node into the plane: %.3g m" % penetration)
    print("iterations: %d" % s.iterations)
    k = np.nonzero(touching)[0]
    lr.print_table("contact points in contact (quarter, reference positions)", {
        "X1_m": m.contact_centre[k, 0], "X3_m": m.contact_centre[k, 2],
        "pressure_Pa": p[k], "area_m2": area[k], "gap_m": s.fields["gap"][k]}, fmt="%.5g")

    fig = plt.figure(figsize=(12.0, 10.0))
    gs = fig.add_gridspec(2, 3, height_ratios=[1.1, 1.0], width_ratios=[1.6, 1.0, 1.0],
                          hspace=0.12, wspace=0.32, top=0.95, bottom=0.06)

    # (a) 3-D view of the deformed surface, mirrored to the whole body; axes (x1, x3, x2).
    ax = fig.add_subplot(gs[0, :], projection="3d", computed_zorder=False)
    polys, colour = [], []
    for sgn in MIRRORS:
        for q in faces:
            polys.append(x[q][:, [0, 2, 1]] * sgn[[0, 2, 1]])
            colour.append(-u[q, 1].mean())
    cmap = plt.get_cmap("viridis")
    norm = plt.Normalize(0, max(colour))
    L1 = np.abs(X[:, 0]).max()
    W = np.abs(x[:, 2]).max() * 1.3
    ax.add_collection3d(Poly3DCollection(
        [np.array([[-L1 - 1, -W, y_plane], [L1 + 1, -W, y_plane], [L1 + 1, W, y_plane],
                   [-L1 - 1, W, y_plane]])], facecolors="0.75", edgecolors="0.4", alpha=0.5))
    ax.add_collection3d(Poly3DCollection(polys, facecolors=cmap(norm(colour)), edgecolors="k",
                                         linewidths=0.15, alpha=1.0))
    ax.set_xlim(-L1 - 1, L1 + 1)
    ax.set_ylim(-W, W)
    ax.set_zlim(y_plane - 0.1, 0.3)
    # True proportions in x1 and x3; the vertical axis (x2) is drawn x2 so that the sag shows.
    ax.set_box_aspect((2 * L1 + 2, 2 * W, 2 * (0.4 - y_plane)), zoom=1.35)
    ax.view_init(elev=22, azim=-58)
    ax.set_yticks([-2, 0, 2])
    ax.set_xlabel("x1 (m)")
    ax.set_ylabel("x3 (m)")
    ax.set_zlabel("x2 (m)")
    ax.set_title("(a) deformed gutter (displacements x1), mirrored from the computed quarter; "
                 "vertical axis stretched x2; grey: the plane x2 = %g m" % y_plane, y=0.98)
    cax = fig.add_axes([0.93, 0.6, 0.012, 0.28])
    cax.grid(False)
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), cax=cax,
                 label="downward displacement -u2 (m)")

    # (b) the contact zone on the plane (x1, x3): deformed positions of the outer-face facets.
    # The contact set and the pressures are per contact point: per facet ("facet-mean"), or per
    # node of the contact surface (the default, "nodal"); then a facet is drawn in the zone when
    # one of its nodes is in the contact set, coloured by the mean pressure of its nodes.
    ax = fig.add_subplot(gs[1, 0])
    cf = m.contact_facets
    if m.contact_nodes is not None:
        point_of = {node: i for i, node in enumerate(m.contact_nodes)}
        pts = [[point_of[n] for n in q] for q in cf]
        facet_touching = [any(touching[i] for i in ids) for ids in pts]
        facet_p = [np.mean(p[ids]) for ids in pts]
    else:
        facet_touching, facet_p = list(touching), list(p)
    footprint, zone, zone_p = [], [], []
    for sgn in MIRRORS:
        for j, q in enumerate(cf):
            poly = (x[q] * sgn)[:, [0, 2]]
            footprint.append(poly)
            if facet_touching[j]:
                zone.append(poly)
                zone_p.append(facet_p[j])
    ax.add_collection(PolyCollection(footprint, facecolors="none", edgecolors="0.75",
                                     linewidths=0.4))
    pc = PolyCollection(zone, array=np.array(zone_p), cmap="Reds", edgecolors="k",
                        linewidths=0.4)
    pc.set_clim(0, p.max())
    ax.add_collection(pc)
    fig.colorbar(pc, ax=ax, label="contact pressure -lambda_c.N (Pa)", shrink=0.9)
    ax.set_xlim(-L1 - 0.5, L1 + 0.5)
    ax.set_ylim(-W, W)
    ax.set_xlabel("x1 (m)")
    ax.set_ylabel("x3 (m)")
    ax.set_title("(b) contact zone on the plane x2 = %g m: %.2f m^2 (reference, whole body)\n"
                 "(grey: outer face seen from below)" % (y_plane, 4 * contact_area))

    # (c) the mid-span cross-section x1 = 0, mirrored in x3.
    ax = fig.add_subplot(gs[1, 1])
    mid = [c for c in cells if np.all(np.abs(X[c[:4], 0]) < 1e-9)]  # faces 0-3 on x1 = 0
    for c in mid:
        q = list(c[:4]) + [c[0]]
        for sg in (1.0, -1.0):
            ax.plot(sg * X[q, 2], X[q, 1], color=style.REFERENCE, lw=0.6, ls="--")
            ax.plot(sg * x[q, 2], x[q, 1], color=style.BODY, lw=0.8)
    ax.plot([], [], color=style.BODY, label="deformed")
    ax.plot([], [], color=style.REFERENCE, ls="--", label="reference")
    style.hatch_support(ax, -2.0, 2.0, y_plane, below=True)
    ax.set_aspect("equal")
    ax.set_xlim(-2.0, 2.0)
    ax.set_ylim(y_plane - 0.25, 0.4)
    ax.set_xlabel("x3 (m)")
    ax.set_ylabel("x2 (m)")
    ax.set_title("(c) mid-span section x1 = 0")
    ax.legend(loc="upper center", fontsize=7)

    # (d) vertical displacement along the gutter: bottom line (X3 = 0 on the outer face) and rim.
    ax = fig.add_subplot(gs[1, 2])
    Ro = np.hypot(X[:, 1], X[:, 2]).max()
    bottom = np.nonzero((np.abs(X[:, 2]) < 1e-9) & (np.abs(X[:, 1] + Ro) < 1e-6))[0]
    rim = np.nonzero((np.abs(X[:, 1]) < 1e-9) & (np.abs(X[:, 2] - Ro) < 1e-6))[0]
    bottom = bottom[np.argsort(X[bottom, 0])]
    rim = rim[np.argsort(X[rim, 0])]
    ax.plot(X[bottom, 0], x[bottom, 1], color=style.BODY, marker="o", ms=2.5,
            label="bottom line (X2 = -%.1f, X3 = 0)" % Ro)
    ax.plot(X[rim, 0], x[rim, 1], color=style.ACCENT, marker="s", ms=2.5,
            label="outer rim (X2 = 0, X3 = %.1f)" % Ro)
    ax.axhline(y_plane, color=style.SUPPORT, lw=1.5)
    ax.set_xlabel("X1 (reference, m)")
    ax.set_ylabel("deformed x2 (m)")
    ax.set_ylim(y_plane - 0.2, 0.2)
    ax.set_title("(d) height along the half length")
    ax.legend(loc="upper left", fontsize=7)

    fig.suptitle("Fig 6 [LTL87]: gutter (length 20 m, Ri = 1 m, thickness 0.2 m, Mooney-Rivlin "
                 "C1 = 50 kPa) under 0.5 kPa on its inner face, ends clamped; %d iterations"
                 % s.iterations, fontsize=11)
    lr.print_table("bottom line and rim (panel d)", {
        "X1_m": X[bottom, 0], "bottom_x2_m": x[bottom, 1], "rim_x2_m": x[rim, 1]}, fmt="%.5g")
    style.save(fig, png)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: fig6.py RESULTS.h5 OUTPUT.png")
    main(sys.argv[1], sys.argv[2])
