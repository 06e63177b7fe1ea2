#!/usr/bin/python3
"""The readings study of Figs 3 and 4 [LTL87 sec. 8]: which reading of the paper's
silent data (where the bar is fixed, on which face and in which direction the traction
g2 = 10 (1 - x1) kPa acts) reproduces its captions (Fig 3 magnified x20, Fig 4 at t = 800 s
magnified x50, i.e. millimetre displacements)?

Every run is `ltl_run` on the Fig 3 or Fig 4 configuration of the main figures with `--set`
overrides that state the reading completely (fixed ends, traction face and sign), the kernel
rule and q_c, so the study does not depend on which reading the figure configurations draw.

    make readings
    /usr/bin/python3 experiments/readings/run_readings.py [--bin build/experiments/ltl_run]
        [--out results/readings] [--only SUBSTRING]... [--max-iter 20000] [--jobs 2] [--list]

Writes one HDF5 per run, `OUT/<bar>_<reading>_<kernel>_qc<q_c>[_<variant>].h5`, with the root
attributes `study_case`, `study_bar`, `study_reading`, `study_kernel`, `study_q_c`,
`study_max_iter`, `study_variant`, `study_wall_seconds`, `study_exit_code`, `study_message`
added to the solver's own. A run whose iteration cap is reached at step k stops with exit code 1
and its file keeps steps 1..k-1 with status "diverged at step k (t = ...)": the study records it
as "runaway at t_k". When step 1 itself fails the solver writes no file (by design: nothing
converged); this script then writes a file with the same study attributes, the solver's message
as `status` and no /steps group, so that the table is still built from files only.

[choice] max_iter = 20 000 per time step (the figures use 200 000): the hardest converged step
of the study needs 12 323 iterations (R5, Fig 4), under R3 at most 8 095, while a runaway step
needs 50 000-95 000 with q_c = 3e7 and more with 1e9, so a cap of 20 000 marks the runaway step
and keeps `make readings` within about 13 minutes on 2 shared cores. The `cap` variant reruns R1 with 200 000 to check
that the cap does not move the runaway time and to measure the peeled state.
"""

import argparse
import concurrent.futures as cf
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
BASE = {"fig3": os.path.join(ROOT, "experiments/fig3/fig3.toml"),
        "fig4": os.path.join(ROOT, "experiments/fig4/fig4.toml")}

# g = (0, s 10 (1 - x1)) kPa, s = +1 upward (away from the support), -1 downward.
def traction(group, sign):
    v = 10 * sign
    return ('load.traction=[{group="%s", value=["0 Pa", "%g kPa"], '
            'gradient=[["0 Pa/m", "0 Pa/m"], ["%g kPa/m", "0 Pa/m"]]}]' % (group, v, -v))


def fixed(*groups):
    return "fixed=[%s]" % ", ".join('{group="%s"}' % g for g in groups)


# The readings (the numbering). R8 (R1 with the load ramped over 800 s) is not here: the
# solver's loads are dead and constant in time; it has no load ramp.
READINGS = {
    "R1": ("fixed x1=1, top face pulled up (the literal reading)", [fixed("right"), traction("top", +1)]),
    "R2": ("fixed x1=0, top face pulled up", [fixed("left"), traction("top", +1)]),
    "R3": ("fixed x1=1, top face pressed down", [fixed("right"), traction("top", -1)]),
    "R5": ("both ends fixed, top face pulled up", [fixed("left", "right"), traction("top", +1)]),
    "R7": ("fixed x1=1, glued face pulled up", [fixed("right"), traction("contact", +1)]),
}

QC = {"3e7": "3e7 Pa/m", "1e9": "1e9 Pa/m"}


def cases(max_iter, mesh=False):
    """(name, bar, reading, kernel, q_c key, variant, overrides)."""
    out = []
    for bar in ("fig3", "fig4"):
        for r in READINGS:
            for kernel in ("centre", "exact"):
                for qc in QC:
                    out.append((bar, r, kernel, qc, "", max_iter, []))
        # The cap check: R1 with the figures' cap, the peeled state at 800 s.
        out.append((bar, "R1", "centre", "3e7", "cap200k", 200000, []))
    if mesh:
        # Mesh dependence of the kernel rules: the Fig 3 bar with 56 and 112 contact facets.
        for nx in (56, 112):
            for r in ("R1", "R3"):
                for kernel in ("centre", "exact"):
                    out.append(("fig3", r, kernel, "3e7", "nx%d" % nx, max_iter,
                                ["mesh.parameters.nx=%d" % nx]))
    result = []
    for bar, r, kernel, qc, variant, cap, extra in out:
        name = "%s_%s_%s_qc%s%s" % (bar, r, kernel, qc, "_" + variant if variant else "")
        sets = READINGS[r][1] + ["contact.kernel=%s" % kernel, 'algorithm.q_c="%s"' % QC[qc],
                                 "algorithm.max_iter=%d" % cap] + extra
        result.append(dict(name=name, bar=bar, reading=r, kernel=kernel, q_c=float(qc),
                           variant=variant, max_iter=cap, sets=sets))
    return result


def annotate(path, case, wall, rc, message):
    import h5py
    mode = "a" if os.path.exists(path) else "w"
    with h5py.File(path, mode) as f:
        if mode == "w":  # step 1 failed: no solver file
            f.attrs["name"] = case["bar"]
            f.attrs["status"] = message
        for k in ("bar", "reading", "kernel", "q_c", "max_iter", "variant"):
            f.attrs["study_" + k] = case[k]
        f.attrs["study_case"] = case["name"]
        f.attrs["study_reading_text"] = READINGS[case["reading"]][0]
        f.attrs["study_overrides"] = "\n".join(case["sets"])
        f.attrs["study_wall_seconds"] = wall
        f.attrs["study_exit_code"] = rc
        f.attrs["study_message"] = message


def run(case, binary, out):
    path = os.path.join(out, case["name"] + ".h5")
    cmd = [binary, BASE[case["bar"]], "-q", "-o", path]
    for s in case["sets"]:
        cmd += ["--set", s]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    t0 = time.time()
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.time() - t0
    message = (p.stderr.strip().splitlines() or [""])[-1]
    if p.returncode not in (0, 1) or (p.returncode == 1 and "diverged at step" not in message):
        raise RuntimeError("%s: ltl_run failed (exit %d): %s" % (case["name"], p.returncode,
                                                                 p.stderr))
    annotate(path, case, wall, p.returncode, message)
    return case["name"], wall, p.returncode, message


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=os.path.join(ROOT, "build/experiments/ltl_run"))
    ap.add_argument("--out", default=os.path.join(ROOT, "results/readings"))
    ap.add_argument("--only", action="append", default=[],
                    help="run the cases whose name contains this (repeatable)")
    ap.add_argument("--max-iter", type=int, default=20000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--mesh", action="store_true",
                    help="also the refined contact surfaces (56, 112 facets) of Fig 3")
    ap.add_argument("--list", action="store_true")
    a = ap.parse_args()
    todo = [c for c in cases(a.max_iter, a.mesh)
            if not a.only or any(s in c["name"] for s in a.only)]
    if a.list:
        for c in todo:
            print(c["name"], " ".join("--set '%s'" % s for s in c["sets"]))
        return 0
    os.makedirs(a.out, exist_ok=True)
    t0 = time.time()
    # The long runs first (q_c = 1e9, the refined meshes, the cap check), so the pool ends level.
    todo.sort(key=lambda c: -(c["q_c"] > 1e8) * 2 - bool(c["variant"]) - (c["reading"] != "R3"))
    with cf.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        futures = [pool.submit(run, c, a.bin, a.out) for c in todo]
        for f in cf.as_completed(futures):
            name, wall, rc, msg = f.result()
            print("%-36s %6.1f s  %s" % (name, wall,
                                         "complete" if rc == 0 else msg.split(": ", 2)[-1][:90]),
                  flush=True)
    print("%d runs in %.0f s (%d jobs)" % (len(todo), time.time() - t0, a.jobs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
