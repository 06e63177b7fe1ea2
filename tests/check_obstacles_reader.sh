#!/bin/sh
# The Python reader on results files of one and of several obstacles (a CTest): a coarse V-groove
# ([[contact]] x 2, experiments/vgroove) and the first problem ([contact]); the reader splits the
# contact points by obstacle (figures/ltl_results.py: Mesh.obstacles, Mesh.obstacle_points), the
# per-obstacle measures are there and the two faces' resultants balance the load; then the
# example's figure script draws its PNG (skipped without matplotlib).
#   Usage: check_obstacles_reader.sh BUILD_DIR SOURCE_DIR PYTHON
set -eu
build=$1
src=$(cd "$2" && pwd)
python=$3
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
run="$build/experiments/ltl_run"
"$run" "$src/experiments/vgroove/vgroove.toml" -q -o "$dir/vgroove.h5" \
  --set mesh.parameters.n=2 --set time.steps=1
"$run" "$src/experiments/first_problem/block.toml" -q -o "$dir/block.h5"
"$python" - "$src/figures" "$dir/vgroove.h5" "$dir/block.h5" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
import ltl_results as lr
r = lr.load(sys.argv[2])
m, s = r.mesh, r.steps[-1]
assert m.obstacles() == 2, m.obstacles()
k0, k1 = m.obstacle_points(0), m.obstacle_points(1)
assert len(k0) + len(k1) == len(m.contact_area) and len(k0) == len(k1), (len(k0), len(k1))
assert k0.max() < k1.min()                      # obstacle after obstacle
p = s.fields["contact_pressure"]
f0 = float(np.dot(m.contact_area[k0], p[k0]))
assert abs(f0 - s.measures["contact_force"]) < 1e-9 * f0, (f0, s.measures["contact_force"])
load = 2 * 150e3 * 0.02 * 0.25                  # the ramp's factor at t = 1 s: 1/4
ry = s.measures["contact_resultant_y"] + s.measures["contact_resultant_y_1"]
rx = s.measures["contact_resultant_x"] + s.measures["contact_resultant_x_1"]
assert abs(ry - load) < 1e-8 * load and abs(rx) < 1e-8 * load, (rx, ry, load)
b = lr.load(sys.argv[3]).mesh
assert b.obstacles() == 1 and len(b.obstacle_points(0)) == len(b.contact_area)
print("reader: 2 obstacles of %d points each, resultants (%.6g, %.6g) N/m for a load of %.6g N/m;"
      " one obstacle read as before" % (len(k0), rx, ry, load))
PY
if "$python" -c "import matplotlib" 2>/dev/null; then
  "$python" "$src/experiments/vgroove/plot_vgroove.py" "$dir/vgroove.h5" "$dir/vgroove.png"
  test -s "$dir/vgroove.png"
fi
