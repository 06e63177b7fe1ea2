#!/bin/sh
# `make install` into a temporary prefix (a CTest): ltl_run and the Python reader are installed,
# run from there, and read a results file.  Usage: check_install.sh BUILD_DIR SOURCE_DIR
set -eu
build=$1
src=$2
prefix=$(mktemp -d)
trap 'rm -rf "$prefix"' EXIT
cmake --install "$build" --prefix "$prefix" > "$prefix.log"
cat "$prefix.log"; rm -f "$prefix.log"
test -x "$prefix/bin/ltl_run" || { echo "no $prefix/bin/ltl_run"; exit 1; }
test -x "$prefix/bin/ltl-results" || { echo "no $prefix/bin/ltl-results"; exit 1; }
module=$(find "$prefix/lib" -name ltl_results.py)
test -n "$module" || { echo "ltl_results.py not installed"; exit 1; }
test -f "$(dirname "$module")/ltl_plot.py" || { echo "ltl_plot.py (ltl-results plot) not installed"; exit 1; }
# A small run with the installed runner, read by the installed reader.
sed -n '/R"(parameters/,/^)";/p' "$src/tests/testing.hpp" | sed '1s/.*R"(//;$d' > "$prefix/body"
{ printf 'name = "case"\n[mesh]\ngeometry = "%s"\n' "$src/experiments/fig5/half_disc.geo"
  cat "$prefix/body"; } > "$prefix/case.toml"
"$prefix/bin/ltl_run" "$prefix/case.toml" -q -o "$prefix/case.h5"
"$prefix/bin/ltl-results" "$prefix/case.h5" | tee "$prefix/summary"
grep -q "status: complete" "$prefix/summary"
PYTHONPATH=$(dirname "$module") /usr/bin/python3 -c "
import ltl_results, sys
assert ltl_results.__file__.startswith('$prefix'), ltl_results.__file__
r = ltl_results.load('$prefix/case.h5')
assert len(r.steps) == 1 and r.steps[0].equilibrium['force_residual'] < 0.1
print('installed reader OK:', ltl_results.__file__)"
