"""One thread's Mrays/s of antumbra.rays against embreex (Embree 4.4) on a built-in scene:
incoherent rays aimed at triangles, a 512x512 pinhole camera, and shadow rays from its hits.

    python scripts/bench_rays.py target/release/antumbra city 100000 300000

The antumbra binary records the scene; the antumbra wheel (a release build, for figures that
mean something) and embreex must be installed (docs/ray-queries.md).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh

import antumbra
from antumbra.rays import Scene


def world_triangles(binary: str, scene: str, budget: str) -> tuple[np.ndarray, np.ndarray]:
    """Frame 1 of a built-in scene, its objects placed in world space (float32)."""
    out = os.path.join(tempfile.mkdtemp(), "scene.antrec")
    subprocess.run(
        [binary, "record", "--scene", scene, "--triangles", budget, "--frames", "1",
         "--size", "64x40", "--out", out],
        check=True,
        capture_output=True,
    )  # fmt: skip
    rec = antumbra.read_recording(out)
    vertices, triangles, first = [], [], 0
    for o in rec["frames"][0]["objects"]:
        mesh = rec["meshes"][o["mesh_hash"]]
        m = np.asarray(o["matrix_world"])
        p = mesh["positions"].astype(np.float64) @ m[:3, :3].T + m[:3, 3]
        vertices.append(p.astype(np.float32))
        triangles.append(mesh["triangles"].astype(np.int64) + first)
        first += len(p)
    return np.concatenate(vertices), np.concatenate(triangles)


def best(f, repeat: int = 3):
    """The fastest of ``repeat`` runs: (seconds, answer)."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        answer = f()
        times.append(time.perf_counter() - start)
    return min(times), answer


def line(what: str, rays: int, ours, theirs) -> None:
    (ta, a), (te, e) = ours, theirs
    same = (a == e).mean() * 100
    print(
        f"{what}: antumbra {rays / ta / 1e6:.2f} Mrays/s, embreex {rays / te / 1e6:.2f}, "
        f"ratio {te / ta:.2f}x, same answer {same:.2f}%"
    )


def main(binary: str, scene: str, budget: str, n: int) -> None:
    v, t = world_triangles(binary, scene, budget)
    rng = np.random.default_rng(1)
    lo, hi = v.min(0), v.max(0)
    start = time.perf_counter()
    ours = Scene(v, t, width=8, threads=1)
    built = time.perf_counter() - start
    start = time.perf_counter()
    emb = rtcore_scene.EmbreeScene()
    TriangleMesh(scene=emb, vertices=v, indices=t.astype(np.int32))
    emb.run(v[:1], np.ones((1, 3), np.float32))  # embreex commits on the first query
    emb_built = time.perf_counter() - start
    print(f"{scene}: {len(t)} triangles; one thread")
    print(f"build: antumbra sah/8 {built * 1e3:.0f} ms, embreex {emb_built * 1e3:.0f} ms")

    # Incoherent: from anywhere in the bounds towards a random triangle's centroid.
    o = (lo + rng.random((n, 3)) * (hi - lo)).astype(np.float32)
    d = (v[t[rng.integers(0, len(t), n)]].mean(axis=1) - o).astype(np.float32)
    for q in ("INTERSECT", "OCCLUDED"):
        line(f"aimed {q}", n, best(lambda q=q: ours.run(o, d, query=q, threads=1)),
             best(lambda q=q: emb.run(o, d, query=q)))  # fmt: skip
    for order in ("fbto", "sato", "sorted:budget=0.05"):
        seconds, _ = best(lambda order=order: ours.occluded(o, d, 0.0, 1.0, order=order, threads=1))
        w = ours.occluded(o, d, 0.0, 1.0, order=order, counters=True)["work"].mean(axis=0)
        print(
            f"aimed segments, order {order}: {n / seconds / 1e6:.2f} Mrays/s; per ray N_B "
            f"{w[0]:.2f}, N_L {w[1]:.2f}, N_T {w[2]:.2f}, N_box {w[3]:.2f}"
        )

    # Coherent: a pinhole camera above a corner of the scene, looking at its centre.
    centre = (lo + hi) / 2.0
    eye = centre + (hi - lo) * np.array([0.6, -0.6, 0.5])
    forward = (centre - eye) / np.linalg.norm(centre - eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    g = (np.arange(512) + 0.5) / 512 * 2 - 1
    gx, gy = np.meshgrid(g, -g)
    cd = forward + 0.6 * (gx.ravel()[:, None] * right + gy.ravel()[:, None] * up)
    cd = cd.astype(np.float32)
    co = np.tile(eye.astype(np.float32), (len(cd), 1))
    for q in ("INTERSECT", "OCCLUDED"):
        line(f"camera {q}", len(cd), best(lambda q=q: ours.run(co, cd, query=q, threads=1)),
             best(lambda q=q: emb.run(co, cd, query=q)))  # fmt: skip

    # Shadow rays from the camera's hits to a point above the scene (no origin offset: Embree's
    # [0, 1] finds the surface a ray leaves, antumbra's (0, 1] does not).
    hit = ours.intersect(co, cd)
    h = hit["triangle"] >= 0
    p = co[h].astype(np.float64) + cd[h].astype(np.float64) * hit["t"][h, None]
    light = centre + np.array([0.2, 0.3, 2.0]) * (hi - lo)
    so, sd = p.astype(np.float32), (light - p).astype(np.float32)
    kw = {"dists": 1.0, "query": "OCCLUDED"}
    line(f"shadow OCCLUDED, {len(so)} rays", len(so),
         best(lambda: ours.run(so, sd, interval="open", threads=1, **kw)),
         best(lambda: emb.run(so, sd, **kw)))  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]))
