#!/usr/bin/env python3
"""Writes the small texture test files of this folder (run it here; the outputs are kept in git):
  quad.obj, quad.mtl, texels.png  a 2 x 2 unit quad in the XY plane facing +z, map_Kd of a
                                  2 x 2 image: red, green (top row), blue, white (bottom row)
  checker_mask.gltf               a 4 x 4 unit quad in the XZ plane at y = 1 facing +y, its
                                  base colour's alpha an 8 x 8 checker, alphaMode MASK at 0.5;
                                  buffer and image embedded as data: URIs
  checker_mask.glb                the same as binary glTF, the image in a buffer view
  texture_transform.gltf          quad.obj's quad as glTF, its base colour a 4 x 4 image of
                                  2 x 2 blocks (red, green on top; blue, white below) moved
                                  by KHR_texture_transform to its top-right block (offset
                                  [0.5, 0], scale 0.5): green all over
"""
import base64, json, struct, zlib


def png(width, height, rgba_rows):
    raw = b"".join(b"\0" + bytes(row) for row in rgba_rows)
    def chunk(kind, data):
        c = kind + data
        return struct.pack(">I", len(data)) + c + struct.pack(">I", zlib.crc32(c) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


# The textured quad (OBJ + MTL + PNG). OBJ's v = 0 is the image's bottom row.
with open("texels.png", "wb") as f:
    f.write(png(2, 2, [[255, 0, 0, 255, 0, 255, 0, 255], [0, 0, 255, 255, 255, 255, 255, 255]]))
with open("quad.mtl", "w") as f:
    f.write("newmtl texels\nKd 0.8 0.8 0.8\nmap_Kd texels.png\n")
with open("quad.obj", "w") as f:
    f.write("mtllib quad.mtl\n"
            "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
            "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
            "usemtl texels\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n")

# The cut-out checker (glTF 2, everything embedded).
n = 8
rows = [[c for x in range(n) for c in (200, 200, 200, 255 if (x + y) % 2 == 0 else 0)] for y in range(n)]
image = png(n, n, rows)
positions = [(-2, 1, -2), (2, 1, -2), (2, 1, 2), (-2, 1, 2)]
uvs = [(0, 0), (1, 0), (1, 1), (0, 1)]
indices = [0, 2, 1, 0, 3, 2]  # counter-clockwise seen from +y
data = (b"".join(struct.pack("<3f", *p) for p in positions) + b"".join(struct.pack("<2f", *t) for t in uvs) +
        b"".join(struct.pack("<H", i) for i in indices))
gltf = {
    "asset": {"version": "2.0", "generator": "lightmesh tests/data/textures/make_test_files.py"},
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0, "name": "checker"}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
    "materials": [{"name": "checker", "alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": True,
                   "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0}}],
    "textures": [{"source": 0, "sampler": 0}],
    "samplers": [{"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}],
    "images": [{"uri": "data:image/png;base64," + base64.b64encode(image).decode()}],
    "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," +
                 base64.b64encode(data).decode()}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                    {"buffer": 0, "byteOffset": 48, "byteLength": 32},
                    {"buffer": 0, "byteOffset": 80, "byteLength": 12}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                   "min": [-2, 1, -2], "max": [2, 1, 2]},
                  {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                  {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}],
}
with open("checker_mask.gltf", "w") as f:
    json.dump(gltf, f, indent=1)
    f.write("\n")

# The same as .glb: one binary buffer holding the geometry and the PNG (a buffer view).
glb = json.loads(json.dumps(gltf))
pad = (4 - len(data) % 4) % 4
binary = data + b"\0" * pad + image
binary += b"\0" * ((4 - len(binary) % 4) % 4)
glb["buffers"] = [{"byteLength": len(binary)}]
glb["bufferViews"].append({"buffer": 0, "byteOffset": len(data) + pad, "byteLength": len(image)})
glb["images"] = [{"bufferView": 3, "mimeType": "image/png"}]
text = json.dumps(glb).encode()
text += b" " * ((4 - len(text) % 4) % 4)
with open("checker_mask.glb", "wb") as f:
    f.write(struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(text) + 8 + len(binary)))
    f.write(struct.pack("<I4s", len(text), b"JSON") + text)
    f.write(struct.pack("<I4s", len(binary), b"BIN\0") + binary)

# KHR_texture_transform: the 2 x 2 quad facing +z with a 4 x 4 image of 2 x 2 blocks, the
# transform showing only its top-right block (glTF's uv origin is the image's top-left
# corner); the quadrants' centres fall on texel centres.
tpositions = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
tuvs = [(0, 1), (1, 1), (1, 0), (0, 0)]  # glTF v runs down the image
tindices = [0, 1, 2, 0, 2, 3]
tdata = (b"".join(struct.pack("<3f", *p) for p in tpositions) + b"".join(struct.pack("<2f", *t) for t in tuvs) +
         b"".join(struct.pack("<H", i) for i in tindices))
block = {(0, 0): (255, 0, 0), (1, 0): (0, 255, 0), (0, 1): (0, 0, 255), (1, 1): (255, 255, 255)}
texels = png(4, 4, [[c for x in range(4) for c in block[(x // 2, y // 2)] + (255,)] for y in range(4)])
transform = {
    "asset": {"version": "2.0", "generator": "lightmesh tests/data/textures/make_test_files.py"},
    "extensionsUsed": ["KHR_texture_transform"],
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0, "name": "quad"}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
    "materials": [{"name": "quarter", "pbrMetallicRoughness": {
        "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0], "scale": [0.5, 0.5]}}},
        "metallicFactor": 0}}],
    "textures": [{"source": 0, "sampler": 0}],
    "samplers": [{"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}],
    "images": [{"uri": "data:image/png;base64," + base64.b64encode(texels).decode()}],
    "buffers": [{"byteLength": len(tdata), "uri": "data:application/octet-stream;base64," +
                 base64.b64encode(tdata).decode()}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                    {"buffer": 0, "byteOffset": 48, "byteLength": 32},
                    {"buffer": 0, "byteOffset": 80, "byteLength": 12}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                   "min": [-1, -1, 0], "max": [1, 1, 0]},
                  {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                  {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}],
}
with open("texture_transform.gltf", "w") as f:
    json.dump(transform, f, indent=1)
    f.write("\n")
