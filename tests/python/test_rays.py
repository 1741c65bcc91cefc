"""antumbra.rays against Embree 4.4 (embreex) on random triangle soups and a built-in scene.

Embree's triangle test is not watertight the way antumbra's is, and the two trace in different
float32 spaces (Embree in the caller's, antumbra in its normalised render space), so answers may
differ where rounding decides them. An exact float64 crossing test classifies every ray; the
documented edge conventions (docs/ray-queries.md) are:

- the closest crossing lies within ``EDGE`` (relative to the scene's size) of a triangle's edge:
  a ray through a shared edge or vertex may hit either triangle (or, for Embree, neither);
- two triangles are crossed at nearly the same t (``T_TIE``): either may be reported;
- the crossing is within ``T_TIE`` of the interval's ends (0 or tfar).

Every other ray must give the same triangle (and the same occlusion), with t within ``T_TOL`` and
barycentrics within ``UV_TOL`` of Embree's. The counts of disagreements are asserted to be 0.
"""

from __future__ import annotations

import subprocess

import embreex.mesh_construction as embreex_mesh
import embreex.rtcore_scene as embreex_scene
import numpy as np
import pytest

import antumbra
from antumbra.rays import Scene

# Relative to the scene's extent (the largest side of its bounding box).
EDGE = 1e-5
T_TIE = 1e-5
# Of t, relative to the extent over the direction's length; barycentrics absolute.
T_TOL = 1e-5
UV_TOL = 1e-3


def embree(vertices: np.ndarray, triangles: np.ndarray):
    scene = embreex_scene.EmbreeScene()
    embreex_mesh.TriangleMesh(
        scene=scene, vertices=vertices.astype(np.float32), indices=triangles.astype(np.int32)
    )
    return scene


def soup(rng: np.random.Generator, n: int, centre=0.0, scale=1.0):
    """``n`` random, mutually intersecting float32 triangles in a cube of side 2 * scale."""
    c = rng.uniform(-1, 1, (n, 1, 3))
    v = c + rng.uniform(-0.3, 0.3, (n, 3, 3))
    vertices = (v.reshape(-1, 3) * scale + centre).astype(np.float32)
    return vertices, np.arange(3 * n, dtype=np.int64).reshape(n, 3)


def random_rays(rng: np.random.Generator, vertices: np.ndarray, n: int):
    lo, hi = vertices.min(0).astype(np.float64), vertices.max(0).astype(np.float64)
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    origins = (mid + rng.uniform(-1.5, 1.5, (n, 3)) * half).astype(np.float32)
    directions = rng.normal(size=(n, 3)).astype(np.float32)
    return origins, directions


def crossings(v, origins, directions):
    """Per ray and triangle (``v``: (m, 3, 3) float64 vertices), in float64: t of the crossing
    with the triangle's plane (nan when parallel) and the signed distance of the crossing point
    from the nearest edge line (positive inside)."""
    v0, e1, e2 = v[:, 0], v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
    area2 = np.linalg.norm(np.cross(e1, e2), axis=1)
    lengths = np.stack(
        [
            np.linalg.norm(v[:, 2] - v[:, 1], axis=1),
            np.linalg.norm(e2, axis=1),
            np.linalg.norm(e1, axis=1),
        ],
        axis=1,
    )
    o = origins[:, None, :]
    d = directions[:, None, :]
    p = np.cross(d, e2[None])
    det = np.einsum("rtk,tk->rt", p, e1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        q = o - v0[None]
        u = np.einsum("rtk,rtk->rt", q, p) * inv
        qe = np.cross(q, e1[None])
        w = np.einsum("rtk,rtk->rt", np.broadcast_to(d, qe.shape), qe) * inv
        t = np.einsum("rtk,tk->rt", qe, e2) * inv
        dist = np.minimum(
            np.minimum((1 - u - w) * (area2 / lengths[:, 0]), u * (area2 / lengths[:, 1])),
            w * (area2 / lengths[:, 2]),
        )
    parallel = np.abs(det) <= 1e-14 * np.linalg.norm(d, axis=2) * area2[None]
    t[parallel] = np.nan
    return t, dist


def classify(vertices, triangles, origins, directions, tfar):
    """Per ray: the exact closest triangle (-1 none), whether the closest hit is clear of the
    edge conventions, whether the occlusion answer is, and the scene's extent over the
    direction's length (t's scale)."""
    v = vertices.astype(np.float64)[triangles]
    extent = float(np.ptp(vertices.astype(np.float64), axis=0).max())
    o, d = origins.astype(np.float64), directions.astype(np.float64)
    t_scale = extent / np.linalg.norm(d, axis=1)
    far = np.asarray(tfar, dtype=np.float64)
    closest = np.full(len(o), -1)
    closest_clear = np.zeros(len(o), dtype=bool)
    occlusion_clear = np.zeros(len(o), dtype=bool)
    chunk = max(1, 1_000_000 // len(triangles))
    for s in range(0, len(o), chunk):
        r = slice(s, s + chunk)
        t, dist = crossings(v, o[r], d[r])
        t_tie = T_TIE * t_scale[r, None]
        tt = np.where(np.isfinite(t), t, np.inf)
        end = far[r, None]
        # Candidates: not clearly outside the triangle or the interval.
        cand = (dist >= -EDGE * extent) & (tt >= -t_tie) & (tt <= end + t_tie)
        near_ends = (np.abs(tt) <= t_tie) | (np.abs(tt - end) <= t_tie)
        clear = cand & (dist > EDGE * extent) & ~near_ends
        tc = np.where(cand, tt, np.inf)
        order = np.argsort(tc, axis=1)[:, :2]
        rows = np.arange(len(tc))
        first, t1 = order[:, 0], tc[rows, order[:, 0]]
        t2 = tc[rows, order[:, 1]] if tc.shape[1] > 1 else np.full(len(tc), np.inf)
        has = np.isfinite(t1)
        closest[r] = np.where(has, first, -1)
        with np.errstate(invalid="ignore"):
            apart = t2 - t1 > t_tie[:, 0]
        closest_clear[r] = ~has | (clear[rows, first] & apart)
        occlusion_clear[r] = ~cand.any(axis=1) | clear.any(axis=1)
    return closest, closest_clear, occlusion_clear, t_scale


def compare(vertices, triangles, origins, directions, tfar, **options):
    """Disagreements between antumbra and Embree on rays clear of the edge conventions, and
    how many rays that left to compare."""
    ours = Scene(vertices, triangles, **options)
    theirs = embree(vertices, triangles)
    a = ours.run(origins, directions, tfar, output=1)
    # embreex writes its answers into the array of distances it is given: a copy each.
    e = theirs.run(origins, directions, tfar.copy(), output=1)
    a_occ = ours.run(origins, directions, tfar, query="OCCLUDED")
    e_occ = theirs.run(origins, directions, tfar.copy(), query="OCCLUDED")
    closest, closest_clear, occlusion_clear, t_scale = classify(
        vertices, triangles, origins, directions, tfar
    )
    # The exact answer on clear rays is what both must give.
    assert (a["primID"][closest_clear] == closest[closest_clear]).all()
    id_diff = closest_clear & (a["primID"] != e["primID"])
    same = closest_clear & (a["primID"] >= 0) & (a["primID"] == e["primID"])
    t_diff = same & (np.abs(a["tfar"] - e["tfar"]) > T_TOL * t_scale)
    uv_diff = same & ((np.abs(a["u"] - e["u"]) > UV_TOL) | (np.abs(a["v"] - e["v"]) > UV_TOL))
    # Embree's Ng differs from the caller-space cross product by rounding of order
    # eps * |vertex - origin| per edge (as measured: its test works relative to the ray origin).
    v = vertices.astype(np.float64)[triangles[np.maximum(e["primID"], 0)]]
    e1 = np.linalg.norm(v[:, 1] - v[:, 0], axis=1)
    e2 = np.linalg.norm(v[:, 2] - v[:, 0], axis=1)
    reach = np.linalg.norm(v - origins.astype(np.float64)[:, None], axis=2).max(axis=1)
    ng_tol = 1e-5 * e1 * e2 + 1e-6 * reach * (e1 + e2)
    ng_diff = same & (np.abs(a["Ng"] - e["Ng"]).max(axis=1) > ng_tol)
    occ_diff = occlusion_clear & (a_occ != e_occ)
    return {
        "ids": int(id_diff.sum()),
        "t": int(t_diff.sum()),
        "uv": int(uv_diff.sum()),
        "Ng": int(ng_diff.sum()),
        "occluded": int(occ_diff.sum()),
        "compared": int(closest_clear.sum()),
        "hits": int(same.sum()),
        "left_out": int((~closest_clear).sum()),
    }


ZERO = {"ids": 0, "t": 0, "uv": 0, "Ng": 0, "occluded": 0}


def assert_agree(counts: dict, rays: int) -> None:
    assert {k: counts[k] for k in ZERO} == ZERO, counts
    # The comparison means something: most rays compared, many of them hits.
    assert counts["compared"] > 0.95 * rays, counts
    assert counts["hits"] > 0.15 * rays, counts


@pytest.mark.parametrize(
    ("seed", "centre", "scale", "width", "method"),
    [
        (1, 0.0, 1.0, 8, "sah"),
        (2, 0.0, 1.0, 2, "sbvh"),
        (3, 0.0, 1.0, 4, "osah"),
        (4, 1000.0, 10.0, 8, "sah"),
        (5, 0.0, 1e-3, 8, "sbvh"),
    ],
)
def test_random_soups_agree_with_embree(seed, centre, scale, width, method):
    rng = np.random.default_rng(seed)
    vertices, triangles = soup(rng, 600, centre, scale)
    origins, directions = random_rays(rng, vertices, 3000)
    # A third of the rays are segments ending inside the soup.
    tfar = np.where(np.arange(3000) % 3 == 0, 1.0, 1e37).astype(np.float32)
    counts = compare(vertices, triangles, origins, directions, tfar, width=width, method=method)
    assert_agree(counts, 3000)


@pytest.fixture(scope="module")
def city(antumbra_bin, tmp_path_factory):
    """Frame 1 of the built-in city, its objects' meshes placed in world space (float32)."""
    out = tmp_path_factory.mktemp("rays") / "city.antrec"
    subprocess.run(
        [
            str(antumbra_bin),
            "record",
            "--scene",
            "city",
            "--triangles",
            "20000",
            "--frames",
            "1",
            "--size",
            "64x40",
            "--out",
            str(out),
        ],
        check=True,
        capture_output=True,
    )
    rec = antumbra.read_recording(out)
    vertices, triangles, first = [], [], 0
    for o in rec["frames"][0]["objects"]:
        mesh = rec["meshes"][o["mesh_hash"]]
        m = np.asarray(o["matrix_world"], dtype=np.float64)
        p = mesh["positions"].astype(np.float64) @ m[:3, :3].T + m[:3, 3]
        vertices.append(p.astype(np.float32))
        triangles.append(mesh["triangles"].astype(np.int64) + first)
        first += len(p)
    return np.concatenate(vertices), np.concatenate(triangles)


@pytest.mark.parametrize("width", [2, 8])
def test_a_built_in_scene_agrees_with_embree(city, width):
    vertices, triangles = city
    assert len(triangles) > 10_000
    rng = np.random.default_rng(7)
    origins, directions = random_rays(rng, vertices, 1500)
    # Half the rays aim at a random triangle's centroid, so that most of those hit something.
    aimed = rng.choice(len(triangles), 750)
    centroids = vertices.astype(np.float64)[triangles[aimed]].mean(axis=1)
    directions[:750] = (centroids - origins[:750]).astype(np.float32)
    tfar = np.full(len(origins), 1e37, dtype=np.float32)
    counts = compare(vertices, triangles, origins, directions, tfar, width=width)
    assert_agree(counts, len(origins))


def test_the_interval_is_embrees_by_default_and_antumbras_on_request():
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
    triangles = np.array([[0, 1, 2]])
    ours, theirs = Scene(vertices, triangles), embree(vertices, triangles)
    # Starting on the triangle; ending exactly on it; ending just short of it.
    origins = np.array([[0.25, 0.25, 0.0], [0.25, 0.25, 1.0], [0.25, 0.25, 1.0]], np.float32)
    directions = np.array([[0, 0, -1]], dtype=np.float32)
    tfar = np.array([10.0, 1.0, np.nextafter(np.float32(1), np.float32(0))], dtype=np.float32)
    for query in ("INTERSECT", "OCCLUDED"):
        expected = theirs.run(origins, directions, tfar.copy(), query=query)
        assert expected.tolist() == [0, 0, -1]
        assert ours.run(origins, directions, tfar, query=query).tolist() == expected.tolist()
    opened = ours.run(origins, directions, tfar, query="OCCLUDED", interval="open")
    assert opened.tolist() == [-1, 0, -1]


def test_run_mirrors_embreex_return_conventions():
    rng = np.random.default_rng(3)
    vertices, triangles = soup(rng, 50)
    origins, directions = random_rays(rng, vertices, 200)
    ours, theirs = Scene(vertices, triangles), embree(vertices, triangles)
    for query in ("INTERSECT", "OCCLUDED", "DISTANCE"):
        a, e = (
            ours.run(origins, directions, query=query),
            theirs.run(origins, directions, query=query),
        )
        assert (a.dtype, a.shape) == (e.dtype, e.shape), query
    a, e = ours.run(origins, directions, output=1), theirs.run(origins, directions, output=1)
    assert sorted(a) == sorted(e)
    for k in e:
        assert (a[k].dtype, a[k].shape) == (e[k].dtype, e[k].shape), k
    # A miss: primID and geomID -1, tfar unchanged (1e37), Ng zero.
    miss = e["primID"] == -1
    assert miss.any()
    assert (a["primID"][miss] == -1).all() and (a["geomID"][miss] == -1).all()
    assert (a["tfar"][miss] == np.float32(1e37)).all()
    # One direction for every ray, as embreex allows.
    one = ours.run(origins, directions[:1])
    assert (one == theirs.run(origins, directions[:1])).sum() >= 0.95 * len(one)


def test_counters_orders_kernels_and_threads_change_no_answer():
    rng = np.random.default_rng(5)
    vertices, triangles = soup(rng, 400)
    origins, directions = random_rays(rng, vertices, 2000)
    scene = Scene(vertices, triangles, width=8)
    base = scene.occluded(origins, directions)["occluded"]
    first = scene.intersect(origins, directions)
    for order in ("stored", "fbto", "sato", "rtsah", "random:seed=2", "sorted:budget=0.2"):
        for kernel in ("auto", "scalar", "sse", "avx2"):
            r = scene.occluded(
                origins, directions, order=order, kernel=kernel, threads=2, counters=True
            )
            assert (r["occluded"] == base).all(), (order, kernel)
            assert r["work"].shape == (len(origins), 4) and r["work"].dtype == np.uint64
            assert (r["work"][:, 3] >= 1).all()  # every ray tests the root's box
    counted = scene.intersect(origins, directions, counters=True, threads=1)
    for k in ("t", "triangle", "u", "v"):
        assert np.array_equal(counted[k], first[k]), k
    hit = counted["triangle"] >= 0
    assert (counted["work"][hit, 2] >= 1).all()  # a hit tested a triangle


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: Scene(np.zeros((3, 2)), [[0, 1, 2]]), r"vertices: expected .* shape \(n, 3\)"),
        (lambda: Scene(np.zeros((3, 3)), np.zeros((1, 3))), r"triangles: expected an integer"),
        (lambda: Scene(np.zeros((3, 3)), [[0, 1, 3]]), r"triangle 0 refers to vertex 3"),
        (lambda: Scene(np.zeros((3, 3)), [[0, 1, -1]]), r"vertex index -1"),
        (lambda: Scene([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]), r"vertex 0"),
        (lambda: Scene(np.eye(3), [[0, 1, 2]], method="auto"), r"method:"),
        (lambda: Scene(np.eye(3), [[0, 1, 2]], width=3), r"width: must be 2, 4 or 8"),
        (
            lambda: Scene(np.eye(3), [[0, 1, 2]]).run(np.zeros((2, 3)), np.ones((3, 3))),
            r"vec_directions: 3 rows for 2 origins",
        ),
        (
            lambda: Scene(np.eye(3), [[0, 1, 2]]).run(np.zeros((1, 3)), np.zeros((1, 3))),
            r"ray 0: direction is zero",
        ),
        (
            lambda: Scene(np.eye(3), [[0, 1, 2]]).run(np.zeros((1, 3)), [[0, 0, np.inf]]),
            r"direction of ray 0",
        ),
        (
            lambda: Scene(np.eye(3), [[0, 1, 2]]).run(
                np.zeros((1, 3)), np.ones((1, 3)), query="NEAREST"
            ),
            r"query:",
        ),
        (
            lambda: Scene(np.eye(3), [[0, 1, 2]]).occluded(
                np.zeros((1, 3)), np.ones((1, 3)), order="srdh"
            ),
            r"order:",
        ),
        (
            lambda: Scene(np.eye(3), [[0, 1, 2]]).occluded(
                np.zeros((1, 3)), np.ones((1, 3)), kernel="avx9"
            ),
            r"kernel:",
        ),
        (
            lambda: Scene(np.eye(3), [[0, 1, 2]]).run(
                np.zeros((2, 3)), np.ones((2, 3)), dists=[1.0, 2.0, 3.0]
            ),
            r"dists:",
        ),
    ],
)
def test_bad_input_is_named(call, message):
    with pytest.raises(antumbra.InvalidInput, match=message):
        call()


@pytest.mark.parametrize("threads", [-1, -(2**40), 1025])
@pytest.mark.parametrize(
    "call",
    [
        lambda threads: Scene(np.eye(3), [[0, 1, 2]], threads=threads),
        lambda threads: Scene(np.eye(3), [[0, 1, 2]]).intersect(
            np.zeros((1, 3)), np.ones((1, 3)), threads=threads
        ),
        lambda threads: Scene(np.eye(3), [[0, 1, 2]]).occluded(
            np.zeros((1, 3)), np.ones((1, 3)), threads=threads
        ),
    ],
)
def test_a_thread_count_out_of_range_is_a_value_error_naming_the_limit(call, threads):
    with pytest.raises(ValueError, match=rf"threads: must be in 0\.\.=1024, got {threads}$"):
        call(threads)
