#!/usr/bin/env python3
"""Writes the glTF files of the cameras-and-lights tests (run from this folder).

lit_scene.gltf: a grey floor quad (20 x 20 at y = 0) and a red unit cube standing at the
origin; two cameras ("Main" from the front, the first; "Top" straight down, image up = -z,
right = +x); four lights: "Bulb" a point light at (0, 4, 4), 10 cd; "Spot" a spot light at
(4, 5, 0) shining down, cone half-angles 10 and 20 degrees, 25 cd; "Sun" a directional
light travelling along (1, -1, 0)/sqrt(2), 0.8 lux, so the cube's shadow falls on the
floor at x in [0.5, 1.5], z in [-0.5, 0.5]. The other files are variants for the hostile
cases and the many-lights case.
"""
import base64
import json
import math
import struct


def normalize(v):
    n = math.sqrt(sum(c * c for c in v))
    return [c / n for c in v]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def quat_from_basis(x, y, z):
    """The unit quaternion (x, y, z, w) of the rotation whose columns are x, y, z."""
    m = [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]]
    t = m[0][0] + m[1][1] + m[2][2]
    if t > 0:
        s = math.sqrt(t + 1.0) * 2
        return [(m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s]
    if m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2
        return [0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s]
    if m[1][1] > m[2][2]:
        s = math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2
        return [(m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s]
    s = math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2
    return [(m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s]


def look_rotation(eye, target, up=(0, 1, 0)):
    """The node rotation that points a glTF camera or light (-z) from eye at target."""
    back = normalize([e - t for e, t in zip(eye, target)])
    right = normalize(cross(up, back))
    true_up = cross(back, right)
    return quat_from_basis(right, true_up, back)


def direction_rotation(d):
    """The node rotation whose -z is the direction d."""
    back = normalize([-c for c in d])
    helper = [0, 0, 1] if abs(back[1]) > 0.9 else [0, 1, 0]
    right = normalize(cross(helper, back))
    return quat_from_basis(right, cross(back, right), back)


def geometry():
    pos = [(-10, 0, -10), (10, 0, -10), (10, 0, 10), (-10, 0, 10)]  # floor
    floor_idx = [0, 2, 1, 0, 3, 2]  # facing +y
    c = []
    for x in (-0.5, 0.5):
        for y in (0.0, 1.0):
            for z in (-0.5, 0.5):
                c.append((x, y, z))
    # Cube corners: index = 4*ix + 2*iy + iz; faces wound outwards.
    cube = [0, 1, 3, 0, 3, 2,  4, 6, 7, 4, 7, 5,  0, 4, 5, 0, 5, 1,  2, 3, 7, 2, 7, 6,  0, 2, 6, 0, 6, 4,  1, 5, 7, 1, 7, 3]
    return pos, floor_idx, c, cube


def build(cameras, lights, camera_nodes, light_nodes):
    floor_pos, floor_idx, cube_pos, cube_idx = geometry()
    blob = b""
    views, accessors = [], []

    def add(data, fmt, count, target, acc_type, comp, minmax=None):
        nonlocal blob
        offset = len(blob)
        raw = struct.pack("<" + fmt * (len(data)), *data)
        blob += raw
        while len(blob) % 4:
            blob += b"\0"
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(raw), "target": target})
        acc = {"bufferView": len(views) - 1, "componentType": comp, "count": count, "type": acc_type}
        if minmax:
            acc["min"], acc["max"] = minmax
        accessors.append(acc)
        return len(accessors) - 1

    def flat(points):
        return [c for p in points for c in p]

    def bounds(points):
        return [[min(p[i] for p in points) for i in range(3)], [max(p[i] for p in points) for i in range(3)]]

    fp = add(flat(floor_pos), "f", 4, 34962, "VEC3", 5126, bounds(floor_pos))
    fi = add(floor_idx, "I", 6, 34963, "SCALAR", 5125)
    cp = add(flat(cube_pos), "f", 8, 34962, "VEC3", 5126, bounds(cube_pos))
    ci = add(cube_idx, "I", 36, 34963, "SCALAR", 5125)
    nodes = [{"name": "Floor", "mesh": 0}, {"name": "Cube", "mesh": 1}]
    nodes += camera_nodes + light_nodes
    gltf = {
        "asset": {"version": "2.0", "generator": "lightmesh tests/data/cameras_lights/make_test_files.py"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": [
            {"name": "Floor", "primitives": [{"attributes": {"POSITION": fp}, "indices": fi, "material": 0}]},
            {"name": "Cube", "primitives": [{"attributes": {"POSITION": cp}, "indices": ci, "material": 1}]},
        ],
        "materials": [
            {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0}},
            {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.1, 0.1, 1], "metallicFactor": 0}},
        ],
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    if cameras:
        gltf["cameras"] = cameras
    if lights:
        gltf["extensionsUsed"] = ["KHR_lights_punctual"]
        gltf["extensions"] = {"KHR_lights_punctual": {"lights": lights}}
    return gltf


def camera_node(name, index, eye, target, up=(0, 1, 0)):
    return {"name": name, "camera": index, "translation": list(eye), "rotation": look_rotation(eye, target, up)}


def light_node(name, index, position, direction=None):
    n = {"name": name, "translation": list(position), "extensions": {"KHR_lights_punctual": {"light": index}}}
    if direction:
        n["rotation"] = direction_rotation(direction)
    return n


CAMERAS = [
    {"name": "Main", "type": "perspective", "perspective": {"yfov": math.radians(40), "aspectRatio": 1.5,
                                                             "znear": 0.1}},
    {"name": "Top", "type": "perspective", "perspective": {"yfov": math.radians(60), "znear": 0.1}},
]
CAMERA_NODES = [camera_node("Main", 0, (0, 3, 6), (0, 0.5, 0)),
                camera_node("Top", 1, (0, 12, 0), (0, 0, 0), up=(0, 0, -1))]
LIGHTS = [
    {"name": "Bulb", "type": "point", "color": [1, 1, 1], "intensity": 10},
    {"name": "Spot", "type": "spot", "color": [1, 1, 1], "intensity": 25,
     "spot": {"innerConeAngle": math.radians(10), "outerConeAngle": math.radians(20)}},
    {"name": "Sun", "type": "directional", "color": [1, 1, 1], "intensity": 0.8},
]
LIGHT_NODES = [light_node("Bulb", 0, (0, 4, 4)),
               light_node("Spot", 1, (4, 5, 0), (0, -1, 0)),
               light_node("Sun", 2, (0, 0, 0), (1, -1, 0))]


def write(name, gltf):
    with open(name, "w") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")


def collada():
    """lit_scene.dae: the floor and the cube of lit_scene.gltf in COLLADA, with its camera
    "Main" (xfov: COLLADA's full horizontal angle, 2 atan(1.5 tan 20°) = 57.2°, aspect 1.5:
    the same view as the glTF's) and its point light (quadratic attenuation 1: inverse
    square, 10) and sun (directional, 0.8); nodes place them with matrices."""
    floor_pos, floor_idx, cube_pos, cube_idx = geometry()
    pos = list(floor_pos) + list(cube_pos)
    idx = list(floor_idx) + [i + 4 for i in cube_idx]

    def matrix(translation, rotation):
        x, y, z, w = rotation
        r = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
             [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
             [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
        rows = [r[i] + [translation[i]] for i in range(3)] + [[0, 0, 0, 1]]
        return " ".join("%.9g" % v for row in rows for v in row)

    xfov = math.degrees(2 * math.atan(1.5 * math.tan(math.radians(20))))
    cam = matrix((0, 3, 6), look_rotation((0, 3, 6), (0, 0.5, 0)))
    bulb = matrix((0, 4, 4), (0, 0, 0, 1))
    sun = matrix((0, 0, 0), direction_rotation((1, -1, 0)))
    return f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><up_axis>Y_UP</up_axis></asset>
  <library_cameras><camera id="cam" name="Main"><optics><technique_common><perspective>
    <xfov>{xfov:.6f}</xfov><aspect_ratio>1.5</aspect_ratio><znear>0.1</znear><zfar>100</zfar>
  </perspective></technique_common></optics></camera></library_cameras>
  <library_lights>
    <light id="bulb" name="Bulb"><technique_common><point><color>10 10 10</color>
      <constant_attenuation>0</constant_attenuation><linear_attenuation>0</linear_attenuation>
      <quadratic_attenuation>1</quadratic_attenuation></point></technique_common></light>
    <light id="sun" name="Sun"><technique_common><directional><color>0.8 0.8 0.8</color></directional></technique_common></light>
  </library_lights>
  <library_geometries><geometry id="geo" name="Scene"><mesh>
    <source id="pos"><float_array id="pos-a" count="{3 * len(pos)}">{" ".join("%g" % c for p in pos for c in p)}</float_array>
      <technique_common><accessor source="#pos-a" count="{len(pos)}" stride="3"><param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
    <vertices id="verts"><input semantic="POSITION" source="#pos"/></vertices>
    <triangles count="{len(idx) // 3}"><input semantic="VERTEX" source="#verts" offset="0"/><p>{" ".join(str(i) for i in idx)}</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="scene">
    <node id="model" name="Model"><instance_geometry url="#geo"/></node>
    <node id="Main" name="Main"><matrix>{cam}</matrix><instance_camera url="#cam"/></node>
    <node id="Bulb" name="Bulb"><matrix>{bulb}</matrix><instance_light url="#bulb"/></node>
    <node id="Sun" name="Sun"><matrix>{sun}</matrix><instance_light url="#sun"/></node>
  </visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
"""


def main():
    write("lit_scene.gltf", build(CAMERAS, LIGHTS, CAMERA_NODES, LIGHT_NODES))
    # The sun alone, for the shadow methods' comparison.
    write("sun_only.gltf", build(CAMERAS[:1], LIGHTS[2:], CAMERA_NODES[:1],
                                 [light_node("Sun", 0, (0, 0, 0), (1, -1, 0))]))
    # Hostile cameras: a zero field of view; one wider than 180 degrees; a node scaled to 0.
    for name, fov, scale in (("camera_zero_fov", 0.0, None), ("camera_wide_fov", 3.3, None),
                             ("camera_zero_scale", 0.7, [0, 0, 0])):
        cam = [{"name": "Bad", "type": "perspective", "perspective": {"yfov": fov, "znear": 0.1}}]
        node = camera_node("Bad", 0, (0, 3, 6), (0, 0.5, 0))
        if scale:
            node["scale"] = scale
        write(name + ".gltf", build(cam, LIGHTS[:1], [node], LIGHT_NODES[:1]))
    # Hostile lights: a spot whose inner cone is wider than its outer; one of 90 degrees or
    # more; a negative intensity; a sun on a node scaled to 0.
    for name, light in (
        ("spot_inner_outer", {"name": "S", "type": "spot", "intensity": 5,
                              "spot": {"innerConeAngle": 0.6, "outerConeAngle": 0.3}}),
        ("spot_wide", {"name": "S", "type": "spot", "intensity": 5,
                       "spot": {"innerConeAngle": 0.2, "outerConeAngle": 1.7}}),
        ("light_negative", {"name": "S", "type": "point", "intensity": -5}),
    ):
        write(name + ".gltf", build(CAMERAS[:1], [light], CAMERA_NODES[:1], [light_node("S", 0, (4, 5, 0), (0, -1, 0))]))
    # An orthographic camera first: the default passes over it to the perspective one.
    ortho = [{"name": "Ortho", "type": "orthographic", "orthographic": {"xmag": 3, "ymag": 2, "znear": 0.1,
                                                                          "zfar": 50}}] + CAMERAS[:1]
    write("camera_orthographic.gltf",
          build(ortho, LIGHTS[:1], [camera_node("Ortho", 0, (0, 12, 0), (0, 0, 0), up=(0, 0, -1)),
                                    camera_node("Main", 1, (0, 3, 6), (0, 0.5, 0))], LIGHT_NODES[:1]))
    sun_node = light_node("S", 0, (0, 0, 0), (1, -1, 0))
    sun_node["scale"] = [0, 0, 0]
    write("sun_zero_scale.gltf", build(CAMERAS[:1], LIGHTS[2:], CAMERA_NODES[:1], [sun_node]))
    # (10,000 lights: the test writes that file itself, tests/integration/model_cameras_lights_test.cpp.)
    with open("lit_scene.dae", "w") as f:
        f.write(collada())

if __name__ == "__main__":
    main()

