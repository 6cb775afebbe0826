#!/bin/sh
# fetch-bench-mesh.sh -- the real meshes bench_accel's "trees" scene uses.
#
# Two trees of Debian's sweethome3d-furniture package (Scopia collection, CC-BY 3.0):
# japaneseMaple.obj (198,396 triangles) and copperBeech.obj (187,308 triangles), 385,704 in
# all, a garden like the paper's "Garden" scene (234,568 triangles). No single mesh file of
# more than 200,000 triangles was found in a Debian 12 package; these two are the largest
# real meshes there (cura's UltimakerRobot_support.stl has 187,974).
#
# Only `apt-get download` and `dpkg -x` touch the package archive (run `apt-get update`
# first on a fresh machine); the .sh3f furniture library is a zip file, unpacked locally.
# Files land in ${XDG_CACHE_HOME:-$HOME/.cache}/lightmesh/garden/, where bench_accel looks
# by default (or set LIGHTMESH_BENCH_MESH to a ':'-separated list of mesh files).
set -eu

cache="${XDG_CACHE_HOME:-$HOME/.cache}/lightmesh"
dest="$cache/garden"
maple="$dest/scopia/japaneseMaple/japaneseMaple.obj"
beech="$dest/scopia/copperBeech/copperBeech.obj"

if [ -f "$maple" ] && [ -f "$beech" ]; then
    echo "already there: $maple $beech"
    exit 0
fi

work="$cache/download"
mkdir -p "$work" "$dest"
cd "$work"
if ! ls sweethome3d-furniture_*.deb >/dev/null 2>&1; then
    # apt-get download writes to the current folder; as root it warns that _apt cannot
    # write there, which is harmless.
    apt-get download sweethome3d-furniture || {
        echo "fetch-bench-mesh: apt-get download failed; run 'apt-get update' first" >&2
        exit 1
    }
fi
rm -rf "$work/pkg"
dpkg -x sweethome3d-furniture_*.deb "$work/pkg"
library="$work/pkg/usr/share/sweethome3d/furniture/Scopia.sh3f"
[ -f "$library" ] || { echo "fetch-bench-mesh: $library not in the package" >&2; exit 1; }

if command -v unzip >/dev/null 2>&1; then
    unzip -o -q "$library" 'scopia/japaneseMaple/*' 'scopia/copperBeech/*' -d "$dest"
else
    python3 - "$library" "$dest" <<'EOF'
import sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as z:
    for name in z.namelist():
        if name.startswith(("scopia/japaneseMaple/", "scopia/copperBeech/")):
            z.extract(name, sys.argv[2])
EOF
fi
rm -rf "$work"  # the .deb (120 MB) is not needed any more
echo "garden meshes: $maple $beech"
