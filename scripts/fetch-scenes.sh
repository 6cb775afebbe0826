#!/usr/bin/env bash
# Fetches the real scenes' models from Debian packages into the lightmesh cache
# (${XDG_CACHE_HOME:-~/.cache}/lightmesh), outside the source tree. Only `apt-get download`
# and `dpkg -x` touch the network and the packages; nothing is installed.
# Scene files in scenes/ refer to these models as "cache:<path>" (see README).
# Usage: scripts/fetch-scenes.sh        (idempotent: skips what is already there)
set -euo pipefail
cache="${XDG_CACHE_HOME:-$HOME/.cache}/lightmesh"
debs="$cache/debs"; pkg="$cache/packages"; models="$cache/models"
mkdir -p "$debs" "$pkg" "$models"

fetch() {  # fetch PACKAGE: download and unpack it once
  local p=$1
  if [ ! -d "$pkg/$p" ]; then
    if ! ls "$debs/$p"_*.deb >/dev/null 2>&1; then
      echo "fetch-scenes: downloading $p" >&2
      (cd "$debs" && apt-get download "$p" >/dev/null 2>&1) || {
        apt-get update -qq >/dev/null 2>&1 || true
        (cd "$debs" && apt-get download "$p")
      }
    fi
    dpkg -x "$debs/$p"_*.deb "$pkg/$p.tmp" && mv "$pkg/$p.tmp" "$pkg/$p"
  fi
}

# Sweet Home 3D's Scopia furniture library (sweethome3d-furniture): the garden gazebo
# ("barnum", like the paper's Gazebo), the playground climbing frame ("parque") and a
# Japanese maple (foliage: 198k triangles of leaves and branches).
fetch sweethome3d-furniture
if [ ! -f "$models/scopia/barnum/barnum.obj" ] || [ ! -f "$models/scopia/parque/parque.obj" ] ||
   [ ! -f "$models/scopia/japaneseMaple/japaneseMaple.obj" ]; then
  python3 - "$pkg/sweethome3d-furniture/usr/share/sweethome3d/furniture/Scopia.sh3f" "$models" <<'PY'
import sys, zipfile
archive, out = sys.argv[1], sys.argv[2]
with zipfile.ZipFile(archive) as z:
    for name in z.namelist():
        if name.startswith(("scopia/barnum/", "scopia/parque/", "scopia/japaneseMaple/")) and not name.endswith("/"):
            z.extract(name, out)
PY
fi

# Castle Game Engine's demo castle (castle-game-engine-doc): glTF with instanced trees,
# like the paper's "Child park" in size.
fetch castle-game-engine-doc
src="$pkg/castle-game-engine-doc/usr/share/doc/castle-game-engine-doc/examples/mobile/simple_3d_demo/data"
if [ ! -f "$models/castle/castle.gltf" ]; then
  mkdir -p "$models/castle.tmp"
  cp -r "$src"/. "$models/castle.tmp/"
  # Debian compresses large documentation files; glTF needs its buffers as they were.
  find "$models/castle.tmp" -name '*.gz' -exec gunzip -f {} +
  rm -rf "$models/castle" && mv "$models/castle.tmp" "$models/castle"
fi

# MORSE's land-1 environment (morse-simulator-data): a garden with instanced trees, like
# the paper's "Garden" (Blender file, Z up).
fetch morse-simulator-data
src="$pkg/morse-simulator-data/usr/share/morse/data/environments/land-1"
if [ ! -f "$models/land-1/buildings_2.blend" ]; then
  mkdir -p "$models/land-1.tmp"
  cp -r "$src"/. "$models/land-1.tmp/"
  find "$models/land-1.tmp" -name '*.gz' -exec gunzip -f {} +
  rm -rf "$models/land-1" && mv "$models/land-1.tmp" "$models/land-1"
fi

echo "fetch-scenes: models in $models:" >&2
for f in scopia/barnum/barnum.obj scopia/parque/parque.obj scopia/japaneseMaple/japaneseMaple.obj castle/castle.gltf land-1/buildings_2.blend; do
  if [ -f "$models/$f" ]; then echo "  $f"; else echo "  $f MISSING" >&2; exit 1; fi
done
