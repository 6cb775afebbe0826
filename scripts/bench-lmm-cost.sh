#!/usr/bin/env bash
# The light mesh's cost against hard shadows, as the README's tables show it:
#   1. 1024x768, CC 100 and 200, kI 1.2, 2, 3: no shadows, RT, Нет and the default
#      (consensus), every method on the same back-end: Embree (the fastest), then the
#      nested grid;
#   2. Нет and СТ with cell summaries (--cell-summaries on), kI 2, on Embree;
#   3. the garden at 3072x1536, kI 2, on Embree.
# Needs the real scenes (scripts/fetch-scenes.sh) and a Release build (scripts/build.sh).
# Writes Markdown and CSV into FOLDER (default docs/bench). About 7 minutes on 2 cores (REPEAT timed runs per cell, default 5).
# Usage: [REPEAT=N] scripts/bench-lmm-cost.sh [FOLDER] [extra bench options, e.g. --threads 2]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
exe="${LIGHTMESH:-$root/build/apps/lightmesh}"
out="${1:-docs/bench}"
shift || true
mkdir -p "$out"
scenes=(--scene builtin:gazebo --scene scenes/real/castle.json --scene scenes/real/parque.json
        --scene scenes/real/garden.json --scene scenes/real/maple.json)
for accel in embree grid; do
  "$exe" bench "${scenes[@]}" --size 1024x768 --cc 100,200 --ki 1.2,2,3 --variants none,consensus \
    --accels "$accel" --repeat "${REPEAT:-5}" --markdown "$out/lmm-cost-1024x768-$accel.md" \
    --csv "$out/lmm-cost-1024x768-$accel.csv" -q "$@"
done
"$exe" bench "${scenes[@]}" --size 1024x768 --cc 100 --ki 2 --variants none,inside --cell-summaries on \
  --accels embree --repeat "${REPEAT:-5}" --markdown "$out/lmm-cost-summaries-on.md" \
  --csv "$out/lmm-cost-summaries-on.csv" -q "$@"
"$exe" bench --scene scenes/real/garden.json --size 3072x1536 --cc 100 --ki 2 --variants none,consensus \
  --accels embree --repeat "${REPEAT:-5}" --markdown "$out/lmm-cost-3072x1536-garden.md" \
  --csv "$out/lmm-cost-3072x1536-garden.csv" -q "$@"
echo "bench-lmm-cost: tables in $out/lmm-cost-*.md"
