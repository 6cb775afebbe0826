#!/usr/bin/env python3
"""Writes a scene of many references to one mesh file (a grid of copies), for measuring
instancing: an OBJ (a UV sphere of 1,024 triangles with normals, or a cube of 12) and a
scene file that places it N times. Deterministic.

  scripts/make-instanced-scene.py [--copies N] [--shape sphere|cube] [--slices S] [--varied] OUT_DIR

--slices sets the sphere's detail (32: 1,024 triangles; 448: 199,808). --varied turns, scales non-uniformly and mirrors some copies (for the differential tests).
`lightmesh render OUT_DIR/SHAPE-N.json -o x.png`; `lightmesh info` lists the instances.
"""
import argparse, json, math, os


def sphere_obj(stacks=17, slices=32):
    v, n, f = [], [], []
    for i in range(stacks + 1):
        th = math.pi * i / stacks
        for j in range(slices):
            ph = 2 * math.pi * j / slices
            p = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            v.append(p), n.append(p)
    idx = lambda i, j: i * slices + (j % slices) + 1
    for i in range(stacks):
        for j in range(slices):
            a, b, c, d = idx(i, j), idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1)
            if i > 0:
                f.append((a, b, c))
            if i < stacks - 1:
                f.append((b, d, c))
    lines = ["v %.6f %.6f %.6f" % p for p in v] + ["vn %.6f %.6f %.6f" % p for p in n]
    lines += ["f %d//%d %d//%d %d//%d" % (a, a, b, b, c, c) for a, b, c in f]
    return "\n".join(lines) + "\n", len(f)


def cube_obj():
    v = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    quads = [(1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4)]
    lines = ["v %d %d %d" % p for p in v]
    for a, b, c, d in quads:
        lines += ["f %d %d %d" % (a, b, c), "f %d %d %d" % (a, c, d)]
    return "\n".join(lines) + "\n", 12


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--copies", type=int, default=5000)
    ap.add_argument("--shape", choices=["sphere", "cube"], default="sphere")
    ap.add_argument("--slices", type=int, default=32)
    ap.add_argument("--varied", action="store_true")
    ap.add_argument("out")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    text, tris = sphere_obj(a.slices // 2 + 1, a.slices) if a.shape == "sphere" else cube_obj()
    mesh = a.shape + ("" if a.shape == "cube" or a.slices == 32 else str(a.slices)) + ".obj"
    with open(os.path.join(a.out, mesh), "w") as f:
        f.write(text)
    side = math.ceil(math.sqrt(a.copies))
    meshes = []
    for k in range(a.copies):
        i, j = k % side, k // side
        t = {"translate": [3.0 * (i - side / 2), 1.0, 3.0 * (j - side / 2)]}
        if a.varied:
            t = {"scale": [1.0 + 0.3 * (k % 3), 0.6 + 0.2 * (k % 4), 1.0 - 0.4 * (k % 5 == 2) - 1.8 * (k % 7 == 3)],
                 "rotate": [[0.3, 1, 0.2, 17.0 * k]], "translate": t["translate"]}
        meshes.append({"file": mesh, "transform": t})
    extent = 3.0 * side
    scene = {
        "camera": {"position": [0.3 * extent, 0.45 * extent, 0.75 * extent], "look_at": [0, 0, 0], "fov": 40},
        "lights": [{"position": [-0.3 * extent, 0.6 * extent, 0.2 * extent], "intensity": 1, "falloff": "none",
                    "radius": 0.01 * extent}],
        "meshes": meshes,
        "ground": {"up": "y", "height": 0},
        "render": {"width": 320, "height": 240},
    }
    name = "%s-%d%s.json" % (mesh[:-4], a.copies, "-varied" if a.varied else "")
    with open(os.path.join(a.out, name), "w") as f:
        json.dump(scene, f, indent=1)
    print(os.path.join(a.out, name), a.copies * tris, "triangles")


if __name__ == "__main__":
    main()
