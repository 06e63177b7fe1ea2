#!/usr/bin/python3
"""Uzawa vs Bermudez-Moreno: convergence histories and parameter sweeps.

Usage: /usr/bin/python3 figures/compare.py RESULTS_DIR OUTPUT.pdf   (`make compare`)

Reads only the HDF5 files written by build/experiments/compare (one per problem and variant):
one page per problem with both residual parts against iteration and against wall time
(histories of all time steps concatenated), then the sweeps of R and rho; prints the table of
iterations and time to tolerance that the pages show.
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
            fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
            for k, (variant, (res, h)) in enumerate(sorted(runs[problem].items())):
                if h is None:
                    continue
                c = f"C{k}"
                for ax, x in zip(axes, (h["n"], h["t"])):
                    ax.semilogy(x, h["r_G"], color=c, lw=0.8, label=f"{variant}: r_G")
                    ax.semilogy(x, h["r_B"], color=c, lw=0.8, ls="--", label=f"{variant}: r_B")
            axes[0].set_xlabel("iteration (all time steps end to end)")
            axes[1].set_xlabel("wall time [s]")
            for ax in axes:
                ax.set_ylabel("scaled residual")
                ax.grid(True, which="both", alpha=0.3)
            axes[0].legend(fontsize=7)
            fig.suptitle(f"{problem}: Uzawa (4.3) vs Bermudez-Moreno (7.7)-(7.10)")
            fig.tight_layout()
            pdf.savefig(fig)
            plt.close(fig)

        for problem in sorted(p for p in runs if p.startswith("sweep")):
            fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
            for variant_prefix, marker in (("uzawa-R", "o"), ("bermudez-moreno-R", "s")):
                pts = sorted((float(v[len(variant_prefix):]), h["iterations"] if h else np.nan)
                             for v, (res, h) in runs[problem].items() if v.startswith(variant_prefix))
                if pts:
                    R, it = zip(*pts)
                    axes[0].loglog(R, it, marker=marker, label=variant_prefix[:-2])
            axes[0].set_xlabel("R")
            axes[0].set_ylabel("iterations to tolerance (all steps)")
            axes[0].legend()
            pts = sorted((float(v[len("bermudez-moreno-rho"):]), h["iterations"] if h else np.nan)
                         for v, (res, h) in runs[problem].items()
                         if v.startswith("bermudez-moreno-rho"))
            if pts:
                rho, it = zip(*pts)
                axes[1].plot(rho, it, marker="s", color="C1")
                axes[1].set_xlabel("rho (Bermudez-Moreno)")
                axes[1].set_ylabel("iterations to tolerance")
            else:
                axes[1].set_visible(False)
            for ax in axes:
                ax.grid(True, which="both", alpha=0.3)
            fig.suptitle(f"{problem}: how the speed depends on R and rho (missing = no convergence)")
            fig.tight_layout()
            pdf.savefig(fig)
            plt.close(fig)
    print(f"wrote {output}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
