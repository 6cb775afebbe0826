"""lightmesh.read_image, write_image and compare: the io code's files and the CLI's figures."""
import json
import math
import subprocess

import numpy as np
import pytest


def test_exr_round_trip_is_exact(lightmesh, tmp_path):
    rng = np.random.default_rng(58)
    image = rng.random((7, 5, 3), dtype=np.float32) * 4
    lightmesh.write_image(tmp_path / "x.exr", image)
    back = lightmesh.read_image(tmp_path / "x.exr")
    assert back.dtype == np.float32 and back.tobytes() == image.tobytes()


def test_png_round_trip_within_8_bits(lightmesh, tmp_path):
    image = np.linspace(0, 1, 4 * 6 * 3, dtype=np.float32).reshape(4, 6, 3)
    lightmesh.write_image(str(tmp_path / "x.png"), image)
    back = lightmesh.read_image(str(tmp_path / "x.png"))
    assert back.shape == image.shape
    assert np.abs(back - image).max() < 0.02


def test_write_image_refuses_bad_input_and_keeps_the_old_file(lightmesh, tmp_path):
    target = tmp_path / "kept.exr"
    target.write_bytes(b"old")
    with pytest.raises(lightmesh.Error, match="expected a \\(height, width, 3\\) array"):
        lightmesh.write_image(target, np.zeros((4, 4)))
    assert target.read_bytes() == b"old"
    with pytest.raises(lightmesh.Error, match=r"x\.jpg"):
        lightmesh.write_image(tmp_path / "x.jpg", np.zeros((2, 2, 3), np.float32))
    with pytest.raises(lightmesh.Error, match=r"nothing\.exr"):
        lightmesh.read_image(tmp_path / "nothing.exr")


def test_compare_gives_the_cli_figures(lightmesh, cli, tmp_path):
    small = dict(width=64, height=48)
    soft = lightmesh.render("builtin:gazebo", **small)
    rt = lightmesh.render("builtin:gazebo", shadows="rt", **small)
    none = lightmesh.render("builtin:gazebo", shadows="none", **small)
    for name, image in [("soft", soft), ("rt", rt), ("none", none)]:
        lightmesh.write_image(tmp_path / f"{name}.exr", image)
    figures = lightmesh.compare(soft, rt, no_shadows=none)
    out = subprocess.run([cli, "compare", str(tmp_path / "soft.exr"), str(tmp_path / "rt.exr"), "--json"],
                         check=True, capture_output=True, text=True).stdout
    expected = json.loads(out)
    for key in ["psnr", "ssim", "rmse", "rmse_linear", "max_diff", "pixels"]:
        assert figures[key] == pytest.approx(expected[key], rel=1e-5), key  # the JSON has 8 digits
    assert figures["pixels"] == 64 * 48 and not figures["identical"]
    assert figures["shadow_total_a"] > 0 and figures["shadow_total_b"] > 0
    assert figures["shadow_ratio"] == pytest.approx(figures["shadow_total_b"] / figures["shadow_total_a"])
    # Paths work as arrays do; an image against itself is identical, PSNR infinite.
    same = lightmesh.compare(tmp_path / "soft.exr", soft)
    assert same["identical"] and math.isinf(same["psnr"])
    mask = np.zeros_like(soft)
    mask[:10] = 1
    assert lightmesh.compare(soft, rt, mask=mask)["pixels"] == 10 * 64


def test_compare_refuses_different_sizes(lightmesh):
    with pytest.raises(lightmesh.Error):
        lightmesh.compare(np.zeros((2, 2, 3), np.float32), np.zeros((3, 2, 3), np.float32))
