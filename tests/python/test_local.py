"""The in-process session (antumbra.LocalSession): rendering, results, and the errors of bad
input. No daemon is needed."""

from __future__ import annotations

import ctypes
import ctypes.util
import math
import struct

import numpy as np
import pytest

import antumbra
from conftest import (
    HEIGHT,
    RESOLUTION,
    WIDTH,
    box,
    camera,
    lights,
    objects,
    send_frame,
    translation,
    upload_scene,
)

STATS_COLUMNS = {
    "scene",
    "frame",
    "method",
    "pass",
    "light",
    "rebuilt",
    "build_ms",
    "bvh_nodes",
    "bvh_bytes",
    "triangles",
    "rays",
    "trace_ms",
    "mrays_per_s",
    "timed_without_counters",
    "occluded_fraction",
    "nb_per_ray",
    "nl_per_ray",
    "nt_per_ray",
    "nbox_per_ray",
    "back_facing",
    "unreached",
    "prepare_ms",
    "references",
    "visible_input",
    "visibility_ms",
    "nts_per_ray",
    "auto_choice",
    "auto_estimate_ms",
    "alpha_lookups_per_ray",
    "trees_refit",
    "packets",
    "steps_per_packet",
    "handoffs_per_ray",
}


@pytest.fixture
def session():
    with antumbra.LocalSession() as s:
        yield s


@pytest.fixture
def scene(session):
    hashes = upload_scene(session)
    assert send_frame(session, hashes, 1) == []
    return session, hashes


# ---------------------------------------------------------------------------------------------
# Meshes and hashes


def _libxxhash():
    """The C library's XXH3_64bits, an implementation independent of ours (None if absent)."""
    name = ctypes.util.find_library("xxhash")
    if name is None:
        return None
    fn = ctypes.CDLL(name).XXH3_64bits
    fn.restype = ctypes.c_uint64
    fn.argtypes = [ctypes.c_char_p, ctypes.c_size_t]
    return fn


def xxh3_reference(positions: np.ndarray, triangles: np.ndarray) -> int | None:
    """docs/protocol.md's mesh hash: XXH3 of the counts and the little-endian bytes."""
    xxh3 = _libxxhash()
    if xxh3 is None:
        return None
    p = positions.astype("<f4").tobytes()
    t = triangles.astype("<u4").tobytes()
    data = struct.pack("<Q", len(p) // 12) + p + struct.pack("<Q", len(t) // 12) + t
    return xxh3(data, len(data))


def test_mesh_hash_matches_the_protocol():
    tri_p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
    tri_t = np.array([[0, 1, 2]], dtype=np.uint32)
    assert antumbra.mesh_hash(tri_p, tri_t) == 0x6FFD2BEBBB67E42D
    p, t = box()
    reference = xxh3_reference(p, t)
    if reference is not None:
        assert antumbra.mesh_hash(p, t) == reference
    # Any integer dtype and memory layout gives the same hash.
    assert antumbra.mesh_hash(p, t.astype(np.int64)) == antumbra.mesh_hash(p, t)
    assert antumbra.mesh_hash(np.asfortranarray(p), t[::1]) == antumbra.mesh_hash(p, t)
    strided = np.zeros((8, 6), dtype=np.float32)
    strided[:, ::2] = p
    assert antumbra.mesh_hash(strided[:, ::2], t) == antumbra.mesh_hash(p, t)


def test_upload_and_missing(session):
    p, t = box()
    h = antumbra.mesh_hash(p, t)
    assert session.missing_meshes([h, 7]) == [h, 7]
    assert session.upload_mesh("Cube", p, t) == h
    assert session.missing_meshes([h, 7, 7]) == [7]
    stats = session.stats()
    assert stats["meshes_cached"] == 1
    assert stats["bytes_cached"] == p.nbytes + 12 * len(t)
    # The same content again is the same mesh.
    assert session.upload_mesh("Cube.001", p.copy(), t.copy()) == h
    assert session.stats()["meshes_cached"] == 1


def test_frame_update_reports_missing_meshes(session):
    hashes = {"Ground": 11, "Box": 22, "Tall": 11}
    missing = session.frame_update(1, objects(hashes), camera(), lights(), RESOLUTION)
    assert missing == [11, 22]  # distinct, in order of first use


# ---------------------------------------------------------------------------------------------
# Rendering


def test_render_shapes_values_and_stats(scene):
    session, _ = scene
    r = session.render(1, spp=8)
    assert (r.frame, r.width, r.height) == (1, WIDTH, HEIGHT)
    names = [n for n, _ in r.planes]
    assert names == [
        "shadow.Sun",
        "shadow.Lamp",
        "combined",
        "primary.N_B",
        "primary.N_L",
        "primary.N_T",
        "shadow.N_B",
        "shadow.N_L",
        "shadow.N_T",
    ]
    for name, image in r.planes:
        assert image.dtype == np.float32, name
        assert image.shape == (HEIGHT, WIDTH), name
        assert np.isfinite(image).all(), name
    assert set(r.masks) == {"Sun", "Lamp"}
    for light, mask in r.masks.items():
        assert mask.min() >= 0.0 and mask.max() <= 1.0, light
        assert (mask < 0.5).sum() > 20, f"{light}: no shadow"
        assert (mask == 1.0).sum() > WIDTH * HEIGHT // 2, f"{light}: mostly shadowed"
    np.testing.assert_allclose(
        r.combined, (r.masks["Sun"] + r.masks["Lamp"]) / 2, rtol=0, atol=1e-6
    )
    assert r.images["primary.N_B"].max() > 0
    # Stats: the primary pass, then one row per shadow-casting light.
    assert [(s["pass"], s["light"]) for s in r.stats] == [
        ("primary", ""),
        ("shadow", "Sun"),
        ("shadow", "Lamp"),
    ]
    for row in r.stats:
        assert set(row) == STATS_COLUMNS
        assert row["frame"] == 1 and row["scene"] == "antumbra-python"
        assert row["rays"] > 0
    assert r.stats[0]["rays"] == WIDTH * HEIGHT
    assert 0 < r.stats[1]["occluded_fraction"] < 1
    # The visible set: sorted (object, triangle) pairs of the four objects.
    assert r.visible.dtype == np.uint32 and r.visible.shape[1] == 2
    assert len(r.visible) > 0
    assert set(np.unique(r.visible[:, 0])) <= {0, 1, 2, 3}
    keys = r.visible[:, 0].astype(np.int64) << 32 | r.visible[:, 1]
    assert (np.diff(keys) > 0).all()


def test_passes_and_settings(scene):
    session, _ = scene
    r = session.render(1, passes=["combined"])
    assert [n for n, _ in r.planes] == ["combined"]
    assert r.visible is None and r.masks == {}
    r = session.render(
        1, passes=("masks", "visible"), timing="only", build="sah", width=2, order="stored"
    )
    assert [n for n, _ in r.planes] == ["shadow.Sun", "shadow.Lamp"]
    assert r.stats[0]["method"] == "sah/bin2/stored"
    assert r.stats[0]["timed_without_counters"]
    r = session.render(1, passes=["heat_maps"], leaf_size=2, bins=8)
    assert r.planes[0][0] == "primary.N_B"


def test_smallest_leaf_changes_work_not_masks(scene):
    session, _ = scene
    osah = {"build": "osah", "visibility": "exact", "width": 2, "order": "fbto"}
    base = session.render(1, passes=["masks", "heat_maps"], **osah)
    r = session.render(1, passes=["masks", "heat_maps"], min_leaf_size=8, **osah)
    planes = dict(r.planes)
    for name, mask in base.planes:
        if name.startswith("shadow.") and not name.startswith("shadow.N_"):
            assert np.array_equal(mask, planes[name]), name
    # Leaves of up to 8 triangles: no more nodes entered, at least as many triangle tests.
    assert planes["primary.N_T"].sum() >= dict(base.planes)["primary.N_T"].sum()
    assert planes["primary.N_B"].sum() < dict(base.planes)["primary.N_B"].sum()


def test_width_and_order_change_work_not_masks(scene):
    session, _ = scene
    base = session.render(1, passes=["masks"])
    for width, order in [
        (4, "sato"),
        (8, "sorted:logging=fbto:budget=0.5"),
        (2, "rtsah"),
        (2, "srdh:rays=all:min_occluded=0"),
    ]:
        r = session.render(1, passes=["masks"], build="sah", width=width, order=order)
        assert all(
            np.array_equal(x, y) for (_, x), (_, y) in zip(base.planes, r.planes, strict=True)
        )
        shadow = [s for s in r.stats if s["pass"] == "shadow"]
        assert shadow and all(s["method"].startswith(f"sah/bin{width}/") for s in shadow)
        # prepare_ms: the per-light preparation (sorting, or the SRDH ray set and build); a
        # per-tree order (sato, rtsah) is made once for all lights, reported on the first row.
        per_light = order.startswith(("sorted", "srdh"))
        per_tree = order in ("sato", "rtsah")
        assert len(shadow) > 1
        assert [s["prepare_ms"] > 0 for s in shadow] == [
            per_light or (per_tree and i == 0) for i in range(len(shadow))
        ]


def test_build_srdh_is_the_srdh_order(scene):
    session, _ = scene
    r = session.render(1, passes=["masks"], build="srdh", width=2)
    assert all(s["method"].startswith("sah/bin2/srdh:rays=16x16") for s in r.stats)
    with pytest.raises(antumbra.InvalidInput, match="cannot also be 'sato'"):
        session.render(1, build="srdh", order="sato")
    assert antumbra.render_settings(build="srdh")["order"].startswith("srdh")


def test_osah_viability_rule_changes_work_not_masks(scene):
    session, _ = scene
    base = session.render(1, passes=["masks"])
    for rule in ("strict", "paper"):
        r = session.render(
            1, passes=["masks"], build="osah", visibility="exact", osah_viability=rule
        )
        assert all(
            np.array_equal(x, y) for (_, x), (_, y) in zip(base.planes, r.planes, strict=True)
        )
    settings = antumbra.render_settings(build="osah", osah_viability="paper")
    assert settings["osah_viability"] == "paper"
    assert antumbra.render_settings()["osah_viability"] == "strict"


def test_collapse_and_spatial_axes_change_work_not_masks(scene):
    session, _ = scene
    base = session.render(1, passes=["masks"])
    work = {}
    for collapse in ("sah", "greedy"):
        r = session.render(1, passes=["masks"], width=8, collapse=collapse)
        assert all(
            np.array_equal(x, y) for (_, x), (_, y) in zip(base.planes, r.planes, strict=True)
        )
        work[collapse] = r.stats[0]["bvh_nodes"]
    # Different trees (fewer, fuller nodes with the SAH collapse), the same answers.
    assert work["sah"] < work["greedy"]
    r = session.render(1, passes=["masks"], build="sbvh", spatial_axes="all")
    assert all(np.array_equal(x, y) for (_, x), (_, y) in zip(base.planes, r.planes, strict=True))
    settings = antumbra.render_settings(collapse="greedy", spatial_axes="all")
    assert (settings["collapse"], settings["spatial_axes"]) == ("greedy", "all")
    default = antumbra.render_settings()
    assert (default["collapse"], default["spatial_axes"]) == ("sah", "object")


def test_render_is_deterministic_and_reuses_bvhs(scene):
    session, _ = scene
    # A fixed method: auto's second render chooses from what the first measured.
    fixed = {"build": "sah", "width": 2, "order": "fbto"}
    a = session.render(1, spp=4, seed=3, **fixed)
    b = session.render(1, spp=4, seed=3, **fixed)
    assert all(np.array_equal(x, y) for (_, x), (_, y) in zip(a.planes, b.planes, strict=True))
    assert [s["rebuilt"] for s in b.stats] == [False] * 3
    c = session.render(1, spp=4, seed=4, **fixed)
    assert not np.array_equal(a.masks["Lamp"], c.masks["Lamp"])  # another sample pattern


def test_matrices_are_row_major_like_blender(session):
    """An object placed by a translation in the last column renders exactly like its mesh
    translated in object space: the client turns Blender's row-major matrices column-major."""
    p, t = box()
    moved = (p + np.array([2.0, -1.0, 0.0], dtype=np.float32)).astype(np.float32)
    h = session.upload_mesh("Box", p, t)
    hm = session.upload_mesh("BoxMoved", moved, t)
    ground = session.upload_mesh("Ground", *box(8.0))

    def render(mesh_hash, matrix):
        objs = [
            {
                "name": "Ground",
                "mesh_hash": ground,
                "matrix_world": translation(0, 0, -8.0),
            },
            {"name": "Box", "mesh_hash": mesh_hash, "matrix_world": matrix},
        ]
        session.frame_update(1, objs, camera(), lights(), RESOLUTION)
        return session.render(1, passes=["masks", "combined"])

    a = render(h, translation(2.0, -1.0, 0.0))
    b = render(hm, np.eye(4))
    # Nested lists and any object with rows (as mathutils.Matrix) work too.
    c = render(h, translation(2.0, -1.0, 0.0).tolist())

    class Rows:
        def __init__(self, m):
            self.m = m

        def __len__(self):
            return 4

        def __getitem__(self, i):
            return tuple(self.m[i])

    d = render(h, Rows(translation(2.0, -1.0, 0.0)))
    for other in (b, c, d):
        for (_, x), (_, y) in zip(a.planes, other.planes, strict=True):
            assert np.array_equal(x, y)
    e = render(h, np.eye(4))
    assert not np.array_equal(a.combined, e.combined)


def test_progress_callback(scene):
    session, _ = scene
    calls = []
    session.render(1, progress=lambda *a: calls.append(a))
    assert calls == [("render", 0, 2), ("encode", 1, 2)]
    with pytest.raises(antumbra.RequestError) as e:
        session.render(1, progress=lambda *a: False)
    assert e.value.code == "Cancelled"

    class Stop(Exception):
        pass

    def boom(*_):
        raise Stop("stop")

    with pytest.raises(Stop):
        session.render(1, progress=boom)
    assert session.render(1).frame == 1  # still usable
    assert session.stats()["renders_cancelled"] == 1


def test_animation(session):
    hashes = upload_scene(session)
    results = []
    for frame in (1, 2, 3):
        assert send_frame(session, hashes, frame) == []
        results.append(session.render(frame))
    assert [r.frame for r in results] == [1, 2, 3]
    assert not np.array_equal(results[0].combined, results[2].combined)
    # Earlier frames stay renderable.
    again = session.render(1)
    assert np.array_equal(again.combined, results[0].combined)


def test_area_and_spot_lights(scene):
    session, hashes = scene
    extra = [
        {
            "name": "Area",
            "type": "AREA",
            "shape": "RECTANGLE",
            "size": 1.0,
            "size_y": 0.5,
            "matrix_world": translation(0.0, 0.0, 5.0),
        },
        {
            "name": "Spot",
            "type": "SPOT",
            "spot_size": math.radians(60),
            "spot_blend": 0.2,
            "shadow_soft_size": 0.0,
            "matrix_world": translation(1.0, 1.0, 6.0),
        },
        {"name": "NoShadow", "type": "POINT", "matrix_world": np.eye(4), "use_shadow": False},
    ]
    session.frame_update(2, objects(hashes, 2), camera(2), lights() + extra, RESOLUTION)
    r = session.render(2, spp=4)
    assert list(r.masks) == ["Sun", "Lamp", "Area", "Spot"]


def test_lights_of_one_name_keep_every_mask(scene):
    """Two lights named Sun and one named like a heat map keep a mask each, under the unique
    names the planes use (Sun, Sun#2, N_B#2), so no mask is lost in the dict."""
    session, hashes = scene
    sun, lamp = lights()
    twin = dict(lamp, name="Sun")
    heat = dict(lamp, name="N_B", matrix_world=translation(0.5, 0.5, 6.0))
    session.frame_update(2, objects(hashes, 2), camera(2), [sun, twin, heat], RESOLUTION)
    r = session.render(2, spp=1)
    assert list(r.masks) == ["Sun", "Sun#2", "N_B#2"]
    for name, array in r.masks.items():
        assert array is r.images[f"shadow.{name}"]
    # The sun's and the lamp's masks, not one of them twice.
    assert not np.array_equal(r.masks["Sun"], r.masks["Sun#2"])


def test_recording(scene, tmp_path):
    session, hashes = scene
    path = tmp_path / "session.antrec"
    session.start_recording(path)
    # Meshes the file lacks are reported missing, so the usual loop uploads them.
    assert sorted(send_frame(session, hashes, 2)) == sorted(set(hashes.values()))
    upload_scene(session)
    assert send_frame(session, hashes, 3) == []
    assert session.stop_recording() == (2, 0)
    data = path.read_bytes()
    assert data.startswith(b"ANTREC1\n")
    with pytest.raises(antumbra.InvalidInput, match="no recording"):
        session.stop_recording()


# ---------------------------------------------------------------------------------------------
# Bad input: clear errors that name what is wrong


def test_nan_vertex_names_the_mesh(session):
    p, t = box()
    p[5, 1] = np.nan
    with pytest.raises(antumbra.InvalidInput, match=r"mesh 'Rock\.001'.*NaN.*index 5"):
        session.upload_mesh("Rock.001", p, t)
    p[5, 1] = np.inf
    with pytest.raises(ValueError, match="Rock"):  # InvalidInput is a ValueError too
        session.upload_mesh("Rock", p, t)


def test_index_out_of_range_names_the_mesh(session):
    p, t = box()
    t[3, 2] = 8
    with pytest.raises(
        antumbra.InvalidInput, match=r"mesh 'Suzanne': triangle 3 refers to vertex 8.*8 vertices"
    ):
        session.upload_mesh("Suzanne", p, t)
    t = t.astype(np.int32)
    t[3, 2] = -1
    with pytest.raises(antumbra.InvalidInput, match=r"mesh 'Suzanne'.triangles: triangle 3.*-1"):
        session.upload_mesh("Suzanne", p, t)


@pytest.mark.parametrize(
    ("positions", "triangles", "pattern"),
    [
        (np.zeros((4, 3)), None, r"'M'.positions: .*float32.*float64 array of shape \(4, 3\)"),
        (np.zeros((4, 2), np.float32), None, r"'M'.positions: .*shape \(n, 3\).*\(4, 2\)"),
        (np.zeros(12, np.float32), None, r"'M'.positions: .*\(12,\)"),
        ([[0.0, 0.0, 0.0]], None, r"'M'.positions: .*got list"),
        (np.zeros((4, 3), np.int32), None, r"'M'.positions: .*float32.*int32"),
        (None, np.zeros((2, 3), np.float32), r"'M'.triangles: .*integer.*float32"),
        (None, np.zeros((2, 4), np.uint32), r"'M'.triangles: .*\(m, 3\).*\(2, 4\)"),
        (None, np.zeros((2, 3), bool), r"'M'.triangles: .*integer.*bool"),
        (None, "012", r"'M'.triangles: .*got str"),
    ],
)
def test_wrong_array_shapes_and_dtypes(session, positions, triangles, pattern):
    p, t = box()
    p = p if positions is None else positions
    t = t if triangles is None else triangles
    with pytest.raises(antumbra.InvalidInput, match=pattern):
        session.upload_mesh("M", p, t)
    with pytest.raises(TypeError):  # InvalidInput is a TypeError too
        session.upload_mesh("M", p, t)


def test_mesh_name_must_be_a_string(session):
    with pytest.raises(antumbra.InvalidInput, match="mesh name: expected a str, got int"):
        session.upload_mesh(3, *box())


def test_unknown_mesh_hash_names_the_object(scene):
    session, hashes = scene
    objs = [*objects(hashes), {"name": "Ghost", "mesh_hash": 12345, "matrix_world": np.eye(4)}]
    assert session.frame_update(5, objs, camera(), lights(), RESOLUTION) == [12345]
    with pytest.raises(antumbra.RequestError) as e:
        session.render(5)
    assert e.value.code == "UnknownMesh"
    assert "object 'Ghost'" in str(e.value) and "frame 5" in str(e.value)
    assert e.value.session_usable
    assert not isinstance(e.value, antumbra.DaemonError)
    assert session.render(1).frame == 1  # the session goes on


def test_render_of_a_frame_never_sent(scene):
    session, _ = scene
    with pytest.raises(antumbra.RequestError, match="no FrameUpdate for frame 9") as e:
        session.render(9)
    assert e.value.code == "InvalidInput"


def frame_with(session, hashes, *, obj=None, cam=None, light=None, resolution=RESOLUTION):
    objs = objects(hashes)
    if obj is not None:
        objs[1] = {**objs[1], **obj}
    c = camera() if cam is None else {**camera(), **cam}
    ls = lights() if light is None else [{**lights()[0], **light}]
    return session.frame_update(1, objs, c, ls, resolution)


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        ({"obj": {"matrix_world": np.eye(3)}}, r"objects\[1\] 'Box.A'.matrix_world: .*4x4"),
        ({"obj": {"matrix_world": "eye"}}, r"objects\[1\] 'Box.A'.matrix_world: .*got str"),
        (
            {"obj": {"matrix_world": np.full((4, 4), np.nan)}},
            r"objects\[1\] 'Box.A'.matrix_world\[0\]\[0\]: must be finite",
        ),
        ({"obj": {"mesh_hash": -1}}, r"objects\[1\] 'Box.A'.mesh_hash: -1 is out of range"),
        ({"obj": {"mesh_hash": 1.5}}, r"objects\[1\] 'Box.A'.mesh_hash: expected an integer"),
        ({"obj": {"name": 7}}, r"objects\[1\].name: expected a str, got int"),
        ({"obj": {"visible_camera": 1}}, r"'Box.A'.visible_camera: expected True or False"),
        ({"obj": {"colour": 1}}, r"'Box.A': unknown field 'colour'"),
        ({"cam": {"lens": "50"}}, r"camera.lens: expected a number, got str"),
        ({"cam": {"lens": -1.0}}, r"frame 1: camera.lens: must be a positive number"),
        ({"cam": {"sensor_fit": "DIAGONAL"}}, r"camera.sensor_fit: expected one of 'AUTO'"),
        ({"cam": {"clip_end": 0.01}}, r"frame 1: camera.clip_start/clip_end"),
        ({"light": {"type": "LASER"}}, r"lights\[0\] 'Sun'.type: expected one of 'POINT'"),
        ({"light": {"angle": 4.0}}, r"frame 1: light 'Sun'.angle: must be at most pi"),
        ({"light": {"use_shadow": "yes"}}, r"'Sun'.use_shadow: expected True or False"),
        ({"resolution": {"x": 0, "y": 10}}, r"frame 1: resolution: must be positive"),
        ({"resolution": {"x": 10}}, r"resolution.y: missing"),
        ({"resolution": {"x": 10, "y": 10, "scale": 2}}, r"resolution: unknown field 'scale'"),
        ({"resolution": (10, 10, 10)}, r"resolution: expected a dict or an \(x, y\) pair"),
        (
            {"resolution": {"x": 100000, "y": 100000}},
            r"exceeds the limit of 67108864 \(max_image_pixels\)",
        ),
    ],
)
def test_bad_scene_fields_are_named(scene, kwargs, pattern):
    session, hashes = scene
    with pytest.raises(antumbra.InvalidInput, match=pattern):
        frame_with(session, hashes, **kwargs)


def test_bad_containers(scene):
    session, hashes = scene
    with pytest.raises(antumbra.InvalidInput, match=r"objects: expected a list, got dict"):
        session.frame_update(1, {"a": 1}, camera(), [], RESOLUTION)
    with pytest.raises(antumbra.InvalidInput, match=r"objects\[0\]: expected a dict, got int"):
        session.frame_update(1, [1], camera(), [], RESOLUTION)
    with pytest.raises(antumbra.InvalidInput, match=r"objects\[0\]: unknown field 'nme'"):
        session.frame_update(1, [{"nme": "x"}], camera(), [], RESOLUTION)
    with pytest.raises(antumbra.InvalidInput, match=r"objects\[0\] 'x'.mesh_hash: missing"):
        session.frame_update(1, [{"name": "x"}], camera(), [], RESOLUTION)
    with pytest.raises(antumbra.InvalidInput, match=r"camera.matrix_world: missing"):
        session.frame_update(1, [], {}, [], RESOLUTION)
    with pytest.raises(antumbra.InvalidInput, match=r"frame: expected an integer, got float"):
        session.frame_update(1.0, [], camera(), [], RESOLUTION)
    with pytest.raises(antumbra.InvalidInput, match=r"hashes\[1\]: expected an integer"):
        session.missing_meshes([1, "2"])
    with pytest.raises(antumbra.InvalidInput, match=r"visible_shadow.*cast_shadow.*not both"):
        frame_with(session, hashes, obj={"visible_shadow": True, "cast_shadow": False})


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        ({"spp": 0}, r"spp: expected an integer in 1..=4096, got an integer \(0\)"),
        ({"spp": 5000}, r"spp"),
        ({"spp": 2.5}, r"spp: expected an integer in 1..=4096, got a number \(2.5\)"),
        ({"spp": True}, r"spp: expected an integer in 1..=4096, got a boolean \(true\)"),
        ({"spd": 4}, r"spd: unknown setting \(known: spp, seed, "),
        ({"osah_w": [0.5]}, r"osah_w: expected a boolean, an integer, a number or text, got list"),
        ({"bins": 1}, r"bins"),
        ({"leaf_size": 0}, r"leaf_size|max_leaf_size"),
        (
            {"leaf_size": 4, "min_leaf_size": 5},
            r"min_leaf_size: must be at most leaf_size \(4\), got 5",
        ),
        (
            {"min_leaf_size": -1},
            r"min_leaf_size: expected an integer in 1..=64, got an integer \(-1\)",
        ),
        ({"order": "far"}, r"order: .*unknown order 'far'"),
        ({"order": "sorted:budget=2"}, r"order: .*budget must be in \(0, 1\]"),
        ({"width": 3}, r"width: expected one of 2, 4, 8, got an integer \(3\)"),
        (
            {"build": "lbvh"},
            r"build: expected one of sah, sbvh, abvh, osah, vsah, srdh, auto, got text \('lbvh'\)",
        ),
        ({"timing": "always"}, r"timing: expected one of"),
        ({"osah_viability": "loose"}, r"osah_viability: expected one of strict, paper"),
        ({"collapse": "lazy"}, r"collapse: expected one of sah, greedy"),
        ({"spatial_axes": "xy"}, r"spatial_axes: expected one of object, all"),
        ({"timing": 1}, r"timing: expected one of off, on, only, got an integer \(1\)"),
        ({"passes": ["masks", "shadows"]}, r"passes: unknown pass 'shadows'"),
        ({"progress": 3}, r"progress: expected a callable"),
        ({"frame": "1"}, r"frame: expected an integer, got str"),
    ],
)
def test_bad_render_settings_are_named(scene, kwargs, pattern):
    session, _ = scene
    kwargs = {"frame": 1, **kwargs}
    with pytest.raises(antumbra.InvalidInput, match=pattern):
        session.render(**kwargs)


def test_closed_session(session):
    session.close()
    assert session.closed
    with pytest.raises(antumbra.ConnectionLost, match="closed"):
        session.missing_meshes([1])
    session.close()  # twice is fine


def test_blender_resolution_names_and_pairs(scene):
    session, hashes = scene
    blender = {"resolution_x": 40, "resolution_y": 30, "resolution_percentage": 50}
    session.frame_update(1, objects(hashes), camera(), lights(), blender)
    assert session.render(1).combined.shape == (15, 20)
    session.frame_update(1, objects(hashes), camera(), lights(), (40, 30))
    r = session.render(1)
    assert (r.width, r.height) == (40, 30)


def test_object_ids_pass(scene):
    """``object_ids``: per pixel the index of the object hit in the frame's object list, -1
    for background; the same objects as the visible set, and it follows the list's order."""
    session, hashes = scene
    r = session.render(1, passes=("object_ids", "visible"))
    assert [n for n, _ in r.planes] == ["primary.object"]
    ids = r.object_ids
    assert ids is r.images["primary.object"]
    assert ids.shape == (HEIGHT, WIDTH) and ids.dtype == np.float32
    assert set(np.unique(ids)) <= {-1.0, 0.0, 1.0, 2.0, 3.0}
    assert (ids == np.round(ids)).all()
    seen = {int(v) for v in np.unique(ids) if v >= 0}
    assert seen == {int(o) for o in np.unique(r.visible[:, 0])}
    assert len(seen) >= 3
    # Not asked for: absent; asked with the other passes: last, after the heat maps.
    assert session.render(1).object_ids is None
    full = session.render(1, passes=("masks", "combined", "heat_maps", "object_ids"))
    assert full.planes[-1][0] == "primary.object"
    assert np.array_equal(full.object_ids, ids)

    # The same scene with the object list reversed: the same picture, indices reversed.
    objs = objects(hashes, 1)
    assert session.frame_update(2, objs[::-1], camera(1), lights(), RESOLUTION) == []
    rev = session.render(2, passes=["object_ids"]).object_ids
    n = len(objs)
    assert np.array_equal(rev, np.where(ids < 0, -1.0, n - 1 - ids).astype(np.float32))
    # Hidden from the camera: never an id.
    objs[1]["visible_camera"] = False
    assert session.frame_update(3, objs, camera(1), lights(), RESOLUTION) == []
    hidden = session.render(3, passes=["object_ids"]).object_ids
    assert not (hidden == 1.0).any()
    assert np.array_equal(hidden[ids != 1.0], ids[ids != 1.0])


def test_settings_schema_describes_every_setting_render_takes():
    schema = antumbra.settings_schema()
    names = [s["name"] for s in schema]
    assert len(names) == len(set(names))
    assert {"spp", "build", "order", "leaf_size", "min_leaf_size", "osah_w", "width"} <= set(names)
    defaults = antumbra.render_settings()
    assert sorted(defaults) == sorted(names)
    for s in schema:
        assert s["default"] == defaults[s["name"]], s["name"]
        assert s["help"] and s["group_title"], s["name"]
        assert s["type"] in ("bool", "int", "float", "choice", "text"), s
        if s["type"] in ("int", "float"):
            assert s["min"] <= s["default"] <= s["max"], s
        if s["type"] == "choice":
            assert s["default"] in s["choices"], s
    # Each setting reaches the render: a non-default value of each comes back as given.
    for s in schema:
        if s["type"] == "choice":
            other = next(c for c in s["choices"] if c != s["default"])
        elif s["type"] == "bool":
            other = not s["default"]
        elif s["type"] == "int":
            other = s["min"] if s["default"] != s["min"] else s["min"] + 1
        else:
            continue
        given = {s["name"]: other}
        if s["name"] == "min_leaf_size":
            given["leaf_size"] = 64
        if s["name"] == "build" and other == "srdh":
            continue
        assert antumbra.render_settings(**given)[s["name"]] == other, s["name"]
