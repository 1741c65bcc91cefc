"""Per-triangle material slots and per-corner UVs of a mesh whose materials need alpha (issue 38).

``mesh_alpha(obj_eval, mesh, sources)`` returns None when no slot's material needs alpha (the
mesh travels as today), else a ``MeshAlpha``:

- ``material_index``: uint32 (m,), each triangle's material slot, clamped to the object's slots
  as Cycles clamps it;
- ``uvs``: per UV map the slots' textures read (keyed as the contract's ``uv_map``: "" is the
  active render map), float32 (m, 3, 2), the UV at each triangle's corners;
- ``warnings``: what was read as Cycles would read it but is likely a mistake.

Triangles are the exporter's (``exporter._triangles``), row for row: ``triangle_loops`` takes
the exporter's routes with corner numbers where the exporter has vertex numbers (a mesh of
triangles is its corner array in face order; a mesh of triangles and quads goes through the
exporter's ``_split_quads``, diagonal flip included; any other mesh, and every mesh in 3.4, is
read from ``loop_triangles``, which the exporter's split reproduces). So ``corner_vert[loops]``
equals the exporter's ``triangles`` (tests/blender/test_materials.py checks it, and against
``loop_triangles``, in every Blender). Everything is read with ``foreach_get``.

A UV map a texture names but the mesh lacks, and non-finite UVs, read as UV (0, 0) (what
Cycles' attribute lookup gives for a missing map) with a warning naming the object, the
materials and their Image Texture nodes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# The exporter's own readers: the same triangulation, by construction.
from .exporter import _int_attribute, _positions, _split_quads


@dataclass
class MeshAlpha:
    material_index: np.ndarray
    uvs: dict[str, np.ndarray]
    warnings: list[str] = field(default_factory=list)
    #: The corner (loop) indices of each triangle, int32 (m, 3).
    loops: np.ndarray | None = None


def triangle_loops(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle's corner indices, int32 (m, 3), and its face, int32 (m,), in the
    exporter's triangle order, by the exporter's own routes: a mesh of triangles is its corner
    array; a mesh of triangles and quads is split by the exporter's ``_split_quads`` (given
    corner numbers for vertices and per-corner positions, it returns corners); any other mesh,
    or a Blender without ``.corner_vert`` (3.4), is read from ``loop_triangles`` (~130 ms per
    million triangles, against ~85 ms for the quad split in numpy)."""
    if hasattr(mesh, "calc_loop_triangles") and not mesh.loop_triangles:
        mesh.calc_loop_triangles()
    corner_vert = _int_attribute(mesh, ".corner_vert")
    faces = getattr(mesh, "loop_triangle_polygons", None)
    if corner_vert is not None and len(corner_vert) == 3 * len(mesh.polygons):
        count = len(mesh.polygons)
        return np.arange(3 * count, dtype=np.int32).reshape(-1, 3), np.arange(count, dtype=np.int32)
    if corner_vert is not None and faces is not None:
        triangle_faces = np.empty(len(faces), dtype=np.int32)
        faces.foreach_get("value", triangle_faces)
        corners = np.arange(len(corner_vert), dtype=np.int32)
        split = _split_quads(corners, triangle_faces, _positions(mesh)[corner_vert])
        if split is not None:
            return split.astype(np.int32), triangle_faces
    loops = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("loops", loops)
    triangle_faces = np.empty(len(mesh.loop_triangles), dtype=np.int32)
    mesh.loop_triangles.foreach_get("polygon_index", triangle_faces)
    return loops.reshape(-1, 3), triangle_faces


def triangle_materials(mesh, triangle_faces: np.ndarray, slots: int) -> np.ndarray:
    """Each triangle's material slot, uint32 (m,), clamped to [0, SLOTS - 1] as Cycles clamps
    it."""
    face_material = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("material_index", face_material)
    index = face_material[triangle_faces]
    return np.clip(index, 0, max(slots - 1, 0)).astype(np.uint32)


def _uv_layer(mesh, name: str):
    """The UV map NAME ("" the active render one); None if the mesh has none of that name."""
    layers = mesh.uv_layers
    if name:
        return layers.get(name)
    return next((layer for layer in layers if layer.active_render), None)


def corner_uvs(mesh, layer) -> np.ndarray:
    """A UV map's value at every corner, float32 (corners, 2)."""
    uvs = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    attributes = getattr(mesh, "attributes", None)
    attribute = attributes.get(layer.name) if attributes is not None else None
    if attribute is not None and attribute.domain == "CORNER" and attribute.data_type == "FLOAT2":
        attribute.data.foreach_get("vector", uvs)  # 3.5+: UV maps are attributes
    else:
        layer.data.foreach_get("uv", uvs)
    return uvs.reshape(-1, 2)


def _users(obj_name: str, sources: list, uv_map: str) -> str:
    """Who reads UV_MAP, for messages: object, materials and their Image Texture nodes."""
    readers = [
        f"material '{material}', node '{source.node}'"
        for material, source in sources
        if source.kind == "texture" and source.uv_map == uv_map
    ]
    return f"object '{obj_name}', " + "; ".join(readers)


def mesh_alpha(obj_eval, mesh, sources: list) -> MeshAlpha | None:
    """MESH's slots and UVs for OBJ_EVAL's SOURCES: one (material name, ``AlphaSource``) per
    material slot, in slot order. None when no slot needs alpha."""
    if not any(source.needs_alpha for _, source in sources):
        return None
    loops, triangle_faces = triangle_loops(mesh)
    material_index = triangle_materials(mesh, triangle_faces, len(sources))
    warnings: list[str] = []
    uvs: dict[str, np.ndarray] = {}
    for uv_map in sorted({s.uv_map for _, s in sources if s.kind == "texture"}):
        layer = _uv_layer(mesh, uv_map)
        who = _users(obj_eval.name, sources, uv_map)
        if layer is None:
            what = f"UV map '{uv_map}' is absent" if uv_map else "the mesh has no UV map"
            warnings.append(f"{who}: {what}; read as UV (0, 0), as Cycles does")
            uvs[uv_map] = np.zeros((len(loops), 3, 2), dtype=np.float32)
            continue
        per_corner = corner_uvs(mesh, layer)[loops]
        # One flat reduction first (~5 ms per million triangles); per triangle only if needed.
        if not np.isfinite(per_corner.reshape(-1)).all():
            bad = ~np.isfinite(per_corner.reshape(len(loops), 6)).all(axis=1)
            first = int(np.flatnonzero(bad)[0])
            warnings.append(
                f"{who}: UV map '{layer.name}' has non-finite UVs on {int(bad.sum())} "
                f"triangles (first: triangle {first}); read as UV (0, 0)"
            )
            per_corner = np.nan_to_num(per_corner, nan=0.0, posinf=0.0, neginf=0.0)
        uvs[uv_map] = np.ascontiguousarray(per_corner, dtype=np.float32)
    return MeshAlpha(material_index=material_index, uvs=uvs, warnings=warnings, loops=loops)
