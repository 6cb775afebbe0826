"""Shared fixtures of the Python module's tests (python/tests; docs/python.md).

CTest runs them with PYTHONPATH at the build's module (build/python) and LIGHTMESH_EXE at
the CLI; without the module they are skipped, and so are the CLI comparisons without it."""
import json
import os
import pathlib
import shutil

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def lightmesh():
    return pytest.importorskip("lightmesh", reason="the lightmesh module was not built (docs/python.md)")


@pytest.fixture(scope="session")
def cli():
    exe = os.environ.get("LIGHTMESH_EXE") or shutil.which("lightmesh")
    if not exe or not os.path.exists(exe):
        candidate = ROOT / "build" / "apps" / "lightmesh"
        exe = str(candidate) if candidate.exists() else None
    if not exe:
        pytest.skip("no lightmesh executable (set LIGHTMESH_EXE)")
    return exe


@pytest.fixture()
def table_vase():
    """scenes/table_vase.json as a dict, and its folder (where its mesh paths start)."""
    path = ROOT / "scenes" / "table_vase.json"
    return json.loads(path.read_text()), path.parent
