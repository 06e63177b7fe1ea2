"""Fig 5 of [LTL87]: a Mooney-Rivlin cylinder resting on a plane under its own weight.

    /usr/bin/python3 figures/fig5.py results/fig5.h5 results/fig5.png

Reads only the results file. Panels: (a) the deformed cylinder (the computed half x1 >= 0
mirrored to the whole) on the plane, at true scale; (b) a zoom on the contact zone; (c) the
contact pressure p = -lambda_c . N per contact point against the deformed x1: per contact node
(discretization.contact = "nodal", the default) or per facet over its deformed extent
("facet-mean", the paper's). Prints the contact half-width, the peak pressure, the total contact
force against the weight, and the table of the contact points.
"""

import sys

import numpy as np

import style  # noqa: F401  (Agg backend and rc parameters, before pyplot)
import matplotlib.pyplot as plt  # noqa: E402

import ltl_results as lr  # noqa: E402

ZOOM_EXAGGERATION = 3  # vertical exaggeration of the zoom on the contact zone


def main(h5, png):
    r = lr.load(h5)
    if not r.steps:
        sys.exit("%s: no time step stored" % h5)
    s = r.steps[-1]
    m = r.mesh
    cfg = lr.config(r)
    N = np.array([lr.quantity(v) for v in cfg["contact"]["plane_normal"]])
    N = N / np.linalg.norm(N)
    p0 = np.array([lr.quantity(v) for v in cfg["contact"]["plane_point"]])
    f = np.array([lr.quantity(v) for v in cfg["load"]["body_force"]])

    u = s.fields["u"]
    x = lr.deformed(m.X, u)
    mirror = np.array([-1.0, 1.0])          # the symmetry plane x1 = 0
    p = s.fields["contact_pressure"]         # = -lambda_c . N, per facet (nominal)
    gap = s.fields["gap"]
    area = m.contact_area
    ms = s.measures                          # the solver's measures (lib/measures.hpp)
    nodal = m.contact_nodes is not None
    if nodal:   # one point per contact node: its deformed x1 is both "ends"
        ends = np.stack([m.contact_nodes, m.contact_nodes], axis=1)
    else:
        ends = m.contact_facets[:, :2]       # end vertices of each P2 edge
    x_end = x[ends, 0]                       # (#points, 2) deformed x1 of the ends
    x_centre = m.contact_centre[:, 0] + s.fields["e"][:, 0]   # deformed points (nodes or means)
    what = "nodes" if nodal else "facets"

    # The numbers of the figure: the stored measures (a_edge: the deformed x1 of the outermost
    # node carrying a point in contact), only the weight and the drop of the top are this
    # figure's own.
    half_width = ms["a_edge"]
    force = ms["contact_force"]
    weight = np.linalg.norm(f) * m.cell_volume.sum()
    top = np.argmin(np.linalg.norm(m.X - [0.0, 1.0], axis=1))
    cnodes = np.unique(m.contact_facets)
    cnodes = cnodes[np.argsort(np.arctan2(m.X[cnodes, 1], m.X[cnodes, 0]))]  # along the arc
    penetration = ms["contact_penetration"]
    print("contact %s in contact: %d of %d" % (what, ms["in_contact_count"], ms["contact_points"]))
    print("contact half-width a = %.4f m (deformed x1 of the outermost contact %s carrying "
          "pressure)" % (half_width, "node" if nodal else "facet's outer end"))
    print("peak contact pressure: %.4g Pa" % ms["p_max"])
    print("total contact force (half cylinder): %.5g N/m; weight |f| |Omega| = %.4g N/m^3 x "
          "%.5f m^2 = %.5g N/m; ratio %.4f"
          % (force, np.linalg.norm(f), m.cell_volume.sum(), weight, force / weight))
    print("drop of the top (u2 at X = (%.3g, %.3g)): %.4f m" % (*m.X[top], -u[top, 1]))
    print("largest penetration of a contact node into the plane: %.4g m "
          "(the constraint is imposed on %s)" % (max(penetration, 0.0),
                                                 "every node" if nodal else "facet means"))
    print("iterations: %d" % s.iterations)
    lr.print_table("contact %s (panel c)" % what, {
        "X1_centre_m": m.contact_centre[:, 0], "X2_centre_m": m.contact_centre[:, 1],
        "x1_from_m": x_end.min(axis=1), "x1_to_m": x_end.max(axis=1), "x1_centre_m": x_centre,
        "pressure_Pa": p, "gap_m": gap, "weight_m": area}, fmt="%.5g")
    lr.print_table("contact nodes (panel b)", {
        "X1_m": m.X[cnodes, 0], "X2_m": m.X[cnodes, 1], "x1_m": x[cnodes, 0],
        "x2_m": x[cnodes, 1], "above_plane_m": -(x[cnodes] - p0) @ N}, fmt="%.5g")

    fig = plt.figure(figsize=(11.0, 8.8))
    gs = fig.add_gridspec(2, 2, width_ratios=[1.0, 1.2], height_ratios=[1.3, 1.0], hspace=0.22,
                          wspace=0.2, top=0.92)

    def draw_body(ax):
        for sign in (np.array([1.0, 1.0]), mirror):
            style.draw_p2_outline(ax, m.X * sign, m.cells)
            style.draw_p2_mesh(ax, x * sign, m.cells)
        ax.plot([], [], color=style.BODY, label="deformed (x1)")
        ax.plot([], [], color=style.REFERENCE, ls="--", label="reference")

    # (a) the whole cylinder.
    ax = fig.add_subplot(gs[0, 0])
    draw_body(ax)
    style.hatch_support(ax, -1.4, 1.4, p0[1], below=True, label="plane x2 = %g m" % p0[1])
    ax.axvline(0, color=style.REFERENCE, lw=0.6, ls=":")
    ax.set_aspect("equal")
    ax.set_xlim(-1.4, 1.4)
    ax.set_ylim(p0[1] - 0.15, 1.15)
    ax.set_xlabel("x1 (m)")
    ax.set_ylabel("x2 (m)")
    ax.set_title("(a) deformed cylinder, true scale (x1)\n(half x1 >= 0 computed, mirrored)")
    ax.legend(loc="upper right")

    # (b) zoom on the contact zone, with the contact nodes.
    ax = fig.add_subplot(gs[0, 1])
    draw_body(ax)
    for sign in (1.0, -1.0):
        ax.plot(sign * x[cnodes, 0], x[cnodes, 1], "o", ms=3, color=style.CONTACT,
                label="contact nodes" if sign > 0 else None)
    style.hatch_support(ax, -1.0, 1.0, p0[1], below=True)
    ax.set_xlim(-1.0, 1.0)
    ax.set_ylim(p0[1] - 0.1, p0[1] + 0.3)
    ax.set_aspect(ZOOM_EXAGGERATION)
    ax.set_xlabel("x1 (m)")
    ax.set_ylabel("x2 (m)")
    ax.set_title("(b) contact zone, x2 exaggerated x%g: contact nodes cross the plane by up to "
                 "%.2g m;\nnon-penetration is imposed on %s" %
                 (ZOOM_EXAGGERATION, max(penetration, 0.0),
                  "every contact node" if nodal else "the facet means"))
    ax.legend(loc="upper center", ncol=3)

    # (c) contact pressure per facet over its deformed extent.
    ax = fig.add_subplot(gs[1, :])
    order = np.argsort(x_centre)
    for sign in (1.0, -1.0):
        if nodal:
            ax.plot(sign * x_centre[order], p[order] / 1e6, "o-", ms=3.5, color=style.CONTACT,
                    label="p per contact node (deformed x1)" if sign > 0 else None)
        else:
            for k in range(len(p)):
                ax.plot(sign * x_end[k], [p[k] / 1e6] * 2, color=style.CONTACT, lw=2)
            ax.plot(sign * x_centre, p / 1e6, "o", ms=3.5, color="k",
                    label="facet centres (deformed)" if sign > 0 else None)
    if not nodal:
        ax.plot([], [], color=style.CONTACT, lw=2, label="p per facet, over its deformed extent")
    ax.axvspan(-half_width, half_width, color=style.CONTACT, alpha=0.08)
    ax.set_xlim(-1.15, 1.15)
    ax.set_ylim(-0.05, 1.5 * p.max() / 1e6)
    ax.set_xlabel("deformed x1 (m)")
    ax.set_ylabel("contact pressure -lambda_c.N (MPa)")
    ax.set_title("(c) contact pressure (per reference length); contact half-width %.3f m"
                 % half_width)
    ax.legend(loc="upper right")

    fig.suptitle("Fig 5 [LTL87]: Mooney-Rivlin cylinder (R = 1 m, C1 = 435 kPa, C2 = 65 kPa) "
                 "on the plane x2 = -1 under f2 = %.0f kN/m^3; %d iterations"
                 % (f[1] / 1e3, s.iterations), fontsize=11)
    style.save(fig, png)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: fig5.py RESULTS.h5 OUTPUT.png")
    main(sys.argv[1], sys.argv[2])
