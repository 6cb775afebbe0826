#!/usr/bin/env bash
# What --shadows denoised gains at N = 1 over area's N = 1 (docs/denoised-shadows.md): per
# scene, PSNR of `--shadows area --samples 1` and of `--shadows denoised --samples 1`
# against area with 256 rays per light, at 1024x768. References are rendered once into
# REF_DIR (default /tmp/ref, as SCENE-1024.exr) and reused.
# Usage: scripts/denoise-gain.sh [LIGHTMESH] [SCENE ...]
#   SCENE: gazebo, barnum, parque, castle, maple, garden, foliage, terrain (default: all)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bin="${1:-$root/build/apps/lightmesh}"
shift || true
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(gazebo barnum parque castle maple garden foliage terrain)
ref_dir="${REF_DIR:-/tmp/ref}"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
mkdir -p "$ref_dir"
size=(--width 1024 --height 768)
psnr() { "$bin" compare "$1" "$2" --json | sed 's/.*"psnr": *\([0-9.]*\).*/\1/'; }
printf '| scene | area N=1 dB | denoised N=1 dB | gain |\n|---|---|---|---|\n'
for s in "${scenes[@]}"; do
    case "$s" in
        gazebo) path=builtin:gazebo ;;
        foliage) path="$root/scenes/foliage/foliage.json" ;;
        terrain) path="$root/scenes/terrain/terrain.json" ;;
        *) path="$root/scenes/real/$s.json" ;;
    esac
    ref="$ref_dir/$s-1024.exr"
    [ -f "$ref" ] || "$bin" render "$path" -q "${size[@]}" --shadows area --samples 256 -o "$ref"
    "$bin" render "$path" -q "${size[@]}" --shadows area --samples 1 -o "$out/a1.exr"
    "$bin" render "$path" -q "${size[@]}" --shadows denoised --samples 1 -o "$out/d1.exr"
    a=$(psnr "$ref" "$out/a1.exr")
    d=$(psnr "$ref" "$out/d1.exr")
    printf '| %s | %.2f | %.2f | %+.2f |\n' "$s" "$a" "$d" "$(echo "$d - $a" | bc -l)"
done
