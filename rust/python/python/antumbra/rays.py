"""Ray queries on your own triangles and rays, on numpy arrays (``docs/ray-queries.md``).

Two faces over the same native tree (``antumbra-rays``):

- :class:`Scene`: as embreex's ``EmbreeScene`` (build once, then ``run(origins, directions,
  dists, query, output)`` with ``'INTERSECT'``, ``'OCCLUDED'`` or ``'DISTANCE'``), plus
  antumbra's choices: build method, width, child order, box kernel, threads, work counters;
- :class:`RayMeshIntersector`: trimesh's ray interface (``intersects_any``,
  ``intersects_first``, ``intersects_id``, ``intersects_location``, ``contains_points``), so a
  trimesh user can set ``mesh.ray = antumbra.rays.RayMeshIntersector(mesh)``.

The t interval: :class:`Scene` follows Embree, ``[tnear, tfar]`` with ``tnear = 0`` (a ray
starting on a triangle hits it at t = 0); ``interval="open"`` gives antumbra's own
``(tnear, tfar]``. Vertices and rays may be float32 or float64: the scene is re-centred and
scaled by a power of two in float64 before it is rounded to float32, so meshes far from the
origin or at any scale trace well, and t is the parameter along the caller's own direction.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._native import RayScene
from .errors import InvalidInput

__all__ = ["RayMeshIntersector", "Scene"]

# embreex's tfar when no distance is given.
_EMBREE_FAR = 1e37
# Work counter columns of ``counters=True``.
WORK_COLUMNS = ("N_B", "N_L", "N_T", "N_box")


def _describe(a: Any) -> str:
    if isinstance(a, np.ndarray):
        return f"{a.dtype} array of shape {a.shape}"
    return type(a).__name__


def _points(name: str, a: Any, rows: int | None = None) -> np.ndarray:
    """An (n, 3) float32 or float64 array as C-contiguous float64 (lists become arrays)."""
    if not isinstance(a, np.ndarray):
        a = np.asarray(a, dtype=np.float64)
    if a.dtype.kind not in "fiu" or a.ndim != 2 or a.shape[1] != 3:
        raise InvalidInput(f"{name}: expected a float array of shape (n, 3), got {_describe(a)}")
    if rows is not None and a.shape[0] != rows:
        raise InvalidInput(f"{name}: expected {rows} rows, got {a.shape[0]}")
    return np.ascontiguousarray(a, dtype=np.float64)


def _triangles(a: Any) -> np.ndarray:
    """An (m, 3) integer array of vertex indices as C-contiguous uint32."""
    if not isinstance(a, np.ndarray):
        a = np.asarray(a)
    if a.dtype.kind not in "iu" or a.ndim != 2 or a.shape[1] != 3:
        raise InvalidInput(
            f"triangles: expected an integer array of shape (m, 3), got {_describe(a)}"
        )
    if a.size and (a.min() < 0 or a.max() >= 2**32 - 1):
        bad = a.min() if a.min() < 0 else a.max()
        raise InvalidInput(f"triangles: vertex index {bad} is not a valid index")
    return np.ascontiguousarray(a, dtype=np.uint32)


def _per_ray(name: str, value: Any, n: int, default: float) -> np.ndarray:
    """A number or an (n,) array of t bounds as float32."""
    if value is None:
        return np.full(n, default, dtype=np.float32)
    a = np.asarray(value, dtype=np.float32)
    if a.ndim == 0:
        return np.full(n, a, dtype=np.float32)
    if a.shape != (n,):
        raise InvalidInput(f"{name}: expected a number or shape ({n},), got {_describe(a)}")
    return np.ascontiguousarray(a)


def _closed(interval: str) -> bool:
    if interval not in ("closed", "open"):
        raise InvalidInput(
            f"interval: 'closed' ([tnear, tfar]) or 'open' ((tnear, tfar]), got {interval!r}"
        )
    return interval == "closed"


class Scene:
    """A BVH over ``vertices`` ((n, 3) float) and ``triangles`` ((m, 3) int), traced as
    embreex's ``EmbreeScene`` is.

    ``method`` is the builder (``sah``, ``sbvh``, ``abvh``, ``osah``, ``vsah``), ``width`` 2, 4
    or 8, ``collapse`` how the wide tree is made (``sah``, ``greedy``), ``visible`` an optional
    (m,) bool array read by ``abvh``, ``osah`` and ``vsah``, ``threads`` the build's threads (0:
    all). Triangles of zero area are kept out of the tree (never hit).
    """

    def __init__(
        self,
        vertices: Any,
        triangles: Any,
        *,
        method: str = "sah",
        width: int = 8,
        collapse: str = "sah",
        visible: Any = None,
        threads: int = 0,
    ) -> None:
        self.vertices = _points("vertices", vertices)
        self.triangles = _triangles(triangles)
        if visible is not None:
            visible = np.ascontiguousarray(visible, dtype=bool)
        self._native = RayScene(
            self.vertices,
            self.triangles,
            method=method,
            width=int(width),
            collapse=collapse,
            threads=int(threads),
            visible=visible,
        )

    @property
    def degenerate_count(self) -> int:
        """Triangles left out of the tree for their zero area."""
        return self._native.degenerate_count

    def _rays(self, vec_origins: Any, vec_directions: Any) -> tuple[np.ndarray, np.ndarray]:
        """Origins and directions as (n, 3) float64; one direction (1, 3) serves every ray."""
        origins = _points("vec_origins", vec_origins)
        directions = _points("vec_directions", vec_directions)
        if directions.shape[0] == 1 and origins.shape[0] != 1:
            directions = np.ascontiguousarray(np.broadcast_to(directions, origins.shape))
        if directions.shape != origins.shape:
            raise InvalidInput(
                f"vec_directions: {directions.shape[0]} rows for {origins.shape[0]} origins"
            )
        return origins, directions

    def intersect(
        self,
        origins: Any,
        directions: Any,
        tnear: Any = 0.0,
        tfar: Any = None,
        *,
        interval: str = "closed",
        kernel: str = "auto",
        threads: int = 0,
        counters: bool = False,
    ) -> dict[str, np.ndarray]:
        """Closest hits: ``t`` (float32, inf for a miss), ``triangle`` (int64, -1 for a miss),
        ``u``, ``v`` (float32, Embree's barycentrics) and, with ``counters``, ``work`` ((n, 4)
        uint64: N_B, N_L, N_T, N_box per ray). Ties in t go to the smaller triangle index."""
        o, d = self._rays(origins, directions)
        n = len(o)
        return self._native.intersect(
            o,
            d,
            _per_ray("tnear", tnear, n, 0.0),
            _per_ray("tfar", tfar, n, np.inf),
            closed=_closed(interval),
            kernel=kernel,
            threads=int(threads),
            counters=counters,
        )

    def occluded(
        self,
        origins: Any,
        directions: Any,
        tnear: Any = 0.0,
        tfar: Any = None,
        *,
        interval: str = "closed",
        order: str = "fbto",
        kernel: str = "auto",
        threads: int = 0,
        counters: bool = False,
    ) -> dict[str, np.ndarray]:
        """Any hit: ``occluded`` (bool) and, with ``counters``, ``work``. ``order`` is the child
        order (``stored``, ``fbto``, ``sato``, ``rtsah``, ``random:seed=S``,
        ``sorted[:budget=F]``, the last prepared from that share of these rays); it changes the
        work, never the answers."""
        o, d = self._rays(origins, directions)
        n = len(o)
        return self._native.occluded(
            o,
            d,
            _per_ray("tnear", tnear, n, 0.0),
            _per_ray("tfar", tfar, n, np.inf),
            closed=_closed(interval),
            order=order,
            kernel=kernel,
            threads=int(threads),
            counters=counters,
        )

    def run(
        self,
        vec_origins: Any,
        vec_directions: Any,
        dists: Any = None,
        query: str = "INTERSECT",
        output: Any = None,
        *,
        interval: str = "closed",
        order: str = "fbto",
        kernel: str = "auto",
        threads: int = 0,
        counters: bool = False,
    ) -> Any:
        """embreex's ``EmbreeScene.run``: rays from ``vec_origins`` along ``vec_directions``
        (one direction may serve all) for t in ``[0, dists]`` (``dists`` a number or one per
        ray; 1e37 when not given).

        - ``'INTERSECT'``: the closest triangle's index per ray, int32, -1 for a miss;
        - ``'OCCLUDED'``: 0 where something blocks the ray, -1 where nothing does, int32;
        - ``'DISTANCE'``: t of the closest hit, float32, ``dists`` where none;
        - ``output`` (with ``'INTERSECT'`` or ``'DISTANCE'``): a dict of ``u``, ``v``, ``Ng``
          (the unnormalised geometric normal (v1 - v0) x (v2 - v0), zero for a miss), ``tfar``,
          ``primID`` and ``geomID`` (0, or -1 for a miss), as embreex gives it.

        With ``counters`` the answer comes with the (n, 4) work per ray: ``(answer, work)``.
        """
        if query not in ("INTERSECT", "OCCLUDED", "DISTANCE"):
            raise InvalidInput(
                f"query: {query!r} is not one of 'INTERSECT', 'OCCLUDED', 'DISTANCE'"
            )
        o, d = self._rays(vec_origins, vec_directions)
        tfar = _per_ray("dists", dists, len(o), _EMBREE_FAR)
        options = {"interval": interval, "kernel": kernel, "threads": threads, "counters": counters}
        if query == "OCCLUDED":
            r = self.occluded(o, d, 0.0, tfar, order=order, **options)
            answer: Any = np.where(r["occluded"], 0, -1).astype(np.int32)
        else:
            r = self.intersect(o, d, 0.0, tfar, **options)
            hit = r["triangle"] >= 0
            t = np.where(hit, r["t"], tfar).astype(np.float32)
            if output:
                answer = {
                    "u": r["u"],
                    "v": r["v"],
                    "Ng": self._normals(r["triangle"]),
                    "tfar": t,
                    "primID": r["triangle"].astype(np.int32),
                    "geomID": np.where(hit, 0, -1).astype(np.int32),
                }
            elif query == "INTERSECT":
                answer = r["triangle"].astype(np.int32)
            else:
                answer = t
        return (answer, r["work"]) if counters else answer

    def _normals(self, triangle: np.ndarray) -> np.ndarray:
        """(v1 - v0) x (v2 - v0) in float32 of each hit triangle, zeros for a miss."""
        out = np.zeros((len(triangle), 3), dtype=np.float32)
        hit = triangle >= 0
        v = self.vertices.astype(np.float32)[self.triangles[triangle[hit]]]
        out[hit] = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        return out


class RayMeshIntersector:
    """trimesh's ray interface over antumbra's tree: ``mesh.ray = RayMeshIntersector(mesh)``.

    ``geometry`` is a ``trimesh.Trimesh`` (anything with ``vertices``, ``faces``, ``bounds``,
    ``scale`` and a content ``__hash__``); the tree is rebuilt when that hash changes. Keyword
    options go to :class:`Scene` (``method``, ``width``, ``threads``, ...).

    Conventions: directions are unitized, as trimesh does; t runs over ``(0, inf)``, so a ray
    starting on a triangle does not hit it (what trimesh's tests expect of a ray leaving a
    surface). With ``multiple_hits`` each ray is traced again from just past its last hit
    (``max(1e-8, 1e-6 * mesh.scale)`` further, the step of trimesh's embree intersector), so a
    ray through an edge or vertex shared by several triangles reports one of them (the
    watertight test hits at least one): parity counts (``contains_points``) stay right. Locations
    are the intersection of the ray with the hit triangle's plane, in float64.
    """

    def __init__(self, geometry: Any, **options: Any) -> None:
        self.mesh = geometry
        self._options = options
        self._built: tuple[int, Scene] | None = None

    @property
    def _scene(self) -> Scene:
        key = hash(self.mesh)
        if self._built is None or self._built[0] != key:
            self._built = (key, Scene(self.mesh.vertices, self.mesh.faces, **self._options))
        return self._built[1]

    def _rays(self, ray_origins: Any, ray_directions: Any) -> tuple[np.ndarray, np.ndarray]:
        origins = _points("ray_origins", ray_origins)
        directions = _points("ray_directions", ray_directions, rows=len(origins))
        length = np.linalg.norm(directions, axis=1)
        if not np.all(length > 0):
            raise InvalidInput(f"ray_directions: row {int(np.argmin(length > 0))} has zero length")
        return origins, directions / length[:, None]

    def intersects_first(self, ray_origins: Any, ray_directions: Any, **_: Any) -> np.ndarray:
        """The index of the first triangle each ray hits, -1 for none (int64)."""
        o, d = self._rays(ray_origins, ray_directions)
        return self._scene.intersect(o, d, interval="open")["triangle"]

    def intersects_any(self, ray_origins: Any, ray_directions: Any, **_: Any) -> np.ndarray:
        """Whether each ray hits the mesh at all (an any-hit query)."""
        o, d = self._rays(ray_origins, ray_directions)
        return self._scene.occluded(o, d, interval="open")["occluded"]

    def intersects_id(
        self,
        ray_origins: Any,
        ray_directions: Any,
        multiple_hits: bool = True,
        max_hits: int = 100,
        return_locations: bool = False,
        **_: Any,
    ) -> tuple[np.ndarray, ...]:
        """``(index_tri, index_ray)`` of every hit (the first only unless ``multiple_hits``),
        and the hit ``locations`` ((k, 3) float64) with ``return_locations``. Hits come in
        rounds: every ray's first hit, then every ray's second, ..."""
        o, d = self._rays(ray_origins, ray_directions)
        step = max(1e-8, 1e-6 * float(self.mesh.scale))
        live = np.arange(len(o))
        tnear = np.zeros(len(o), dtype=np.float32)
        tris, rays, locations = [], [], []
        for _ in range(max_hits if multiple_hits else 1):
            if len(live) == 0:
                break
            r = self._scene.intersect(o[live], d[live], tnear[live], interval="open")
            hit = r["triangle"] >= 0
            live, tri, t = live[hit], r["triangle"][hit], r["t"][hit]
            tris.append(tri)
            rays.append(live)
            if return_locations:
                locations.append(self._locations(o[live], d[live], tri, t))
            tnear[live] = t.astype(np.float64) + step
        index_tri = np.concatenate([np.zeros(0, dtype=np.int64), *tris])
        index_ray = np.concatenate([np.zeros(0, dtype=np.int64), *rays])
        if return_locations:
            return index_tri, index_ray, np.concatenate([np.zeros((0, 3)), *locations])
        return index_tri, index_ray

    def intersects_location(
        self, ray_origins: Any, ray_directions: Any, multiple_hits: bool = True, **_: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(locations, index_ray, index_tri)`` of every hit, as trimesh's intersectors."""
        index_tri, index_ray, locations = self.intersects_id(
            ray_origins, ray_directions, multiple_hits=multiple_hits, return_locations=True
        )
        return locations, index_ray, index_tri

    def contains_points(self, points: Any) -> np.ndarray:
        """Whether each point is inside the mesh, by trimesh's parity test over these rays."""
        from trimesh.ray.ray_util import contains_points

        return contains_points(self, points)

    def _locations(
        self, origins: np.ndarray, directions: np.ndarray, tri: np.ndarray, t: np.ndarray
    ) -> np.ndarray:
        """Where each ray meets its triangle's plane (float64); along the ray at t where the
        ray lies in that plane."""
        v = np.asarray(self.mesh.vertices, dtype=np.float64)[np.asarray(self.mesh.faces)[tri]]
        normal = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        across = np.einsum("ij,ij->i", normal, directions)
        towards = np.einsum("ij,ij->i", normal, v[:, 0] - origins)
        safe = across != 0
        s = np.where(safe, towards / np.where(safe, across, 1.0), t)
        return origins + directions * s[:, None]
