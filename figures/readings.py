"""The readings study of Figs 3 and 4 (experiments/readings/run_readings.py): one page with the
table of every run and the plots of beta at the first facet and of the debonding front.

    /usr/bin/python3 figures/readings.py results/readings results/readings.pdf   # + .png, .md
    /usr/bin/python3 figures/readings.py results/readings --table-only           # the table only

Reads only the HDF5 files of the directory (each with the study_* root attributes of the
driver); no number is typed in. Per run:
  outcome   "stable to T s" (status complete), or "runaway at t_k" when the iteration cap was
            reached at step k (the file keeps steps 1..k-1; status "diverged at step k (t = ...)")
  beta1     beta on the facet nearest x1 = 0 (the free end under the largest load, g2 = 10 kPa)
  front     the debonding front (the stored measure "front" of lib/measures.hpp: the largest
            facet-centre x1 whose glue is broken; "-" when no facet has debonded)
  umax      max|u|, the largest nodal displacement (m; the stored measure "max_displacement")
  at t = 30, 100, 800 s; "." when the step is not stored (the run ran away before)
  iterations  the sum over the stored steps ("+cap" when the next step reached the cap)
  x RAPPORT   max|u| at the last stored step times the caption's magnification (20 for Fig 3,
            50 for Fig 4), divided by the bar's thickness H: about 1 or less is a drawing like
            the captions' (a visibly deformed bar); 100 means the drawn bar would leave the page
"""

import argparse
import glob
import os
import re
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ltl_results as lr  # noqa: E402

RAPPORT = {"fig3": 20, "fig4": 50}
TIMES = (30.0, 100.0, 800.0)
DIVERGED = re.compile(r"diverged at step (\d+) \(t = ([0-9.eE+-]+) s\)")


class Run:
    """What the table and the plots need from one results file."""

    def __init__(self, path):
        self.path = path
        with h5py.File(path, "r") as f:
            self.attrs = {k: lr._value(v) for k, v in f.attrs.items()}
            has_steps = "steps" in f and "mesh" in f
        a = self.attrs
        self.case = a.get("study_case", os.path.basename(path)[:-3])
        self.bar = a.get("study_bar", a.get("name", "?"))
        self.reading = a.get("study_reading", "?")
        self.kernel = a.get("study_kernel", "?")
        self.q_c = float(a.get("study_q_c", np.nan))
        self.variant = a.get("study_variant", "")
        self.max_iter = int(a.get("study_max_iter", 0))
        self.status = a.get("status", "")
        self.t, self.beta1, self.front, self.umax, self.iters = [], [], [], [], []
        self.H = self.facets = None
        if has_steps:
            r = lr.load(path, fields=["beta"])
            cfg = lr.config(r)
            # The labels of the driver must be what the solver ran.
            kernel = cfg.get("contact", {}).get("kernel", "centre")
            if self.kernel != "?" and kernel != self.kernel:
                raise ValueError("%s: study_kernel %s but the run used %s" % (path, self.kernel,
                                                                              kernel))
            q_c = lr.quantity(cfg["algorithm"]["q_c"])
            if np.isfinite(self.q_c) and abs(q_c - self.q_c) > 1e-6 * q_c:
                raise ValueError("%s: study_q_c %g but the run used %g" % (path, self.q_c, q_c))
            X = r.mesh.X
            self.H = X[:, 1].max() - X[:, 1].min()
            xc = r.mesh.contact_centre[:, 0]
            self.facets = len(xc)
            first = int(np.argmin(xc))
            for s in r.steps:
                if "front" not in s.measures:
                    raise ValueError("%s: step %d has no stored measures (/steps/N/measures); "
                                     "re-run the study" % (path, s.p))
                self.t.append(s.t)
                self.beta1.append(s.fields["beta"][first])
                self.front.append(s.measures["front"])
                self.umax.append(s.measures["max_displacement"])
                self.iters.append(s.iterations)
        self.t = np.array(self.t)
        m = DIVERGED.search(self.status)
        self.runaway = float(m.group(2)) if m else None

    def at(self, values, t):
        k = np.flatnonzero(np.abs(self.t - t) < 1e-6)
        return values[k[0]] if k.size else None

    def outcome(self):
        if self.runaway is not None:
            return "runaway at %g s" % self.runaway
        if self.status == "complete":
            return "stable to %g s" % self.t[-1]
        return self.status or "?"


def fmt(v, f):
    if v is None:
        return "."
    if isinstance(v, float) and np.isnan(v):
        return "-"
    return f % v


COLUMNS = ["case", "bar", "reading", "kernel", "q_c", "cap", "facets", "outcome"] + \
    ["beta1 %gs" % t for t in TIMES] + ["front %gs [m]" % t for t in TIMES] + \
    ["umax %gs [m]" % t for t in TIMES] + ["iterations", "umax x RAPPORT / H (t)"]


def row(r):
    cells = [r.case, r.bar, r.reading, r.kernel, "%.0e" % r.q_c, "%d" % r.max_iter,
             "%d" % r.facets if r.facets else ".", r.outcome()]
    cells += [fmt(r.at(r.beta1, t), "%.3f") for t in TIMES]
    cells += [fmt(r.at(r.front, t), "%.3f") for t in TIMES]
    cells += [fmt(r.at(r.umax, t), "%.3g") for t in TIMES]
    cells.append("%d%s" % (sum(r.iters), "+cap" if r.runaway is not None else ""))
    if len(r.t):
        cells.append("%.3g (%g s)" % (r.umax[-1] * RAPPORT.get(r.bar, 1) / r.H, r.t[-1]))
    else:
        cells.append(".")
    return cells


def load_runs(directory):
    paths = sorted(glob.glob(os.path.join(directory, "*.h5")))
    if not paths:
        sys.exit("%s: no results files (*.h5)" % directory)
    return [Run(p) for p in paths]


def table(runs):
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for r in runs:
        lines.append("| " + " | ".join(row(r)) + " |")
    return "\n".join(lines)


READING_COLOUR = {"R1": "#c0392b", "R2": "#e67e22", "R3": "#1f4e79", "R5": "#27ae60",
                  "R7": "#8e44ad"}


def plot(runs, pdf):
    import style  # noqa: F401
    import matplotlib.pyplot as plt

    main = [r for r in runs if not r.variant]
    mesh = [r for r in runs if r.variant.startswith("nx") or
            (not r.variant and r.bar == "fig3" and r.reading in ("R1", "R3") and r.q_c < 1e8)]
    fig = plt.figure(figsize=(16.5, 23.4))
    gs = fig.add_gridspec(4, 2, height_ratios=[2.6, 1, 1, 1], hspace=0.3, wspace=0.15,
                          top=0.97, bottom=0.03, left=0.05, right=0.98)
    ax = fig.add_subplot(gs[0, :])
    ax.axis("off")
    short = ["case", "outcome"] + COLUMNS[8:]
    idx = [COLUMNS.index(c) for c in short]
    cells = [[row(r)[i] for i in idx] for r in runs]
    tb = ax.table(cellText=cells, colLabels=short, loc="upper center", cellLoc="right",
                  colLoc="right")
    tb.auto_set_font_size(False)
    tb.set_fontsize(6.5)
    tb.auto_set_column_width(list(range(len(short))))
    tb.scale(1, 1.05)
    ax.set_title("Readings of Figs 3 and 4 [LTL87 sec. 8]: which data give the captions' "
                 "millimetre displacements (Fig 3 x20, Fig 4 at 800 s x50)? case = "
                 "bar_reading_kernel_qc[_variant]. R1 fixed x1=1 pulled up (literal); R2 fixed "
                 "x1=0 pulled up;\nR3 fixed x1=1 pressed down; R5 both ends fixed pulled up; R7 "
                 "fixed x1=1, glued face pulled up. '.' = not reached (runaway before), '-' = "
                 "no debonded facet (beta < kDebondedBeta, lib/measures.hpp).", fontsize=9, loc="left")
    for j, bar in enumerate(("fig3", "fig4")):
        for i, (attr, label) in enumerate((("beta1", "beta at the first facet (x1 near 0)"),
                                           ("front", "debonding front: largest x1 of a "
                                                     "debonded facet [m]"))):
            a = fig.add_subplot(gs[1 + i, j])
            for r in main:
                if r.bar != bar or not len(r.t):
                    continue
                ls = "-" if r.kernel == "centre" else "--"
                a.plot(r.t, getattr(r, attr), ls, color=READING_COLOUR.get(r.reading, "k"),
                       lw=2.2 if r.q_c < 1e8 else 0.9, alpha=0.85 if r.q_c < 1e8 else 1,
                       label="%s %s q_c %.0e" % (r.reading, r.kernel, r.q_c))
                if r.runaway is not None:
                    a.plot([r.t[-1]], [getattr(r, attr)[-1]], "x", ms=8,
                           color=READING_COLOUR.get(r.reading, "k"))
            a.set_xscale("symlog", linthresh=50)
            a.set_xlim(0, 800)
            a.set_xlabel("t [s] (x marks the last step before a runaway)")
            a.set_title("%s: %s" % ("Fig 3 bar (H = 0.2 m)" if bar == "fig3"
                                    else "Fig 4 bar (H = 0.05 m)", label))
            if i == 0:
                a.legend(ncol=2, fontsize=6)
    for i, (attr, label) in enumerate((("beta1", "beta at the first facet"),
                                       ("front", "debonding front [m]"))):
        a = fig.add_subplot(gs[3, i])
        for r in mesh:
            if not len(r.t):
                continue
            nx = r.facets
            a.plot(r.t, getattr(r, attr), "-" if r.kernel == "centre" else "--",
                   color=READING_COLOUR.get(r.reading, "k"),
                   lw={28: 2.4, 56: 1.5, 112: 0.8}.get(nx, 1),
                   label="%s %s %d facets" % (r.reading, r.kernel, nx))
            if r.runaway is not None:
                a.plot([r.t[-1]], [getattr(r, attr)[-1]], "x", ms=8,
                       color=READING_COLOUR.get(r.reading, "k"))
        a.set_xscale("symlog", linthresh=50)
        a.set_xlim(0, 800)
        a.set_xlabel("t [s]")
        a.set_title("Mesh dependence of the kernel rules (Fig 3 bar, q_c = 3e7): " + label)
        a.legend(ncol=2, fontsize=6)
    png = os.path.splitext(pdf)[0] + ".png"
    fig.savefig(png, dpi=110)
    style.save(fig, pdf)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("directory")
    ap.add_argument("output", nargs="?", default=None, help="the page, .pdf (and .png, .md)")
    ap.add_argument("--table-only", action="store_true")
    a = ap.parse_args()
    runs = load_runs(a.directory)
    text = table(runs)
    print(text)
    if a.table_only:
        return 0
    out = a.output or os.path.join(a.directory, "readings.pdf")
    with open(os.path.splitext(out)[0] + ".md", "w") as f:
        f.write(text + "\n")
    plot(runs, out)
    print("wrote %s, %s, %s" % (out, os.path.splitext(out)[0] + ".png",
                                os.path.splitext(out)[0] + ".md"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
