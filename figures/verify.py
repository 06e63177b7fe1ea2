"""make verify: the package against the independent Newton solver under mesh refinement.

    /usr/bin/python3 figures/verify.py results/verify results/verify.png

Reads, from the directory given, the JSON rows written by
  build/experiments/refinement figN ... json=results/verify/figN_ltl.json     (this package)
  experiments/peer/peer.py figN ... --out results/verify/figN_peer.json      (dolfinx peer)
and draws, for Fig 5 (drop of the top, contact half-width, peak contact pressure, penetration)
and Fig 6 (sag, contact force / load, peak pressure, penetration), the value against the mesh
size h for both codes, and the error |v_h - v_peer| against h with the fitted order (least
squares slope of log error against log h), v_peer the peer's value on its finest mesh. Prints
the same numbers as a table. Nothing is typed in: every number comes from the JSON files.
"""
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import style  # noqa: E402  (selects the Agg backend)
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import NullFormatter  # noqa: E402

# observable -> (label, key in the package's rows, key in the peer's observables)
OBSERVABLES = {
    "fig5": [("drop of the top (m)", "drop", "drop"),
             ("contact half-width a_moment (m)", "a_moment", "a_moment"),
             ("peak contact pressure (Pa)", "p_max", "p_max"),
             ("penetration (m)", "penetration", "penetration")],
    "fig6": [("sag (m)", "drop", "sag"),
             ("contact force / load", "force_ratio", "force_ratio"),
             ("peak contact pressure (Pa)", "p_max", "p_max"),
             ("penetration (m)", "penetration", "penetration")],
}
# mesh size of a level: fig5, the edge length (pi/2) Rc / K; fig6, the arc edge (pi/2) Ri / (9 L)
H = {"fig5": lambda level: (math.pi / 2) / level, "fig6": lambda level: (math.pi / 2) / (9 * level)}


def load(path):
    with open(path) as fh:
        return json.load(fh)


def fitted_order(h, err):
    """Least-squares slope of log(err) against log(h) (None with fewer than two points)."""
    pts = [(math.log(a), math.log(b)) for a, b in zip(h, err) if b > 0]
    if len(pts) < 2:
        return None
    x, y = np.array(pts).T
    return float(np.polyfit(x, y, 1)[0])


def series(figure, ltl, peer):
    """Per observable: (label, h_ltl, v_ltl, h_peer, v_peer, reference, order)."""
    out = []
    ours = [r for r in ltl["runs"] if r["converged"]]
    theirs = sorted(peer["runs"], key=lambda r: r["level"])
    for label, k_ltl, k_peer in OBSERVABLES[figure]:
        hl = [H[figure](r["level"]) for r in ours]
        vl = [r[k_ltl] for r in ours]
        hp = [H[figure](r["level"]) for r in theirs if k_peer in r["observables"]]
        vp = [r["observables"][k_peer] for r in theirs if k_peer in r["observables"]]
        ref = vp[-1] if vp else None
        order = None
        if ref is not None and "penetration" not in k_ltl:
            order = fitted_order(hl, [abs(v - ref) for v in vl])
        out.append((label, hl, vl, hp, vp, ref, order))
    return out


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    d, png = sys.argv[1], sys.argv[2]
    figures = [f for f in ("fig5", "fig6")
               if os.path.exists(os.path.join(d, f + "_ltl.json"))
               and os.path.exists(os.path.join(d, f + "_peer.json"))]
    if not figures:
        sys.exit(f"{d}: no pair figN_ltl.json / figN_peer.json (run make verify)")
    fig, axes = plt.subplots(2 * len(figures), 4, figsize=(style.FULL[0], 4.2 * len(figures)),
                             squeeze=False)
    for i, figure in enumerate(figures):
        ltl = load(os.path.join(d, figure + "_ltl.json"))
        peer = load(os.path.join(d, figure + "_peer.json"))
        print(f"{figure}: this package (ALG2) against the dolfinx Newton peer")
        for j, (label, hl, vl, hp, vp, ref, order) in enumerate(series(figure, ltl, peer)):
            print(f"  {label}")
            print("    h        " + "  ".join(f"{h:10.4g}" for h in hl) + "   (package)")
            print("    value    " + "  ".join(f"{v:10.6g}" for v in vl))
            print("    h        " + "  ".join(f"{h:10.4g}" for h in hp) + "   (peer)")
            print("    value    " + "  ".join(f"{v:10.6g}" for v in vp))
            if order is not None:
                print(f"    fitted order of |package - peer finest| = {order:.2f}")
            ax = axes[2 * i, j]
            ax.semilogx(hl, vl, "o-", color=style.BODY, label="package (ALG2)")
            ax.semilogx(hp, vp, "s--", color=style.CONTACT, label="peer (dolfinx Newton)")
            ax.set_title(f"{figure}: {label}")
            ax.set_xlabel("h (m)")
            ax.invert_xaxis()
            if j == 0:
                ax.legend()
            ax = axes[2 * i + 1, j]
            if "penetration" in label:
                ax.loglog(hl, [max(v, 1e-16) for v in vl], "o-", color=style.BODY)
                ax.loglog(hp, [max(v, 1e-16) for v in vp], "s--", color=style.CONTACT)
                ax.set_title(f"{figure}: penetration (m)")
            elif ref is not None:
                err = [abs(v - ref) for v in vl]
                ax.loglog(hl, [max(e, 1e-16) for e in err], "o-", color=style.BODY,
                          label=f"package, order {order:.2f}" if order is not None else "package")
                errp = [abs(v - ref) for v in vp[:-1]]
                if errp:
                    ax.loglog(hp[:-1], [max(e, 1e-16) for e in errp], "s--", color=style.CONTACT,
                              label="peer")
                ax.set_title(f"{figure}: |v_h - v_peer,finest|")
                ax.legend()
            ax.set_xlabel("h (m)")
    for ax in axes.flat:  # no minor tick labels on the log axes (they overlap)
        ax.xaxis.set_minor_formatter(NullFormatter())
    fig.tight_layout()
    style.save(fig, png)


if __name__ == "__main__":
    main()
