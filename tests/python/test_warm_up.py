"""Warm-ups through the client (``render(warm_up=True)``, ``compare_frame(warm_up=True)``): a
session that warms up on the two frames before a chunk renders the chunk's frames as a session
that rendered every frame does, over the daemon and in a LocalSession; a warm-up returns no
planes and no rows, and a report refuses it."""

from __future__ import annotations

import numpy as np
import pytest

import antumbra
from conftest import RESOLUTION, camera, lights, objects, upload_scene

#: OSAH from the previous frame's visible set, collapsed to 8 wide, sorted per light.
SETTINGS = {"build": "osah", "visibility": "previous", "width": 8, "order": "sorted", "spp": 2}
#: The frames: the camera and the tall box move until frame 3, hold still to 5, move on at 6.
FRAMES = range(1, 7)
TIMES = ("_ms", "_ms_min", "_ms_max", "mrays_per_s")


def pose(frame: int) -> int:
    return frame if frame <= 3 or frame >= 6 else 3


def send(session, hashes, frame: int) -> None:
    p = pose(frame)
    assert session.frame_update(frame, objects(hashes, p), camera(p), lights(), RESOLUTION) == []


def untimed(rows: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if not k.endswith(TIMES)} for r in rows]


def same(a: antumbra.Result, b: antumbra.Result) -> None:
    assert [n for n, _ in a.planes] == [n for n, _ in b.planes]
    for (name, x), (_, y) in zip(a.planes, b.planes, strict=True):
        assert np.array_equal(x.view(np.uint32), y.view(np.uint32)), f"frame {a.frame}: {name}"
    assert untimed(a.stats) == untimed(b.stats), f"frame {a.frame}"
    assert np.array_equal(a.visible, b.visible)


def one_run(session) -> dict[int, antumbra.Result]:
    hashes = upload_scene(session)
    out = {}
    for f in FRAMES:
        send(session, hashes, f)
        out[f] = session.render(f, **SETTINGS)
    return out


def chunk_from(session, start: int) -> tuple[list[antumbra.Result], dict[int, antumbra.Result]]:
    hashes = upload_scene(session)
    warmed = []
    for f in (start - 2, start - 1):
        send(session, hashes, f)
        warmed.append(session.render(f, warm_up=True, **SETTINGS))
    done = {}
    for f in FRAMES:
        if f >= start:
            send(session, hashes, f)
            done[f] = session.render(f, **SETTINGS)
    return warmed, done


@pytest.mark.parametrize("where", ["daemon", "local"])
def test_a_chunk_after_two_warm_ups_renders_what_one_run_renders(where, daemon):
    def session():
        if where == "local":
            return antumbra.LocalSession()
        return antumbra.Client.connect(daemon.socket_path)

    with session() as s:
        run = one_run(s)
    # The test means something: one run reuses its trees at frame 5 and rebuilds at frame 6.
    assert not any(r["rebuilt"] for r in run[5].stats)
    assert all(r["rebuilt"] for r in run[6].stats)
    with session() as s:
        warmed, done = chunk_from(s, 5)
    for w, f in zip(warmed, (3, 4), strict=True):
        assert (w.frame, w.width, w.height) == (f, run[f].width, run[f].height)
        assert w.planes == [] and w.stats == [] and w.masks == {}
        assert np.array_equal(w.visible, run[f].visible)
    for f, r in done.items():
        same(r, run[f])
    # Without the warm-ups frame 5 is a fresh session's: its trees are built, not reused.
    with session() as s:
        hashes = upload_scene(s)
        send(s, hashes, 5)
        assert all(r["rebuilt"] for r in s.render(5, **SETTINGS).stats)


def steps_of(steps: list[tuple]):
    return lambda *a: steps.append(a)


def test_a_comparison_warms_up_and_a_report_refuses_the_warm_up(daemon, short_tmp):
    # Fixed orders: a warm-up does not teach auto, so with auto only the masks would agree.
    methods = ["sah=build=sah,width=2,order=fbto", "osah=build=osah,width=4,order=fbto"]

    def rows(session, frames, warm=()):
        hashes = upload_scene(session)
        out = {}
        for f in warm:
            send(session, hashes, f)
            steps: list[tuple] = []
            w = session.compare_frame(f, methods, repeat=1, warm_up=True, progress=steps_of(steps))
            assert w.rows == [] and w.mismatches == [] and w.heat == {}
            assert steps[-1] == ("compare", 2, 2)
            report = antumbra.CompareReport(
                short_tmp / "report", scene="s", methods=methods, repeat=1
            )
            with pytest.raises(antumbra.InvalidInput, match="is a warm-up"):
                report.add(w)
        for f in frames:
            send(session, hashes, f)
            cf = session.compare_frame(f, methods, repeat=1, images=False)
            out[f] = untimed(cf.rows)
        return out

    with antumbra.Client.connect(daemon.socket_path) as s:
        run = rows(s, FRAMES)
    with antumbra.Client.connect(daemon.socket_path) as s:
        chunk = rows(s, [5, 6], warm=(3, 4))
    assert chunk == {f: run[f] for f in (5, 6)}
