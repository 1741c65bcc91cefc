"""The panel's Trade operator in both Blenders (Debian's 3.4 with the legacy zip, the bpy module
with the extension): the knob list is the client's KNOBS, "Trade animation" over two frames with
two knobs ticked writes the trade folder under the output folder and shows each knob's
recommendation as trade.md states it; a knob's bad value is an error naming knob and value."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest
from conftest import blender_env, run_blender

import antumbra

SCRIPT = Path(__file__).parent / "scripts" / "operator_trade.py"
FRAMES = 2


def run_script(kind, zips, blend, antumbra_bin, tmp: Path) -> dict:
    out = tmp / "out"
    args = ["--zip", str(zips[kind]), "--kind", kind, "--blend", str(blend)]
    args += ["--frames", str(FRAMES), "--out", str(out), "--binary", str(antumbra_bin)]
    args += ["--socket", str(tmp / "d.sock")]
    if kind == "legacy":
        done = run_blender(["-P", str(SCRIPT), "--", *args], tmp / "home")
    else:
        (tmp / "home").mkdir()
        done = subprocess.run(
            [sys.executable, str(SCRIPT), "--", *args],
            env=blender_env(tmp / "home"),
            capture_output=True,
            text=True,
            timeout=300,
        )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return json.loads((out / "report.json").read_text())


@pytest.mark.parametrize("kind", ["legacy", pytest.param("extension", marks=pytest.mark.bpy)])
def test_trade_operator(kind, addon_zips, scene_blend, antumbra_bin, short_tmp):
    if kind == "legacy" and shutil.which("blender") is None:
        pytest.fail("Debian's blender is not installed")
    report = run_script(kind, addon_zips, scene_blend, antumbra_bin, short_tmp)
    want = "3.4" if kind == "legacy" else ".".join(metadata.version("bpy").split(".")[:2])
    assert report["version"].startswith(want), report
    assert report["knobs"] == [k["name"] for k in antumbra.KNOBS]
    assert report["ticked"] == ["spp", "width=2,8"]

    run = report["animation"]
    assert run["result"] == ["FINISHED"], run
    folder = short_tmp / "out" / "files" / "trade"
    assert "trade.md in" in run["status"] and str(folder) in run["status"], run
    with open(folder / "trade.csv") as f:
        rows = list(csv.DictReader(f))
    assert {int(r["frame"]) for r in rows} == set(range(1, FRAMES + 1))
    assert rows[0]["knob"] == "spp" and rows[-1]["knob"] == "width"
    assert {r["answers"] for r in rows if r["knob"] == "width"} == {"equal"}
    for knob in ("spp", "width"):
        assert (folder / "plots" / f"{knob}.png").is_file(), knob
    table = run["table"]
    assert table["frames"] == FRAMES and table["folder"] == str(folder)
    md = (folder / "trade.md").read_text()
    for r in table["recommendations"]:
        assert f"| {r['knob']} | {r['default']} | {r['recommended']} |" in md, r

    bad = report["bad"]
    assert bad["result"] == ["ERROR"], bad
    assert "knob 'osah_w': value '2'" in bad["error"], bad
