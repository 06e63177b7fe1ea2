#!/bin/sh
# `ltl-results plot` on two tiny runs (a CTest): a block pressed on a plane by a ramped pressure
# (load factor against displacement, with the contact force) and a block stretched by a ramped
# prescribed displacement (the support's reaction against its displacement, checked against
# the closed form 2 (C1 + C2)(lambda - lambda^-3) a): each gives a PNG. Skipped (exit 77) when
# matplotlib is not installed.  Usage: check_plot.sh BUILD_DIR SOURCE_DIR PYTHON
set -eu
build=$1
src=$(cd "$2" && pwd)
python=$3
if ! "$python" -c "import matplotlib" 2>/dev/null; then
  echo "SKIPPED: matplotlib is not installed for $python (Debian: python3-matplotlib)"
  exit 77
fi
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
run="$build/experiments/ltl_run"
plot="$src/figures/ltl_results.py"
# 1. Force control, with contact.
"$run" "$src/experiments/first_problem/block.toml" -q -o "$dir/block.h5" \
  --set 'load.ramp="linear"' --set 'load.ramp_time="2 s"' --set time.steps=2
"$python" "$plot" plot "$dir/block.h5" -o "$dir/block.png" > "$dir/block.out"
cat "$dir/block.out"
grep -q "load factor against displacement" "$dir/block.out"
grep -q "contact force" "$dir/block.out"
# 2. Displacement control: [[fixed]] with a per-component value, ramped (tests/geometry/).
"$run" "$src/tests/geometry/stretch.toml" -q -o "$dir/stretch.h5" \
  --set 'load.ramp_time="2 s"' --set time.steps=2
"$python" "$plot" plot "$dir/stretch.h5" > "$dir/stretch.out"
cat "$dir/stretch.out"
test -f "$dir/stretch.png"
# The printed curve (x = support displacement, y = its reaction) against the closed form.
"$python" - "$dir/stretch.out" "$dir/block.png" "$dir/stretch.png" <<'PY'
import sys
import matplotlib.image
lines = open(sys.argv[1]).read().split("# ")[1].splitlines()
assert lines[0].startswith("(a) reaction against prescribed displacement"), lines[0]
rows = [tuple(map(float, l.split())) for l in lines[2:]]
assert len(rows) == 3, rows
for x, y in rows:
    lam = 1 + x / 0.1
    exact = 2 * (435e3 + 65e3) * (lam - lam ** -3) * 0.1
    assert abs(y - exact) <= 1e-5 * max(abs(exact), 1.0), (x, y, exact)
for png in sys.argv[2:]:
    image = matplotlib.image.imread(png)
    assert image.shape[0] > 200 and image.shape[1] > 400, (png, image.shape)
print("plots OK:", ", ".join(sys.argv[2:]))
PY
