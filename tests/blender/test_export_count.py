"""What the exporter sends, in Debian's Blender 3.4 (``blender -b``) and in the bpy module of
this Python (5.0.1 or 5.3): each evaluated thing once (text, curve, surface and metaball objects,
which the depsgraph lists both as themselves and as the instance of their evaluated mesh, also
when placed by a collection instance, send as many triangles as Blender evaluates), and corner
normals (smooth and custom ones) only when asked for, leaving every hash as it was otherwise."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ADDON, blender_env, run_blender

SCRIPTS = Path(__file__).parent / "scripts"
KINDS = ["blender", pytest.param("bpy", marks=pytest.mark.bpy)]


def run_script(kind: str, script: str, tmp: Path) -> dict:
    out = tmp / "out.json"
    args = ["--addon", str(ADDON), "--out", str(out)]
    if kind == "blender":
        done = run_blender(["-P", str(SCRIPTS / script), "--", *args], tmp / "home")
    else:
        done = subprocess.run(
            [sys.executable, str(SCRIPTS / script), "--", *args],
            env=blender_env(tmp / "home"),
            capture_output=True,
            text=True,
            timeout=300,
        )
    assert out.is_file(), done.stdout[-3000:] + done.stderr[-3000:]
    return json.loads(out.read_text())


@pytest.mark.parametrize("kind", KINDS)
def test_text_curve_surface_and_metaball_are_sent_once(kind, addon_zips, short_tmp):
    sent = run_script(kind, "export_count.py", short_tmp)
    assert sent["triangles"] == sent["blender"], sent
    # The two collection instances of Word's evaluated mesh travel as one array, named after
    # the object whose mesh they place, their instances by their order.
    assert sent["names"] == [
        "Circle",
        "Cube",
        "Mball",
        "SurfSphere",
        "Text",
        "Word",
        "Word[0]",
        "Word[1]",
    ], sent


@pytest.mark.parametrize("kind", KINDS)
def test_corner_normals_only_when_asked_and_only_for_smooth_meshes(kind, addon_zips, short_tmp):
    sent = run_script(kind, "export_normals.py", short_tmp)
    assert sent["Sphere"]["normals"] == [3 * 960, 3], sent
    assert sent["Sphere"]["radial"] < 1.0, "smooth normals point away from the centre"
    assert sent["Square"]["lean"] == pytest.approx([0.6, 0.0, 0.8], abs=1e-4), "custom normals"
    assert sent["Cube"]["normals"] is None, "a flat mesh sends none"
    for name in ("Sphere", "Square"):
        assert not sent[name]["same_hash"], "normals are hashed"
    for name in ("Sphere plain", "Cube plain", "Square plain", "Cube"):
        assert sent[name]["normals"] is None and sent[name]["same_hash"], name
