"""lightmesh.bench(): `lightmesh bench`'s cells as its --json writes them, from keyword
options checked as the CLI's are."""
import math
import os
import signal
import threading
import time

import pytest

TINY = dict(scene="builtin:gazebo", size="32x24", repeat=1, cc=20, variants=["consensus", "grid"])
CELL_KEYS = {"scene", "width", "height", "method", "variant", "paper_name", "accel", "cc", "ki", "samples", "role",
             "median_s", "runs_s", "setup_s", "image", "camera_rays", "shadow_rays", "peak_memory_bytes"}


def test_bench_cells(lightmesh):
    seen = []
    cells = lightmesh.bench(**TINY, progress=lambda done, total: seen.append((done, total)))
    assert isinstance(cells, list) and cells
    # The matrix: no shadows, RT, and each variant at the one (CC, kI).
    assert {(c["method"], c["variant"]) for c in cells} == {("none", ""), ("rt", ""), ("lmm", "consensus"),
                                                            ("lmm", "grid")}
    for c in cells:
        assert CELL_KEYS <= c.keys()
        assert (c["scene"], c["width"], c["height"]) == ("builtin:gazebo", 32, 24)
        assert len(c["runs_s"]) == 1 and c["median_s"] == c["runs_s"][0] > 0
        assert c["camera_rays"] == 32 * 24
        assert (c["shadow_rays"] > 0) == (c["method"] == "rt")  # the light mesh traces segments, not rays
        assert c["peak_memory_bytes"] > 0
    assert [c["cc"] for c in cells if c["method"] == "lmm"] == [20, 20]
    assert seen and seen[-1] == (len(cells), len(cells)) and seen == sorted(seen)


def test_bench_quality_judges_the_competitors(lightmesh):
    doc = lightmesh.bench(**TINY, quality=True, area_samples=[1, 4], ref_samples=16, no_none=True, report=True)
    assert set(doc) == {"repeat", "cells", "quality"} and doc["repeat"] == 1
    cells = doc["cells"]
    assert not any(c["method"] == "none" for c in cells)
    judged = {(c["method"], c["samples"]): c for c in cells if "ref_psnr" in c and c["role"] != "reference"}
    assert {("soft", 0), ("area", 1), ("area", 4)} <= judged.keys()
    for c in judged.values():
        assert isinstance(c["ref_psnr"], float) and math.isfinite(c["ref_psnr"]) and c["ref_psnr"] > 10
        assert 0 < c["ref_ssim"] <= 1
    # Four rays per light are closer to the reference than one.
    assert judged[("area", 4)]["ref_psnr"] > judged[("area", 1)]["ref_psnr"]
    competitors = doc["quality"][0]["competitors"]
    assert competitors["ref_samples"] == 16 and any(r["method"] == "soft" for r in competitors["rows"])


def test_bench_bad_options(lightmesh):
    with pytest.raises(lightmesh.Error, match=r"sizes=: not an option of lightmesh.bench\(\); did you mean size=\?"):
        lightmesh.bench(sizes="32x24")
    with pytest.raises(lightmesh.Error, match=r"cc=: must be between 1 and 4096, got 0"):
        lightmesh.bench(**dict(TINY, cc=[20, 0]))
    with pytest.raises(lightmesh.Error, match=r"size= 32by24: expected WIDTHxHEIGHT"):
        lightmesh.bench(**dict(TINY, size="32by24"))
    with pytest.raises(lightmesh.Error, match=r"repeat=: expected an int"):
        lightmesh.bench(**dict(TINY, repeat="3"))
    with pytest.raises(lightmesh.Error, match=r"scene= cannot be combined with table="):
        lightmesh.bench(scene="builtin:gazebo", table=1)
    with pytest.raises(lightmesh.Error, match=r"accels=: \"nope\" is not one of"):
        lightmesh.bench(**dict(TINY, accels="nope"))
    with pytest.raises(lightmesh.Error, match=r"variants=.*must not be empty"):
        lightmesh.bench(**dict(TINY, variants=[]))
    # Hostile values: NaN, infinities, counts past int, negative thread counts.
    for bad, message in [(dict(ki=float("nan")), r"ki=: must be between 0.01 and 16, got nan"),
                         (dict(cc=2 ** 40), r"cc=: expected an int"),
                         (dict(light_radius=float("inf"), quality=True), r"light_radius=: must be a finite number"),
                         (dict(ref_samples=10 ** 6), r"ref_samples=: must be between 1 and 4096"),
                         (dict(threads=-1), r"threads=: must be between 0 and 1024"),
                         (dict(scene=[]), r"scene=: must not be empty"),
                         (dict(quality="yes"), r"quality=: expected True or False")]:
        with pytest.raises(lightmesh.Error, match=message):
            lightmesh.bench(**dict(TINY, **bad))
    with pytest.raises(lightmesh.Error, match=r"no_such\.json"):
        lightmesh.bench(**dict(TINY, scene="no_such.json"))


def test_bench_keyboard_interrupt(lightmesh):
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        # Renders of a fraction of a second each, many of them: the bench stops after the one under way.
        lightmesh.bench(scene="builtin:gazebo", size="640x480", repeat=20, variants="consensus", force=True)
    timer.join()
    assert time.monotonic() - start < 30


def test_help_lists_bench_options(lightmesh):
    doc = lightmesh.bench.__doc__
    for key in ["scene", "size", "cc", "ki", "variants", "quality", "area_samples", "ref_samples", "threads", "report"]:
        assert f"    {key}" in doc
