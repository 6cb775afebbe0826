"""lightmesh.render(..., visibility=True): each light's visibility at each pixel's camera
hits, the very value the shadow method shaded the pixel with."""
import numpy as np
import pytest

from conftest import ROOT

MODELS = ROOT / "scenes" / "models"
SIZE = dict(width=64, height=48)
LIGHTS = [
    {"position": [-2.0, 4.0, 2.5], "intensity": 18, "falloff": "inverse_square", "radius": 0.3},
    {"position": [3.0, 3.0, 1.0], "intensity": 5, "falloff": "inverse_square", "radius": 0.2},
    {"position": [0.5, 2.0, -3.0], "intensity": 4, "falloff": "inverse_square", "radius": 0.1},
]


def scene(lights):
    """The table and vases on a ground, diffuse only, no mirror and no ambient term: a
    pixel is Σ Ω·V over its lights. The camera sees the sky above the table (no hit)."""
    return {
        "camera": {"position": [0.9, 1.2, 3.2], "look_at": [0.25, 0.9, 0], "up": [0, 1, 0], "fov": 45},
        "ambient": 0,
        "background": [0.1, 0.1, 0.1],
        "materials": {"matte": {"kd": 0.7, "ks": 0, "mirror": 0}},
        "lights": lights,
        "meshes": [
            {"file": str(MODELS / "table.obj"), "material": "matte"},
            {"file": str(MODELS / "vase.obj"), "material": "matte", "transform": {"translate": [0.35, 0.78, -0.05]}},
        ],
        "ground": {"height": 0, "up": "y", "size": 3, "material": "matte"},
    }


METHODS = {
    "rt": {},
    "soft": {},
    "area": {"samples": 8},
    "exact": {},
    "denoised": {"samples": 4},
    "lmm": {"cc": 40},
}


@pytest.mark.parametrize("shadows", list(METHODS))
def test_visibility_times_unshadowed_is_the_image(lightmesh, shadows):
    one = scene(LIGHTS[:1])
    options = dict(SIZE, shadows=shadows, **METHODS[shadows])
    image, vis = lightmesh.render(one, visibility=True, **options)
    assert vis.dtype == np.float32 and vis.shape == (48, 64, 1)
    unshadowed = lightmesh.render(one, **dict(SIZE, shadows="none"))
    hit = ~np.isnan(vis[..., 0])
    assert 0 < hit.sum() < hit.size  # the sky is seen
    # Where no camera ray hits: the background, NaN.
    assert np.all(image[~hit] == np.float32(0.1))
    shadowed = vis[..., 0][hit, None] * unshadowed[hit]
    np.testing.assert_allclose(shadowed, image[hit], rtol=1e-6, atol=1e-7)
    # The image is the one rendered without visibility=True, bit for bit.
    assert lightmesh.render(one, **options).tobytes() == image.tobytes()
    # Shadows there are: some pixels see part of the light, some none of it.
    assert np.any(vis[hit] < 0.5) and np.any(vis[hit] == 1)


@pytest.mark.parametrize("shadows", ["rt", "soft", "area", "denoised"])
def test_visibility_of_several_lights(lightmesh, shadows):
    options = dict(SIZE, shadows=shadows, **METHODS.get(shadows, {}))
    image, vis = lightmesh.render(scene(LIGHTS), visibility=True, **options)
    assert vis.shape == (48, 64, 3) and vis.dtype == np.float32
    hit = ~np.isnan(vis[..., 0])
    assert np.all(np.isnan(vis[~hit]))
    assert np.all((vis[hit] >= 0) & (vis[hit] <= 1))
    # Each light casts its own shadows: the lights' values differ somewhere.
    assert np.any(vis[hit][:, 0] != vis[hit][:, 1]) and np.any(vis[hit][:, 1] != vis[hit][:, 2])
    if shadows == "rt":
        assert set(np.unique(vis[hit])) <= {0.0, 1.0}
    else:
        assert np.any((vis[hit] > 0) & (vis[hit] < 1))  # penumbrae


def test_visibility_is_the_mean_over_the_pixel_samples(lightmesh):
    _, vis = lightmesh.render(scene(LIGHTS), visibility=True, shadows="rt", aa=2, **SIZE)
    hit = vis[~np.isnan(vis)]
    # k of the n samples that hit the scene (n = 4 inside, fewer at the sky's edge) see it.
    means = {np.float32(k) / np.float32(n) for n in range(1, 5) for k in range(n + 1)}
    assert set(np.unique(hit)) <= means
    assert np.any(hit == 0.25) and np.any(hit == 0.75)  # pixels across a shadow's edge
    assert np.any((hit == np.float32(1 / 3)) | (hit == np.float32(2 / 3)) | (hit == 0.5))  # the sky's edge


@pytest.mark.parametrize("shadows", ["soft", "area", "denoised"])
def test_visibility_is_the_same_for_any_thread_count(lightmesh, shadows):
    options = dict(SIZE, shadows=shadows, visibility=True, **METHODS.get(shadows, {}))
    one = lightmesh.render(scene(LIGHTS), threads=1, **options)[1]
    two = lightmesh.render(scene(LIGHTS), threads=2, **options)[1]
    assert one.tobytes() == two.tobytes()


def test_loaded_scene_visibility_and_bad_values(lightmesh):
    loaded = lightmesh.load(scene(LIGHTS[:2]), **SIZE)
    image, vis = loaded.render(visibility=True, shadows="rt")
    assert vis.shape == (48, 64, 2)
    assert loaded.render(shadows="rt").tobytes() == image.tobytes()
    assert isinstance(loaded.render(visibility=False), np.ndarray)
    with pytest.raises(lightmesh.Error, match="visibility=: expected True or False"):
        lightmesh.render(scene(LIGHTS[:1]), visibility="yes", **SIZE)
    with pytest.raises(lightmesh.Error, match="did you mean visibility="):
        lightmesh.render(scene(LIGHTS[:1]), visibilty=True, **SIZE)


def test_help_lists_visibility(lightmesh):
    assert "visibility" in lightmesh.render.__doc__ and "visibility" in lightmesh.Scene.render.__doc__
