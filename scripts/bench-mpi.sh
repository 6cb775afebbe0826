#!/usr/bin/env bash
# bench-mpi.sh -- the MPI benchmark: one frame over MPI ranks on this machine.
#   [RUNS=5] scripts/bench-mpi.sh [SCENE] [render options]
# Default: the MORSE garden (scripts/fetch-scenes.sh) at 1024x768, the default light mesh
# at kI 2. Runs 1 rank x 1 thread, 2 ranks x 1 thread and 1 rank x 2 threads, interleaved,
# RUNS times each; prints the medians of the render phase (rank 0's wall clock from the
# first tile handed out to the gathered image) and of the whole process (mpirun included),
# the speed-ups, and the light-mesh nodes evaluated twice because ranks do not share them.
# --bind-to none: OpenMPI binds each of up to 2 ranks to one core by default, which would
# leave a rank's second thread on the same core.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
exe="${LIGHTMESH:-$root/build/apps/lightmesh}"
scene="${1:-$root/scenes/real/garden.json}"
shift || true
opts=(--width 1024 --height 768 --shadows lmm --ki 2 "$@")
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
declare -A render whole
configs=("1 1" "2 1" "1 2")
for ((run = 0; run < ${RUNS:-5}; ++run)); do
  for c in "${configs[@]}"; do
    read -r n t <<<"$c"
    start=$(date +%s.%N)
    mpirun --oversubscribe --bind-to none -np "$n" "$exe" render "$scene" "${opts[@]}" -t "$t" -q --stats -o "$out/img.png" >"$out/stats"
    end=$(date +%s.%N)
    render[$c]+="$(sed -n 's/.*: render \([0-9.]*\) s$/\1/p' "$out/stats" | head -1) "
    whole[$c]+="$(awk -v a="$start" -v b="$end" 'BEGIN {print b - a}') "
    cp "$out/stats" "$out/stats-$n-$t"
  done
done
median() { tr ' ' '\n' | grep . | sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }
declare -A mr mw
for c in "${configs[@]}"; do
  mr[$c]=$(echo "${render[$c]}" | median)
  mw[$c]=$(echo "${whole[$c]}" | median)
  printf "%s rank(s) x %s thread(s): render %.3f s, whole process %.3f s (medians of %d)\n" ${c} "${mr[$c]}" "${mw[$c]}" "${RUNS:-5}"
done
ratio() { awk -v a="$1" -v b="$2" 'BEGIN {print a / b}'; }
printf "speed-up 2 ranks x 1 thread over 1 rank x 1 thread: render %.2f, whole %.2f (target >= 1.85)\n" \
  "$(ratio "${mr[1 1]}" "${mr[2 1]}")" "$(ratio "${mw[1 1]}" "${mw[2 1]}")"
printf "2 ranks x 1 thread against 1 rank x 2 threads: render %.2f, whole %.2f (target >= 0.95)\n" \
  "$(ratio "${mr[1 2]}" "${mr[2 1]}")" "$(ratio "${mw[1 2]}" "${mw[2 1]}")"
single=$(sed -n 's/.*nodes evaluated \([0-9]*\) (.*/\1/p' "$out/stats-1-1" | head -1)
both=$(sed -n 's/.*nodes evaluated by all ranks together \([0-9,]*\).*/\1/p' "$out/stats-2-1" | tr -d ,)
if [ -n "$single" ] && [ -n "$both" ]; then
  printf "light-mesh nodes: one process %d, 2 ranks together %d: %.1f %% evaluated twice\n" "$single" "$both" \
    "$(awk -v a="$both" -v b="$single" 'BEGIN {print 100 * (a - b) / b}')"
fi
grep '^rank' "$out/stats-2-1"
