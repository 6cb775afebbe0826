#!/usr/bin/env python3
"""Writes the many-light scene files: a scene file with its lights replaced by a grid of
lamps (docs/many-lights.md).

  scripts/many-lights.py BASE.json OUT.json --grid NX NZ --box X0 Z0 X1 Z1 --height Y
                         --intensity I [--range R] [--radius R] [--name TEXT]
                         [--ambient A] [--background R G B] [--check LIGHTMESH]

The lamps stand in an NX x NZ grid over the box [X0, X1] x [Z0, Z1] at height Y (cell
centres), each of intensity I (inverse-square falloff), with a range when given; with
--check LIGHTMESH, lamps that `LIGHTMESH info` finds inside a closed object are left out
(one run per lamp dropped). The
base file's camera, materials, meshes, ground and render object are kept; paths of
meshes given relative to BASE's folder are rewritten relative to OUT's.
"""
import argparse
import json
import os
import re
import subprocess


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("base")
    p.add_argument("out")
    p.add_argument("--grid", nargs=2, type=int, required=True)
    p.add_argument("--box", nargs=4, type=float, required=True)
    p.add_argument("--height", type=float, required=True)
    p.add_argument("--intensity", type=float, required=True)
    p.add_argument("--range", type=float)
    p.add_argument("--radius", type=float)
    p.add_argument("--name")
    p.add_argument("--ambient", type=float)
    p.add_argument("--background", nargs=3, type=float)
    p.add_argument("--check", help="lightmesh binary: drop lamps inside closed objects")
    a = p.parse_args()
    with open(a.base) as f:
        scene = json.load(f)
    nx, nz = a.grid
    x0, z0, x1, z1 = a.box
    lights = []
    for k in range(nz):
        for i in range(nx):
            light = {"position": [round(x0 + (i + 0.5) * (x1 - x0) / nx, 4), a.height,
                                  round(z0 + (k + 0.5) * (z1 - z0) / nz, 4)],
                     "intensity": a.intensity}
            if a.range is not None:
                light["range"] = a.range
            if a.radius is not None:
                light["radius"] = a.radius
            lights.append(light)
    scene["lights"] = lights
    if a.name:
        scene["name"] = a.name
    if a.ambient is not None:
        scene["ambient"] = a.ambient
    if a.background:
        scene["background"] = a.background
    base_dir = os.path.dirname(os.path.abspath(a.base))
    out_dir = os.path.dirname(os.path.abspath(a.out))
    for m in scene.get("meshes", []):
        f = m["file"]
        if not f.startswith("cache:") and not os.path.isabs(f):
            m["file"] = os.path.relpath(os.path.join(base_dir, f), out_dir)
    def write():
        with open(a.out, "w") as f:
            json.dump(scene, f, indent=1)
            f.write("\n")

    write()
    while a.check:
        r = subprocess.run([a.check, "info", a.out], capture_output=True, text=True)
        m = re.search(r"/lights/(\d+)/position: the light .* is inside a closed object", r.stderr)
        if not m:
            break
        del scene["lights"][int(m.group(1))]
        write()
    print("%s: %d lamps" % (a.out, len(scene["lights"])))


if __name__ == "__main__":
    main()
