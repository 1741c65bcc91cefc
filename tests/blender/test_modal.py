"""The modal "Render animation" in a real Blender window (Debian's 3.4 under Xvfb): Esc,
pressed through ``Window.event_simulate`` after the first frame, cancels the job; the scene's
frame is put back, the images show the last complete frame, and only complete frames have files
and statistics."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest
from conftest import blender_env

SCRIPT = Path(__file__).parent / "scripts" / "modal_esc.py"


def test_escape_cancels_and_leaves_complete_frames(
    addon_zips, scene_blend, antumbra_bin, short_tmp
):
    xvfb_run, blender = shutil.which("xvfb-run"), shutil.which("blender")
    if xvfb_run is None or blender is None:
        pytest.fail("needs xvfb-run and Debian's blender (scripts/setup.sh installs both)")
    out = short_tmp / "out"
    home = short_tmp / "home"
    home.mkdir()
    done = subprocess.run(
        [
            *(xvfb_run, "-a", "-s", "-screen 0 1280x800x24", blender, "--factory-startup"),
            *("-noaudio", "--enable-event-simulate", str(scene_blend), "-P", str(SCRIPT), "--"),
            *("--zip", str(addon_zips["legacy"]), "--binary", str(antumbra_bin)),
            *("--socket", str(short_tmp / "d.sock"), "--out", str(out)),
        ],
        env=blender_env(home),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    report = json.loads((out / "report.json").read_text())
    first, last = report["frame_range"]
    assert report["status"].startswith("cancelled after "), report
    finished = int(report["status"].split()[2])
    assert 1 <= finished < last - first + 1, report
    assert report["frame_current"] == report["start_frame"] != first, report
    assert report["combined_frame"] == report["last_frame"] == first + finished - 1, report
    assert report["records"] == [
        f"frame_{f:04d}.stats.json" for f in range(first, first + finished)
    ], report
