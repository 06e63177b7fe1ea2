#!/usr/bin/python3
"""Freezes the dolfinx peer's converged values as reference data for `make test`.

    /usr/bin/python3 experiments/peer/make_reference.py results/verify tests/reference/peer.toml [fig5] [fig6]

Reads results/verify/fig5_peer.json, fig6_peer.json and fig6_peer_q1p0.json (written by
`make verify` / `make verify-fig6`, i.e. by experiments/peer/peer.py) and writes, per figure and
observable, the value on the peer's finest mesh and, as its tolerance, the change between its
two finest meshes (the peer's own discretization error). With figure names, only those sections
are (re)written and every other section of the existing file is kept as it is; without, every
figure whose JSON exists. tests/test_peer.cpp compares the package's refined answers with them;
CI never needs dolfinx.

[fig6] is the Q2/Q1 Taylor-Hood peer (fig6_peer.json) or, without it, the Q1/P0 peer's finest
mesh (the element is named in the section's comment); [fig6_q1p0] lists, per level, the values
of the Q1/P0 mean-dilatation peer on the package's own H8 geometry: the same discrete problem as
the package's H8 with mean-det incompressibility and nodal contact, so the package should meet
them at the same level to its stopping tolerance.
"""
import json
import os
import re
import sys

KEYS = {"fig5": ["drop", "a_moment", "a_edge", "p_max"],
        "fig6": ["sag", "force_ratio", "contact_force", "contact_area_nodal"]}
SOURCES = {"fig5": "fig5_peer.json", "fig6": "fig6_peer.json", "fig6_q1p0": "fig6_peer_q1p0.json"}
HEADER = ["# Converged values of the independent dolfinx peer (experiments/peer/peer.py: Taylor-Hood",
          "# P2/P1 or Q2/Q1, or Q1/P0 where a section says so, full Newton, penalty contact at the",
          "# contact nodes) on its finest mesh;",
          "# tol = |finest - second finest|, the peer's own discretization error.",
          "# Regenerate: make verify && make peer-reference (needs python3-dolfinx; review the diff);",
          "# one figure only: make peer-reference PEER_FIGS=fig6 (the other sections are kept).",
          ""]


def read_sections(path):
    """{section name: its lines (header line included)} of an existing reference file."""
    sections, name = {}, None
    if not os.path.exists(path):
        return sections
    with open(path) as fh:
        for line in fh.read().splitlines():
            m = re.match(r"^\[([A-Za-z0-9_]+)\]\s*$", line)
            if m:
                name = m.group(1)
                sections[name] = [line]
            elif name is not None:
                sections[name].append(line)
    for lines in sections.values():
        while lines and not lines[-1].strip():
            lines.pop()
    return sections


def load_runs(path):
    """(data, runs sorted by level); data["command"]: the peer command(s) that wrote the runs."""
    with open(path) as fh:
        data = json.load(fh)
    runs = sorted(data["runs"], key=lambda r: r["level"])
    cmds = []
    for r in runs:
        if r.get("command") and r["command"] not in cmds:
            cmds.append(r["command"])
    if cmds:
        data["command"] = " && ".join(cmds)
    return data, runs


def section_finest(fig, path):
    data, runs = load_runs(path)
    if len(runs) < 2:
        sys.exit(f"{path}: needs at least two mesh levels")
    a, b = runs[-2], runs[-1]
    lines = [f"[{fig}]"]
    if "command" in data:
        lines.append(f"# {data['command']}")
        lines.append(f"# then: make peer-reference PEER_FIGS={fig}")
    if fig == "fig6":
        lines.append(f"# element {b.get('element')}, geometry order {b.get('geom_order')}, levels "
                     + ", ".join(f"{r['level']} ({r['cells']} cells)" for r in runs)
                     + f"; penalty {b['observables']['penalty']:.0e} Pa/m")
    lines.append(f'levels = [{a["level"]}, {b["level"]}]')
    for k in KEYS[fig]:
        v, w = b["observables"][k], a["observables"][k]
        lines.append(f'"{k}" = {{ value = {v:.12g}, tol = {max(abs(v - w), 1e-12 * abs(v)):.3g} }}')
    return lines


def section_levels(fig, path):
    data, runs = load_runs(path)
    lines = [f"[{fig}]",
             "# Q1/P0 mean dilatation (per cell int (det F - 1) q = 0, 2x2x2 Gauss), nodal penalty",
             "# contact at the H8 vertices, the package's trilinear geometry: the package's H8",
             "# discrete problem with mean-det incompressibility, per level (no tolerance: the",
             "# package should meet each value to its stopping tolerance at the same level)."]
    if "command" in data:
        lines.append(f"# {data['command']}")
        lines.append("# then: make peer-reference PEER_FIGS=fig6")
    lines.append(f"levels = [{', '.join(str(r['level']) for r in runs)}]")
    lines.append(f"cells = [{', '.join(str(r['cells']) for r in runs)}]")
    for k in KEYS["fig6"]:
        vals = ", ".join(f"{r['observables'][k]:.12g}" for r in runs)
        lines.append(f'"{k}" = [{vals}]')
    return lines


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    src, dst, only = sys.argv[1], sys.argv[2], sys.argv[3:]
    for f in only:
        if f not in ("fig5", "fig6"):
            sys.exit(f"make_reference.py: unknown figure '{f}' (fig5 or fig6)")
    sections = read_sections(dst)
    wanted = [s for s in SOURCES if not only or s.split("_")[0] in only]
    for sec in wanted:
        path = os.path.join(src, SOURCES[sec])
        if sec == "fig6" and not os.path.exists(path):  # no Q2/Q1 run: the Q1/P0 peer's finest
            path = os.path.join(src, SOURCES["fig6_q1p0"])
        if not os.path.exists(path):
            msg = f"{path}: missing, [{sec}] " + ("kept as it was" if sec in sections else "not written")
            if only:
                sys.exit(msg + " (run make verify / verify-fig6 first)")
            print(msg)
            continue
        sections[sec] = section_levels(sec, path) if sec == "fig6_q1p0" else section_finest(sec, path)
    order = [s for s in SOURCES if s in sections] + [s for s in sections if s not in SOURCES]
    lines = list(HEADER)
    for sec in order:
        lines += sections[sec] + [""]
    with open(dst, "w") as fh:
        fh.write("\n".join(lines))
    print(f"wrote {dst} ({', '.join(order)})")


if __name__ == "__main__":
    main()
