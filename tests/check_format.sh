#!/bin/sh
# Every C++ source of the repository is as clang-format (the repository's .clang-format) writes
# it; the test fails naming the files that are not. Fix with: make format
# Usage: check_format.sh SOURCE_DIR [CLANG_FORMAT]
set -u
src=${1:?source directory}
cf=${2:-clang-format}
command -v "$cf" > /dev/null 2>&1 || { echo "check_format: $cf not found (bash .ci/deps.sh installs it)"; exit 1; }
bad=0
files=$(find "$src/lib" "$src/tests" "$src/experiments" \( -name '*.cpp' -o -name '*.hpp' \) | sort)
[ -n "$files" ] || { echo "check_format: no C++ sources under $src"; exit 1; }
for f in $files; do
  if ! "$cf" --style=file --dry-run -Werror "$f" > /dev/null 2>&1; then
    echo "not clang-format clean: ${f#$src/}"
    bad=1
  fi
done
[ $bad -eq 0 ] && echo "clang-format clean: $(echo "$files" | wc -l) files"
exit $bad
