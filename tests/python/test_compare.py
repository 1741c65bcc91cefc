"""``compare()`` on both sessions: one request renders a frame with every method, each method
keeping its state across frames; rows as compare.csv's; counters equal to each method rendered
alone; bad methods refused; a real difference reported; progress per method pass; Ctrl-C
cancels and the session goes on; the daemon's memory budget bounds every method together."""

from __future__ import annotations

import numpy as np
import pytest

import antumbra
from conftest import (
    RESOLUTION,
    camera,
    grid,
    lights,
    objects,
    send_frame,
    upload_missing,
    upload_scene,
)

FRAMES = (1, 2, 3)
# A dict and the equivalent LABEL=SETTINGS strings: both forms are accepted.
METHODS = {
    "base": {"build": "sah", "width": 2, "order": "fbto"},
    "sorted4": {"build": "sah", "width": 4, "order": "sorted"},
    "osah4": {"build": "osah", "visibility": "previous", "width": 4, "order": "sorted"},
}
METHOD_STRINGS = [
    "base=build=sah,width=2,order=fbto",
    "sorted4=build=sah,width=4,order=sorted",
    "osah4=build=osah,visibility=previous,width=4,order=sorted",
]
COMMON = {"spp": 2, "seed": 7}
# Columns that are times (they differ between runs) or only name the comparison.
NOT_COUNTERS = {"label", "settings", "timed_without_counters", "mrays_per_s"}


def counters(row: dict) -> dict:
    return {
        k: v
        for k, v in row.items()
        if k not in NOT_COUNTERS and not k.endswith(("_ms", "_min", "_max"))
    }


def records(rows) -> list[dict]:
    """compare()'s rows as dicts, whether pandas made them a DataFrame or not."""
    if isinstance(rows, list):
        return rows
    return rows.to_dict("records")


def send(session, frame: int) -> None:
    hashes = upload_scene(session)
    upload_missing(session, send_frame(session, hashes, frame))


def compare_frames(session, methods=METHODS, frames=FRAMES, **kw) -> list[dict]:
    out = []
    for f in frames:
        send(session, f)
        out.extend(records(session.compare(f, methods, **kw, **COMMON)))
    return out


@pytest.fixture(params=["local", "daemon"])
def session(request, antumbra_bin, short_tmp):
    if request.param == "local":
        s = antumbra.LocalSession()
    else:
        s = antumbra.Client.spawn(antumbra_bin, socket_path=short_tmp / "d.sock", timeout=60)
    yield s
    s.close()


def test_rows_for_every_method_pass_and_light(session):
    rows = compare_frames(session, repeat=2)
    assert all(list(r) == list(antumbra.COMPARE_COLUMNS) for r in rows)
    shadow_lights = [light["name"] for light in lights()]
    want = {
        (f, label, p, light)
        for f in FRAMES
        for label in METHODS
        for p, light in [("primary", "")] + [("shadow", name) for name in shadow_lights]
    }
    got = [(r["frame"], r["label"], r["pass"], r["light"]) for r in rows]
    assert sorted(got) == sorted(want), got
    for r in rows:
        spec = METHOD_STRINGS[list(METHODS).index(r["label"])]
        assert r["settings"].startswith(r["label"] + "=")
        assert set(r["settings"].split("=", 1)[1].split(",")) == set(
            spec.split("=", 1)[1].split(",")
        )
        assert r["rays"] > 0
        assert r["build_ms_min"] <= r["build_ms"] <= r["build_ms_max"]
        assert r["frame_ms_min"] <= r["frame_ms"] <= r["frame_ms_max"]


def test_string_methods_equal_dict_methods():
    with antumbra.LocalSession() as a, antumbra.LocalSession() as b:
        by_dict = compare_frames(a, METHODS, repeat=1)
        by_text = compare_frames(b, METHOD_STRINGS, repeat=1)
    assert [counters(r) for r in by_dict] == [counters(r) for r in by_text]


def test_each_method_equals_its_render_alone(session, antumbra_bin, short_tmp):
    rows = compare_frames(session, repeat=1)
    for label, settings in METHODS.items():
        # A fresh session of the same kind renders the method alone over the same frames.
        if isinstance(session, antumbra.Client):
            alone = antumbra.Client.connect(session.socket_path, timeout=60)
        else:
            alone = antumbra.LocalSession()
        with alone:
            for f in FRAMES:
                send(alone, f)
                result = alone.render(f, passes=("masks",), **settings, **COMMON)
                mine = [counters(r) for r in rows if r["label"] == label and r["frame"] == f]
                assert mine == [counters(r) for r in result.stats], (label, f)
    # OSAH with previous-frame visibility uses the previous frame: frame 1 differs from later
    # frames in how the tree was built (so state carried across the session's frames).
    assert any(r["visible_input"] for r in rows if r["label"] == "osah4" and r["frame"] > 1)


def test_local_and_daemon_rows_have_the_same_counters(daemon):
    with antumbra.LocalSession() as local:
        a = compare_frames(local, repeat=1)
    b = compare_frames(daemon, repeat=1)
    assert [counters(r) for r in a] == [counters(r) for r in b]


def test_one_request_and_one_upload_for_all_methods(daemon):
    before = daemon.stats()
    hashes = upload_scene(daemon)
    for f in FRAMES:
        # Every mesh went up once, before the first frame: no frame lacks one.
        assert send_frame(daemon, hashes, f) == []
        rows = records(daemon.compare(f, METHODS, repeat=2, **COMMON))
        assert {r["label"] for r in rows} == set(METHODS)
        after = daemon.stats()
        # One Compare request per frame, whatever the number of methods.
        assert after["renders_done"] == before["renders_done"] + f
    assert after["meshes_cached"] == before["meshes_cached"] + len(hashes)
    assert after["renders_failed"] == before["renders_failed"]


def test_default_methods(session):
    send(session, 1)
    rows = records(session.compare(1, repeat=1, spp=1))
    labels = [m.split("=", 1)[0] for m in antumbra.DEFAULT_METHODS]
    assert labels[0] == "base"
    assert list(dict.fromkeys(r["label"] for r in rows)) == labels


@pytest.mark.parametrize(
    ("methods", "baseline", "named"),
    [
        ({"x": {"widht": 2}}, None, "widht"),
        (["x=widht=2"], None, "'widht' is not a setting"),
        ({"x": {"width": 3}}, None, "width"),
        ({"a b": {"width": 2}}, None, "label"),
        (["base=width=2", "base=width=4"], None, "used twice"),
        (["base=width=2"], "nope", "'nope' is not the label"),
        ("base=width=2", None, "one string"),
    ],
)
def test_bad_methods_are_refused_naming_them(session, methods, baseline, named):
    send(session, 1)
    with pytest.raises(antumbra.InvalidInput, match=named):
        session.compare(1, methods, baseline=baseline)
    # The session goes on.
    assert records(session.compare(1, ["base=width=2"], repeat=1, spp=1))


def test_a_real_difference_is_reported(session):
    send(session, 1)
    # Different light-sample seeds on soft lights: different masks, same primary ids.
    with pytest.raises(antumbra.AnswersDiffer) as e:
        session.compare(1, {"a": {"seed": 1}, "b": {"seed": 2}}, repeat=1, spp=4)
    mismatches = e.value.mismatches
    assert mismatches
    assert all(m["label"] == "b" and m["frame"] == 1 and m["pixels"] > 0 for m in mismatches)
    assert {m["what"] for m in mismatches} <= {f"light '{light['name']}'" for light in lights()}
    message = str(e.value)
    assert "frame 1" in message and "method 'b'" in message and "pixels" in message
    assert "light '" in message
    assert {r["label"] for r in records(e.value.rows)} == {"a", "b"}


def stages(session, frame: int, **kw) -> list[tuple[str, int, int]]:
    seen = []
    session.compare(frame, METHODS, progress=lambda *p: seen.append(p), **kw, **COMMON)
    # A daemon whose render slots are busy also reports 'queued'.
    return [p for p in seen if p[0] != "queued"]


def test_progress_reports_every_method_pass(session):
    send(session, 1)
    # Three methods, one counted and two timed passes each.
    assert stages(session, 1, repeat=2) == [("compare", i, 9) for i in range(10)]


# Frame 2 of the interrupt test: big enough that the daemon is still comparing when the Cancel
# sent after the first method pass arrives (seconds per method pass).
HEAVY = {"x": 800, "y": 600, "percentage": 100}


def test_keyboard_interrupt_cancels_and_the_session_goes_on(session):
    hashes = upload_scene(session)
    upload_missing(session, send_frame(session, hashes, 1))
    first = records(session.compare(1, METHODS, repeat=1, **COMMON))
    session.frame_update(2, objects(hashes, 2), camera(2), lights(), HEAVY)

    def interrupt(stage, done, total):
        if stage == "compare" and done == 1:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        session.compare(2, METHODS, repeat=1, progress=interrupt, **COMMON)
    assert session.stats()["renders_cancelled"] == 1
    assert session.active_request is None
    # Returning False cancels too, answered as a cancelled render is.
    with pytest.raises(antumbra.RequestError) as e:
        session.compare(2, METHODS, repeat=1, progress=lambda *p: p[1] < 1, **COMMON)
    assert e.value.code == "Cancelled" and e.value.session_usable
    assert "Compare frame 2" in str(e.value) and "cancelled by the client" in str(e.value)
    # Frame 3 follows frame 1 in every method, as if frame 2 had never been asked for.
    send(session, 3)
    third = records(session.compare(3, METHODS, repeat=1, **COMMON))
    with antumbra.LocalSession() as alone:
        want = compare_frames(alone, frames=(1, 3), repeat=1)
    assert [counters(r) for r in first + third] == [counters(r) for r in want]


def test_the_memory_budget_bounds_every_method_together(antumbra_bin, short_tmp):
    # About 200k triangles: each method's trees take about 100 MiB, so one method fits in
    # 256 MiB and three methods, each keeping its own trees, do not.
    ground = grid(320)
    with antumbra.Client.spawn(
        antumbra_bin,
        socket_path=short_tmp / "d.sock",
        args=["--render-memory-mb", "256"],
        timeout=120,
    ) as daemon:
        h = daemon.upload_mesh("Big", *ground)
        ground_only = [{"name": "Big", "mesh_hash": h, "matrix_world": np.eye(4)}]
        daemon.frame_update(1, ground_only, camera(), lights(), RESOLUTION)
        with pytest.raises(antumbra.DaemonError) as e:
            daemon.compare(1, METHODS, repeat=1, **COMMON)
        assert e.value.code == "LimitExceeded" and e.value.session_usable
        message = str(e.value)
        assert "comparing 3 methods" in message and "max_render_bytes" in message, message
        for settings in METHODS.values():
            assert daemon.render(1, passes=("masks",), **settings, **COMMON).frame == 1
