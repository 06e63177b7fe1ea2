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
             ("contact area, nodal (m^2)", "contact_area", "contact_area_nodal"),
             ("peak nodal contact pressure (Pa)", "p_max", "p_max_vertex")],
}
# Fig 6 has a second peer: Q1/P0 (mean dilatation) on the package's own H8 geometry, i.e. the
# same discrete problem as the package's H8 with mean-det incompressibility; the reference
# (fig6_peer.json) is the Q2/Q1 Taylor-Hood peer.
SECOND_PEER = {"fig6": ("fig6_peer_q1p0.json", "peer Q1/P0 (same H8 problem)")}
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


def series(figure, ltl, peer, peer2=None):
    """Per observable: (label, h_ltl, v_ltl, h_peer, v_peer, reference, order, second) with
    second = (h, v, order) of the second peer (or None)."""
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
        second = None
        if peer2 is not None:
            r2 = sorted(peer2["runs"], key=lambda r: r["level"])
            h2 = [H[figure](r["level"]) for r in r2 if k_peer in r["observables"]]
            v2 = [r["observables"][k_peer] for r in r2 if k_peer in r["observables"]]
            o2 = fitted_order(h2, [abs(v - ref) for v in v2]) if ref is not None and v2 else None
            second = (h2, v2, o2)
        out.append((label, hl, vl, hp, vp, ref, order, second))
    return out


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    d, png = sys.argv[1], sys.argv[2]
    def peer_file(f):
        """figN_peer.json, or for Fig 6 without a Q2/Q1 run the Q1/P0 peer alone."""
        p = os.path.join(d, f + "_peer.json")
        if not os.path.exists(p) and f in SECOND_PEER:
            p = os.path.join(d, SECOND_PEER[f][0])
        return p

    figures = [f for f in ("fig5", "fig6")
               if os.path.exists(os.path.join(d, f + "_ltl.json")) and os.path.exists(peer_file(f))]
    if not figures:
        sys.exit(f"{d}: no pair figN_ltl.json / figN_peer.json (run make verify)")
    fig, axes = plt.subplots(2 * len(figures), 4, figsize=(style.FULL[0], 4.2 * len(figures)),
                             squeeze=False)
    for i, figure in enumerate(figures):
        ltl = load(os.path.join(d, figure + "_ltl.json"))
        peer = load(peer_file(figure))
        peer2, label2 = None, None
        if figure in SECOND_PEER and os.path.exists(os.path.join(d, figure + "_peer.json")) \
                and os.path.exists(os.path.join(d, SECOND_PEER[figure][0])):
            peer2 = load(os.path.join(d, SECOND_PEER[figure][0]))
            label2 = SECOND_PEER[figure][1]
        print(f"{figure}: this package (ALG2) against the dolfinx Newton peer")
        for j, (label, hl, vl, hp, vp, ref, order, second) in enumerate(series(figure, ltl, peer, peer2)):
            print(f"  {label}")
            print("    h        " + "  ".join(f"{h:10.4g}" for h in hl) + "   (package)")
            print("    value    " + "  ".join(f"{v:10.6g}" for v in vl))
            print("    h        " + "  ".join(f"{h:10.4g}" for h in hp) + "   (peer)")
            print("    value    " + "  ".join(f"{v:10.6g}" for v in vp))
            if second is not None:
                print("    h        " + "  ".join(f"{h:10.4g}" for h in second[0]) + f"   ({label2})")
                print("    value    " + "  ".join(f"{v:10.6g}" for v in second[1]))
                if second[2] is not None:
                    print(f"    fitted order of |{label2} - peer finest| = {second[2]:.2f}")
            if order is not None:
                print(f"    fitted order of |package - peer finest| = {order:.2f}")
            ax = axes[2 * i, j]
            ax.semilogx(hl, vl, "o-", color=style.BODY, label="package (ALG2)")
            elem = peer["runs"][0].get("element", "taylor-hood") if peer["runs"] else "taylor-hood"
            name = {"taylor-hood": "Taylor-Hood", "q1p0": "Q1/P0"}.get(elem, elem)
            ax.semilogx(hp, vp, "s--", color=style.CONTACT, label=f"peer {name} (dolfinx Newton)")
            if second is not None:
                ax.semilogx(second[0], second[1], "^:", color="0.4", label=label2)
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
                if second is not None and second[1]:
                    ax.loglog(second[0], [max(abs(v - ref), 1e-16) for v in second[1]], "^:",
                              color="0.4", label=label2 + (f", order {second[2]:.2f}"
                                                          if second[2] is not None else ""))
                ax.set_title(f"{figure}: |v_h - v_peer,finest|")
                ax.legend()
            ax.set_xlabel("h (m)")
    for ax in axes.flat:  # no minor tick labels on the log axes (they overlap)
        ax.xaxis.set_minor_formatter(NullFormatter())
    fig.tight_layout()
    style.save(fig, png)


if __name__ == "__main__":
    main()
