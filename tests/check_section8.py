"""The numbers paper_notes/section8.md quotes for Figs 5-6 and the Signorini problem are what the
code gives (a CTest): the Fig 5 and Fig 6 paragraphs (iterations, Newton's iterations, contact nodes,
half-widths, peak pressure, force ratio, drop), the Fig 5 and Signorini rows of the `make compare`
table, and the R and rho sweeps of Fig 5. Each number is read from the note and compared with
a run of build/experiments/ltl_run (or hertz), so a stale number fails the test.

    /usr/bin/python3 tests/check_section8.py BUILD_DIR SOURCE_DIR
"""

import os
import re
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def number(text):
    return float(text.replace(" ", ""))


def find(pattern, text, what):
    m = re.search(pattern, text, re.S)
    if not m:
        fail("section8.md: cannot find %s (pattern %r)" % (what, pattern))
    return m


def check(what, quoted, measured, rel=0.0, abs_=0.0):
    ok = abs(quoted - measured) <= max(rel * abs(measured), abs_)
    print("%-55s note %-12.6g run %-12.6g %s" % (what, quoted, measured, "ok" if ok else "STALE"))
    return ok


def main(build, src, tmp):
    note = open(os.path.join(src, "paper_notes", "section8.md"), encoding="utf-8").read()
    run = os.path.join(build, "experiments", "ltl_run")
    cfg = os.path.join(src, "experiments", "fig5", "fig5.toml")
    good = True

    def fig5(name, *sets):
        out = os.path.join(tmp, name + ".h5")
        args = [run, cfg, "-q", "-o", out]
        for s in sets:
            args += ["--set", s]
        ok = subprocess.run(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
        if ok != 0:
            return None
        return h5py.File(out, "r")

    # 1. The Fig 5 paragraph.
    para = find(r"What we see \(`make fig5`.*?discretization\.md\)", note, "the Fig 5 paragraph")
    para = para.group(0)
    f = fig5("plain")
    if f is None:
        fail("Fig 5 did not run")
    step = f["steps/000001"]
    m = {k: float(v[()]) for k, v in step["measures"].items() if k != "in_contact"}
    X, u = f["mesh/X"][()], step["u"][()]
    top = int(np.argmin(np.linalg.norm(X - [0.0, 1.0], axis=1)))
    weight = 400e3 * np.pi / 2  # f2 = 400 kN/m^3 on the half disc of radius 1
    q = lambda p, what: number(find(p, para, what).group(1))
    good &= check("Fig 5 iterations", q(r"([\d ]+) iterations to\s+`tol", "iterations"),
                  step.attrs["iterations"], rel=0.02)
    n = fig5("newton", 'algorithm.solver="newton"')
    good &= check("Fig 5 Newton iterations", q(r"driver's last line: (\d+) iterations", "Newton"),
                  n["steps/000001"].attrs["iterations"] if n else np.nan, rel=0.1)
    good &= check("Fig 5 contact nodes touching", q(r"(\d+) of the \d+ contact nodes", "touching"),
                  m["in_contact_count"])
    good &= check("Fig 5 contact nodes", q(r"\d+ of the (\d+) contact nodes", "nodes"),
                  m["contact_points"])
    good &= check("Fig 5 a_edge [m]", q(r"`a_edge` ([\d.]+) m", "a_edge"), m["a_edge"], abs_=6e-5)
    good &= check("Fig 5 a_moment [m]", q(r"`a_moment` ([\d.]+) m", "a_moment"), m["a_moment"],
                  abs_=6e-5)
    good &= check("Fig 5 p_max [MPa]", q(r"pressure ([\d.]+) MPa", "p_max"), m["p_max"] / 1e6,
                  abs_=6e-4)
    good &= check("Fig 5 contact force [N/m]", q(r"half cylinder, ([\d.e]+) N/m", "force"),
                  m["contact_force"], rel=1e-4)
    good &= check("Fig 5 force / weight", q(r"\(ratio ([\d.]+)\)", "ratio"),
                  m["contact_force"] / weight, abs_=6e-5)
    good &= check("Fig 5 drop [m]", q(r"drops by ([\d.]+) m", "drop"), -u[top, 1], abs_=6e-5)

    # 1b. The Fig 6 paragraph (one run of the figure's configuration, plain ALG2, and one with
    # the Newton phase).
    para6 = find(r"What we see \(`make fig6`.*?Pa\.", note, "the Fig 6 paragraph").group(0)
    q6 = lambda p, what: number(find(p, para6, what).group(1))
    cfg6 = os.path.join(src, "experiments", "fig6", "fig6.toml")
    runs6 = {}
    for name, sets in (("fig6", []), ("fig6-newton", ['algorithm.solver="newton"'])):
        out = os.path.join(tmp, name + ".h5")
        args = [run, cfg6, "-q", "-o", out] + [a for s_ in sets for a in ("--set", s_)]
        if subprocess.run(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode:
            fail("Fig 6 (%s) did not run" % name)
        runs6[name] = h5py.File(out, "r")["steps/000001"]
    s6 = runs6["fig6"]
    m6 = {k: float(v[()]) for k, v in s6["measures"].items() if k != "in_contact"}
    good &= check("Fig 6 iterations", q6(r"([\d ]+) iterations to `tol", "iterations"),
                  s6.attrs["iterations"], rel=0.02)
    row6 = find(r"\| Fig 6 \| - \| ([\d ]+) it,", note, "the Fig 6 row")
    good &= check("table: Fig 6 Uzawa", number(row6.group(1)), s6.attrs["iterations"], rel=0.02)
    good &= check("Fig 6 Newton iterations", q6(r"driver's last line: (\d+)\s+iterations",
                                                "Newton"),
                  runs6["fig6-newton"].attrs["iterations"], rel=0.1)
    good &= check("Fig 6 sag [m]", q6(r"sags ([\d.]+) m", "sag"), -s6["u"][()][:, 1].min(),
                  abs_=6e-5)
    good &= check("Fig 6 contact nodes touching", q6(r"(\d+) of the \d+ contact nodes", "touch"),
                  m6["in_contact_count"])
    good &= check("Fig 6 contact nodes", q6(r"\d+ of the (\d+) contact nodes", "nodes"),
                  m6["contact_points"])
    good &= check("Fig 6 contact area [m^2]", q6(r"over ([\d.]+) m\^2", "area"),
                  m6["contact_area"], abs_=6e-4)
    good &= check("Fig 6 contact force [N]", q6(r"carries ([\d.]+) N", "force"),
                  m6["contact_force"], abs_=0.06)
    good &= check("Fig 6 p_max [Pa]", q6(r"pressure is ([\d.]+) Pa", "p_max"), m6["p_max"],
                  abs_=0.6)

    # 2. The Fig 5 row of the table, and the R and rho sweeps.
    row = find(r"\| Fig 5 \| - \| ([\d ]+) it, [^|]*\| ([\d ]+) it,", note, "the Fig 5 row")
    bm = fig5("bm", "algorithm.update=bermudez-moreno")
    good &= check("table: Fig 5 Uzawa", number(row.group(1)), step.attrs["iterations"], rel=0.02)
    good &= check("table: Fig 5 Bermudez-Moreno", number(row.group(2)),
                  bm["steps/000001"].attrs["iterations"] if bm else np.nan, rel=0.02)
    sweep = find(r"Uzawa needs ([\d ]+), ([\d ]+), ([\d ]+) iterations and\s+Bermudez-Moreno "
                 r"([\d ]+), ([\d ]+), ([\d ]+) for `R = 5, 10, 20`", note, "the R sweep")
    for k, (update, R) in enumerate([(u_, R) for u_ in ("uzawa", "bermudez-moreno")
                                     for R in (5, 10, 20)]):
        r = fig5("%s-R%d" % (update, R), "algorithm.update=" + update, "algorithm.R=%d" % R)
        good &= check("R sweep: %s R = %d" % (update, R), number(sweep.group(k + 1)),
                      r["steps/000001"].attrs["iterations"] if r else np.nan, rel=0.02)
    rho = find(r"Bermudez-Moreno needs ([\d ]+), ([\d ]+), ([\d ]+) and ([\d ]+) iterations for\s+"
               r"`rho = 0.55, 0.7, 0.75, 0.8`", note, "the rho sweep")
    for k, value in enumerate((0.55, 0.7, 0.75, 0.8)):
        r = fig5("rho%g" % value, "algorithm.update=bermudez-moreno", "algorithm.rho=%g" % value)
        good &= check("rho sweep: rho = %g" % value, number(rho.group(k + 1)),
                      r["steps/000001"].attrs["iterations"] if r else np.nan, rel=0.02)
    good &= check("rho sweep: rho = 0.9 does not converge (1: it does)", 0,
                  0 if fig5("rho0.9", "algorithm.update=bermudez-moreno", "algorithm.rho=0.9",
                            "algorithm.max_iter=3000") is None else 1)

    # 3. The Signorini row: hertz's cost table, level 1.
    row = find(r"\| Signorini \(Hertz, level 1\) \| - \| ([\d ]+) it, [^|]*\| ([\d ]+) it,", note,
               "the Signorini row")
    out = subprocess.run([os.path.join(build, "experiments", "hertz"), "2", "0.1", "0.75",
                          os.path.join(tmp, "hertz")], capture_output=True, text=True).stdout
    level1 = find(r"\n\s+1\s+\d+\s+[\d.]+ \|\s+(\d+)\s+[\d.]+ \|\s+(\d+)", out.split("Cost of")[-1],
                  "hertz's level 1 cost row (in hertz's output)")
    good &= check("table: Signorini Uzawa", number(row.group(1)), int(level1.group(1)), rel=0.02)
    good &= check("table: Signorini Bermudez-Moreno", number(row.group(2)), int(level1.group(2)),
                  rel=0.02)
    if not good:
        fail("paper_notes/section8.md quotes numbers the code no longer gives (STALE above): "
             "update the note")
    print("section8.md: every checked number is what the code gives")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: check_section8.py BUILD_DIR SOURCE_DIR")
    directory = tempfile.mkdtemp(prefix="ltl_section8_")
    try:
        main(sys.argv[1], sys.argv[2], directory)
    finally:
        shutil.rmtree(directory, ignore_errors=True)
