"""The panel's Trade operator in both Blenders (Debian's 3.4 with the legacy zip, the bpy module
with the extension): the knob list is the client's KNOBS, "Trade animation" over two frames with
two knobs ticked writes the trade folder under the output folder and shows each knob's
recommendation as trade.md states it; a knob's bad value is an error naming knob and value."""

from __future__ import annotations

import csv

import pytest
from sweep_panel import run_script

import antumbra

FRAMES = 2


@pytest.mark.parametrize("kind", ["legacy", pytest.param("extension", marks=pytest.mark.bpy)])
def test_trade_operator(kind, addon_zips, scene_blend, antumbra_bin, short_tmp):
    report = run_script(
        "operator_trade.py", FRAMES, kind, addon_zips, scene_blend, antumbra_bin, short_tmp
    )
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
