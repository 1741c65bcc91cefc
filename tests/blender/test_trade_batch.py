"""``batch.py -- --trade`` in Debian's ``blender -b``: a work knob and an image knob over three
frames into OUT/trade (trade.csv, plots, trade.md, the recommendations printed); with the last
frame's record deleted, a second run trades exactly it again (after the frame before it, for the
knobs' state) and the final trade.csv equals the uninterrupted run's but for the times; an
unknown knob is refused naming the knobs, from the client's table."""

from __future__ import annotations

import csv
from pathlib import Path

from conftest import ADDON, blender_env, run_blender

import antumbra

BATCH = ADDON / "batch.py"
FRAMES = 3
KNOBS = ["width=2,8", "spp=1,4"]
TIMES = ("_ms", "_ms_min", "_ms_max")


def batch(blend: Path, out: Path, tmp: Path, antumbra_bin: Path, *extra: str):
    env = blender_env(tmp / "home", ANTUMBRA_BIN=str(antumbra_bin))
    args = ["--out", str(out), "--scale", "0.25", "--socket", str(tmp / "d.sock")]
    return run_blender([str(blend), "-P", str(BATCH), "--", *args, *extra], tmp / "home", env=env)


def traded_frames(stdout: str) -> list[int]:
    return [
        int(line.split()[2])
        for line in stdout.splitlines()
        if line.startswith("antumbra: frame ") and " pass " not in line
    ]


def rows_without_times(path: Path) -> list[dict]:
    with open(path) as f:
        return [{k: v for k, v in r.items() if not k.endswith(TIMES)} for r in csv.DictReader(f)]


def test_trade_batch_writes_and_resumes(scene_blend, antumbra_bin, short_tmp):
    out = short_tmp / "out"
    run = ["--frames", f"1-{FRAMES}", "--trade", *KNOBS, "--repeat", "1"]
    done = batch(scene_blend, out, short_tmp, antumbra_bin, *run)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert traded_frames(done.stdout) == list(range(1, FRAMES + 1)), done.stdout
    default = antumbra.render_settings()["width"]
    assert any(f"width: {w} (default {default})" in done.stdout for w in (2, 8)), done.stdout
    folder = out / "trade"
    whole = rows_without_times(folder / "trade.csv")
    # Two values per knob, each with the primary pass and both lights' shadow passes.
    assert len(whole) == FRAMES * 4 * 3
    assert [r["knob"] for r in whole[:2]] == ["width", "width"]
    assert {r["answers"] for r in whole if r["knob"] == "width"} == {"equal"}
    assert all(r["rmse"] for r in whole if r["knob"] == "spp" and r["pass"] == "shadow")
    for knob in ("width", "spp"):
        assert (folder / "plots" / f"{knob}.png").is_file()
    assert (folder / "trade.md").read_text().startswith("# Trade: ")

    (folder / "frames" / f"frame_{FRAMES:04d}.json").unlink()
    again = batch(scene_blend, out, short_tmp, antumbra_bin, *run)
    assert again.returncode == 0, again.stdout[-3000:] + again.stderr[-3000:]
    assert f"resuming: {FRAMES - 1} frame(s) already traded" in again.stdout
    assert traded_frames(again.stdout) == [FRAMES], again.stdout
    assert f"traded again for the knobs' state: {FRAMES - 1}," in again.stdout
    assert rows_without_times(folder / "trade.csv") == whole


def test_an_unknown_knob_is_named(scene_blend, antumbra_bin, short_tmp):
    done = batch(scene_blend, short_tmp / "out", short_tmp, antumbra_bin, "--trade", "osah_x")
    assert done.returncode != 0
    names = ", ".join(k["name"] for k in antumbra.KNOBS)
    assert f"'osah_x' is not a knob (knobs: {names})" in done.stderr + done.stdout
