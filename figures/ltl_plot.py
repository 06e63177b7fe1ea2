"""`ltl-results plot RESULTS.h5 [-o OUT.png]`: the pictures of any run, from its results file.

    /usr/bin/python3 figures/ltl_results.py plot results/my_problem.h5   # -> results/my_problem.png

Panels (a panel whose data the run does not have is left out, never drawn empty):
  - load-displacement: with a support whose displacement is prescribed (a [[fixed]] value or a
    [[displacement]]), its reaction against its displacement, in the component where the
    displacement is largest; otherwise the load factor against the largest nodal displacement
    (measures load_factor, max_displacement), with the total reaction of the supports on a second
    axis. Files written before reactions and load factors were stored fall back to the step
    number.
  - convergence: r_G + r_B (the scaled residuals of (3.3)) over the iterations of every step, one
    after the other, with the step boundaries marked.
  - contact over time (with a contact surface): the contact pressure of each contact point
    against its reference coordinate x1, one curve per step, early (dark) to late (light); and,
    with glue, beta the same way.
Prints every number it plots (as the figure scripts do). Needs matplotlib; without it, a message
and exit status 1.
"""

import os
import sys

import numpy as np


def _support_curve(results):
    """(x, y, xlabel, ylabel, title) of the load-displacement curve."""
    steps = results.steps
    R = [s.fields.get("reactions") for s in steps]
    U = [s.fields.get("support_u") for s in steps]
    labels = steps[-1].attrs.get("conditions", "").split("; ") if steps else []
    unit_f = "N/m" if results.mesh.dim == 2 else "N"
    if R and all(r is not None for r in R) and all(u is not None for u in U):
        last_u, last_r = np.abs(U[-1]), np.abs(R[-1])
        moved = (last_u > 0) & (last_r > 0)  # a support that moves and pushes back
        if moved.any():
            k, c = np.unravel_index(np.argmax(np.where(moved, last_u, -1)), last_u.shape)
            x = np.array([0.0] + [u[k, c] for u in U])
            y = np.array([0.0] + [r[k, c] for r in R])
            comp = "xyz"[c]
            name = labels[k] if k < len(labels) else "condition %d" % k
            return (x, y, "displacement u_%s of %s [m]" % (comp, name),
                    "reaction R_%s of %s [%s]" % (comp, name, unit_f),
                    "reaction against prescribed displacement")
    load = [s.measures.get("load_factor", np.nan) for s in steps]
    disp = [s.measures.get("max_displacement", np.nan) for s in steps]
    if np.all(np.isnan(load)):
        load = [s.p for s in steps]
        ylabel = "step p (no load factor stored in this file)"
    else:
        ylabel = "load factor"
    return (np.array([0.0] + disp), np.array([0.0] + list(load)), "max nodal |u| [m]", ylabel,
            "load factor against displacement")


def plot(path, out=None):
    """Draws the pictures of the results file `path` into `out` (default: path with .png)."""
    import ltl_results
    try:
        import matplotlib
    except ImportError:
        sys.exit("ltl-results plot: matplotlib is not installed (Debian: apt-get install "
                 "python3-matplotlib); the summary `ltl-results FILE` needs only h5py")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = ltl_results.load(path)
    if not r.steps:
        sys.exit("ltl-results plot: %s: no completed step to plot (status: %s)" % (
            path, r.attrs.get("status", "")))
    out = out or os.path.splitext(path)[0] + ".png"
    # The picture replaces a picture only: not the results file, not through a symbolic link.
    if os.path.islink(out):
        raise OSError("%s: is a symbolic link (to %s); refusing to write through it" % (
            out, os.readlink(out)))
    if os.path.exists(out) and os.path.samefile(out, path):
        raise OSError("%s: is the results file itself; refusing to write the picture over it"
                      % out)
    contact = r.mesh.contact_centre is not None and "contact_pressure" in r.steps[-1].fields
    glued = contact and "beta" in r.steps[-1].fields and (
        r.steps[-1].measures.get("beta_min") is not None)
    panels = 2 + contact + glued
    fig, axes = plt.subplots(1, panels, figsize=(4.2 * panels, 3.8))
    title = "%s (%s)" % (r.attrs.get("name", os.path.basename(path)), r.attrs.get("status", ""))
    fig.suptitle(title)

    x, y, xl, yl, what = _support_curve(r)
    ax = axes[0]
    ax.plot(x, y, "o-", color="#1f4e79")
    ax.set_xlabel(xl)
    ax.set_ylabel(yl)
    ax.set_title("(a) " + what)
    ltl_results.print_table("(a) " + what, {"x": x, "y": y})
    # A force on the second axis: the contact force with a contact surface, else the total
    # reaction of the supports when it is not round-off (symmetry planes alone carry none).
    unit_f = "N/m" if r.mesh.dim == 2 else "N"
    force, flabel = None, ""
    if not what.startswith("reaction"):
        if all("contact_force" in s.measures for s in r.steps):
            force = np.array([s.measures["contact_force"] for s in r.steps])
            flabel = "contact force [%s]" % unit_f
        elif all("reactions" in s.fields for s in r.steps):
            R = [s.fields["reactions"] for s in r.steps]
            force = np.array([np.linalg.norm(q.sum(axis=0)) for q in R])
            scale = max(np.abs(q).max() for q in R) if R[0].size else 0.0
            flabel = "|total reaction of the supports| [%s]" % unit_f
            if not force.max() > 1e-8 * scale:
                force = None
    if force is not None:
        ax2 = ax.twinx()
        ax2.grid(False)
        ax2.plot(x, np.r_[0.0, force], "s--", color="#e67e22", ms=3)
        ax2.set_ylabel(flabel, color="#e67e22")
        ltl_results.print_table("(a) " + flabel, {"x": x, "force": np.r_[0.0, force]})

    ax = axes[1]
    start, rows = 0, []
    for s in r.steps:
        n = np.asarray(s.history.get("n", []), dtype=float)
        res = np.asarray(s.history.get("r_G", []), dtype=float) + np.asarray(
            s.history.get("r_B", []), dtype=float)
        if len(n):
            ax.semilogy(start + n, np.maximum(res, 1e-300), lw=0.8, color="#1f4e79")
            ax.axvline(start + n[-1], color="0.7", lw=0.5)
            rows.append((s.p, len(n), res[-1]))
            start += n[-1]
    ax.set_xlabel("iteration, all steps in order (grey: end of a step)")
    ax.set_ylabel("r_G + r_B")
    ax.set_title("(b) convergence")
    if rows:
        ltl_results.print_table("(b) convergence", {
            "p": [q[0] for q in rows], "iterations": [q[1] for q in rows],
            "final r_G + r_B": [q[2] for q in rows]})

    if contact:
        x1 = r.mesh.contact_centre[:, 0]
        order = np.argsort(x1)
        cmap = plt.get_cmap("viridis")
        fields = [("contact_pressure", "contact pressure [Pa]")] + (
            [("beta", "adhesion intensity beta")] if glued else [])
        for j, (name, label) in enumerate(fields):
            ax = axes[2 + j]
            n = len(r.steps)
            for k, s in enumerate(r.steps):
                ax.plot(x1[order], s.fields[name][order], color=cmap(0.9 * k / max(n - 1, 1)),
                        lw=0.9, label="t = %g s" % s.t if k in (0, n - 1) else None)
            ax.set_xlabel("reference x1 of the contact point [m]")
            ax.set_ylabel(label)
            ax.set_title("(%s) %s over time" % ("cd"[j], name))
            ax.legend()
            ltl_results.print_table("(%s) %s, last step" % ("cd"[j], name), {
                "x1": x1[order], name: r.steps[-1].fields[name][order]})
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    print("wrote %s" % out)
    return out


def main(argv):
    usage = "usage: ltl-results plot RESULTS.h5 [-o OUT.png]"
    if argv[:1] in (["-h"], ["--help"]):
        print(usage + "\n\n" + __doc__.split("\n\n", 2)[2])
        return 0
    if not argv:
        print(usage, file=sys.stderr)
        return 2
    path, out = argv[0], None
    rest = argv[1:]
    if rest[:1] == ["-o"] and len(rest) == 2:
        out = rest[1]
    elif rest:
        print(usage, file=sys.stderr)
        return 2
    if not path or out == "":  # as ltl_run's -o '': never a default in its place
        print("%s: the %s file name is empty" % (usage, "results" if not path else "output"),
              file=sys.stderr)
        return 2
    try:
        plot(path, out)
    except (OSError, ValueError) as err:
        print("ltl-results plot: %s" % err, file=sys.stderr)
        return 1
    return 0
