"""A body in contact with several rigid obstacles ([[contact]], paper_notes/obstacles.md): the
figure of experiments/oring and experiments/vgroove.

    /usr/bin/python3 figures/obstacles.py results/vgroove.h5 results/vgroove.png [--mirror]

Reads only the results file. Panels: (a) the deformed body (mirrored about x1 = 0 with
--mirror: a half model) over its reference outline, the obstacles' planes, the contact points
coloured by obstacle where they press; (b) the contact pressure p = -lambda_c . N_k of each
obstacle against the position of its points along its plane. Prints each obstacle's force, its
resultant and the load.
"""

import sys

import numpy as np

import style  # noqa: F401  (Agg backend and rc parameters, before pyplot)
import matplotlib.pyplot as plt  # noqa: E402

import ltl_results as lr  # noqa: E402


def obstacles_of(results):
    """The planes (point, unit normal, group) of the resolved configuration, in order."""
    cfg = lr.resolved_config(results)
    contact = cfg["contact"]
    if isinstance(contact, dict):
        contact = [contact]
    out = []
    for c in contact:
        N = np.array([float(v) for v in c["plane_normal"]])
        out.append((np.array([float(v) for v in c["plane_point"]]), N / np.linalg.norm(N),
                    c["group"]))
    return out


def main(h5, png, mirror=False):
    r = lr.load(h5)
    if not r.steps:
        sys.exit("%s: no time step stored" % h5)
    s, m = r.steps[-1], r.mesh
    planes = obstacles_of(r)
    if m.obstacles() != len(planes):
        sys.exit("%s: %d obstacles in the file, %d in its configuration" % (
            h5, m.obstacles(), len(planes)))
    x = lr.deformed(m.X, s.fields["u"])
    p = s.fields["contact_pressure"]
    xp = lr.deformed(m.contact_centre, s.fields["u"][m.contact_nodes]) \
        if m.contact_nodes is not None else m.contact_centre
    fig, (ax, bx) = plt.subplots(1, 2, figsize=style.WIDE)
    reflections = [np.array([1.0, 1.0])] + ([np.array([-1.0, 1.0])] if mirror else [])
    for R in reflections:
        style.draw_p2_outline(ax, m.X * R, m.cells)
        style.draw_p2_mesh(ax, x * R, m.cells)
    lo, hi = x.min(axis=0), x.max(axis=0)
    if mirror:
        lo[0] = -hi[0]
    size = (hi - lo).max()
    colours = [style.SEQUENCE(k, len(planes), "tab10") for k in range(len(planes))]
    for k, (p0, N, group) in enumerate(planes):
        T = np.array([-N[1], N[0]])
        if T[0] < 0 or (T[0] == 0 and T[1] < 0):  # every plane read left to right
            T = -T
        t = np.linspace(-1.5 * size, 1.5 * size, 2)
        line = p0[None, :] + t[:, None] * T[None, :]
        ax.plot(line[:, 0], line[:, 1], color=colours[k], lw=2,
                label="obstacle %d (%s)" % (k, group))
        idx = m.obstacle_points(k)
        pressed = idx[p[idx] > 1e-6 * max(p.max(), 1e-300)]
        ax.plot(xp[pressed, 0], xp[pressed, 1], "o", ms=3, color=colours[k])
        along = xp[idx] @ T
        order = np.argsort(along)
        bx.plot(along[order] * 1e3, p[idx][order] / 1e3, "o-", ms=3, lw=0.6, color=colours[k],
                label="obstacle %d (%s)" % (k, group))
    pad = 0.15 * size
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.set_title("(a) deformed, t = %g s (dashed: reference)" % s.t)
    ax.set_xlabel("x1 (m)")
    ax.set_ylabel("x2 (m)")
    ax.legend(fontsize=7, loc="upper right")
    bx.set_xlabel("deformed position along the plane (mm)")
    bx.set_ylabel("contact pressure -lambda_c . N (kPa)")
    bx.set_title("(b) contact pressure per obstacle")
    bx.legend(fontsize=7)
    style.save(fig, png)
    for k in range(len(planes)):
        sfx = "" if k == 0 else "_%d" % k
        res = [s.measures.get("contact_resultant_%s%s" % (c, sfx), float("nan")) for c in "xy"]
        print("obstacle %d: force %.6g N/m, resultant (%.6g, %.6g) N/m, %d points in contact" % (
            k, s.measures.get("contact_force" + sfx, float("nan")), res[0], res[1],
            int(s.measures.get("in_contact_count" + sfx, 0))))


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(args) != 2:
        sys.exit(__doc__)
    main(args[0], args[1], mirror="--mirror" in sys.argv[1:])
