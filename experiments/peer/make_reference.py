#!/usr/bin/python3
"""Freezes the dolfinx peer's converged values as reference data for `make test`.

    /usr/bin/python3 experiments/peer/make_reference.py results/verify tests/reference/peer.toml

Reads results/verify/fig5_peer.json and fig6_peer.json (written by `make verify`, i.e. by
experiments/peer/peer.py) and writes, per figure and observable, the value on the peer's finest
mesh and, as its tolerance, the change between its two finest meshes (the peer's own
discretization error). tests/test_peer.cpp compares the package's refined answers with them;
CI never needs dolfinx.
"""
import json
import os
import sys

KEYS = {"fig5": ["drop", "a_moment", "a_edge", "p_max"], "fig6": ["sag", "force_ratio", "p_max"]}


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, dst = sys.argv[1], sys.argv[2]
    lines = ["# Converged values of the independent dolfinx peer (experiments/peer/peer.py: Taylor-Hood",
             "# P2/P1 or Q2/Q1, full Newton, penalty contact at the contact nodes) on its finest mesh;",
             "# tol = |finest - second finest|, the peer's own discretization error.",
             "# Regenerate: make verify && make peer-reference (needs python3-dolfinx; review the diff).",
             ""]
    for fig, keys in KEYS.items():
        path = os.path.join(src, fig + "_peer.json")
        if not os.path.exists(path):
            print(f"{path}: missing, [{fig}] not written (run make verify first)")
            continue
        with open(path) as fh:
            runs = sorted(json.load(fh)["runs"], key=lambda r: r["level"])
        if len(runs) < 2:
            sys.exit(f"{path}: needs at least two mesh levels")
        a, b = runs[-2], runs[-1]
        lines.append(f"[{fig}]")
        lines.append(f'levels = [{a["level"]}, {b["level"]}]')
        for k in keys:
            v, w = b["observables"][k], a["observables"][k]
            lines.append(f'"{k}" = {{ value = {v:.12g}, tol = {max(abs(v - w), 1e-12 * abs(v)):.3g} }}')
        lines.append("")
    with open(dst, "w") as fh:
        fh.write("\n".join(lines))
    print(f"wrote {dst}")


if __name__ == "__main__":
    main()
