"""The socket session against the real daemon (`antumbra serve`), spawned per test from
$ANTUMBRA_BIN or target/{release,debug}/antumbra. These tests fail (they do not skip) when the
binary is missing or has no `serve` subcommand."""

from __future__ import annotations

import os
import subprocess
import threading
import time

import numpy as np
import pytest

import antumbra
from conftest import (
    RESOLUTION,
    box,
    camera,
    lights,
    objects,
    send_frame,
    translation,
    upload_missing,
    upload_scene,
)

# Columns that measure time, which differ between two renders of the same frame.
TIMED = {"build_ms", "trace_ms", "mrays_per_s", "prepare_ms", "visibility_ms"}


def assert_same_result(a: antumbra.Result, b: antumbra.Result) -> None:
    assert (a.frame, a.width, a.height) == (b.frame, b.width, b.height)
    assert [n for n, _ in a.planes] == [n for n, _ in b.planes]
    for (name, x), (_, y) in zip(a.planes, b.planes, strict=True):
        assert x.dtype == y.dtype == np.float32, name
        assert np.array_equal(x, y), f"{name} differs"
    assert (a.visible is None) == (b.visible is None)
    if a.visible is not None:
        assert np.array_equal(a.visible, b.visible)
    strip = [{k: v for k, v in row.items() if k not in TIMED} for row in a.stats]
    assert strip == [{k: v for k, v in row.items() if k not in TIMED} for row in b.stats]


def eventually(condition, seconds: float = 5.0) -> bool:
    deadline = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def test_spawned_daemon_says_welcome(daemon):
    assert daemon.server.startswith("antumbra")
    assert daemon.protocol_version == antumbra.PROTOCOL_VERSION
    assert daemon.limits["max_spp"] >= 1
    assert daemon.process is not None and daemon.process.poll() is None
    assert not daemon.closed


def test_animation_equals_local_session_bit_for_bit(daemon):
    local = antumbra.LocalSession()
    hashes = upload_scene(daemon)
    assert upload_scene(local) == hashes
    seen = []
    for frame in (1, 2, 3):
        assert send_frame(daemon, hashes, frame) == []
        assert send_frame(local, hashes, frame) == []
        progress = []

        def report(*a, progress=progress):
            progress.append(a)

        remote = daemon.render(frame, spp=8, seed=frame, progress=report)
        here = local.render(frame, spp=8, seed=frame)
        assert_same_result(remote, here)
        assert progress[-1] == ("encode", 1, 2)
        seen.append(remote.combined)
    assert not np.array_equal(seen[0], seen[2])  # the tall box moved
    ids = daemon.render(3, passes=["object_ids"]).object_ids
    assert ids is not None and ids.shape == seen[0].shape
    assert np.array_equal(ids, local.render(3, passes=["object_ids"]).object_ids)
    # The daemon counts a render once its result is sent: allow it a moment.
    assert eventually(lambda: daemon.stats()["renders_done"] == 4)


def test_unchanged_meshes_are_not_uploaded_again(daemon):
    hashes = upload_scene(daemon)
    assert send_frame(daemon, hashes, 1) == []
    daemon.render(1, passes=["combined"])
    before = daemon.stats()
    assert before["meshes_cached"] == 3
    # Second frame: same meshes, new transforms.
    assert daemon.missing_meshes(list(hashes.values())) == []
    assert send_frame(daemon, hashes, 2) == []
    r = daemon.render(2, passes=["combined"])
    after = daemon.stats()
    assert after["meshes_cached"] == before["meshes_cached"]
    assert after["bytes_cached"] == before["bytes_cached"]
    assert r.stats[0]["triangles"] > 0


def test_meshes_outlive_the_session(daemon):
    hashes = upload_scene(daemon)
    with antumbra.Client.connect(daemon.socket_path) as second:
        assert second.missing_meshes(list(hashes.values())) == []
        assert daemon.stats()["sessions"] == 2
        assert send_frame(second, hashes, 1) == []
        assert second.render(1).frame == 1
    assert second.closed


def test_daemon_error_names_the_object(daemon):
    hashes = upload_scene(daemon)
    objs = [*objects(hashes), {"name": "Ghost", "mesh_hash": 424242, "matrix_world": np.eye(4)}]
    assert daemon.frame_update(4, objs, camera(), lights(), RESOLUTION) == [424242]
    with pytest.raises(antumbra.DaemonError) as e:
        daemon.render(4)
    assert e.value.code == "UnknownMesh"
    assert "object 'Ghost'" in str(e.value)
    assert e.value.session_usable
    assert isinstance(e.value, antumbra.RequestError)
    # The session goes on.
    assert send_frame(daemon, hashes, 1) == []
    assert daemon.render(1).frame == 1
    with pytest.raises(antumbra.DaemonError, match="no FrameUpdate for frame 77") as e:
        daemon.render(77)
    assert e.value.code == "InvalidInput"


def test_same_errors_as_local_for_bad_meshes(daemon):
    p, t = box()
    p[2, 0] = np.nan
    with pytest.raises(antumbra.InvalidInput, match=r"mesh 'Bad'.*NaN"):
        daemon.upload_mesh("Bad", p, t)
    with pytest.raises(antumbra.InvalidInput, match=r"'Bad'.positions: .*float32"):
        daemon.upload_mesh("Bad", p.astype(np.float64), t)
    assert daemon.stats()["meshes_cached"] == 0


def test_progress_false_cancels(daemon):
    hashes = upload_scene(daemon)
    heavy = {"x": 200, "y": 150, "percentage": 100}
    area = {
        "name": "Area",
        "type": "AREA",
        "size": 2.0,
        "matrix_world": translation(0, 0, 6.0),
    }
    daemon.frame_update(1, objects(hashes), camera(), [*lights(), area], heavy)
    with pytest.raises(antumbra.DaemonError) as e:
        daemon.render(1, spp=32, progress=lambda stage, done, total: stage != "render")
    assert e.value.code == "Cancelled"
    assert e.value.session_usable
    # The Ack of the Cancel does not confuse the next request.
    assert daemon.missing_meshes(list(hashes.values())) == []
    assert daemon.stats()["renders_cancelled"] == 1


def test_progress_exception_propagates_and_session_goes_on(daemon):
    hashes = upload_scene(daemon)
    send_frame(daemon, hashes, 1)

    class Stop(Exception):
        pass

    def stop(*_):
        raise Stop

    with pytest.raises(Stop):
        daemon.render(1, progress=stop)
    assert daemon.render(1).frame == 1
    assert daemon.missing_meshes([1]) == [1]


def test_cancel_from_another_thread(daemon):
    hashes = upload_scene(daemon)
    heavy = {"x": 200, "y": 150, "percentage": 100}
    area = {"name": "Area", "type": "AREA", "size": 2.0, "matrix_world": translation(0, 0, 6)}
    daemon.frame_update(1, objects(hashes), camera(), [*lights(), area], heavy)
    outcome = {}

    def run():
        try:
            outcome["result"] = daemon.render(1, spp=32)
        except antumbra.AntumbraError as e:
            outcome["error"] = e

    thread = threading.Thread(target=run)
    thread.start()
    deadline = time.monotonic() + 30
    while daemon.active_request is None and time.monotonic() < deadline:
        time.sleep(0.001)
    assert daemon.active_request is not None
    # The session is busy with the render; only cancel() may be used meanwhile.
    with pytest.raises(antumbra.SessionBusy):
        daemon.stats()
    assert daemon.cancel()
    thread.join(60)
    assert "error" in outcome, outcome
    assert isinstance(outcome["error"], antumbra.DaemonError)
    assert outcome["error"].code == "Cancelled"
    assert daemon.active_request is None
    assert not daemon.cancel()
    assert daemon.stats()["renders_cancelled"] == 1


def test_recording_replays_with_the_cli(daemon, antumbra_bin, short_tmp):
    hashes = upload_scene(daemon)
    recording = short_tmp / "scene.antrec"
    daemon.start_recording(recording)
    for frame in (1, 2):
        upload_missing(daemon, send_frame(daemon, hashes, frame))
    assert daemon.stop_recording() == (2, 0)
    # Uploads to the file only: the daemon already held every mesh.
    assert daemon.stats()["meshes_cached"] == 3
    out = short_tmp / "out"
    run = subprocess.run(
        [str(antumbra_bin), "render", "--scene", str(recording), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    assert any(out.rglob("*.exr")), list(out.rglob("*"))


def test_close_and_shutdown(antumbra_bin, short_tmp):
    client = antumbra.Client.spawn(antumbra_bin, socket_path=short_tmp / "s.sock", timeout=30)
    process = client.process
    with antumbra.Client.connect(client.socket_path) as other:
        other.shutdown()
        assert other.closed
    process.wait(timeout=30)
    with pytest.raises((antumbra.ConnectionLost, antumbra.DaemonTimeout)):
        client.stats()
    client.close()
    with pytest.raises(antumbra.ConnectionLost):
        client.stats()


def test_spawned_daemon_stops_on_close(antumbra_bin):
    with antumbra.Client.spawn(antumbra_bin, timeout=30) as client:
        path = client.socket_path
        process = client.process
        assert os.path.exists(path)
    assert process.poll() is not None
    assert not os.path.exists(path)
    with pytest.raises(antumbra.DaemonUnavailable, match="antumbra serve --socket"):
        antumbra.Client.connect(path)


def test_spawn_reports_a_daemon_that_cannot_start(antumbra_bin, short_tmp):
    with pytest.raises(antumbra.DaemonUnavailable, match="exited"):
        antumbra.Client.spawn(antumbra_bin, socket_path=short_tmp / "x.sock", args=["--bogus"])
