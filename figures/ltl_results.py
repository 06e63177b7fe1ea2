"""Read a results file of the solver (HDF5, layout in experiments/README.md) into numpy arrays.

    import ltl_results
    r = ltl_results.load("run.h5")
    r.attrs["status"], r.mesh.X, r.steps[-1].p, r.steps[-1].fields["u"], r.steps[-1].history["r_B"]
    r.steps[-1].equilibrium        # force_residual, det_error, penetration, det_min of the step
    r.steps[-1].measures["front"]  # the step's measures (lib/measures.hpp), e.g. the front
    r.steps[-1].in_contact         # the contact set per contact point (bool), or None
    ltl_results.resolved_config(r)  # the configuration in SI with every default (dict)
    ltl_results.status_line(r)      # the status; for "running", whether a process writes it

Arrays keep the file's layout: u (#nodes, dim); E, lambda, P, sigma (#cells, dim, dim) with
[c, i, j] the (i, j) entry of cell c's tensor; sigma33 (#cells, plane strain), pressure
(#cells); e, lambda_c (#points, dim); beta, contact_pressure, gap (#points). Which datasets are
fields, where they live and their units is FIELDS, the field table of the writer
(lib/results_fields.hpp), copied below and checked by tests/test_results_layers.cpp;
Step.units[name] is a field's unit. The 2-D "xdmf" subgroup (padded copies for ParaView) is not
loaded. The "measures" subgroup (every reported
number, computed once by lib/measures.hpp: contact force, half-width, debonding front, opening,
...) is Step.measures (name -> float), Step.measure_units and Step.measure_descriptions (name ->
str), and Step.in_contact (bool per contact point); figure scripts read these and never
recompute a definition or threshold. r.steps holds results only: the last
iterate of a step that did not converge (/unconverged) is in r.unconverged, apart, for diagnosis,
and so is a checkpoint of a step still iterating (ltl_run --checkpoint; Step.checkpoint).
Nothing here plots; figure scripts print what they plot with print_table().

As a program it prints a summary of a file (steps, iterations, equilibrium measure), or with
`plot` draws its load-displacement curve, convergence and contact fields (ltl_plot.py):
    /usr/bin/python3 ltl_results.py run.h5
    /usr/bin/python3 ltl_results.py plot run.h5 [-o run.png]

Use /usr/bin/python3 (it has h5py and numpy).
"""

import io
import os
import stat
import struct
import sys
import time

import h5py
import numpy as np

HISTORY_COLUMNS = ("n", "r_G", "r_B", "t_global", "t_strain", "t_contact", "t_update", "wall")

# BEGIN FIELDS (from lib/results_fields.hpp; tests/test_results_layers.cpp checks it)
# name: (location, shape, unit in 2-D, unit in 3-D)
FIELDS = {
    "X": ("mesh", "vector", "m", "m"),
    "cells": ("mesh", "table", "1", "1"),
    "cell_volume": ("mesh", "scalar", "m^2", "m^3"),
    "contact_facets": ("mesh", "table", "1", "1"),
    "contact_nodes": ("mesh", "scalar", "1", "1"),
    "contact_topology": ("mesh", "table", "1", "1"),
    "contact_centre": ("mesh", "vector", "m", "m"),
    "contact_area": ("mesh", "scalar", "m", "m^2"),
    "contact_obstacle": ("mesh", "scalar", "1", "1"),
    "u": ("node", "vector", "m", "m"),
    "E": ("cell", "tensor", "1", "1"),
    "detF": ("cell", "scalar", "1", "1"),
    "stretches": ("cell", "vector3", "1", "1"),
    "von_mises": ("cell", "scalar", "Pa", "Pa"),
    "sigma_node": ("node", "tensor3", "Pa", "Pa"),
    "von_mises_node": ("node", "scalar", "Pa", "Pa"),
    "lambda": ("cell", "tensor", "Pa", "Pa"),
    "P": ("cell", "tensor", "Pa", "Pa"),
    "sigma": ("cell", "tensor", "Pa", "Pa"),
    "sigma33": ("cell", "scalar", "Pa", "Pa"),
    "pressure": ("cell", "scalar", "Pa", "Pa"),
    "beta": ("point", "scalar", "1", "1"),
    "e": ("point", "vector", "m", "m"),
    "lambda_c": ("point", "vector", "Pa", "Pa"),
    "contact_pressure": ("point", "scalar", "Pa", "Pa"),
    "gap": ("point", "scalar", "m", "m"),
    "reactions": ("support", "vector", "N/m", "N"),
    "support_u": ("support", "vector", "m", "m"),
    "in_contact": ("point", "scalar", "1", "1"),
    "history": ("step", "table", "1 1 1 s s s s s", "1 1 1 s s s s s"),
}
# END FIELDS

# Where the per-step fields live (a step's fields are the FIELDS rows at these locations).
STEP_LOCATIONS = ("node", "cell", "point", "support")


class Mesh:
    """The reference mesh: X (#nodes, dim), cells (#cells, nodes per cell, gmsh order),
    cell_volume (#cells), and on the contact surface (None without one) contact_facets
    (#facets, nodes per facet), and per contact point contact_centre (#points, dim) and
    contact_area (#points, its weight). The contact points are the facets (discretization.contact
    = "facet-mean") or, when contact_nodes (#points, mesh node of each) is not None, the nodes of
    the contact surface (the default, "nodal").

    Several obstacles ([[contact]], paper_notes/obstacles.md): the contact points (and facets)
    of every obstacle one after the other, contact_obstacle (#points) the obstacle of each (all
    zeros with one obstacle, whose file has no such dataset); obstacles() is their number and
    obstacle_points(k) the indices of obstacle k's points, which slice every per-point field
    (e, lambda_c, beta, contact_pressure, gap, in_contact)."""

    def __init__(self, X, cells, cell_volume, contact_facets=None, contact_centre=None,
                 contact_area=None, cell_type="", contact_boundary="", contact_nodes=None,
                 contact_obstacle=None):
        self.X = X
        self.cells = cells
        self.cell_volume = cell_volume
        self.contact_facets = contact_facets
        self.contact_centre = contact_centre
        self.contact_area = contact_area
        self.cell_type = cell_type
        self.contact_boundary = contact_boundary
        self.contact_nodes = contact_nodes
        n_points = 0 if contact_area is None else len(contact_area)
        if contact_nodes is not None:
            n_points = len(contact_nodes)
        elif contact_facets is not None and contact_area is None:
            n_points = len(contact_facets)
        self.contact_obstacle = (np.asarray(contact_obstacle, dtype=int)
                                 if contact_obstacle is not None
                                 else np.zeros(n_points, dtype=int))

    @property
    def dim(self):
        return self.X.shape[1]

    def obstacles(self):
        """The number of obstacles: 0 without contact, 1 for a [contact] table."""
        if self.contact_facets is None:
            return 0
        return int(self.contact_obstacle.max()) + 1 if len(self.contact_obstacle) else 1

    def obstacle_points(self, k):
        """The indices of the contact points of obstacle k (consecutive)."""
        return np.flatnonzero(self.contact_obstacle == k)


EQUILIBRIUM = ("force_residual", "det_error", "penetration", "det_min")


class Step:
    """One stored time step: p, t, iterations, status, fields (name -> array), history
    (column name -> array over the iterations), attrs (all attributes of the step), equilibrium
    (the equilibrium measure: force_residual, det_error, penetration, det_min; empty in files of
    format version 1, without det_min in files written before it existed), converged (False only for an entry of Results.unconverged), checkpoint (True for an entry of Results.unconverged that --checkpoint saved while the step was still iterating), measures (name ->
    float, /steps/N/measures; empty in older files), measure_units, measure_descriptions (name ->
    str), in_contact (bool per contact point, None without contact or in older files), units
    (field name -> unit, from FIELDS)."""

    def __init__(self, p, t, iterations, status, fields, history, attrs, measures=None,
                 measure_units=None, measure_descriptions=None, in_contact=None, units=None):
        self.p = p
        self.t = t
        self.iterations = iterations
        self.status = status
        self.fields = fields
        self.history = history
        self.attrs = attrs
        self.equilibrium = {k: float(attrs[k]) for k in EQUILIBRIUM if k in attrs}
        self.converged = not attrs.get("unconverged", 0)
        # An entry of Results.unconverged saved by --checkpoint: the step was still iterating.
        self.checkpoint = bool(attrs.get("checkpoint", 0))
        self.measures = measures or {}
        self.measure_units = measure_units or {}
        self.measure_descriptions = measure_descriptions or {}
        self.in_contact = in_contact
        self.units = units or {}

    def __repr__(self):
        return "Step(p=%d, t=%g, iterations=%d, fields=%s)" % (
            self.p, self.t, self.iterations, sorted(self.fields))


class Results:
    """A loaded results file: path, attrs (dict of root attributes), mesh, steps (by p; results
    only), unconverged (steps that did not converge, their last iterate and history: NOT
    results), format_version (1 for files written before the attribute existed)."""

    def __init__(self, path, attrs, mesh, steps, unconverged=()):
        self.path = path
        self.attrs = attrs
        self.mesh = mesh
        self.steps = steps
        self.unconverged = list(unconverged)
        self.format_version = int(attrs.get("format_version", 1))

    def step(self, p):
        """The step with number p (KeyError if it is not stored)."""
        for s in self.steps:
            if s.p == p:
                return s
        raise KeyError("%s: no step %d (stored: %s)" % (self.path, p, [s.p for s in self.steps]))

    def times(self):
        return np.array([s.t for s in self.steps])


def _value(v):
    """An attribute value as plain Python (str, int, float)."""
    if isinstance(v, bytes):
        return v.decode("utf-8")
    if isinstance(v, np.ndarray) and v.shape == ():
        v = v[()]
    if isinstance(v, np.generic):
        return v.item()
    return v


def _attrs(obj):
    return {k: _value(v) for k, v in obj.attrs.items()}


def _journal_image(path):
    """The bytes of `path` with the redo journal `path + ".journal"` applied, when a writer was
    killed in the middle of an in-place commit (lib/results_commit.hpp: the format); None when
    there is no complete journal."""
    try:
        if not stat.S_ISREG(os.stat(path + ".journal").st_mode):
            return None  # not a journal of this code (a FIFO there would block the read)
        with open(path + ".journal", "rb") as j:
            data = j.read()
    except OSError:
        return None
    n = len(data)
    if n < 56 or n % 8 or data[:8] != b"LTLJRNL1" or data[-8:] != b"LTLJEND1":
        return None
    w = np.frombuffer(data, dtype="<u8", count=(n - 24) // 8)
    with np.errstate(over="ignore"):
        s1 = int(w.sum(dtype=np.uint64))
        s2 = int((w * np.arange(1, len(w) + 1, dtype=np.uint64)).sum(dtype=np.uint64))
    if (s1, s2) != struct.unpack_from("<QQ", data, n - 24):
        return None
    old, new, count = struct.unpack_from("<QQQ", data, 8)
    with open(path, "rb") as f:
        image = bytearray(f.read())
    if not min(old, new) <= len(image) <= max(old, new):  # not this file's journal
        return None
    image = image[:new] + bytes(max(0, new - len(image)))
    at = 32
    for _ in range(count):
        offset, length = struct.unpack_from("<QQ", data, at)
        at += 16
        image[offset:offset + length] = data[at:at + length]
        at += length + (-length % 8)
    return bytes(image)


def _open(path):
    # With HDF5's file locking: a writer updating the file in place holds it exclusively for a
    # few milliseconds; wait for it (about ten seconds at most, then read without locking).
    image = _journal_image(path)
    if image is not None:
        return h5py.File(io.BytesIO(image), "r")
    for _ in range(1000):
        try:
            return h5py.File(path, "r", locking="best-effort")
        except (TypeError, ValueError):  # h5py older than 3.5, or HDF5 without the option
            return h5py.File(path, "r")
        except OSError as err:
            if "lock" not in str(err):
                raise
            time.sleep(0.01)
    return h5py.File(path, "r", locking=False)


def load(path, fields=None):
    """Loads the results file `path`. `fields` (a list of names) limits the per-step fields read;
    None reads all of them. Raises OSError/ValueError naming the file if it cannot be read."""
    try:
        mode = os.stat(path).st_mode  # through a symbolic link: the file it names
    except OSError as err:
        raise OSError("%s: cannot read the results file (%s)" % (path, err.strerror)) from err
    if not stat.S_ISREG(mode):
        raise OSError("%s: %s" % (path, "is a directory, not a results file" if stat.S_ISDIR(mode)
                                  else "is not a regular file (a FIFO, device or socket); "
                                  "refusing to read it"))
    try:
        f = _open(path)
    except OSError as err:
        raise OSError("%s: cannot read the results file (%s)" % (path, err)) from err
    with f:
        if "mesh" not in f or "steps" not in f:
            raise ValueError("%s: not a results file (no /mesh or /steps group)" % path)
        try:
            return _load(path, f, fields)
        except (KeyError, TypeError, IndexError, AttributeError) as err:
            raise ValueError("%s: not a results file of this code, or a damaged one (%s)" % (
                path, err)) from err


def _load(path, f, fields):
    """The body of load, on the open file `f`."""
    m = f["mesh"]
    get = lambda name: m[name][()] if name in m else None
    mesh = Mesh(X=m["X"][()], cells=m["cells"][()], cell_volume=get("cell_volume"),
                contact_facets=get("contact_facets"), contact_centre=get("contact_centre"),
                contact_area=get("contact_area"), cell_type=_value(m.attrs.get("cell_type", "")),
                contact_boundary=_value(m["contact_facets"].attrs.get("boundary", ""))
                if "contact_facets" in m else "", contact_nodes=get("contact_nodes"),
                contact_obstacle=get("contact_obstacle"))
    steps = _read_steps(f["steps"], fields, mesh.dim)
    unconverged = _read_steps(f["unconverged"], fields, mesh.dim) if "unconverged" in f else []
    return Results(path, _attrs(f), mesh, steps, unconverged)


def _read_steps(group, fields, dim):
    """The step groups (six-digit names) of /steps or /unconverged, in increasing p."""
    steps = []
    step_fields = [k for k, row in FIELDS.items() if row[0] in STEP_LOCATIONS]
    for name in sorted(k for k in group if len(k) == 6 and k.isdigit()):
        g = group[name]
        a = _attrs(g)
        data = {k: g[k][()] for k in step_fields
                if k in g and isinstance(g[k], h5py.Dataset) and (fields is None or k in fields)}
        h = g["history"][()] if "history" in g else np.zeros((0, len(HISTORY_COLUMNS)))
        columns = _value(g["history"].attrs.get("columns", "")) if "history" in g else ""
        names = columns.split() if columns else list(HISTORY_COLUMNS)
        history = {c: h[:, i] for i, c in enumerate(names)}
        measures, units, texts, in_contact = {}, {}, {}, None
        if "measures" in g:
            for k, d in g["measures"].items():
                if k == "in_contact":
                    in_contact = d[()].astype(bool)
                    continue
                measures[k] = float(d[()])
                units[k] = _value(d.attrs.get("unit", ""))
                texts[k] = _value(d.attrs.get("description", ""))
        steps.append(Step(p=int(a["p"]), t=float(a["t"]), iterations=int(a["iterations"]),
                          status=a.get("status", ""), fields=data, history=history, attrs=a,
                          measures=measures, measure_units=units, measure_descriptions=texts,
                          in_contact=in_contact,
                          units={k: FIELDS[k][2 if dim == 2 else 3] for k in data}))
    steps.sort(key=lambda s: s.p)
    return steps


def deformed(X, u, scale=1.0):
    """Deformed positions X + scale * u (both (#nodes, dim))."""
    X = np.asarray(X, dtype=float)
    u = np.asarray(u, dtype=float)
    if X.shape != u.shape:
        raise ValueError("deformed: X has shape %s, u %s" % (X.shape, u.shape))
    return X + scale * u


def print_table(title, columns, file=None, fmt="%.6g"):
    """Prints the numbers a figure plots: `columns` maps a column name to a 1-D array (all of one
    length, or scalars), printed as an aligned table under `title` (to stdout by default)."""
    out = file if file is not None else sys.stdout
    names = list(columns)
    cols = [np.atleast_1d(np.asarray(columns[n])) for n in names]
    rows = max((len(c) for c in cols), default=0)
    cells = [[fmt % c[i] if len(c) > i else "" for c in cols] for i in range(rows)]
    width = [max([len(n)] + [len(r[j]) for r in cells]) for j, n in enumerate(names)]
    print("# " + title, file=out)
    print("  ".join(n.rjust(w) for n, w in zip(names, width)), file=out)
    for r in cells:
        print("  ".join(v.rjust(w) for v, w in zip(r, width)), file=out)


_PREFIX = {"G": 1e9, "M": 1e6, "k": 1e3, "m": 1e-3, "u": 1e-6, "µ": 1e-6}


def quantity(value):
    """A configuration value in SI as a float: a number, or a string "number unit" whose unit's
    first symbol may carry a prefix G, M, k, m, u (e.g. "-400 kN/m^3" -> -4e5, "10 kPa" -> 1e4,
    "1000 1/m" -> 1000, "0.5 m" -> 0.5). Only the prefix is applied; the unit is not checked."""
    if isinstance(value, (int, float)):
        return float(value)
    parts = str(value).split(None, 1)
    number = float(parts[0])
    unit = parts[1].strip() if len(parts) > 1 else ""
    if len(unit) > 1 and unit[0] in _PREFIX and unit[1].isalpha():
        number *= _PREFIX[unit[0]]
    return number


def config(results):
    """The configuration as given (root attribute "config", TOML, with --set applied) as a dict;
    convert its values with quantity(). resolved_config() has them in SI with every default."""
    import tomllib  # Python >= 3.11
    return tomllib.loads(results.attrs["config"])


def resolved_config(results):
    """The resolved configuration (root attribute "config_resolved": every value in SI, every
    default filled in) as a dict; None for files of format version 1, which do not have it."""
    import tomllib  # Python >= 3.11
    text = results.attrs.get("config_resolved")
    return tomllib.loads(text) if text else None


def writer_of(path):
    """The process of this machine that writes the results file `path` now: the pid holding a
    lock on its lock file (<the file's real directory>/<its name>.lock, lib/output_guard.hpp),
    read from /proc/locks, so that asking takes no lock; 0 when no process of this machine holds
    it (a job on another machine of a cluster does not show here); None when that cannot be told
    (no /proc/locks: not Linux)."""
    lock = os.path.join(os.path.realpath(os.path.dirname(os.path.abspath(path))),
                        os.path.basename(path) + ".lock")
    try:
        st = os.stat(lock)
    except FileNotFoundError:
        return 0
    try:
        with open("/proc/locks") as f:
            lines = f.read().splitlines()
    except OSError:
        return None
    # "1: FLOCK  ADVISORY  WRITE 1234 08:01:5678 0 EOF": pid, then major:minor:inode (hex, hex,
    # decimal); a lock that waits for another is marked "->". Any kind of lock (a network file
    # system may list a flock as POSIX), matched on the inode alone: on an overlay file system
    # (a container) the device that stat() gives need not be the one listed, and a process wrongly
    # said to write is the safer error.
    inode = ":%d" % st.st_ino
    for line in lines:
        words = line.split()
        if "->" not in words and len(words) >= 6 and words[5].endswith(inode):
            return int(words[4])
    return 0


def status_line(results):
    """The file's status, and for a file that says "running" whether a process of this machine
    still writes it: a run killed (SIGKILL, out of memory) or ended by an error of another MPI
    rank (MPI_Abort ends rank 0, the writer, inside a collective) leaves "running" behind, with
    every step it wrote complete."""
    status = results.attrs.get("status", "")
    if not status.startswith("running"):
        return status
    pid = writer_of(results.path)
    if pid is None:
        return status
    if pid:
        return "%s (written now by process %d of this machine)" % (status, pid)
    return ("%s -- but no process of this machine writes it: unless a job on another machine "
            "does, the run ended without updating its status (killed, or ended by an error of "
            "another MPI rank); the steps it holds are complete, and --resume continues it" % status)


def summary(results, file=None):
    """Prints a file's status (status_line) and one row per step: t, iterations, final
    residuals and the equilibrium measure; then the unconverged steps, marked as such."""
    out = file if file is not None else sys.stdout
    print("%s: %s, format version %d, status: %s" % (
        results.path, results.attrs.get("name", ""), results.format_version,
        status_line(results)), file=out)
    for title, steps in (("steps (results)", results.steps),
                         ("UNCONVERGED steps (not results: last iterate, for diagnosis)",
                          [s for s in results.unconverged if not s.checkpoint]),
                         ("CHECKPOINTS (not results: the iterate of a step still iterating; "
                          "--resume continues from it)",
                          [s for s in results.unconverged if s.checkpoint])):
        if not steps:
            continue
        last = lambda s, k: s.history[k][-1] if len(s.history.get(k, ())) else np.nan
        print_table(title, {
            "p": [s.p for s in steps], "t [s]": [s.t for s in steps],
            "iterations": [s.iterations for s in steps],
            "r_G": [last(s, "r_G") for s in steps], "r_B": [last(s, "r_B") for s in steps],
            "force_residual": [s.equilibrium.get("force_residual", np.nan) for s in steps],
            "det_error": [s.equilibrium.get("det_error", np.nan) for s in steps],
            "penetration [m]": [s.equilibrium.get("penetration", np.nan) for s in steps],
            "min det F": [s.equilibrium.get("det_min", np.nan) for s in steps],
        }, file=out, fmt="%.4g")
        names = sorted({k for s in steps for k in s.measures})
        if names:
            print_table(title + ": measures (lib/measures.hpp)", dict(
                [("p", [s.p for s in steps])] +
                [("%s [%s]" % (k, steps[-1].measure_units.get(k, "")),
                  [s.measures.get(k, np.nan) for s in steps]) for k in names]),
                file=out, fmt="%.4g")


if __name__ == "__main__":
    import signal
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # `ltl-results FILE | head`: end quietly
    if sys.argv[1:2] == ["plot"]:  # ltl-results plot FILE: the pictures of a run (ltl_plot.py)
        import ltl_plot
        sys.exit(ltl_plot.main(sys.argv[2:]))
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        print("usage: ltl_results.py RESULTS.h5 ...  |  ltl_results.py plot RESULTS.h5 [-o PNG]",
              file=sys.stdout if sys.argv[1:] else sys.stderr)
        sys.exit(0 if sys.argv[1:] else 2)
    for path in sys.argv[1:]:
        try:
            summary(load(path))
        except (OSError, ValueError) as err:
            sys.exit("ltl-results: %s" % err)
