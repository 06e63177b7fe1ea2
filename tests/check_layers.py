#!/usr/bin/env python3
"""The #include graph of lib/ goes down the layers only: a file includes files of its own layer or
of a lower one, never one above it (no arrow from the measures, the discretization or the local
steps up to the solver, from the solver up to the time loop, ...). The layers, lowest first:

  leaf         no physics beyond one formula: errors, hashes, the state, the material law, the
               adhesion law, the signed SVD, a stored measure
  fe/mesh      the mesh (gmsh), the P2/H8 finite elements, the sparse Cholesky factorization
  steps        the local strain and contact steps, the adhesion kernel, the global step's
               matrix, Anderson's extrapolation
  problem      the problem as stated, the configuration (schema, reading, resolved TOML)
  discretization  the discrete operators of one problem
  measures     what is measured on a state: measures, admissibility, reactions
  solver       ALG2, the Newton phase, the fixed-point driver, the Signorini solver
  results      the results file (HDF5, XDMF)
  simulation   the time loop and the guard of its output
  cli          the command line of ltl_run

A file of lib/ that no layer lists is an error too: a new file is placed in a layer here, one
line. Usage: check_layers.py SOURCE_DIR   (exit 1 naming each upward include or unplaced file)
             check_layers.py --self-test  (the check finds an upward include and an unplaced file)
"""
import os
import re
import sys
import tempfile

LAYERS = [
    ("leaf", "error hash mpi_comm cofactor signed_svd state material adhesion contact_points "
             "version stored_measure log_newton interrupt geometry_guard hdf5_io results_info"),
    ("fe/mesh", "mesh fe cholesky cg_amg newton_krylov derived_fields mesh_transfer"),
    ("steps", "strain_step strain_principal contact_step obstacles adhesion_kernel global_step "
              "mpi_global mpi_newton anderson"),
    ("problem", "problem config config_toml config_rows config_schema"),
    ("discretization", "discretization"),
    ("measures", "measures admissibility reactions"),
    ("solver", "alg2 alg2_mpi adaptive_r newton newton_kkt fixed_point iteration signorini"),
    ("results", "results results_commit results_fields results_layout results_pages "
                "results_xdmf"),
    ("simulation", "simulation output_guard nested_start step_fields"),
    ("cli", "cli"),
]

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def layer_of():
    out = {}
    for rank, (name, stems) in enumerate(LAYERS):
        for stem in stems.split():
            out[stem] = (rank, name)
    return out


def stem(filename):
    return os.path.basename(filename).split(".")[0]


def check(lib):
    """Returns the list of violations in the directory `lib`."""
    layers = layer_of()
    problems = []
    for f in sorted(os.listdir(lib)):
        if not re.search(r"\.(hpp|cpp|h|cpp\.in)$", f):
            continue
        if stem(f) not in layers:
            problems.append(f"lib/{f}: in no layer; place it in LAYERS of tests/check_layers.py")
            continue
        rank, name = layers[stem(f)]
        with open(os.path.join(lib, f), encoding="utf-8") as fh:
            text = fh.read()
        for inc in INCLUDE.findall(text):
            if stem(inc) not in layers:
                problems.append(f"lib/{f}: includes \"{inc}\", which is in no layer")
                continue
            r, n = layers[stem(inc)]
            if r > rank:
                problems.append(f"lib/{f} (layer {name}) includes \"{inc}\" (layer {n}, above it)")
    return problems


def self_test():
    with tempfile.TemporaryDirectory() as d:
        with open(os.path.join(d, "discretization.cpp"), "w") as fh:
            fh.write('#include "discretization.hpp"\n#include "alg2.hpp"\n')
        with open(os.path.join(d, "alg2.hpp"), "w") as fh:
            fh.write('#include "measures.hpp"\n')
        with open(os.path.join(d, "newfile.hpp"), "w") as fh:
            fh.write("\n")
        found = check(d)
    expected = ["lib/discretization.cpp (layer discretization) includes \"alg2.hpp\" (layer "
                "solver, above it)",
                "lib/newfile.hpp: in no layer; place it in LAYERS of tests/check_layers.py"]
    if found != expected:
        print("check_layers self-test failed: found", found, "expected", expected)
        return 1
    print("check_layers self-test: an upward include and an unplaced file are found")
    return 0


def main():
    if len(sys.argv) == 2 and sys.argv[1] == "--self-test":
        return self_test()
    if len(sys.argv) != 2:
        print(__doc__.strip().splitlines()[-2].strip())
        return 2
    lib = os.path.join(sys.argv[1], "lib")
    if not os.path.isdir(lib):
        print(f"check_layers: {lib}: no such directory")
        return 1
    problems = check(lib)
    for p in problems:
        print(p)
    if problems:
        return 1
    n = sum(1 for f in os.listdir(lib) if re.search(r"\.(hpp|cpp|h|cpp\.in)$", f))
    print(f"check_layers: {n} files of lib/ in {len(LAYERS)} layers, no include goes up")
    return 0


if __name__ == "__main__":
    sys.exit(main())
