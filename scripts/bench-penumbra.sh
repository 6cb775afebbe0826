#!/usr/bin/env bash
# Contact-hardening penumbrae against true soft shadows (README, "Contact-hardening
# penumbrae against true soft shadows"): per scene, the area-light reference (REF samples,
# light radius R = FRAC × the scene's diagonal), then RUNS interleaved rounds of no shadows,
# RT, the light mesh with its fixed radius, the light mesh with --light-radius R (with the
# default --thin-check all, and with off and lit), and naive soft shadows with 1, 2 and 4
# rays per light, and Нет (the walk without local visibility); prints the median render
# times as ratios to RT from the same rounds and PSNR/SSIM against the reference, then the
# mode's floor with its default --thin-check all: RT's work (P's own ray) plus Нет's walk,
# 1 + (Нет − none) / RT.
#   scripts/bench-penumbra.sh [SCENE...]   (default: gazebo, playground, castle, garden)
# Environment: W, H (1024×768), RUNS (3), FRAC (0.015), REF (256), LM (the binary), OUT
# (folder of the images, default a temporary one).
set -euo pipefail
cd "$(dirname "$0")/.."
LM=${LM:-build/apps/lightmesh}
W=${W:-1024}; H=${H:-768}; RUNS=${RUNS:-3}; FRAC=${FRAC:-0.015}; REF=${REF:-256}
OUT=${OUT:-$(mktemp -d)}
mkdir -p "$OUT"
[ $# -gt 0 ] || set -- builtin:gazebo scenes/real/parque.json scenes/real/castle.json scenes/real/garden.json
methods=(none rt net lmm penumbra-off penumbra-lit penumbra area1 area2 area4)
median() { tr ' ' '\n' | grep . | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
for scene in "$@"; do
  tag=$(basename "$scene" .json | sed 's/^builtin://')
  # The diagonal of the box `info` prints: "bounds [x y z] - [x y z], size ...".
  diag=$("$LM" info "$scene" 2>/dev/null |
         awk '/^bounds/ {gsub(/[\[\],]/, " "); print sqrt(($6-$2)^2 + ($7-$3)^2 + ($8-$4)^2)}')
  R=$(awk -v d="$diag" -v f="$FRAC" 'BEGIN {printf "%.4g", d * f}')
  common=("$scene" --width "$W" --height "$H" -q)
  "$LM" render "${common[@]}" --shadows area --light-radius "$R" --samples "$REF" -o "$OUT/$tag-ref.png" >/dev/null
  declare -A times=()
  for ((i = 0; i < RUNS; ++i)); do
    for m in "${methods[@]}"; do
      case $m in
        none) args=(--shadows none) ;;
        rt) args=(--shadows rt) ;;
        net) args=(--shadows lmm --variant none) ;;
        lmm) args=(--shadows lmm) ;;
        penumbra) args=(--shadows lmm --light-radius "$R") ;;
        penumbra-*) args=(--shadows lmm --light-radius "$R" --thin-check "${m#penumbra-}") ;;
        area*) args=(--shadows area --light-radius "$R" --samples "${m#area}") ;;
      esac
      t=$("$LM" render "${common[@]}" "${args[@]}" -o "$OUT/$tag-$m.png" | grep -o 'render [0-9.]*' | cut -d' ' -f2)
      times[$m]="${times[$m]:-} $t"
    done
  done
  echo "### $tag, ${W}x${H}: light radius $R (${FRAC} of the diagonal $diag), reference $REF rays per light"
  echo
  echo "| method | s (median of $RUNS) | × RT | PSNR dB | SSIM |"
  echo "|---|---|---|---|---|"
  rt=$(echo "${times[rt]}" | median)
  for m in "${methods[@]}"; do
    t=$(echo "${times[$m]}" | median)
    q=$("$LM" compare "$OUT/$tag-ref.png" "$OUT/$tag-$m.png" --json)
    psnr=$(echo "$q" | grep -o '"psnr":[^,]*' | cut -d: -f2)
    ssim=$(echo "$q" | grep -o '"ssim":[^,]*' | cut -d: -f2)
    printf '| %s | %s | %.2f | %.2f | %.4f |\n' "$m" "$t" "$(awk -v a="$t" -v b="$rt" 'BEGIN {print a / b}')" "$psnr" "$ssim"
  done
  echo
  none=$(echo "${times[none]}" | median); net=$(echo "${times[net]}" | median)
  echo "Floor of the penumbra mode with --thin-check all, RT + Нет's walk: $(awk -v n="$net" -v z="$none" -v r="$rt" 'BEGIN {printf "%.2f", 1 + (n - z) / r}')× RT"
  echo
  unset times
done
