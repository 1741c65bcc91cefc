"""Fixtures of the Blender end-to-end tests: the antumbra binary, the built add-on, a built-in
scene as a recording and as a .blend, and running Debian's ``blender -b``.

These tests need what ``scripts/test.sh`` prepares: ``blender_addon/build.py`` run (the zips in
``dist/`` and the client unpacked beside the add-on), Debian's ``blender`` on PATH and the
``bpy`` module in the venv (5.0.1 in ``.venv``). A missing piece is a failure, never a skip.
Tests marked ``bpy`` run in the ``bpy`` module of the Python running pytest; ``-m bpy`` runs
only those, as the version matrix does in ``.venv-bpy53`` (bpy 5.3, docs/blender.md).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
ADDON = REPO / "blender_addon"
DIST = REPO / "dist"
#: The built-in scene the tests render: small, animated, two lights (sun and window).
SCENE, TRIANGLES, FRAMES, SIZE = "bedroom", 12000, 10, (96, 54)


def pytest_configure(config):
    config.addinivalue_line("markers", "bpy: runs in the bpy module of the Python running pytest")


def _binary() -> Path:
    env = os.environ.get("ANTUMBRA_BIN")
    path = Path(env) if env else REPO / "target" / "debug" / "antumbra"
    if not path.is_file():
        pytest.fail(f"no antumbra binary at {path}: build it or set ANTUMBRA_BIN")
    return path


@pytest.fixture(scope="session")
def antumbra_bin() -> Path:
    return _binary()


@pytest.fixture(scope="session")
def addon_zips() -> dict[str, Path]:
    zips = {
        "extension": next(DIST.glob("antumbra-extension-*.zip"), None),
        "legacy": next(DIST.glob("antumbra-addon-*.zip"), None),
    }
    vendored = ADDON / "antumbra" / "_vendor" / "antumbra" / "__init__.py"
    if None in zips.values() or not vendored.exists():
        pytest.fail("the add-on is not built: run python3 blender_addon/build.py first")
    return zips


@pytest.fixture
def short_tmp():
    """A private folder under /tmp (Unix socket paths must stay short)."""
    d = tempfile.mkdtemp(prefix="antbl-", dir="/tmp")
    yield Path(d)
    shutil.rmtree(d, ignore_errors=True)


def blender_env(home: Path, **extra: str) -> dict[str, str]:
    env = {**os.environ, "HOME": str(home), **extra}
    env.pop("PYTHONPATH", None)
    return env


def run_blender(
    args: list[str], home: Path, timeout: float = 300, env: dict | None = None
) -> subprocess.CompletedProcess:
    """Debian's Blender in the background: ``blender -b ARGS`` with a private HOME."""
    blender = shutil.which("blender")
    if blender is None:
        pytest.fail("Debian's blender is not installed (apt-get install blender python3-numpy)")
    home.mkdir(parents=True, exist_ok=True)
    return subprocess.run(
        [blender, "-b", "--factory-startup", "-noaudio", *args],
        env=env or blender_env(home),
        capture_output=True,
        text=True,
        timeout=timeout,
    )


@pytest.fixture(scope="session")
def recording(antumbra_bin, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("scene") / f"{SCENE}.antrec"
    subprocess.run(
        [
            *(str(antumbra_bin), "record", "--scene", SCENE, "--triangles", str(TRIANGLES)),
            *("--frames", f"1-{FRAMES}", "--size", f"{SIZE[0]}x{SIZE[1]}", "--out", str(out)),
        ],
        check=True,
        capture_output=True,
    )
    return out


@pytest.fixture(scope="session")
def scene_blend(recording, addon_zips, tmp_path_factory) -> Path:
    """The built-in scene as a .blend, made by ``make_blend.py`` in Debian's Blender."""
    folder = tmp_path_factory.mktemp("blend")
    out = folder / f"{SCENE}.blend"
    done = run_blender(
        [
            "-P",
            str(ADDON / "make_blend.py"),
            "--",
            "--recording",
            str(recording),
            "--out",
            str(out),
        ],
        folder / "home",
    )
    assert done.returncode == 0 and out.is_file(), done.stdout + done.stderr
    return out


def cli_render(antumbra_bin: Path, recording: Path, frame: int, out: Path, spp: int) -> Path:
    """``antumbra render`` of one frame of a recording; returns the frame's EXR."""
    subprocess.run(
        [
            *(str(antumbra_bin), "render", "--scene", str(recording), "--frames", str(frame)),
            *("--spp", str(spp), "--out", str(out)),
        ],
        check=True,
        capture_output=True,
    )
    return out / f"frame_{frame:04d}.exr"


@pytest.fixture(params=[pytest.param("bpy", marks=pytest.mark.bpy), "blender"])
def blender_kind(request) -> str:
    """Which Blender runs a script: the bpy module of this Python, or Debian's ``blender``; a
    missing one fails its variant (never a skip)."""
    kind = request.param
    if kind == "bpy" and importlib.util.find_spec("bpy") is None:
        pytest.fail(f"this Python ({sys.executable}) has no bpy module (pip install bpy==5.0.1)")
    if kind == "blender" and shutil.which("blender") is None:
        pytest.fail("no `blender` on PATH (apt-get install blender python3-numpy)")
    return kind
