#!/usr/bin/env bash
# Installs what lightmesh needs to build, test and benchmark, from Debian 12's packages.
# Does nothing when everything is there already; needs root (or sudo) otherwise.
set -euo pipefail

packages=(cmake ninja-build g++ pkg-config
          libassimp-dev libtinyobjloader-dev libembree-dev libtbb-dev nlohmann-json3-dev libcli11-dev
          libstb-dev libpng-dev libjpeg62-turbo-dev zlib1g-dev libopenexr-dev libgtest-dev libgmock-dev libbenchmark-dev
          libopenmpi-dev openmpi-bin  # mpirun -np N lightmesh render (optional for the build)
          pybind11-dev python3-dev python3-numpy python3-pytest  # the Python module and its tests (optional)
          python3-matplotlib  # examples/radius_sweep.py's plot
          clang libclang-rt-14-dev  # sanitizer builds and libFuzzer (scripts/fuzz.sh)
          ccache  # scripts/test.sh: the build without MPI compiles the core again; ccache serves it
          universal-ctags)  # scripts/check-sizes.sh: the functions' first and last lines
packages+=("$@")

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "install-deps: installing ${missing[*]}" >&2
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
