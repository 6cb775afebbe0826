#!/usr/bin/env bash
# The layer check: the folders of src/lightmesh form layers, lowest first; a file may include
# headers of its own folder and of the folders below it, never above. The build runs this
# (target check_layers), so an include that points up fails it. Unit tests (*_test.cpp) may
# include anything.
#   util        errors, logging, threads, progress, system, counters
#   math        vectors, rays, boxes, SIMD lanes
#   io          images, image comparison
#   texture     images materials sample: mip-maps, lookups, the cache that reads each once
#   geometry    triangles, meshes
#   settings    what controls a render: the settings table, the options
#   accel       ray queries
#   scene       scenes, scene files, mesh import
#   shadow      shadow methods (the light mesh)
#   render      the renderer, the render job
#   distributed MPI
#   bench       the bench harness: runner, tables, HTML report (library lightmesh_bench)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
layers=(util math io texture geometry settings accel scene shadow render distributed bench)
rank() {
  local i
  for i in "${!layers[@]}"; do [ "${layers[$i]}" = "$1" ] && { echo "$i"; return; }; done
  echo -1
}
status=0
cd "$root/src/lightmesh"
for folder in */; do
  folder="${folder%/}"
  own=$(rank "$folder")
  if [ "$own" -lt 0 ]; then
    echo "check-layers: src/lightmesh/$folder is in no layer (add it to scripts/check-layers.sh)" >&2
    status=1
    continue
  fi
  for file in "$folder"/*.h "$folder"/*.cpp; do
    [ -e "$file" ] || continue
    case "$file" in *_test.cpp) continue ;; esac
    while IFS= read -r target; do
      other=$(rank "$target")
      if [ "$other" -gt "$own" ] || [ "$other" -lt 0 ]; then
        echo "check-layers: src/lightmesh/$file includes lightmesh/$target/, a layer above $folder" >&2
        status=1
      fi
    done < <(sed -n 's|^#include "lightmesh/\([a-z_]*\)/.*|\1|p' "$file" | sort -u)
  done
done
exit $status
