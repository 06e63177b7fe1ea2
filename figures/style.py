"""The shared look of the figures (matplotlib, Agg backend: no display needed).

    import style                       # before pyplot: selects Agg and sets the rc parameters
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=style.FULL)
    style.draw_p2_mesh(ax, x, cells)   # edges of six-node triangles, curved through mid-edge nodes
    style.save(fig, "results/fig3.png")

Colours: REFERENCE for the undeformed body, BODY for the deformed one, SUPPORT for rigid planes,
CONTACT for contact quantities, and SEQUENCE(k, n) for the k-th of n curves of a time series.
"""

import os

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402

FULL = (11.0, 8.5)      # inches: a page-wide figure of several panels
WIDE = (11.0, 4.5)      # inches: one row of panels
DPI = 150

REFERENCE = "0.7"       # grey
BODY = "#1f4e79"        # dark blue
SUPPORT = "0.25"
CONTACT = "#c0392b"     # red
ACCENT = "#e67e22"      # orange

plt.rcParams.update({
    "font.size": 9,
    "axes.titlesize": 10,
    "axes.labelsize": 9,
    "legend.fontsize": 8,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "figure.dpi": DPI,
    "savefig.dpi": DPI,
    "lines.linewidth": 1.2,
})


def SEQUENCE(k, n, cmap="viridis"):
    """Colour of the k-th curve (0-based) of n in a time series, from early (dark) to late."""
    return plt.get_cmap(cmap)(0.9 * k / max(n - 1, 1))


# Six-node triangle (gmsh order): vertices 0, 1, 2; mid-edge nodes 3 (0-1), 4 (1-2), 5 (2-0).
_P2_EDGES = ((0, 1, 3), (1, 2, 4), (2, 0, 5))


def p2_edge_curves(x, cells, samples=6):
    """The edges of six-node triangles as polylines (#edges, samples, 2) through the deformed
    nodes x (#nodes, 2): each edge is the quadratic through its two vertices and its mid-edge
    node, so curved edges show. Edges shared by two cells are drawn once."""
    seen = {}
    for c in cells:
        for a, b, m in _P2_EDGES:
            key = (min(c[a], c[b]), max(c[a], c[b]))
            if key not in seen:
                seen[key] = (c[a], c[b], c[m])
    s = np.linspace(0.0, 1.0, samples)[:, None]
    # Quadratic Lagrange basis on [0, 1] with nodes 0, 1/2, 1.
    la, lm, lb = (1 - s) * (1 - 2 * s), 4 * s * (1 - s), s * (2 * s - 1)
    return np.array([la * x[a] + lm * x[m] + lb * x[b] for a, b, m in seen.values()])


def draw_p2_mesh(ax, x, cells, color=BODY, lw=0.6, **kw):
    """Draws the cell edges of a P2 triangle mesh at positions x (#nodes, 2)."""
    lc = LineCollection(p2_edge_curves(x, cells), colors=color, linewidths=lw, **kw)
    ax.add_collection(lc)
    return lc


def p2_boundary_outline(x, cells, samples=6):
    """Polylines of the boundary edges only (edges that belong to one cell)."""
    count = {}
    for c in cells:
        for a, b, m in _P2_EDGES:
            key = (min(c[a], c[b]), max(c[a], c[b]))
            count[key] = (count.get(key, (0, None))[0] + 1, (c[a], c[b], c[m]))
    s = np.linspace(0.0, 1.0, samples)[:, None]
    la, lm, lb = (1 - s) * (1 - 2 * s), 4 * s * (1 - s), s * (2 * s - 1)
    return np.array([la * x[a] + lm * x[m] + lb * x[b]
                     for n, (a, b, m) in count.values() if n == 1])


def draw_p2_outline(ax, x, cells, color=REFERENCE, lw=0.8, ls="--", **kw):
    """Draws the boundary of a P2 triangle mesh at positions x (#nodes, 2)."""
    lc = LineCollection(p2_boundary_outline(x, cells), colors=color, linewidths=lw,
                        linestyles=ls, **kw)
    ax.add_collection(lc)
    return lc


def hatch_support(ax, x0, x1, y, below=True, color=SUPPORT, label=None):
    """A rigid support: the line y from x0 to x1 with short hatches on the obstacle side."""
    ax.plot([x0, x1], [y, y], color=color, lw=1.5, label=label, zorder=1)
    h = 0.02 * (x1 - x0)
    sign = -1 if below else 1
    for xs in np.linspace(x0, x1, 41)[:-1]:
        ax.plot([xs, xs + h], [y + sign * h, y], color=color, lw=0.6, zorder=1)


def save(fig, path):
    """Saves the figure (directory created if needed), closes it and says where it went."""
    d = os.path.dirname(path)
    if d:
        os.makedirs(d, exist_ok=True)
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)
    print("wrote %s" % path)
