#!/usr/bin/env bash
# The real scenes' checks (ctest label "real"): fetches the models from Debian packages
# (scripts/fetch-scenes.sh, into ~/.cache/lightmesh; about 440 MB of packages the first
# time), builds, and runs tests/real/real_scenes_test.cpp -- loading figures, back-ends
# against brute force on real geometry, the default LMM variant leak-free and close to RT,
# У against Ш, thread-count independence -- on scenes/real/*.json. About a minute.
# Usage: scripts/test-real-scenes.sh [ctest options...]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
scripts/fetch-scenes.sh
scripts/build.sh
cd build
LIGHTMESH_REQUIRE_REAL_SCENES=1 ctest --output-on-failure -L real -j"$(nproc)" "$@"
