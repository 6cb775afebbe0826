#!/usr/bin/env bash
# The main job: install what is missing, build, then render the built-in gazebo scene with
# the default soft shadows (the lights' spheres, from the light mesh's cells) and with
# Whitted's hard shadows (RT), and print both times. Images: gazebo-soft.png and
# gazebo-rt.png in the current folder.
# Usage: scripts/demo.sh [extra options for lightmesh render, e.g. --width 1024 --height 768]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/scripts/build.sh"
exe="$root/build/apps/lightmesh"
echo
# Each process is timed whole too (start-up, loading, set-up, render and the PNG write).
start=$(date +%s%N)
"$exe" render builtin:gazebo -o gazebo-soft.png --stats "$@" | tee /tmp/lightmesh-soft.txt
softWhole=$(( $(date +%s%N) - start ))
echo
start=$(date +%s%N)
"$exe" render builtin:gazebo --shadows rt -o gazebo-rt.png --stats "$@" | tee /tmp/lightmesh-rt.txt
rtWhole=$(( $(date +%s%N) - start ))
soft=$(sed -n 's/.*render \([0-9.]*\) s$/\1/p' /tmp/lightmesh-soft.txt | head -1)
rt=$(sed -n 's/.*render \([0-9.]*\) s$/\1/p' /tmp/lightmesh-rt.txt | head -1)
echo
awk -v l="$softWhole" -v r="$rtWhole" 'BEGIN { printf "whole process: default (soft) %.3f s, RT %.3f s, soft/RT = %.2f\n", l / 1e9, r / 1e9, l / r }'
awk -v l="$soft" -v r="$rt" 'BEGIN { printf "render time: default (soft shadows) %.3f s, RT (hard shadows) %.3f s, soft/RT = %.2f\n", l, r, l / r }'
