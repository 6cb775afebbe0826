#!/bin/sh
# bench-accel.sh -- bench_accel on each of its scenes: the builtin gazebo, the teapot in
# a stadium, the two Scopia trees (scripts/fetch-bench-mesh.sh) and the castle and garden
# scene files (scripts/fetch-scenes.sh); scenes whose files are not fetched are left out with
# a note. REPEAT (default 5) repetitions, medians, the repetitions of all rows interleaved
# at random (a shared machine's load changes then hit every row alike); extra arguments go
# to bench_accel.
#
#   scripts/bench-accel.sh [bench_accel flags]      e.g. --benchmark_filter=/1t
set -eu
cd "$(dirname "$0")/.."
bin=build/bench/bench_accel
[ -x "$bin" ] || { echo "bench-accel: build first (scripts/build.sh)" >&2; exit 1; }
models="${XDG_CACHE_HOME:-$HOME/.cache}/lightmesh/models"
files=""
for scene in castle garden; do
    if build/apps/lightmesh info "scenes/real/$scene.json" >/dev/null 2>&1; then
        files="$files${files:+,}scenes/real/$scene.json"
    else
        echo "note: scenes/real/$scene.json does not load (run scripts/fetch-scenes.sh; models in $models); left out"
    fi
done
exec "$bin" ${files:+--scene-file=$files} --benchmark_repetitions="${REPEAT:-5}" \
    --benchmark_enable_random_interleaving=true \
    --benchmark_report_aggregates_only=true "$@"
