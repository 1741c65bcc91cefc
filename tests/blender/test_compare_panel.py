"""The panel's Compare operator in both Blenders (Debian's 3.4 with the legacy zip, the bpy
module with the extension: 5.0.1, and 5.3 in its own venv): the method list prefilled with the
defaults, "Compare animation" over three frames writing the report folder under the output
folder, the heat maps and difference images in ``bpy.data.images``, the per-method table
matching compare.csv; and two methods whose answers differ reported as errors naming frame,
method, light and pixels."""

from __future__ import annotations

import csv

import pytest
from conftest import SIZE
from sweep_panel import run_script

import antumbra

FRAMES = 3
LIGHTS = ("Sun", "Window")


@pytest.mark.parametrize("kind", ["legacy", pytest.param("extension", marks=pytest.mark.bpy)])
def test_compare_operator(kind, addon_zips, scene_blend, antumbra_bin, short_tmp):
    report = run_script(
        "operator_compare.py", FRAMES, kind, addon_zips, scene_blend, antumbra_bin, short_tmp
    )
    assert report["methods"] == list(antumbra.DEFAULT_METHODS)
    labels = [m.partition("=")[0] for m in antumbra.DEFAULT_METHODS]
    base = labels[0]

    run = report["animation"]
    assert run["result"] == ["FINISHED"], run
    folder = short_tmp / "out" / "files" / "compare"
    assert "report in" in run["status"] and str(folder) in run["status"], run
    for name in ("compare.csv", "compare.json", "summary.md", "report.html"):
        assert (folder / name).is_file(), name
    with open(folder / "compare.csv") as f:
        rows = list(csv.DictReader(f))
    assert {int(r["frame"]) for r in rows} == set(range(1, FRAMES + 1))
    assert len(rows) == FRAMES * len(labels) * (1 + len(LIGHTS))

    # The images: per method its heat map, per method but the baseline its difference.
    size = [SIZE[0] // 2, SIZE[1] // 2]
    images = report["images"]
    for label in labels:
        heat = images[f"antumbra {label} N_B"]
        assert heat["size"] == size and heat["frame"] == FRAMES and heat["max"] > 0, label
        difference = images.get(f"antumbra {label} - {base} N_B")
        if label == base:
            assert difference is None
        else:
            assert difference["size"] == size and difference["scale"] >= 1.0, label

    # The table: every method, all matched, N_B per ray as compare.csv's shadow rows give it.
    table = run["table"]
    assert table["baseline"] == base and table["frames"] == FRAMES
    assert [m["label"] for m in table["methods"]] == labels
    for m in table["methods"]:
        shadow = [r for r in rows if r["label"] == m["label"] and r["pass"] == "shadow"]
        rays = sum(int(r["rays"]) for r in shadow)
        nodes = sum(float(r["nb_per_ray"]) * int(r["rays"]) for r in shadow)
        assert m["nb_per_ray"] == pytest.approx(nodes / rays, rel=1e-6), m
        assert m["matched"] and m["frame_ms"] > 0, m
    assert table["methods"][0]["nb_ratio"] == 1.0

    # A real difference is an error naming frame, method, light and pixels, not swallowed.
    differ = report["differ"]
    assert differ["result"] == ["ERROR"], differ
    assert "frame 2" in differ["error"] and "method 'b'" in differ["error"], differ
    assert "light '" in differ["error"] and "pixels" in differ["error"], differ
    assert differ["status"].startswith("answers differ"), differ
    assert [m["matched"] for m in differ["table"]["methods"]] == [True, False]
    assert (short_tmp / "out" / "differ" / "compare" / "report.html").is_file()
