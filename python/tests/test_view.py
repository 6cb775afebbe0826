"""The scene-loading and view keywords (camera=, smooth_normals=, camera_position=, look_at=,
up=, fov=): the same images as the CLI's --camera, --smooth-normals, --camera-position,
--look-at, --up and --fov, and the same refusals, worded with the keyword."""
import math
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
TWO_CAMERAS = str(ROOT / "tests" / "data" / "cameras_lights" / "lit_scene.gltf")  # "Main", "Top"
SCENE_FILE = str(ROOT / "scenes" / "table_vase.json")
SIZE = dict(width=48, height=36)
SIZE_FLAGS = ["--width", "48", "--height", "36"]


def cli_image(lightmesh, cli, tmp_path, scene, *flags):
    out = tmp_path / "cli.exr"
    subprocess.run([cli, "render", scene, "-q", "-o", str(out), *SIZE_FLAGS, *flags], check=True)
    return lightmesh.read_image(out)


@pytest.fixture(scope="module")
def flat_sphere(tmp_path_factory):
    """A low-poly sphere OBJ without normals: flat faces unless smoothed."""
    rows, cols = 8, 12
    lines = []
    for i in range(rows + 1):
        theta = math.pi * i / rows
        for j in range(cols):
            phi = 2 * math.pi * j / cols
            lines.append(f"v {math.sin(theta) * math.cos(phi):.6f} {math.cos(theta):.6f} "
                         f"{math.sin(theta) * math.sin(phi):.6f}")
    for i in range(rows):
        for j in range(cols):
            a, b = i * cols + j + 1, i * cols + (j + 1) % cols + 1
            c, d = a + cols, b + cols
            lines.append(f"f {a} {c} {d}")
            lines.append(f"f {a} {d} {b}")
    path = tmp_path_factory.mktemp("sphere") / "sphere.obj"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def test_camera_by_index_and_name(lightmesh, cli, tmp_path):
    first = lightmesh.render(TWO_CAMERAS, **SIZE)
    main = lightmesh.render(TWO_CAMERAS, camera=0, **SIZE)
    top = lightmesh.render(TWO_CAMERAS, camera=1, **SIZE)
    assert main.tobytes() == first.tobytes()  # the first camera is the default
    assert top.tobytes() != main.tobytes()
    assert lightmesh.render(TWO_CAMERAS, camera="Top", **SIZE).tobytes() == top.tobytes()
    assert lightmesh.render(TWO_CAMERAS, camera=np.int64(1), **SIZE).tobytes() == top.tobytes()
    assert top.tobytes() == cli_image(lightmesh, cli, tmp_path, TWO_CAMERAS, "--camera", "1").tobytes()
    # load() takes it too, and its camera is the file's "Top"
    scene = lightmesh.load(TWO_CAMERAS, camera="Top", **SIZE)
    assert scene.render().tobytes() == top.tobytes()


def test_camera_refusals(lightmesh):
    with pytest.raises(lightmesh.Error, match=r"lit_scene.gltf: camera=2: the file has 2 cameras \(indices 0 to 1\)"):
        lightmesh.render(TWO_CAMERAS, camera=2, **SIZE)
    with pytest.raises(lightmesh.Error, match=r"camera='Side': the file has no camera named \"Side\""):
        lightmesh.render(TWO_CAMERAS, camera="Side", **SIZE)
    with pytest.raises(lightmesh.Error, match=r"camera=: an index counts from 0, got -1"):
        lightmesh.render(TWO_CAMERAS, camera=-1, **SIZE)
    with pytest.raises(lightmesh.Error, match=r"camera=: expected a camera's name \(str\) or its index"):
        lightmesh.render(TWO_CAMERAS, camera=True, **SIZE)
    with pytest.raises(lightmesh.Error, match=r"camera=1:.*a builtin scene has its own camera"):
        lightmesh.render("builtin:gazebo", camera=1, **SIZE)
    scene = lightmesh.load(TWO_CAMERAS, **SIZE)
    with pytest.raises(lightmesh.Error, match=r"are load options: give them to lightmesh.load\(\)"):
        scene.render(camera=1)


def test_smooth_normals(lightmesh, cli, tmp_path, flat_sphere):
    flat = lightmesh.render(flat_sphere, smooth_normals=0, **SIZE)
    smooth = lightmesh.render(flat_sphere, smooth_normals=60, **SIZE)
    assert smooth.tobytes() != flat.tobytes()
    # A bare mesh file without normals is smoothed at 60 degrees unless told otherwise.
    assert lightmesh.render(flat_sphere, **SIZE).tobytes() == smooth.tobytes()
    cli_smooth = cli_image(lightmesh, cli, tmp_path, flat_sphere, "--smooth-normals", "60")
    assert smooth.tobytes() == cli_smooth.tobytes()
    assert lightmesh.load(flat_sphere, smooth_normals=60.0, **SIZE).render().tobytes() == smooth.tobytes()
    for bad in (-1, 180.5, float("nan")):
        with pytest.raises(lightmesh.Error, match=r"smooth_normals=: must be between 0 and 180, got"):
            lightmesh.render(flat_sphere, smooth_normals=bad, **SIZE)
    with pytest.raises(lightmesh.Error, match=r"smooth_normals=: expected a number, got '60'"):
        lightmesh.render(flat_sphere, smooth_normals="60", **SIZE)


@pytest.mark.parametrize("scene_name", ["scene_file", "mesh_file"])
def test_view_keywords_equal_the_cli(lightmesh, cli, tmp_path, flat_sphere, scene_name):
    scene = SCENE_FILE if scene_name == "scene_file" else flat_sphere
    cases = [
        (dict(camera_position=(1.5, 2.0, 4.0)), ["--camera-position", "1.5,2,4"]),
        (dict(camera_position=np.array([1.5, 2.0, 4.0]), look_at=[0, 0.5, 0]),
         ["--camera-position", "1.5,2,4", "--look-at", "0,0.5,0"]),
        (dict(fov=30), ["--fov", "30"]),
        (dict(up=(0.2, 1, 0)), ["--up", "0.2,1,0"]),
        (dict(up="z"), ["--up", "z"]),
    ]
    for keywords, flags in cases:
        image = lightmesh.render(scene, **keywords, **SIZE)
        expected = cli_image(lightmesh, cli, tmp_path, scene, *flags)
        assert image.tobytes() == expected.tobytes(), keywords
        assert image.tobytes() != lightmesh.render(scene, **SIZE).tobytes(), keywords


def test_scene_render_moves_the_camera_for_one_render(lightmesh, cli, tmp_path):
    scene = lightmesh.load(SCENE_FILE, **SIZE)
    before = scene.render()
    position = scene.camera.position
    moved = scene.render(camera_position=[1.5, 2, 4], look_at=(0, 0.5, 0), fov=35)
    assert scene.camera.position == position  # the loaded camera is kept
    assert scene.render().tobytes() == before.tobytes()
    expected = cli_image(lightmesh, cli, tmp_path, SCENE_FILE, "--camera-position", "1.5,2,4", "--look-at",
                         "0,0.5,0", "--fov", "35")
    assert moved.tobytes() == expected.tobytes()
    with pytest.raises(lightmesh.Error, match=r"up=: must not be zero"):
        scene.render(up=(0, 0, 0))
    assert scene.render().tobytes() == before.tobytes()


def test_load_option_letter_up_on_a_loaded_mesh_file(lightmesh, flat_sphere):
    scene = lightmesh.load(flat_sphere, up="z", **SIZE)  # turns the model as it is loaded
    with pytest.raises(lightmesh.Error, match=r"up=: for a mesh file a letter names the model's up axis"):
        scene.render(up="x")
    scene.render(up=(0, 1, 0.1))  # 3 numbers are the camera's up


@pytest.mark.parametrize("keywords, message", [
    (dict(camera_position=(float("nan"), 0, 1)), r"camera_position=: every number must be finite and within ±1e18"),
    (dict(look_at=[0, float("inf"), 0]), r"look_at=: every number must be finite"),
    (dict(camera_position=(1, 2)), r"camera_position=: expected 3 numbers \(a sequence or an array\), got \(1, 2\)"),
    (dict(camera_position="1,2,3"), r"camera_position=: expected 3 numbers"),
    (dict(look_at=(0, True, 0)), r"look_at=: expected 3 numbers"),
    (dict(camera_position=(1e19, 0, 0)), r"camera_position=: every number must be finite and within ±1e18"),
    (dict(up=(0, 0, 0)), r"up=: must not be zero"),
    (dict(up="w"), r"up=: expected \"x\", \"y\", \"z\" or 3 numbers, got 'w'"),
    (dict(up=(0, float("nan"), 0)), r"up=: every number must be finite"),
    (dict(fov=0), r"fov=: must be a number of degrees between 0 and 180 \(both excluded\), got 0"),
    (dict(fov=180), r"fov=: must be a number of degrees between 0 and 180 \(both excluded\), got 180"),
    (dict(fov=float("nan")), r"fov=: must be a number of degrees between 0 and 180"),
    (dict(fov="wide"), r"fov=: expected a number, got 'wide'"),
    (dict(camera_position=(1, 2, 3), look_at=(1, 2, 3)), r"look_at=: the camera position equals the point looked at"),
    (dict(camera_position=(0, 2, 8), look_at=(0, 0, 8)),
     r"look_at=: the view direction is now parallel to the scene's up direction; give up= too"),
])
def test_hostile_view_values(lightmesh, keywords, message):
    with pytest.raises(lightmesh.Error, match=message):
        lightmesh.render(SCENE_FILE, **keywords, **SIZE)


def test_view_keywords_suggested_and_documented(lightmesh):
    with pytest.raises(lightmesh.Error, match=r"did you mean smooth_normals=\?"):
        lightmesh.render(SCENE_FILE, smooth_normal=30)
    with pytest.raises(lightmesh.Error, match=r"did you mean camera_position=\?"):
        lightmesh.render(SCENE_FILE, camera_positon=(1, 2, 3))
    for keyword in ("camera", "smooth_normals", "camera_position", "look_at", "up", "fov"):
        assert f"    {keyword} (" in lightmesh.render.__doc__
        assert f"    {keyword} (" in lightmesh.load.__doc__
