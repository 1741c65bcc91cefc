"""Instance arrays (``frame_update(..., instances=[...])``): the same frame as one object per
placement, answers bit for bit, in both sessions; only arrays that changed travel to the daemon;
bad arrays are refused naming the array and the instance; recordings keep them."""

from __future__ import annotations

import numpy as np
import pytest

import antumbra
from conftest import RESOLUTION, box, camera, grid, lights, rotation_z, translation

N = 40  # boxes on a ring


def ring(frame: int) -> np.ndarray:
    """N box placements (n, 4, 4), exact in float32 so that objects and arrays agree."""
    out = []
    for i in range(N):
        a = 2 * np.pi * i / N + 0.05 * frame
        m = translation(3.5 * np.cos(a), 3.5 * np.sin(a), 0.0) @ rotation_z(a)
        m[:3, :3] *= 0.4 + 0.01 * (i % 5)
        out.append(m)
    return np.array(out).astype(np.float32).astype(np.float64)


def upload(session) -> dict[str, int]:
    hashes = {}
    for name, arrays in {"Ground": grid(), "Box": box(1.0)}.items():
        hashes[name] = antumbra.mesh_hash(*arrays)
        if session.missing_meshes([hashes[name]]):
            session.upload_mesh(name, *arrays)
    return hashes


def ground(hashes) -> list[dict]:
    return [{"name": "Ground", "mesh_hash": hashes["Ground"], "matrix_world": np.eye(4)}]


def as_objects(hashes, matrices, ids) -> list[dict]:
    return [
        {"name": f"Ring[{i}]", "mesh_hash": hashes["Box"], "matrix_world": m}
        for i, m in zip(ids, matrices, strict=True)
    ]


def as_array(hashes, matrices, ids) -> list[dict]:
    return [{"name": "Ring", "mesh_hash": hashes["Box"], "matrices": matrices, "ids": ids}]


def send(session, frame, hashes, *, instanced: bool, matrices=None) -> list[int]:
    matrices = ring(frame) if matrices is None else matrices
    ids = np.arange(N, dtype=np.uint32) * 3 + 7
    if instanced:
        return session.frame_update(
            frame, ground(hashes), camera(1), lights(), RESOLUTION, as_array(hashes, matrices, ids)
        )
    objects = ground(hashes) + as_objects(hashes, matrices, ids)
    return session.frame_update(frame, objects, camera(1), lights(), RESOLUTION)


PASSES = ("masks", "heat_maps", "object_ids", "visible")


def assert_same_answers(a, b):
    """Masks, object ids and the visible set (work counts depend on a session's history)."""
    assert np.array_equal(a.object_ids, b.object_ids)
    assert a.masks.keys() == b.masks.keys()
    for name in a.masks:
        assert np.array_equal(a.masks[name], b.masks[name]), name
    assert np.array_equal(a.visible, b.visible)


def assert_same(a, b):
    assert [n for n, _ in a.planes] == [n for n, _ in b.planes]
    for (name, x), (_, y) in zip(a.planes, b.planes, strict=True):
        assert np.array_equal(x, y), name
    assert np.array_equal(a.visible, b.visible)


def fresh(kind: str, daemon):
    """A session with no history (the default method learns across frames)."""
    if kind == "local":
        return antumbra.LocalSession()
    return antumbra.Client.connect(daemon.socket_path, timeout=30)


@pytest.mark.parametrize("kind", ["local", "daemon"])
def test_arrays_render_as_objects(kind, daemon):
    with fresh(kind, daemon) as session:
        hashes = upload(session)
        assert send(session, 1, hashes, instanced=False) == []
        objects = session.render(1, passes=PASSES)
    with fresh(kind, daemon) as session:
        upload(session)
        assert send(session, 1, hashes, instanced=True) == []
        arrays = session.render(1, passes=PASSES)
        assert_same(objects, arrays)
        # The boxes are seen and cast shadows: object ids past the ground's.
        ids = arrays.object_ids
        assert (ids >= 1).sum() > 100 and ids.max() <= N
        assert (arrays.masks["Sun"] == 0).sum() > 100
        # And they are where the matrices say: moving the array changes the picture.
        assert send(session, 3, hashes, instanced=True, matrices=ring(9)) == []
        assert not np.array_equal(session.render(3, passes=PASSES).object_ids, ids)


def test_only_changed_arrays_travel(daemon):
    hashes = upload(daemon)
    sent = []
    for frame, matrices in [(1, ring(1)), (2, ring(1)), (3, ring(4)), (4, ring(4))]:
        before = daemon.bytes_sent
        assert send(daemon, frame, hashes, instanced=True, matrices=matrices) == []
        sent.append(daemon.bytes_sent - before)
    matrix_bytes = N * 48
    # Frames 2 and 4 repeat the array before them: sent without its matrices and ids.
    assert sent[0] > matrix_bytes and sent[2] > matrix_bytes
    assert sent[1] < sent[0] - matrix_bytes and sent[3] < sent[2] - matrix_bytes
    # And the daemon renders each as the whole array (a fresh session as reference).
    for frame, matrices in [(2, ring(1)), (4, ring(4))]:
        ours = daemon.render(frame, passes=PASSES)
        with antumbra.LocalSession() as local:
            upload(local)
            send(local, frame, hashes, instanced=True, matrices=matrices)
            assert_same_answers(ours, local.render(frame, passes=PASSES))


def test_a_refused_frame_does_not_become_the_base(daemon):
    """An array repeats the last frame the daemon *accepted*: a refused frame in between
    changes nothing on either side."""
    hashes = upload(daemon)
    send(daemon, 1, hashes, instanced=True, matrices=ring(1))
    bad = camera(1)
    bad["lens"] = -1.0
    with pytest.raises(antumbra.InvalidInput, match="lens"):
        daemon.frame_update(
            2, ground(hashes), bad, lights(), RESOLUTION, as_array(hashes, ring(5), np.arange(N))
        )
    assert send(daemon, 3, hashes, instanced=True, matrices=ring(1)) == []
    ours = daemon.render(3, passes=PASSES)
    with antumbra.LocalSession() as local:
        upload(local)
        send(local, 3, hashes, instanced=True, matrices=ring(1))
        assert_same_answers(ours, local.render(3, passes=PASSES))


BAD_ARRAYS = [
    (
        {"matrices": np.zeros((4, 4))},
        r"instances\[0\] 'Ring'.matrices: expected an array of world matrices",
    ),
    ({"matrices": "no"}, r"instances\[0\] 'Ring'.matrices: expected"),
    (
        {"matrices": np.full((2, 4, 4), np.nan)},
        r"instances\[0\] 'Ring'.matrices\[0\]\[0\]\[0\]: must be finite",
    ),
    (
        {"matrices": np.ones((2, 4, 4))},
        r"instances\[0\] 'Ring'.matrices\[0\]\[3\]: the last row must be \(0, 0, 0, 1\)",
    ),
    ({"ids": np.arange(3)}, r"instances\[0\] 'Ring'.ids: expected 2 integer ids"),
    ({"ids": np.array([0.5, 1.5])}, r"instances\[0\] 'Ring'.ids: expected 2 integer ids"),
    ({"ids": np.array([1, -1])}, r"instances\[0\] 'Ring'.ids\[1\]: -1 is out of range"),
    ({"colour": 1}, r"instances\[0\] 'Ring': unknown field 'colour'"),
]


@pytest.mark.parametrize("change,pattern", BAD_ARRAYS)
def test_bad_arrays_are_named(change, pattern):
    with antumbra.LocalSession() as session:
        hashes = upload(session)
        array = {"name": "Ring", "mesh_hash": hashes["Box"], "matrices": ring(1)[:2]}
        array.update(change)
        with pytest.raises(antumbra.InvalidInput, match=pattern):
            session.frame_update(1, ground(hashes), camera(1), lights(), RESOLUTION, [array])


def test_an_array_of_a_mesh_never_uploaded(daemon):
    """Reported missing like an object's mesh; rendering without it names the array."""
    hashes = upload(daemon)
    array = {"name": "Ring", "mesh_hash": 12345, "matrices": ring(1)}
    missing = daemon.frame_update(1, ground(hashes), camera(1), lights(), RESOLUTION, [array])
    assert missing == [12345]
    with pytest.raises(antumbra.DaemonError, match=r"object 'Ring\[\]' refers to mesh"):
        daemon.render(1)


def test_two_arrays_of_one_name_are_refused(daemon):
    hashes = upload(daemon)
    arrays = as_array(hashes, ring(1), np.arange(N)) * 2
    with pytest.raises(antumbra.DaemonError, match="two instance arrays are named 'Ring'"):
        daemon.frame_update(1, ground(hashes), camera(1), lights(), RESOLUTION, arrays)
    # The session goes on.
    assert send(daemon, 1, hashes, instanced=True) == []


def test_recording_keeps_arrays(daemon, tmp_path):
    path = tmp_path / "rec.antrec"
    daemon.start_recording(path)
    hashes = upload(daemon)
    send(daemon, 1, hashes, instanced=True, matrices=ring(1))
    send(daemon, 2, hashes, instanced=True, matrices=ring(1))  # sent unchanged
    daemon.stop_recording()
    recording = antumbra.read_recording(path)
    frames = recording["frames"]
    assert [f["frame"] for f in frames] == [1, 2]
    for f in frames:
        (array,) = f["instances"]
        assert array["name"] == "Ring" and array["mesh_hash"] == hashes["Box"]
        assert np.array_equal(array["matrices"], ring(1).astype(np.float32))
        assert np.array_equal(array["ids"], np.arange(N) * 3 + 7)
