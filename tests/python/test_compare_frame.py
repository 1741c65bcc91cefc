"""``compare_frame`` and ``CompareReport`` on a built-in scene (a recording of the bedroom),
through a real daemon and in process: heat and difference images shaped as the other images,
frames recorded, the report resumed in a new object and written with every method x frame."""

from __future__ import annotations

import csv
import subprocess
from pathlib import Path

import numpy as np
import pytest

import antumbra

METHODS = [
    "base=build=sah,width=2,order=fbto",
    "sorted4=build=sah,width=4,order=sorted",
    "osah4=build=osah,visibility=previous,width=4,order=sorted",
]
LABELS = [m.split("=", 1)[0] for m in METHODS]
COMMON = {"spp": 2}
SIZE = (40, 30)


@pytest.fixture(scope="module")
def recording(antumbra_bin, tmp_path_factory) -> dict:
    out = tmp_path_factory.mktemp("rec") / "bedroom.antrec"
    subprocess.run(
        [
            str(antumbra_bin),
            "record",
            "--scene",
            "bedroom",
            "--triangles",
            "3000",
            "--frames",
            "1-3",
            "--size",
            f"{SIZE[0]}x{SIZE[1]}",
            "--out",
            str(out),
        ],
        check=True,
        capture_output=True,
    )
    return antumbra.read_recording(out)


@pytest.fixture(params=["local", "daemon"])
def session(request, antumbra_bin, short_tmp):
    if request.param == "local":
        s = antumbra.LocalSession()
    else:
        s = antumbra.Client.spawn(antumbra_bin, socket_path=short_tmp / "d.sock", timeout=60)
    yield s
    s.close()


def send(session, rec: dict, index: int) -> int:
    """Sends frame ``index`` of the recording with the meshes the session lacks."""
    frame = rec["frames"][index]
    missing = session.frame_update(
        frame["frame"], frame["objects"], frame["camera"], frame["lights"], frame["resolution"]
    )
    for h in missing:
        m = rec["meshes"][h]
        session.upload_mesh(m["name"], m["positions"], m["triangles"])
    return frame["frame"]


def compare(session, rec: dict, index: int, **kw) -> antumbra.CompareFrame:
    frame = send(session, rec, index)
    cf = session.compare_frame(frame, METHODS, repeat=1, **kw, **COMMON)
    assert cf.frame == frame
    assert [m.split("=", 1)[0] for m in cf.methods] == LABELS
    assert cf.baseline == "base"
    assert cf.mismatches == []
    assert {(r["frame"], r["label"]) for r in cf.rows} == {(frame, label) for label in LABELS}
    return cf


def check_images(cf: antumbra.CompareFrame) -> None:
    width, height = SIZE
    assert sorted(cf.heat) == sorted(LABELS)
    for label, heat in cf.heat.items():
        assert heat.dtype == np.float32 and heat.shape == (height, width), label
        assert heat.min() >= 0 and heat.sum() > 0, label
    assert sorted(cf.difference) == sorted(set(LABELS) - {cf.baseline})
    for label, diff in cf.difference.items():
        assert diff.dtype == np.float32 and diff.shape == (height, width), label
        assert np.array_equal(diff, cf.heat[label] - cf.heat[cf.baseline]), label


def test_heat_is_the_render_of_the_method_alone(session, recording):
    cf = compare(session, recording, 0)
    check_images(cf)
    # The baseline alone on the first frame, in a fresh session: the same plane, oriented as
    # Result's images are.
    alone = antumbra.LocalSession()
    frame = send(alone, recording, 0)
    result = alone.render(frame, passes=["heat_maps"], build="sah", width=2, order="fbto", **COMMON)
    alone.close()
    assert np.array_equal(cf.heat["base"], result.images["shadow.N_B"])
    without = compare(session, recording, 1, images=False)
    assert without.heat == {} and without.difference == {}


def test_report_recorded_resumed_and_written(session, recording, tmp_path):
    out = tmp_path / "report"
    frames = [f["frame"] for f in recording["frames"]]
    report = antumbra.CompareReport(out, scene="bedroom", methods=METHODS, repeat=1)
    assert report.frames() == []
    for index in range(2):
        cf = compare(session, recording, index)
        check_images(cf)
        report.add(cf)
    # A new object on the same folder resumes it.
    report = antumbra.CompareReport(out, scene="bedroom", methods=METHODS, repeat=1)
    assert report.frames() == frames[:2]
    report.add(compare(session, recording, 2))
    html = Path(report.write())
    assert html == out / "report.html" and html.is_file()
    assert report.mismatches == []
    with open(out / "compare.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == list(antumbra.COMPARE_COLUMNS)
    assert {(int(r["frame"]), r["label"]) for r in rows} == {
        (frame, label) for frame in frames for label in LABELS
    }
    for frame in frames:
        assert (out / "frames" / f"frame_{frame:04d}.json").is_file()
        for label in LABELS[1:]:
            assert (out / "diff" / label / f"frame_{frame:04d}.png").is_file()
    page = html.read_text()
    for plot in ("shadow_nb", "frame_ms", "time_parts", "pareto"):
        assert f'id="plot-{plot}"' in page
    assert page.count('class="diff"') == len(frames) * (len(LABELS) - 1)


def test_a_folder_of_another_comparison_is_refused(tmp_path):
    out = tmp_path / "report"
    antumbra.CompareReport(out, scene="bedroom", methods=METHODS, repeat=1)
    with pytest.raises(antumbra.InvalidInput, match=r"methods: recorded"):
        antumbra.CompareReport(out, scene="bedroom", methods=METHODS[:2], repeat=1)
    with pytest.raises(antumbra.InvalidInput, match=r"repeat: recorded 1, now 3"):
        antumbra.CompareReport(out, scene="bedroom", methods=METHODS)
    with pytest.raises(antumbra.InvalidInput, match=r"baseline: recorded 'base', now 'osah4'"):
        antumbra.CompareReport(out, scene="bedroom", methods=METHODS, baseline="osah4", repeat=1)
    with pytest.raises(antumbra.InvalidInput, match=r"scene: recorded 'bedroom', now 'city'"):
        antumbra.CompareReport(out, scene="city", methods=METHODS, repeat=1)
    with pytest.raises(antumbra.InvalidInput, match=r"is not a setting"):
        antumbra.CompareReport(out, scene="bedroom", methods=["x=widht=8"])
