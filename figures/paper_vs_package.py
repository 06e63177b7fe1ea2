"""The paper's stated cost of each figure beside ours: iterations and solver time.

    /usr/bin/python3 figures/paper_vs_package.py RESULTS_DIR results/paper_vs_package.png

Reads only results files: RESULTS_DIR/figN.h5 (`make figN`: the paper's ALG2, plain, as the
figure configurations state it) and RESULTS_DIR/paper_vs_package/figN-anderson.h5 and
figN-newton.h5 (`make paper-vs-package`: the same configuration with
algorithm.acceleration = "anderson", and with algorithm.solver = "newton", ALG2 into Newton's
method), and the paper's claims from
figures/paper_claims.toml (Fig 5: 40 iterations; Fig 6: 70 iterations, 108 min on a DPS 8;
nothing for Figs 3-4). Iterations: the sum over the time steps of each step's stored
`iterations`; time: the sum of each step's solver wall time (the last `wall` of its history).
A run that is missing or did not finish is written on the plot as such, never left out silently.
Prints the numbers it plots.
"""

import os
import sys
import tomllib

import numpy as np

import style  # noqa: F401  (Agg backend and rc parameters, before pyplot)
import matplotlib.pyplot as plt  # noqa: E402

import ltl_results as lr  # noqa: E402

FIGURES = ("fig3", "fig4", "fig5", "fig6")
OURS = (("plain", "ALG2 (plain)", style.BODY), ("anderson", "ALG2 + Anderson", style.ACCENT),
        ("newton", "ALG2 then Newton", style.CONTACT))


def cost(path):
    """(iterations, solver seconds, status) of a results file; None when it does not exist."""
    if not os.path.exists(path):
        return None
    r = lr.load(path, fields=[])
    its = sum(s.iterations for s in r.steps)
    secs = sum(float(s.history["wall"][-1]) for s in r.steps if len(s.history.get("wall", ())))
    return its, secs, str(r.attrs.get("status", ""))


def main(results, png):
    here = os.path.dirname(os.path.abspath(__file__))
    with open(os.path.join(here, "paper_claims.toml"), "rb") as f:
        claims = tomllib.load(f)
    missing = [f for f in FIGURES if not os.path.exists(os.path.join(results, f + ".h5"))]
    if missing:
        sys.exit("paper_vs_package.py: %s missing in %s: run `make figures` first"
                 % (", ".join(m + ".h5" for m in missing), results))
    rows = {}
    for fig in FIGURES:
        rows[fig] = {"plain": cost(os.path.join(results, fig + ".h5"))}
        for v in ("anderson", "newton"):
            rows[fig][v] = cost(os.path.join(results, "paper_vs_package", "%s-%s.h5" % (fig, v)))

    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.8))
    x = np.arange(len(FIGURES))
    width = 0.2
    for a, (ax, what) in enumerate(zip(axes, ("iterations", "seconds"))):
        # The paper first, then ours.
        for j, (key, label, colour) in enumerate([("paper", "paper [LTL87]", "0.55")] + list(OURS)):
            for i, f in enumerate(FIGURES):
                xi = x[i] + (j - 1.5) * width
                if key == "paper":
                    c = claims.get(f, {})
                    v = c.get("iterations") if a == 0 else (
                        60 * c["cpu_minutes"] if "cpu_minutes" in c else None)
                    note = "not stated" if v is None else ""
                else:
                    run = rows[f][key]
                    v = None if run is None or not run[2].startswith("complete") else run[a]
                    note = ("not run" if run is None else
                            "did not finish" if v is None else "")
                if v is None:
                    ax.text(xi, 0.02, note, rotation=90, ha="center", va="bottom", fontsize=6,
                            color=colour if key != "paper" else "0.3",
                            transform=ax.get_xaxis_transform())
                    continue
                ax.bar(xi, v, width, color=colour)
                ax.text(xi, v * 1.08, "%.3g" % v if a else "%d" % v, ha="center",
                        va="bottom", fontsize=6, rotation=90)
            ax.bar(np.nan, np.nan, color=colour, label=label)  # one legend entry per series
        ax.set_yscale("log")
        ax.set_xticks(x)
        ax.set_xticklabels(["Fig %s" % f[3:] for f in FIGURES])
        ax.set_ylabel("iterations (all time steps)" if a == 0 else
                      "seconds (paper: CPU, DPS 8; ours: solver wall time)")
        ax.set_title("(%s) %s" % ("ab"[a], "iterations" if a == 0 else "time"))
        ax.legend(fontsize=7, loc="upper left")
    for ax, bottom in zip(axes, (1, 1e-3)):  # room above the bars for their values
        ax.set_ylim(bottom, ax.get_ylim()[1] * 30)
    fig.suptitle("The paper's stated cost beside this package's, per figure (Figs 3-4: reading "
                 "R3, 160 steps; Figs 5-6: one step)")
    fig.tight_layout()

    table = {"figure": [f for f in FIGURES],
             "paper_it": [claims.get(f, {}).get("iterations", np.nan) for f in FIGURES],
             "paper_s": [60 * claims[f]["cpu_minutes"] if "cpu_minutes" in claims.get(f, {})
                         else np.nan for f in FIGURES]}
    for key, _, _ in OURS:
        table[key + "_it"] = [rows[f][key][0] if rows[f][key] else np.nan for f in FIGURES]
        table[key + "_s"] = [rows[f][key][1] if rows[f][key] else np.nan for f in FIGURES]
    table["figure"] = np.array([float(f[3:]) for f in FIGURES])
    lr.print_table("paper vs package: iterations and seconds (NaN: not stated / not run)", table,
                   fmt="%.4g")
    style.save(fig, png)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: paper_vs_package.py RESULTS_DIR OUTPUT.png")
    main(sys.argv[1], sys.argv[2])
