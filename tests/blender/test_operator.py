"""The add-on installed as a user installs it, rendering a frame through its operator, in both
Blenders: Debian's 3.4 (legacy add-on zip, ``blender -b``) and the bpy module of this Python
(5.0.1 or 5.3; extension zip, installed by Blender's extension system with its bundled wheel).
The images it puts in ``bpy.data.images`` equal, bit for bit, the command line's render of what
the add-on sent."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest
from conftest import FRAMES, SIZE, blender_env, cli_render, run_blender

import antumbra

SCRIPT = Path(__file__).parent / "scripts" / "operator_render.py"
FRAME, SPP = 3, 2
LIGHTS = ("Sun", "Window")
HEAT = (
    "antumbra heat primary node visits",
    "antumbra heat primary leaf visits",
    "antumbra heat primary triangle tests",
    "antumbra heat shadow node visits",
    "antumbra heat shadow leaf visits",
    "antumbra heat shadow triangle tests",
)


def run_operator(kind, zips, blend, antumbra_bin, tmp: Path):
    out = tmp / "out"
    args = [
        "--zip",
        str(zips[kind]),
        "--kind",
        kind,
        "--blend",
        str(blend),
        "--frame",
        str(FRAME),
        "--out",
        str(out),
        "--binary",
        str(antumbra_bin),
        "--socket",
        str(tmp / "d.sock"),
        "--spp",
        str(SPP),
        "--record",
        str(tmp / "sent.antrec"),
    ]
    if kind == "legacy":
        done = run_blender(["-P", str(SCRIPT), "--", *args], tmp / "home")
    else:
        home = tmp / "home"
        home.mkdir()
        done = subprocess.run(
            [sys.executable, str(SCRIPT), "--", *args],
            env=blender_env(home),
            capture_output=True,
            text=True,
            timeout=300,
        )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    report = json.loads((out / "report.json").read_text())
    images = dict(np.load(out / "images.npz"))
    return report, images, out


@pytest.mark.parametrize("kind", ["legacy", pytest.param("extension", marks=pytest.mark.bpy)])
def test_operator_images_equal_the_command_line(
    kind, addon_zips, scene_blend, antumbra_bin, short_tmp
):
    if kind == "legacy" and shutil.which("blender") is None:
        pytest.fail("Debian's blender is not installed")
    report, images, out = run_operator(kind, addon_zips, scene_blend, antumbra_bin, short_tmp)
    assert report["enabled"], report
    # The extension runs in the bpy module of this Python: 5.0.1 in .venv, 5.3 in .venv-bpy53.
    want = "3.4" if kind == "legacy" else ".".join(metadata.version("bpy").split(".")[:2])
    assert report["version"].startswith(want), report
    assert report["result"] == ["FINISHED"], report
    assert report["frame_current"] == FRAME and report["last_frame"] == FRAME
    assert [row["pass"] for row in report["last_stats"]] == ["primary", "shadow", "shadow"]
    expected = {f"antumbra {light} shadow" for light in LIGHTS} | {"antumbra combined"}
    assert set(report["images"]) == expected | set(HEAT)
    for name, pixels in images.items():
        assert pixels.shape == (SIZE[1], SIZE[0], 4), name

    # The command line renders the frames the add-on sent (recorded by its session).
    assert report["recorded"][0] == 1, report["recorded"]
    cli = antumbra.read_exr(
        cli_render(antumbra_bin, short_tmp / "sent.antrec", FRAME, short_tmp / "cli", SPP)
    )
    for light in LIGHTS:
        ours = images[f"antumbra {light} shadow"][::-1, :, 0]
        assert ours.tobytes() == cli[f"shadow.{light}"].tobytes(), light
        assert 0.0 < ours.mean() < 1.0, f"{light}: the frame should be partly shadowed"
    assert images["antumbra combined"][::-1, :, 0].tobytes() == cli["combined"].tobytes()
    # The heat maps' counts: the files the add-on wrote equal the command line's, byte for byte.
    ours_exr = (out / "files" / f"frame_{FRAME:04d}.exr").read_bytes()
    assert ours_exr == (short_tmp / "cli" / f"frame_{FRAME:04d}.exr").read_bytes()
    assert FRAME <= FRAMES
