"""Fig 3 of [LTL87]: the compressible bar peeled off its support.

    /usr/bin/python3 figures/fig3.py results/fig3.h5 results/fig3.png

Reads only the results file. Panels: (a) the deformed mesh with displacements magnified x20
("RAPPORT = 20", the paper's caption) at the last time step before the peel runs away (the last
step whose largest opening is below 1 mm, chosen from the data); (b) the final configuration
(t = 800 s) at true scale; (c) the adhesion intensity beta along the contact surface at every
step up to the runaway and at the end; (d) the largest opening and the debonding front against
time; (e) the iterations per time step. Prints the numbers it plots.
"""

import sys

import numpy as np

import style  # noqa: F401  (Agg backend and rc parameters, before pyplot)
import matplotlib  # noqa: E402
import matplotlib.ticker  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402

import ltl_results as lr  # noqa: E402

RAPPORT = 20          # the paper's magnification of the displacements
# A drawing choice, not a measure: panel (a) shows the last step whose stored largest opening is
# below this (the peel has not yet run away).
RUNAWAY_OPENING = 1e-3  # m


def contact_normal(r):
    """Unit normal N of the support plane, pointing into the support (from the configuration)."""
    N = np.array([lr.quantity(v) for v in lr.config(r)["contact"]["plane_normal"]])
    return N / np.linalg.norm(N)


def reading(r):
    """Which reading of the paper's silent data the run is (from its configuration): the fixed
    ends and the face and direction of the traction g2 = 10 (1 - x1) kPa, as named in the
    readings study (paper_notes/readings.md), e.g. "R3: fixed at x1 = 1, top face pressed down"."""
    c = lr.config(r)
    fixed = sorted(f["group"] for f in c.get("fixed", []))
    tr = c.get("load", {}).get("traction", [])
    if len(tr) != 1:
        return "tractions: %s" % [t["group"] for t in tr]
    face = tr[0]["group"]
    up = lr.quantity(tr[0]["value"][1]) > 0
    where = {("right",): "fixed at x1 = 1", ("left",): "fixed at x1 = 0",
             ("left", "right"): "both ends fixed"}.get(tuple(fixed), "fixed: %s" % fixed)
    known = {("fixed at x1 = 1", "top", True): "R1 (the literal reading)",
             ("fixed at x1 = 0", "top", True): "R2", ("fixed at x1 = 1", "top", False): "R3",
             ("both ends fixed", "top", True): "R5", ("fixed at x1 = 1", "contact", True): "R7"}
    name = known.get((where, face, up), "reading")
    return "%s: %s, %s face %s" % (name, where, "glued" if face == "contact" else face,
                                   "pulled up" if up else "pressed down")


def front_and_opening(r):
    """Per step, as stored by the solver (lib/measures.hpp, /steps/N/measures): the debonding
    front (largest reference x1 of a contact point whose glue is broken, NaN if none) and the
    largest opening max e . (-N)."""
    front = np.array([s.measures["front"] for s in r.steps])
    opening = np.array([s.measures["max_opening"] for s in r.steps])
    return front, opening


def pre_runaway(r, opening):
    """Index of the last step before the first one whose opening exceeds RUNAWAY_OPENING (the
    last step if none does; None if already the first one does)."""
    over = np.nonzero(opening > RUNAWAY_OPENING)[0]
    if len(over) == 0:
        return len(r.steps) - 1
    return over[0] - 1 if over[0] > 0 else None


def draw_state(ax, r, step, scale, title, legend_loc="upper right"):
    X, cells = r.mesh.X, r.mesh.cells
    x = lr.deformed(X, step.fields["u"], scale)
    style.draw_p2_outline(ax, X, cells)
    style.draw_p2_mesh(ax, x, cells)
    lo = min(X[:, 0].min(), x[:, 0].min())
    hi = max(X[:, 0].max(), x[:, 0].max())
    style.hatch_support(ax, lo - 0.02, hi + 0.02, 0.0, below=True)
    ax.set_aspect("equal")
    ax.set_xlim(lo - 0.05, hi + 0.05)
    ax.set_ylim(-0.06, max(X[:, 1].max(), x[:, 1].max()) + 0.05)
    ax.set_xlabel("x1 (m)")
    ax.set_ylabel("x2 (m)")
    ax.set_title(title)
    ax.plot([], [], color=style.BODY, label="deformed (x%g)" % scale)
    ax.plot([], [], color=style.REFERENCE, ls="--", label="reference")
    ax.legend(loc=legend_loc)


def time_axis(ax, t, labels=True):
    """Time axis linear on [0, 50] s and logarithmic beyond, with plain tick labels."""
    ax.set_xscale("symlog", linthresh=50, linscale=2)
    ax.set_xlim(0, max(t.max() * 1.05, 60))
    ticks = [v for v in (0, 10, 20, 30, 40, 50, 100, 200, 400, 800) if v <= t.max() * 1.05]
    ax.set_xticks(ticks)
    ax.set_xticklabels(["%g" % v for v in ticks] if labels else [])
    ax.xaxis.set_minor_locator(plt.NullLocator())
    ax.axvline(50, color=style.REFERENCE, lw=0.6)
    if labels:
        ax.set_xlabel("t (s)   (linear up to 50 s, logarithmic beyond)")


def opening_panel(ax, t, opening):
    """The largest opening against time: on a log axis when the bar lifts off (with the runaway
    threshold of panel (a) drawn and named), in mm on a linear axis when it stays pressed
    (opening <= 0 at every step: a log axis would be empty)."""
    if np.any(opening > 0):
        ax.semilogy(t, np.where(opening > 0, opening, np.nan), color=style.BODY, marker="o",
                    ms=2.5, label="max e.(-N)")
        ax.axhline(RUNAWAY_OPENING, color=style.REFERENCE, ls=":", lw=1,
                   label="%g mm: runaway threshold (panel a)" % (RUNAWAY_OPENING * 1e3))
        ax.set_ylabel("largest opening\nmax e.(-N) (m)")
        ax.legend(loc="center right")
    else:
        ax.plot(t, opening * 1e3, color=style.BODY, marker="o", ms=2.5)
        ax.axhline(0, color=style.REFERENCE, lw=0.8)
        ax.set_ylabel("largest opening\nmax e.(-N) (mm)")
        ax.text(0.02, 0.92, "pressed: the contact surface never lifts off (opening <= 0)",
                transform=ax.transAxes, va="top", fontsize=8)


def count_axis(ax, t, counts):
    """Counts per step: a log axis with labelled ticks at 1, 2, 5 x 10^k when they span more
    than a decade, else a linear axis (a log axis over less than a decade has one tick label)."""
    lo, hi = max(counts.min(), 1), max(counts.max(), 1)
    ax.plot(t, counts, color="k", marker="o", ms=2.5, drawstyle="steps-mid")
    if hi / lo >= 10:
        ax.set_yscale("log")
        ax.yaxis.set_major_locator(matplotlib.ticker.LogLocator(base=10, subs=(1, 2, 5)))
        ax.yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.yaxis.set_minor_locator(plt.NullLocator())
    else:
        ax.set_ylim(0, hi * 1.1 + 1)


def main(h5, png):
    r = lr.load(h5)
    if not r.steps:
        sys.exit("%s: no time step stored" % h5)
    xc = r.mesh.contact_centre[:, 0]
    t = r.times()
    front, opening = front_and_opening(r)
    iterations = np.array([s.iterations for s in r.steps])
    k_pre = pre_runaway(r, opening)
    last = r.steps[-1]
    if k_pre is None:
        print("note: the opening exceeds %g m from the first step on; panel (a) shows step %d"
              % (RUNAWAY_OPENING, r.steps[0].p))
        k_pre = 0
    pre = r.steps[k_pre]
    k_run = k_pre + 1 if k_pre + 1 < len(r.steps) else None
    print("last step before the runaway (largest opening < %g m): step %d, t = %g s, opening %.3g m"
          % (RUNAWAY_OPENING, pre.p, pre.t, opening[k_pre]))
    if k_run is not None:
        print("runaway step: %d, t = %g s, opening %.4g m, %d iterations"
              % (r.steps[k_run].p, t[k_run], opening[k_run], iterations[k_run]))

    fig = plt.figure(figsize=(11.0, 10.5))
    gs = fig.add_gridspec(3, 2, height_ratios=[0.65, 1.3, 1.0], hspace=0.35, wspace=0.25,
                          top=0.93)

    # (a) the paper's view: displacements x20 just before the peel runs away.
    ax = fig.add_subplot(gs[0, :])
    draw_state(ax, r, pre, RAPPORT,
               "(a) RAPPORT = %d: deformed mesh, displacements x%d, t = %g s (step %d, %s)"
               % (RAPPORT, RAPPORT, pre.t, pre.p,
                  "the last before the runaway" if k_pre + 1 < len(r.steps) else "the last step"))

    # (b) the end of the computation at true scale.
    ax = fig.add_subplot(gs[1, 0])
    draw_state(ax, r, last, 1.0, "(b) t = %g s (step %d), true scale (x1)" % (last.t, last.p))

    # (c) beta along the contact surface.
    ax = fig.add_subplot(gs[1, 1])
    shown = list(range(k_pre + 1))
    if len(shown) > 10:  # no runaway: ten steps spread over the run, early ones denser
        shown = sorted(set(np.unique(np.geomspace(1, k_pre + 1, 10).astype(int) - 1).tolist()))
    shown += [k_run] if k_run is not None else []
    if len(r.steps) - 1 not in shown:
        shown.append(len(r.steps) - 1)
    for j, k in enumerate(shown):
        s = r.steps[k]
        if k <= k_pre:
            kw = dict(color=style.SEQUENCE(j, len(shown)), marker="o", ms=2.5)
        elif k == k_run:
            kw = dict(color=style.CONTACT, marker="s", ms=3, lw=1.8)
        else:
            kw = dict(color="k", ls="--", marker="x", ms=3)
        ax.plot(xc, s.fields["beta"], label="t = %g s" % s.t, **kw)
    ax.set_xlim(0, xc.max() + xc.min())
    ax.set_ylim(-0.03, 1.03)
    ax.set_xlabel("x1 of the contact facet centre (m)")
    ax.set_ylabel("adhesion intensity beta")
    ax.set_title("(c) beta on the contact surface x2 = 0")
    ax.legend(loc="lower right", ncol=2)

    # (d) the largest opening and the debonding front against time; (e) the iterations. The time
    # axis is linear up to 50 s (the steps before and at the runaway) and logarithmic beyond.
    sub = gs[2, 0].subgridspec(2, 1, height_ratios=[1.6, 1.0], hspace=0.08)
    ax = fig.add_subplot(sub[0])
    opening_panel(ax, t, opening)
    ax.set_title("(d) largest opening and debonding front against time")
    time_axis(ax, t, labels=False)
    ax = fig.add_subplot(sub[1])
    ax.plot(t, np.where(np.isnan(front), -0.1, front), color=style.ACCENT, marker="s", ms=2.5,
            drawstyle="steps-mid")
    ax.set_ylim(-0.15, 1.05)
    ax.set_yticks([-0.1, 0, 0.5, 1])
    ax.set_yticklabels(["none", "0", "0.5", "1"])
    ax.set_ylabel("debonding\nfront x1 (m)")
    time_axis(ax, t)

    ax = fig.add_subplot(gs[2, 1])
    count_axis(ax, t, iterations)
    time_axis(ax, t)
    ax.set_ylabel("iterations of (4.1)-(4.4)")
    ax.set_title("(e) iterations per time step (dt = %g s)" % (t[1] - t[0] if len(t) > 1 else t[0]))

    fig.suptitle("Fig 3 [LTL87]: compressible bar [0,1] x [0,0.2] m glued on x2 = 0, "
                 "|g2| = 10 (1 - x1) kPa\nreading %s" % reading(r), fontsize=11)

    # The numbers plotted.
    rows = [k for k in range(len(r.steps)) if k <= (k_run or 0) + 2 or r.steps[k].p % 10 == 0
            or k == len(r.steps) - 1]
    lr.print_table("front and opening against time (panels d, e; steps up to the runaway + 2, "
                   "then every 10th and the last)",
                   {"p": [r.steps[k].p for k in rows], "t_s": t[rows],
                    "iterations": iterations[rows], "front_x1_m": front[rows],
                    "max_opening_m": opening[rows],
                    "beta_min": [r.steps[k].fields["beta"].min() for k in rows]})
    cols = {"x1_m": xc}
    for k in shown:
        cols["t=%gs" % r.steps[k].t] = r.steps[k].fields["beta"]
    lr.print_table("beta at the contact facet centres (panel c)", cols, fmt="%.4g")
    for k, scale, name in ((k_pre, RAPPORT, "a"), (len(r.steps) - 1, 1.0, "b")):
        u = r.steps[k].fields["u"]
        i = np.argmax(np.linalg.norm(u, axis=1))
        print("panel (%s): t = %g s, magnification x%g, largest |u| = %.4g m at X = (%.3f, %.3f)"
              % (name, r.steps[k].t, scale, np.linalg.norm(u[i]), *r.mesh.X[i]))
    style.save(fig, png)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: fig3.py RESULTS.h5 OUTPUT.png")
    main(sys.argv[1], sys.argv[2])
