"""What the Compare and Trade panel tests share: running their operator script in the Blender
asked for (Debian's with the legacy zip, the bpy module with the extension) and reading its
report, checked to come from that Blender."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest
from conftest import blender_env, run_blender

SCRIPTS = Path(__file__).parent / "scripts"


def run_script(script: str, frames: int, kind, zips, blend, antumbra_bin, tmp: Path) -> dict:
    """``scripts/SCRIPT`` over frames 1 to ``frames``, its files under TMP/out; its report."""
    if kind == "legacy" and shutil.which("blender") is None:
        pytest.fail("Debian's blender is not installed")
    out = tmp / "out"
    args = ["--zip", str(zips[kind]), "--kind", kind, "--blend", str(blend)]
    args += ["--frames", str(frames), "--out", str(out), "--binary", str(antumbra_bin)]
    args += ["--socket", str(tmp / "d.sock")]
    if kind == "legacy":
        done = run_blender(["-P", str(SCRIPTS / script), "--", *args], tmp / "home")
    else:
        (tmp / "home").mkdir()
        done = subprocess.run(
            [sys.executable, str(SCRIPTS / script), "--", *args],
            env=blender_env(tmp / "home"),
            capture_output=True,
            text=True,
            timeout=300,
        )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    report = json.loads((out / "report.json").read_text())
    want = "3.4" if kind == "legacy" else ".".join(metadata.version("bpy").split(".")[:2])
    assert report["version"].startswith(want), report
    return report
