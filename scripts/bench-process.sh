#!/usr/bin/env bash
# Times whole `lightmesh render` processes as a user runs them: no shadows, RT and LMM (the
# default variant), interleaved so that a change in the machine's load hits all three alike,
# RUNS times each (default 5). Prints the medians of the render phase (--stats) and of the
# whole process (load, build, render, write), and the ratios of the medians.
# Usage: scripts/bench-process.sh SCENE [RUNS] [extra options for lightmesh render...]
# Example: scripts/bench-process.sh scenes/real/castle.json 5 --width 1024 --height 768
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
exe="${LIGHTMESH:-$root/build/apps/lightmesh}"
[ $# -ge 1 ] || { echo "usage: $0 SCENE [RUNS] [render options...]" >&2; exit 2; }
scene="$1"; shift
runs=5
if [ $# -ge 1 ] && [[ "$1" =~ ^[0-9]+$ ]]; then runs="$1"; shift; fi
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
methods=(none rt lmm)
for ((i = 0; i < runs; ++i)); do
  for m in "${methods[@]}"; do
    start=$(date +%s.%N)
    "$exe" render "$scene" --shadows "$m" -o "$out/$m.png" --stats -q "$@" >"$out/log"
    end=$(date +%s.%N)
    render=$(sed -n 's/.*render \([0-9.]*\) s$/\1/p' "$out/log" | head -1)
    awk -v m="$m" -v r="$render" -v s="$start" -v e="$end" 'BEGIN { print m, r, e - s }' >>"$out/times"
  done
done
median() {  # METHOD COLUMN
  awk -v m="$1" -v c="$2" '$1 == m { print $c }' "$out/times" | sort -g |
    awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'
}
echo "scene $scene, $runs interleaved runs per method, options: ${*:-the scene defaults}"
for m in "${methods[@]}"; do
  printf "  %-5s render %.3f s, process %.3f s\n" "$m" "$(median "$m" 2)" "$(median "$m" 3)"
done
awk -v nr="$(median none 2)" -v rr="$(median rt 2)" -v lr="$(median lmm 2)" \
    -v np="$(median none 3)" -v rp="$(median rt 3)" -v lp="$(median lmm 3)" 'BEGIN {
  printf "  LMM/RT: render %.2f, process %.2f; shadow part (LMM - none)/(RT - none): render %.2f\n",
         lr / rr, lp / rp, (lr - nr) / (rr - nr) }'
