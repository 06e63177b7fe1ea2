"""Fig 4 of [LTL87]: the thin incompressible Mooney-Rivlin bar at t = 800 s.

    /usr/bin/python3 figures/fig4.py results/fig4.h5 results/fig4.png

Reads only the results file. The paper shows, at t = 800 s, the adhesion intensity beta and the
vertical displacement of the contact surface along x1, and the deformed configuration magnified
x50 ("RAPPORT = 50"). Here the bar has peeled off completely long before 800 s and its
displacements are O(1 m), so a x50 picture of that state would be meaningless: panel (c) shows
the x50 view at the last step before the peel runs away (chosen from the data as in Fig 3), and
panel (d) the state at t = 800 s at true scale. Prints the numbers it plots.
"""

import sys
import textwrap

import numpy as np

import style  # noqa: F401  (Agg backend and rc parameters, before pyplot)
import matplotlib.pyplot as plt  # noqa: E402

import ltl_results as lr  # noqa: E402
from fig3 import (RUNAWAY_OPENING, contact_normal, draw_state,  # noqa: E402
                  front_and_opening, pre_runaway, reading)

RAPPORT = 50  # the paper's magnification


def state_height(X, step, scale, width=8.6):
    """Inches of a panel `width` inches wide (the full row of an 11-inch figure) drawing the
    state at equal aspect, framed as draw_state frames it."""
    x = lr.deformed(X, step.fields["u"], scale)
    lo, hi = min(X[:, 0].min(), x[:, 0].min()), max(X[:, 0].max(), x[:, 0].max())
    top = max(X[:, 1].max(), x[:, 1].max())
    return float(np.clip(width * (top + 0.11) / (hi - lo + 0.1), 0.5, 6.0))


def below_plane_note(r, X1, u2, xc, e2):
    """A sentence on the contact nodes below the plane x2 = 0 (u2 < 0 at a node of the contact
    surface, which starts on the plane), or "" when none is: how far, where, and why the
    discretization allows it."""
    k = int(np.argmin(u2))
    tiny = 1e-3 * np.abs(u2).max()  # below it: round-off of a node resting on the plane
    if u2[k] >= -tiny:
        return ""
    res = lr.resolved_config(r) or {}
    rule = res.get("discretization", {}).get("contact", "")
    why = ("non-penetration is imposed on the facet means (contact = \"facet-mean\", the "
           "paper's P0 unknowns): the facet mean e2 there is %.1e m, and a P2 node may dip "
           "between them (paper_notes/discretization.md)"
           % e2[np.argmin(np.abs(xc - X1[k]))] if rule == "facet-mean"
           else "within the iteration's tolerance on the nodal constraint")
    text = ("%d contact node(s) below the plane; the lowest, at x1 = %.3g m, %.2g mm below "
            "(the dip under the free end in (c), x%d): %s"
            % (int(np.sum(u2 < -tiny)), X1[k], -1e3 * u2[k], RAPPORT, why))
    return "\n".join(textwrap.wrap(text, 75))


def main(h5, png):
    r = lr.load(h5)
    if not r.steps:
        sys.exit("%s: no time step stored" % h5)
    N = contact_normal(r)
    m = r.mesh
    xc = m.contact_centre[:, 0]
    front, opening = front_and_opening(r)
    last = r.steps[-1]
    k_pre = pre_runaway(r, opening)
    if k_pre is None:
        print("note: the opening exceeds %g m from the first step on" % RUNAWAY_OPENING)
        k_pre = 0
    pre = r.steps[k_pre]
    print("t = %g s (step %d); last step before the runaway (largest opening < %g m): step %d, "
          "t = %g s" % (last.t, last.p, RUNAWAY_OPENING, pre.p, pre.t))

    # The contact surface at the last step: facet values (beta, e) at the facet centres, and the
    # nodal displacement u2 of the contact nodes (P2: vertices and mid-edge nodes).
    nodes = np.unique(m.contact_facets)
    nodes = nodes[np.argsort(m.X[nodes, 0])]
    lift = last.fields["e"] @ -N          # e . (-N) = e2: vertical displacement, facet means
    u2 = last.fields["u"][nodes] @ -N     # the same at the contact nodes

    # Three rows, each as tall as its content: (c) and (d) are drawn at equal aspect, so their
    # heights follow the drawn bar (a thin bar pressed down is a thin strip; peeled off, it
    # stands up to 1.4 m); (a) and (b) side by side below.
    ran_away = pre is not last
    h_c, h_d, h_ab = state_height(m.X, pre, RAPPORT), state_height(m.X, last, 1.0), 3.2
    height = (h_c + h_d + h_ab) * 1.25 + 1.0
    fig = plt.figure(figsize=(11.0, height))
    gs = fig.add_gridspec(3, 2, height_ratios=[h_c, h_d, h_ab], hspace=0.4, wspace=0.22,
                          top=1 - 0.9 / height, bottom=0.5 / height)

    # (c) the paper's x50 view, at t = 800 s, or at the last step before the runaway if there is
    # one.
    ax = fig.add_subplot(gs[0, :])
    draw_state(ax, r, pre, RAPPORT,
               "(c) RAPPORT = %d: deformed configuration, displacements x%d, at t = %g s (step %d%s)"
               % (RAPPORT, RAPPORT, pre.t, pre.p, ", the last before the runaway" if ran_away
                  else ", as the caption"))

    # (d) the state at t = 800 s, true scale.
    ax = fig.add_subplot(gs[1, :])
    draw_state(ax, r, last, 1.0, "(d) deformed configuration at t = %g s, true scale (x1)" % last.t,
               legend_loc="upper left")

    # (a) beta along x1.
    ax = fig.add_subplot(gs[2, 0])
    ax.plot(xc, last.fields["beta"], color="k", marker="o", ms=3, label="t = %g s" % last.t)
    if ran_away:
        ax.plot(xc, pre.fields["beta"], color=style.REFERENCE, ls="--", marker=".", ms=3,
                label="t = %g s (before the runaway)" % pre.t)
    ax.set_ylim(-0.03, 1.03)
    ax.set_xlim(0, xc.max() + xc.min())
    ax.set_xlabel("x1 (m)")
    ax.set_ylabel("adhesion intensity beta")
    ax.set_title("(a) beta along the contact surface, t = %g s" % last.t)
    ax.legend(loc="center right")

    # (b) vertical displacement of the contact surface.
    ax = fig.add_subplot(gs[2, 1])
    ax.plot(m.X[nodes, 0], u2, color=style.BODY, lw=1.2, label="u2 at the contact nodes")
    ax.plot(xc, lift, ls="none", marker="o", ms=3.5, color=style.CONTACT,
            label="e2 per facet (facet centres)")
    ax.set_xlim(0, xc.max() + xc.min())
    ax.set_xlabel("x1 (reference, m)")
    ax.set_ylabel("vertical displacement (m)")
    ax.set_title("(b) vertical displacement of the contact surface, t = %g s" % last.t)
    dip = below_plane_note(r, m.X[nodes, 0], u2, xc, lift)
    if dip:
        ax.text(0.98, 0.04, dip, transform=ax.transAxes, fontsize=6.5, va="bottom", ha="right",
                bbox=dict(facecolor="white", alpha=0.85, lw=0))
        print("panel (b): " + dip.replace("\n", " "))
    ax.legend(loc="upper right")

    umax = np.linalg.norm(last.fields["u"], axis=1).max()
    if ran_away:
        state = ("at t = %g s the bar has peeled off (max|u| = %.2g m): x%d is shown before the "
                 "runaway (c), the %g s state at x1 (d)" % (last.t, umax, RAPPORT, last.t))
    else:
        state = "max|u| = %.2g m at t = %g s, drawn x%d (c) and at x1 (d)" % (umax, last.t,
                                                                            RAPPORT)
    status = str(r.attrs.get("status", ""))
    if status.startswith("inadmissible") or status.startswith("diverged"):
        # The run was refused at a step (e.g. the literal reading: a cell folds at the clamp once
        # the glue lets go); the figure draws the steps it kept.
        state += "; run refused after t = %g s (%s)" % (last.t, status.split(":")[0])
    fig.suptitle("Fig 4 [LTL87]: incompressible Mooney-Rivlin bar [0,1] x [0,0.05] m, "
                 "C1 = 187.5 kPa, C2 = 0, |g2| = 10 (1 - x1) kPa\nreading %s; %s"
                 % (reading(r), state), fontsize=11)

    lr.print_table("contact surface at t = %g s (panels a, b): facet centres" % last.t,
                   {"x1_m": xc, "beta": last.fields["beta"], "e2_m": lift,
                    "beta_t=%gs" % pre.t: pre.fields["beta"],
                    "e2_t=%gs_m" % pre.t: pre.fields["e"] @ -N}, fmt="%.5g")
    lr.print_table("contact nodes at t = %g s (panel b)" % last.t,
                   {"X1_m": m.X[nodes, 0], "u2_m": u2}, fmt="%.5g")
    lr.print_table("front and largest opening against time (up to the runaway + 1, and the last)",
                   {"p": [s.p for s in r.steps[:k_pre + 2]] + [last.p],
                    "t_s": [s.t for s in r.steps[:k_pre + 2]] + [last.t],
                    "iterations": [s.iterations for s in r.steps[:k_pre + 2]] + [last.iterations],
                    "front_x1_m": np.r_[front[:k_pre + 2], front[-1]],
                    "max_opening_m": np.r_[opening[:k_pre + 2], opening[-1]]})
    for s, scale, name in ((pre, RAPPORT, "c"), (last, 1.0, "d")):
        u = s.fields["u"]
        i = np.argmax(np.linalg.norm(u, axis=1))
        print("panel (%s): t = %g s, magnification x%g, largest |u| = %.4g m at X = (%.3f, %.3f)"
              % (name, s.t, scale, np.linalg.norm(u[i]), *m.X[i]))
    style.save(fig, png)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: fig4.py RESULTS.h5 OUTPUT.png")
    main(sys.argv[1], sys.argv[2])
