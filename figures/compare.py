#!/usr/bin/python3
"""Uzawa vs Bermudez-Moreno: convergence histories and parameter sweeps.

Usage: /usr/bin/python3 figures/compare.py RESULTS_DIR OUTPUT.pdf   (`make compare`)

Reads only the HDF5 files written by build/experiments/compare (one per problem and variant):
one page per problem with the merit r_G + r_B against iteration and against wall time
(histories of all time steps concatenated; an accelerated run as its running minimum over its
faint raw curve, which oscillates), the stopping tolerance as a dashed line, a run that did not
converge dotted and ended by an X; then the sweeps of R and rho, the runs that did not converge
marked x on the top edge; prints the table of iterations and time to tolerance that the pages
show.
"""
import glob
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.backends.backend_pdf import PdfPages  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ltl_results  # noqa: E402


def concatenated_history(res):
    """Histories of every step, end to end: iteration index, wall time, r_G, r_B."""
    n, t, rg, rb, starts = [], [], [], [], []
    it0, t0 = 0, 0.0
    for step in res.steps:
        h = step.history
        if len(h["n"]) == 0:
            continue
        starts.append(it0)
        n.append(it0 + h["n"])
        t.append(t0 + h["wall"])
        rg.append(h["r_G"])
        rb.append(h["r_B"])
        it0 += int(h["n"][-1])
        t0 += float(h["wall"][-1])
    if not n:
        return None
    return dict(n=np.concatenate(n), t=np.concatenate(t), r_G=np.concatenate(rg),
                r_B=np.concatenate(rb), starts=starts, iterations=it0, seconds=t0)


def split_name(stem):
    """<problem>-<variant> of a file written by build/experiments/compare: the problem is the
    first word, or the first two for a sweep ("sweep-fig5-uzawa-R10" -> "sweep-fig5",
    "uzawa-R10"; "fig3-uzawa-2sweeps" -> "fig3", "uzawa-2sweeps")."""
    words = stem.split("-")
    k = 2 if words[0] == "sweep" and len(words) > 2 else 1
    return "-".join(words[:k]), "-".join(words[k:])


def accelerated(variant):
    return "anderson" in variant


def converged(res):
    """Whether the run finished: status "complete" (a failed one says "diverged ..." or
    "inadmissible ...")."""
    return str(res.attrs.get("status", "")).startswith("complete")


def failure(res):
    return str(res.attrs.get("status", "")).split(":")[0]


def tolerance(res):
    """algorithm.tol of the run (its resolved configuration), or None in older files."""
    c = ltl_results.resolved_config(res)
    return c.get("algorithm", {}).get("tol") if c else None


def sweep_panel(ax, points, marker, label, log, color=None):
    """Iterations against a parameter; the runs that did not converge as x on the top edge."""
    good = sorted((x, h["iterations"]) for x, (res, h) in points.items() if h and converged(res))
    bad = sorted(x for x, (res, h) in points.items() if not (h and converged(res)))
    line = None
    if good:
        xs, its = zip(*good)
        line, = (ax.loglog if log else ax.plot)(xs, its, marker=marker, label=label, color=color)
    if bad:
        c = line.get_color() if line else color
        ax.plot(bad, [1.0] * len(bad), "x", ms=9, mew=2, color=c,
                transform=ax.get_xaxis_transform(), clip_on=False,
                label=f"{label}: did not converge ({', '.join('%g' % b for b in bad)})")


def main(directory, output):
    runs = {}
    for path in sorted(glob.glob(os.path.join(directory, "*.h5"))):
        problem, variant = split_name(os.path.basename(path)[:-3])
        res = ltl_results.load(path)
        runs.setdefault(problem, {})[variant] = (res, concatenated_history(res))

    # The table: columns as wide as their longest entry; the status (free text) last.
    rows = []
    for problem, variants in runs.items():
        for variant, (res, h) in variants.items():
            rows.append((problem, variant, "%d" % len(res.steps),
                         "%d" % (h["iterations"] if h else 0),
                         "%.3f" % (h["seconds"] if h else 0.0),
                         str(res.attrs.get("status", "")).split(";")[0]))
    header = ("problem", "variant", "steps", "iterations", "time [s]", "status")
    width = [max([len(header[j])] + [len(r[j]) for r in rows]) for j in range(5)]
    line = lambda r: "  ".join([r[0].ljust(width[0]), r[1].ljust(width[1])] +
                               [r[j].rjust(width[j]) for j in (2, 3, 4)] + [r[5]])
    print(line(header))
    for r in rows:
        print(line(r))

    with PdfPages(output) as pdf:
        for problem in sorted(p for p in runs if not p.startswith("sweep")):
            fig, axes = plt.subplots(1, 2, figsize=(11, 4.6))
            variants = sorted(runs[problem].items(), key=lambda kv: accelerated(kv[0]))
            tol = None
            for k, (variant, (res, h)) in enumerate(variants):
                if h is None:
                    continue
                tol = tol or tolerance(res)
                c = f"C{k}"
                merit = h["r_G"] + h["r_B"]
                label = variant if converged(res) else f"{variant} (FAILED: {failure(res)})"
                for ax, x in zip(axes, (h["n"], h["t"])):
                    if accelerated(variant):
                        # Accelerated iterations oscillate from one iteration to the next: the
                        # raw merit faint and behind, its running minimum as the curve.
                        ax.semilogy(x, merit, color=c, lw=0.4, alpha=0.25, zorder=1)
                        ax.semilogy(x, np.minimum.accumulate(merit), color=c, lw=1.3, zorder=3,
                                    ls="-" if converged(res) else ":",
                                    label=label + " (running min; raw faint)")
                    else:
                        ax.semilogy(x, merit, color=c, lw=1.0, zorder=2,
                                    ls="-" if converged(res) else ":", label=label)
                    if not converged(res):
                        ax.plot(x[-1], merit[-1], "X", color=c, ms=8, zorder=4)
            for ax in axes:
                if tol:
                    ax.axhline(tol, color="k", lw=0.8, ls="--", zorder=5)
                    ax.text(ax.get_xlim()[1], tol, " tol = %g" % tol, va="bottom", ha="right",
                            fontsize=7)
                ax.set_ylabel("r_G + r_B (scaled residuals, (3.3))")
                ax.grid(True, which="both", alpha=0.3)
            axes[0].set_xlabel("iteration (all time steps end to end)")
            axes[1].set_xlabel("wall time [s]")
            axes[0].legend(fontsize=7)
            fig.suptitle(f"{problem}: Uzawa (4.3) vs Bermudez-Moreno (7.7)-(7.10), plain and "
                         "Anderson; X: a run that did not converge")
            fig.tight_layout()
            pdf.savefig(fig)
            plt.close(fig)

        for problem in sorted(p for p in runs if p.startswith("sweep")):
            rho_runs = {v: rh for v, rh in runs[problem].items()
                        if v.startswith("bermudez-moreno-rho")}
            fig, axes = plt.subplots(1, 2 if rho_runs else 1, figsize=(11 if rho_runs else 7.5, 4.2),
                                     squeeze=False)
            axes = axes[0]
            for variant_prefix, marker in (("uzawa-R", "o"), ("bermudez-moreno-R", "s")):
                sweep_panel(axes[0], {float(v[len(variant_prefix):]): rh
                                      for v, rh in runs[problem].items()
                                      if v.startswith(variant_prefix)},
                            marker, variant_prefix[:-2], log=True)
            axes[0].set_xlabel("R")
            axes[0].set_ylabel("iterations to tolerance (all steps)")
            axes[0].legend(fontsize=7)
            if rho_runs:
                sweep_panel(axes[1], {float(v[len("bermudez-moreno-rho"):]): rh
                                      for v, rh in rho_runs.items()}, "s", "bermudez-moreno",
                            log=False, color="C1")
                axes[1].set_xlabel("rho (Bermudez-Moreno)")
                axes[1].set_ylabel("iterations to tolerance")
                axes[1].legend(fontsize=7)
            for ax in axes:
                ax.grid(True, which="both", alpha=0.3)
            fig.suptitle(f"{problem}: iterations against R" + (" and rho" if rho_runs else "") +
                         "\n(x on the top edge: the run did not converge)")
            fig.tight_layout()
            pdf.savefig(fig)
            plt.close(fig)
    print(f"wrote {output}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
