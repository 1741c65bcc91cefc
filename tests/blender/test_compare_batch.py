"""``batch.py -- --compare`` in Debian's ``blender -b``: the default methods over four frames
into OUT/compare; with the last two frames' records deleted, a second run compares exactly
those again (after comparing the frame before them once more, for the methods' state) and the
final compare.csv equals the uninterrupted run's but for the times; answers that differ make
the batch exit 1 with the mismatches printed."""

from __future__ import annotations

import csv
from pathlib import Path

from conftest import ADDON, blender_env, run_blender

import antumbra

BATCH = ADDON / "batch.py"
FRAMES = 4
LIGHTS = ("Sun", "Window")
#: Columns that are times: they differ between runs.
TIMES = ("_ms", "_ms_min", "_ms_max", "mrays_per_s")


def batch(blend: Path, out: Path, tmp: Path, antumbra_bin: Path, *extra: str):
    env = blender_env(tmp / "home", ANTUMBRA_BIN=str(antumbra_bin))
    args = ["--out", str(out), "--spp", "1", "--scale", "0.5", "--socket", str(tmp / "d.sock")]
    return run_blender([str(blend), "-P", str(BATCH), "--", *args, *extra], tmp / "home", env=env)


def compared_frames(stdout: str) -> list[int]:
    return [
        int(line.split()[2])
        for line in stdout.splitlines()
        if line.startswith("antumbra: frame ") and " pass " not in line
    ]


def rows_without_times(path: Path) -> list[dict]:
    with open(path) as f:
        return [{k: v for k, v in r.items() if not k.endswith(TIMES)} for r in csv.DictReader(f)]


def forget_frames(folder: Path, frames: list[int]) -> None:
    """Deletes the report's records of ``frames`` (as if the run had stopped before them)."""
    for f in frames:
        (folder / "frames" / f"frame_{f:04d}.json").unlink()


def test_compare_batch_resumes(scene_blend, antumbra_bin, short_tmp):
    out = short_tmp / "out"
    # The default methods but auto: a resumed comparison warms each method's trees up, not
    # what auto measured, so auto's work rows would differ from one run's (docs/auto.md).
    fixed = [m for m in antumbra.DEFAULT_METHODS if "=auto" not in m]
    run = ["--frames", f"1-{FRAMES}", "--compare", *fixed, "--repeat", "1"]
    done = batch(scene_blend, out, short_tmp, antumbra_bin, *run)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert compared_frames(done.stdout) == list(range(1, FRAMES + 1)), done.stdout
    assert "methods warmed up on (state only): none" in done.stdout
    # Progress per method pass, before the frame's line (the daemon's progress is polled, so a
    # quick pass may be reported only as a later pass's count).
    assert ": compare pass " in done.stdout, done.stdout[-3000:]
    folder = out / "compare"
    labels = [m.partition("=")[0] for m in fixed]
    whole = rows_without_times(folder / "compare.csv")
    assert len(whole) == FRAMES * len(labels) * (1 + len(LIGHTS))
    assert (folder / "report.html").is_file()

    forget_frames(folder, [FRAMES - 1, FRAMES])
    again = batch(scene_blend, out, short_tmp, antumbra_bin, *run)
    assert again.returncode == 0, again.stdout[-3000:] + again.stderr[-3000:]
    assert f"resuming: {FRAMES - 2} frame(s) already compared" in again.stdout
    assert compared_frames(again.stdout) == [FRAMES - 1, FRAMES], again.stdout
    assert f"methods warmed up on (state only): {FRAMES - 2}," in again.stdout
    assert rows_without_times(folder / "compare.csv") == whole


def test_compare_batch_fails_on_differing_answers(scene_blend, antumbra_bin, short_tmp):
    out = short_tmp / "out"
    # Two light-sample seeds: the masks differ.
    done = batch(
        scene_blend,
        out,
        short_tmp,
        antumbra_bin,
        "--frames",
        "2",
        "--spp",
        "4",
        "--repeat",
        "1",
        "--compare",
        "a=seed=1",
        "b=seed=2",
    )
    assert done.returncode == 1, done.stdout[-3000:] + done.stderr[-3000:]
    errors = [line for line in done.stderr.splitlines() if "differs from the baseline" in line]
    assert errors, done.stderr
    assert all("frame 2" in e and "method 'b'" in e and "pixels" in e for e in errors)
    assert (out / "compare" / "report.html").is_file()
