"""lightmesh.render and lightmesh.load: the CLI's pixels, scenes given as dicts, options and
their errors, the GIL, Ctrl-C, progress, a loaded scene's camera and lights."""
import os
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

SMALL = dict(width=64, height=48)


def cli_exr(cli, tmp_path, scene, *flags):
    out = tmp_path / "cli.exr"
    subprocess.run([cli, "render", scene, "-q", "-o", str(out), *flags], check=True)
    return out


@pytest.mark.parametrize("shadows", ["soft", "rt", "area", "lmm"])
def test_equals_cli_exr_bit_for_bit(lightmesh, cli, tmp_path, shadows):
    options = dict(SMALL, shadows=shadows)
    flags = ["--width", "64", "--height", "48", "--shadows", shadows]
    if shadows == "area":
        options["samples"] = 4
        flags += ["--samples", "4"]
    image = lightmesh.render("builtin:gazebo", **options)
    assert image.dtype == np.float32 and image.shape == (48, 64, 3)
    exr = lightmesh.read_image(cli_exr(cli, tmp_path, "builtin:gazebo", *flags))
    assert image.tobytes() == exr.tobytes()


def test_scene_file_with_options_equals_cli(lightmesh, cli, tmp_path, table_vase):
    _, folder = table_vase
    scene = str(folder / "table_vase.json")
    image = lightmesh.render(scene, width=40, height=30, aa=1, light_radius=0.05, accel="embree")
    flags = ["--width", "40", "--height", "30", "--aa", "1", "--light-radius", "0.05", "--accel", "embree"]
    exr = lightmesh.read_image(cli_exr(cli, tmp_path, scene, *flags))
    assert image.tobytes() == exr.tobytes()


def test_dict_scene_renders_as_its_file(lightmesh, table_vase, monkeypatch):
    scene, folder = table_vase
    monkeypatch.chdir(folder)  # a dict's mesh paths are relative to the current folder
    from_dict = lightmesh.render(scene, width=40, height=30)
    from_file = lightmesh.render(str(folder / "table_vase.json"), width=40, height=30)
    assert from_dict.shape == (30, 40, 3)
    assert from_dict.tobytes() == from_file.tobytes()
    assert from_dict.max() > 0


def test_unknown_keyword_suggests_the_near_one(lightmesh):
    with pytest.raises(lightmesh.Error, match=r"widht=: not an option .*did you mean width=\?"):
        lightmesh.render("builtin:gazebo", widht=64)
    with pytest.raises(lightmesh.Error, match=r"did you mean light_radius=\?"):
        lightmesh.render("builtin:gazebo", light_radis=0.1)


def test_bad_values_are_named_by_their_keyword(lightmesh):
    with pytest.raises(lightmesh.Error, match=r"^width=: must be between 1 and 16384, got 0"):
        lightmesh.render("builtin:gazebo", width=0)
    with pytest.raises(lightmesh.Error, match=r"^shadows=: "):
        lightmesh.render("builtin:gazebo", shadows="hard", **SMALL)
    with pytest.raises(lightmesh.Error, match=r"^variant=: unknown light-mesh variant"):
        lightmesh.render("builtin:gazebo", shadows="lmm", variant="bogus", **SMALL)
    assert issubclass(lightmesh.Error, Exception)


def test_errors_carry_the_file_and_json_path(lightmesh, tmp_path, table_vase):
    scene, _ = table_vase
    scene["lights"][1]["position"] = [1, 2]
    bad = tmp_path / "broken-scene.json"
    bad.write_text(__import__("json").dumps(scene))
    with pytest.raises(lightmesh.Error, match=r"broken-scene\.json /lights/1/position: expected 3 numbers"):
        lightmesh.render(str(bad))
    with pytest.raises(lightmesh.Error, match=r"missing\.json"):
        lightmesh.load(tmp_path / "missing.json")
    with pytest.raises(lightmesh.Error, match=r"<dict>\.json /lights/1/position"):
        lightmesh.render(scene)


def test_render_in_a_thread_leaves_python_running(lightmesh):
    options = dict(width=160, height=120, aa=2, shadows="area", samples=16, threads=1)
    results = {}
    worker = threading.Thread(target=lambda: results.setdefault("image", lightmesh.render("builtin:gazebo", **options)))
    ticks = 0
    worker.start()
    while worker.is_alive():
        ticks += 1
        time.sleep(0.001)
    worker.join()
    assert ticks > 10, "the main thread did not run while the render did (GIL held?)"
    assert results["image"].tobytes() == lightmesh.render("builtin:gazebo", **options).tobytes()


@pytest.mark.parametrize("options", [
    dict(width=640, height=480, aa=4, shadows="area", samples=1024),  # by tiles: minutes
    dict(width=2048, height=1536, aa=4),  # the soft default, by rows of tiles: 12 s on 2 cores
])
def test_keyboard_interrupt_stops_a_long_render(lightmesh, options):
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        lightmesh.render("builtin:gazebo", **options)
    timer.join()
    assert time.monotonic() - start < 20


def test_progress_callback(lightmesh):
    seen = []
    lightmesh.render("builtin:gazebo", width=160, height=120, shadows="rt", progress=seen.append)
    assert seen and seen[-1] == 1.0
    assert all(0 <= f <= 1 for f in seen) and seen == sorted(seen)
    with pytest.raises(ZeroDivisionError):
        lightmesh.render("builtin:gazebo", width=160, height=120, progress=lambda f: 1 / 0)


def test_loaded_scene_light_change_equals_a_fresh_load(lightmesh, table_vase, monkeypatch):
    scene, folder = table_vase
    monkeypatch.chdir(folder)
    loaded = lightmesh.load(scene, width=48, height=36)
    first = loaded.render()
    assert first.tobytes() == lightmesh.render(scene, width=48, height=36).tobytes()
    light = loaded.lights[0]
    assert light.position == pytest.approx((-2.0, 4.0, 2.5))
    light.position = (-1.5, 3.5, 2.0)
    light.radius = 0.3
    light.intensity = (12, 11, 10)
    changed = loaded.render()
    scene["lights"][0].update(position=[-1.5, 3.5, 2.0], radius=0.3, intensity=[12, 11, 10])
    scene["lights"][1]["radius"] = loaded.lights[1].radius  # the default radius it was given
    fresh = lightmesh.render(scene, width=48, height=36)
    assert changed.tobytes() == fresh.tobytes()
    assert changed.tobytes() != first.tobytes()


def test_loaded_scene_camera_and_options(lightmesh):
    loaded = lightmesh.load("builtin:gazebo", **SMALL)
    camera = loaded.camera
    assert len(camera.position) == 3 and camera.fov > 0
    camera.fov = camera.fov * 0.5
    narrow = loaded.render()
    rt = loaded.render(shadows="rt")  # options for one render, over the load's
    assert narrow.tobytes() != rt.tobytes()
    camera.look_at = camera.position
    with pytest.raises(lightmesh.Error, match="camera"):
        loaded.render()


def test_help_lists_options_and_defaults(lightmesh):
    doc = lightmesh.render.__doc__
    for name in ["width", "light_radius", "soft_samples", "no_textures", "shadows"]:
        assert name in doc
    assert "default 640" in doc
    assert set(lightmesh.OPTIONS) >= {"width", "height", "aa", "shadows", "soft_samples"}
