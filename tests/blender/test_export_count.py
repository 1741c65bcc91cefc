"""Each evaluated thing is sent once: text, curve, surface and metaball objects (which the
depsgraph lists both as themselves and as the instance of their evaluated mesh), also when placed
by a collection instance, send as many triangles as Blender evaluates. In Debian's Blender 3.4
(``blender -b``) and in the bpy module of this Python (5.0.1 or 5.3)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ADDON, blender_env, run_blender

SCRIPT = Path(__file__).parent / "scripts" / "export_count.py"


@pytest.mark.parametrize("kind", ["blender", pytest.param("bpy", marks=pytest.mark.bpy)])
def test_text_curve_surface_and_metaball_are_sent_once(kind, addon_zips, short_tmp):
    out = short_tmp / "count.json"
    args = ["--addon", str(ADDON), "--out", str(out)]
    if kind == "blender":
        done = run_blender(["-P", str(SCRIPT), "--", *args], short_tmp / "home")
    else:
        done = subprocess.run(
            [sys.executable, str(SCRIPT), "--", *args],
            env=blender_env(short_tmp / "home"),
            capture_output=True,
            text=True,
            timeout=300,
        )
    assert out.is_file(), done.stdout[-3000:] + done.stderr[-3000:]
    sent = json.loads(out.read_text())
    assert sent["triangles"] == sent["blender"], sent
    assert sent["names"] == [
        "Circle",
        "Cube",
        "Letters.0/Word[0.0]",
        "Letters.1/Word[0.0]",
        "Mball",
        "SurfSphere",
        "Text",
        "Word",
    ], sent
