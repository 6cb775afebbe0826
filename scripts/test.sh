#!/usr/bin/env bash
# The whole test suite -- the README's test command, and what CI runs (.ci/run):
#   0. the size check (scripts/check-sizes.sh), before anything is built;
#   1. the Release build (scripts/build.sh) and every test (the Python module's pytest tests too);
#   1b. the build without MPI (core and executable only, in build-nompi): it must build,
#      and say how to get the MPI build when started by mpirun with several processes;
#   2. the asan preset (CMakePresets.json): every test under AddressSanitizer +
#      UndefinedBehaviorSanitizer, built with clang into build-asan (with the fuzz targets);
#   3. the tsan preset: the multithreaded tests (renderer, light mesh, back-ends, CLI
#      determinism) under ThreadSanitizer, in build-tsan;
#   4. each fuzzer for 10 s (scripts/fuzz.sh; FUZZ_SECONDS changes it) on the asan build.
# Usage: scripts/test.sh [--quick] [ctest options...]
#   --quick   step 1 only, for a fast check while developing (CI always runs everything).
# Extra options go to every ctest run, e.g. -R SceneFile.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
quick=0
args=()
for a in "$@"; do
  if [ "$a" = --quick ]; then quick=1; else args+=("$a"); fi
done
jobs="$(nproc)"
start=$SECONDS
step() { echo "== test.sh: $* ($((SECONDS - start)) s)" >&2; }

scripts/install-deps.sh
step "size check"
scripts/check-sizes.sh

step "Release build and tests"
# ccache for the builds this script configures (a new build directory takes CMake's
# CMAKE_CXX_COMPILER_LAUNCHER from the environment): the build without MPI compiles the
# same core library as the Release build, and gets its objects from the cache.
if command -v ccache >/dev/null; then
  export CMAKE_C_COMPILER_LAUNCHER=ccache CMAKE_CXX_COMPILER_LAUNCHER=ccache
fi
# The test program as a unity build (LIGHTMESH_UNITY_TESTS): 40 % less of its compile time.
scripts/build.sh -DLIGHTMESH_UNITY_TESTS=ON
# -LE real: the real scenes' checks need downloads; scripts/test-real-scenes.sh runs them.
(cd build && ctest --output-on-failure -LE real -j"$jobs" "${args[@]}")
[ "$quick" = 1 ] && exit 0

step "build without MPI"
cmake -S . -B build-nompi -G Ninja -DCMAKE_BUILD_TYPE=Release -DLIGHTMESH_ENABLE_MPI=OFF \
  -DLIGHTMESH_BUILD_TESTS=OFF -DLIGHTMESH_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build build-nompi --target lightmesh -j "$jobs"
if message="$(OMPI_COMM_WORLD_SIZE=2 OMPI_COMM_WORLD_RANK=0 build-nompi/apps/lightmesh render builtin:gazebo \
               -o build-nompi/never.png 2>&1 >/dev/null)"; then
  echo "test.sh: the build without MPI rendered under a 2-process launcher" >&2
  exit 1
fi
grep -q "built without MPI: install OpenMPI" <<<"$message" ||
  { echo "test.sh: unexpected message from the build without MPI: $message" >&2; exit 1; }
[ ! -e build-nompi/never.png ] || { echo "test.sh: the build without MPI wrote an image" >&2; exit 1; }

for preset in asan tsan; do
  step "$preset build"
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" -j "$jobs"
  step "$preset tests"
  ctest --preset "$preset" -j"$jobs" "${args[@]}"
done

step "fuzzing, ${FUZZ_SECONDS:-10} s per target"
FUZZ_BUILD_DIR=build-asan FUZZ_LIBRARY_FINDINGS=report scripts/fuzz.sh "${FUZZ_SECONDS:-10}"
step "all passed"
