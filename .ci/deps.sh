#!/usr/bin/env bash
# Installs the Debian packages this project needs, if any is missing. As root it runs apt-get;
# otherwise it prints the exact command to run and fails.
#   bash .ci/deps.sh        what `make figures` and `make test` need
#   bash .ci/deps.sh peer   also the independent dolfinx solver of `make verify` (never CI's)
set -euo pipefail
packages=(cmake make g++ pkg-config libeigen3-dev libsuitesparse-dev libopenblas-dev
          gmsh libgmsh-dev libhdf5-dev libtomlplusplus-dev libgtest-dev clang-format
          python3-matplotlib python3-h5py python3-numpy python3-meshio ccache)
if [[ ${1:-} == peer ]]; then packages+=(python3-dolfinx python3-gmsh); fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then exit 0; fi
if [[ $(id -u) -eq 0 ]]; then
  echo "Installing missing packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "Missing Debian packages: ${missing[*]}" >&2
  echo "Install them with:" >&2
  echo "  sudo apt-get update && sudo apt-get install -y ${missing[*]}" >&2
  exit 1
fi
