"""The evaluated scene of one frame as the daemon's input: meshes (numpy arrays, by content hash),
objects, the camera and lights in Blender's own terms.

Everything is read from the evaluated depsgraph, so modifiers, shape keys, armatures and
geometry-node instances (``depsgraph.object_instances``) are what gets rendered. Bulk data goes
through ``foreach_get`` into numpy; nothing loops over vertices in Python.

As in Cycles, only evaluated meshes carry geometry: a text, curve, surface or metaball object is
listed once as itself and once as the instance of its evaluated mesh, and only the mesh is sent.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

import numpy as np

from .alpha_frame import FrameAlpha
from .instances import read_instances

#: The depsgraph's "no index" in an instance's persistent id.
NO_INDEX = 0x7FFFFFFF


class ExportError(ValueError):
    """A scene the daemon cannot take; the message names the object and frame."""


@dataclass
class MeshData:
    name: str
    positions: np.ndarray
    triangles: np.ndarray
    hash: int
    #: Shading normals at each triangle's corners, float32 (3m, 3); None when not exported.
    normals: np.ndarray | None = None
    #: Each triangle's material slot, uint32 (m,), and the UV maps its alpha materials read,
    #: {name: float32 (m, 3, 2)}; None for a mesh whose slots are all opaque.
    material_slots: np.ndarray | None = None
    uv_maps: dict[str, np.ndarray] | None = None

    def arrays(self) -> dict:
        """The client's mesh arguments (``mesh_hash``, ``upload_mesh``): normals and alpha
        only when there are any, so a plain mesh is hashed and sent as by an older client."""
        return mesh_arrays(
            self.positions, self.triangles, self.normals, self.material_slots, self.uv_maps
        )


@dataclass
class FrameExport:
    frame: int
    objects: list[dict]
    camera: dict
    lights: list[dict]
    resolution: dict
    #: Every mesh the frame's objects use, by hash.
    meshes: dict[int, MeshData]
    seconds: float = 0.0
    triangles: int = 0
    #: Meshes read from Blender this frame (the rest came from the static cache).
    extracted: int = 0
    #: Instance arrays (``frame_update``'s ``instances``): every instance of a mesh placed
    #: more than once through instancing, as one array.
    instances: list[dict] = field(default_factory=list)
    #: The alpha materials the objects' and arrays' ``materials`` refer to, and the image
    #: arrays they read (see ``alpha_frame``).
    alpha: FrameAlpha = field(default_factory=FrameAlpha)
    #: The frame's export warnings not said before in this job (an unsupported node, an
    #: unreadable image, an absent UV map), each said once per job.
    warnings: list[str] = field(default_factory=list)

    def placements(self) -> int:
        """Objects and instances: what the frame places."""
        return len(self.objects) + sum(len(a["matrices"]) for a in self.instances)


def mesh_arrays(positions, triangles, normals=None, material_slots=None, uv_maps=None) -> dict:
    """The client's mesh arguments as keywords: normals, slots and UV maps only when there are
    any, so a plain mesh is hashed and sent as by a client that predates them."""
    arrays = {"positions": positions, "triangles": triangles}
    if normals is not None:
        arrays["normals"] = normals
    if material_slots is not None:
        arrays["material_slots"] = material_slots
        arrays["uv_maps"] = uv_maps or {}
    return arrays


def send(session, e: FrameExport) -> None:
    """Sends a frame's scene state, then the meshes and alpha images the session lacks (after
    a reconnect: all of them)."""
    missing = session.frame_update(
        e.frame,
        e.objects,
        e.camera,
        e.lights,
        e.resolution,
        e.instances,
        alpha_materials=e.alpha.materials,
    )
    for h in missing:
        session.upload_mesh(e.meshes[h].name, **e.meshes[h].arrays())
    for h in missing.images:
        session.upload_image(e.alpha.images[h])


def _matrix(m) -> list[list[float]]:
    return [list(row) for row in m]


@dataclass
class _Topology:
    """A mesh's triangles and what they were derived from, to skip re-reading them while only
    positions change (deforming modifiers, shape keys, armatures)."""

    corner_vert: np.ndarray
    triangle_faces: np.ndarray
    triangles: np.ndarray


def _int_attribute(mesh, name: str) -> np.ndarray | None:
    """An internal int attribute (``.corner_vert``, Blender 3.6+) read in one copy, or None."""
    attributes = getattr(mesh, "attributes", None)
    attribute = attributes.get(name) if attributes is not None else None
    if attribute is None or attribute.data_type != "INT":
        return None
    values = np.empty(len(attribute.data), dtype=np.int32)
    attribute.data.foreach_get("value", values)
    return values


def _positions(mesh) -> np.ndarray:
    positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    attribute = mesh.attributes.get("position") if hasattr(mesh, "attributes") else None
    if attribute is not None and attribute.data_type == "FLOAT_VECTOR":
        attribute.data.foreach_get("vector", positions)
    else:
        mesh.vertices.foreach_get("co", positions)
    return positions.reshape(-1, 3)


def _corner_normals(mesh) -> np.ndarray | None:
    """Shading normals at each triangle's corners (custom normals included), float32 (3m, 3)
    in ``loop_triangles`` order; None for a mesh of flat faces only, whose normal is its
    plane's."""
    smooth = np.zeros(len(mesh.polygons), dtype=bool)
    mesh.polygons.foreach_get("use_smooth", smooth)
    if not smooth.any() and not mesh.has_custom_normals:
        return None
    if hasattr(mesh, "corner_normals"):  # Blender 4.1 and later
        normals = np.empty(len(mesh.corner_normals) * 3, dtype=np.float32)
        mesh.corner_normals.foreach_get("vector", normals)
    else:
        mesh.calc_normals_split()
        normals = np.empty(len(mesh.loops) * 3, dtype=np.float32)
        mesh.loops.foreach_get("normal", normals)
    if not mesh.loop_triangles:
        mesh.calc_loop_triangles()
    loops = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("loops", loops)
    return normals.reshape(-1, 3)[loops]


def _split_quads(
    corner_vert: np.ndarray, triangle_faces: np.ndarray, positions: np.ndarray
) -> np.ndarray | None:
    """Triangles of a mesh of triangles and quads, split as Blender's ``loop_triangles`` splits
    them, from its corner array; None if it has an n-gon. A quad becomes corners (0, 1, 2) and
    (0, 2, 3), unless the diagonal 0-2 lies outside it (Blender's
    ``is_quad_flip_v3_first_third_fast``, evaluated in float32 like Blender), then (0, 1, 3)
    and (1, 2, 3)."""
    per_face = np.bincount(triangle_faces)
    if len(per_face) and per_face.max() > 2:
        return None
    starts = np.zeros(len(per_face), dtype=np.int32)
    np.cumsum(per_face[:-1] + 2, out=starts[1:])
    base = starts[triangle_faces]
    # 1 for a quad's second triangle, whose corners are (0, 2, 3).
    second = np.zeros(len(triangle_faces), dtype=np.int32)
    second[1:] = triangle_faces[1:] == triangle_faces[:-1]
    c0, c1, c2 = base, base + 1 + second, base + 2 + second
    first = np.flatnonzero(second[1:]).astype(np.int32)  # rows of the quads' first triangles
    if len(first):
        q = base[first]
        v = positions[corner_vert[q[:, None] + np.arange(4, dtype=np.int32)]]
        a, c, d = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0], v[:, 3] - v[:, 0]
        cross_a = np.stack(
            [
                a[:, 1] * c[:, 2] - a[:, 2] * c[:, 1],
                a[:, 2] * c[:, 0] - a[:, 0] * c[:, 2],
                a[:, 0] * c[:, 1] - a[:, 1] * c[:, 0],
            ],
            axis=1,
        )
        cross_b = np.stack(
            [
                d[:, 1] * c[:, 2] - d[:, 2] * c[:, 1],
                d[:, 2] * c[:, 0] - d[:, 0] * c[:, 2],
                d[:, 0] * c[:, 1] - d[:, 1] * c[:, 0],
            ],
            axis=1,
        )
        flipped = first[(cross_a * cross_b).sum(axis=1) > 0]
        c2[flipped] += 1  # (0, 1, 3)
        c0[flipped + 1] += 1  # (1, 2, 3)
    return corner_vert[np.stack([c0, c1, c2], axis=1)].astype(np.uint32)


def _triangles(
    mesh, previous: _Topology | None, positions: np.ndarray
) -> tuple[np.ndarray, _Topology | None]:
    """Triangles uint32 (m, 3), as Blender's ``loop_triangles``. Reading those through RNA costs
    ~0.2 s per million, so meshes of triangles and quads are split from their corner array in
    numpy, and a mesh with n-gons keeps its triangles while its corners and triangle-to-face
    map stay the same (an n-gon whose shape changes enough to be split differently keeps the
    old split: a valid triangulation of the same face)."""
    if hasattr(mesh, "calc_loop_triangles") and not mesh.loop_triangles:
        mesh.calc_loop_triangles()
    corner_vert = _int_attribute(mesh, ".corner_vert")
    if corner_vert is not None and len(corner_vert) == 3 * len(mesh.polygons):
        return corner_vert.reshape(-1, 3).astype(np.uint32), None
    faces = getattr(mesh, "loop_triangle_polygons", None)
    if corner_vert is None or faces is None:
        triangles = np.empty(len(mesh.loop_triangles) * 3, dtype=np.uint32)
        mesh.loop_triangles.foreach_get("vertices", triangles)
        return triangles.reshape(-1, 3), None
    triangle_faces = np.empty(len(faces), dtype=np.int32)
    faces.foreach_get("value", triangle_faces)
    split = _split_quads(corner_vert, triangle_faces, positions)
    if split is not None:
        return split, None
    if (
        previous is not None
        and np.array_equal(previous.corner_vert, corner_vert)
        and np.array_equal(previous.triangle_faces, triangle_faces)
    ):
        return previous.triangles, previous
    triangles = np.empty(len(mesh.loop_triangles) * 3, dtype=np.uint32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    triangles = triangles.reshape(-1, 3)
    return triangles, _Topology(corner_vert, triangle_faces, triangles)


def _is_static(original) -> bool:
    """An object whose evaluated mesh cannot change while frames advance: a plain mesh with no
    modifiers, shape keys or animated mesh data. Only its transform may move."""
    if original.type != "MESH" or original.modifiers:
        return False
    data = original.data
    return data.shape_keys is None and data.animation_data is None


def _ray_visibility(original) -> tuple[bool, bool]:
    # Cycles' ray visibility (Object Properties > Visibility), Blender 3.0 and later.
    camera = getattr(original, "visible_camera", True)
    shadow = getattr(original, "visible_shadow", True)
    return bool(camera), bool(shadow)


def camera_dict(camera_object, frame: int) -> dict:
    data = camera_object.data
    if data.type != "PERSP":
        raise ExportError(
            f"frame {frame}: camera '{camera_object.name}' is {data.type}; "
            "antumbra renders perspective cameras only"
        )
    return {
        "matrix_world": _matrix(camera_object.matrix_world),
        "lens": data.lens,
        "sensor_width": data.sensor_width,
        "sensor_height": data.sensor_height,
        "sensor_fit": data.sensor_fit,
        "shift_x": data.shift_x,
        "shift_y": data.shift_y,
        "clip_start": data.clip_start,
        "clip_end": data.clip_end,
    }


def light_dict(name: str, light_object, matrix) -> dict:
    data = light_object.data
    light = {
        "name": name,
        "type": data.type,
        "matrix_world": _matrix(matrix),
        "use_shadow": bool(getattr(data, "use_shadow", True)),
    }
    if data.type in {"POINT", "SPOT"}:
        light["shadow_soft_size"] = data.shadow_soft_size
    if data.type == "SPOT":
        light["spot_size"] = data.spot_size
        light["spot_blend"] = data.spot_blend
    if data.type == "SUN":
        light["angle"] = data.angle
    if data.type == "AREA":
        light["shape"] = data.shape
        light["size"] = data.size
        light["size_y"] = data.size_y
    return light


def resolution_dict(scene, percentage: int) -> dict:
    r = scene.render
    return {
        "x": r.resolution_x,
        "y": r.resolution_y,
        "percentage": percentage,
        "pixel_aspect_x": r.pixel_aspect_x,
        "pixel_aspect_y": r.pixel_aspect_y,
    }


@dataclass
class _GroupAlpha:
    #: Per material slot: the frame's alpha material index, None for an opaque slot.
    slots: list
    #: ``alpha_mesh.MeshAlpha``, or None when a static mesh from an earlier frame holds it.
    mesh: object


@dataclass
class Exporter:
    """Exports frames; keeps the meshes of static objects between frames of one job, so a
    1M-triangle set that only moves is read from Blender once. With ``normals``, meshes with
    smooth faces or custom normals carry their corner normals (for ``facing="shading"``)."""

    client: object
    normals: bool = False
    #: Read materials' alpha (issue 38); off, every material is sent opaque.
    alpha: bool = True
    static: dict[str, MeshData] = field(default_factory=dict)
    topology: dict[str, _Topology] = field(default_factory=dict)
    #: ``object_alpha``'s image arrays, read once per job, and their content hashes.
    images: dict = field(default_factory=dict)
    image_hashes: dict = field(default_factory=dict)
    #: Warnings said in this job.
    said: set = field(default_factory=set)
    _extracted: int = 0

    def frame(self, depsgraph, scene, frame: int, percentage: int) -> FrameExport:
        start = time.perf_counter()
        if scene.camera is None:
            raise ExportError(f"frame {frame}: scene '{scene.name}' has no camera")
        camera = camera_dict(scene.camera.evaluated_get(depsgraph), frame)
        found = read_instances(depsgraph)
        lights = [light_dict(name, obj, matrix) for name, obj, matrix in found.lights]
        objects: list[dict] = []
        arrays: list[dict] = []
        meshes: dict[int, MeshData] = {}
        # Evaluated meshes shared by several groups are read once per frame.
        by_data: dict[tuple, MeshData] = {}
        self._extracted = 0
        triangles = 0
        alpha, known = FrameAlpha(), {}
        for group in found.groups.values():
            if not (group.visible_camera or group.visible_shadow):
                continue
            itself = group.as_itself()
            placed, own = np.flatnonzero(~itself), np.flatnonzero(itself)
            instanced = len(own) == 0
            slots = self._alpha(group, depsgraph, instanced, alpha, known)
            mesh = self._mesh(group.mesh, group.source, instanced, frame, by_data, slots)
            if mesh is None:
                continue
            materials = slots.slots if slots is not None and mesh.material_slots is not None else []
            meshes.setdefault(mesh.hash, mesh)
            triangles += len(mesh.triangles) * len(group.matrices)
            # One instance travels as an object, under its own name.
            as_objects = own if len(placed) > 1 else np.arange(len(group.matrices))
            for row in as_objects:
                objects.append(
                    {
                        "name": group.name_of(row),
                        "mesh_hash": mesh.hash,
                        "matrix_world": group.matrices[row],
                        "visible_camera": group.visible_camera,
                        "visible_shadow": group.visible_shadow,
                        **({"materials": materials} if materials else {}),
                    }
                )
            if len(placed) > 1:
                arrays.append(self._array(group, placed, mesh.hash, arrays))
                if materials:
                    arrays[-1]["materials"] = materials
        return FrameExport(
            frame=frame,
            objects=objects,
            camera=camera,
            lights=lights,
            resolution=resolution_dict(scene, percentage),
            meshes=meshes,
            seconds=time.perf_counter() - start,
            triangles=triangles,
            extracted=self._extracted,
            instances=arrays,
            alpha=alpha,
            warnings=self._first_said(alpha.warnings),
        )

    def _first_said(self, warnings: list[str]) -> list[str]:
        new = [w for w in warnings if w not in self.said]
        self.said.update(new)
        return new

    def _alpha(self, group, depsgraph, instanced: bool, alpha: FrameAlpha, known: dict):
        """The group's slots as the frame's alpha material indices, and its mesh's slots and
        UVs unless a static mesh holds them already; None without alpha (or with it off)."""
        if not self.alpha:
            return None
        from .alpha_object import object_alpha  # alpha_mesh imports this module's readers

        source = group.source
        cached = not instanced and _is_static(source) and source.name in self.static
        obj_eval = source.evaluated_get(depsgraph)
        found = object_alpha(obj_eval, group.mesh, self.images, not cached, known)
        for key in found.image_keys:
            if key is not None and key in self.images and key not in self.image_hashes:
                self.image_hashes[key] = self.client.image_hash(self.images[key][2])
        indices = alpha.slots(found, self.images, self.image_hashes)
        if all(i is None for i in indices):
            return None
        return _GroupAlpha(indices, found.mesh)

    @staticmethod
    def _array(group, rows: np.ndarray, mesh_hash: int, arrays: list[dict]) -> dict:
        """The group's instances as one array named after the mesh's object (a second array
        of that name in the frame gets a number). Its instances are named by the first level
        of their persistent ids that tells them all apart (their index or ``id`` attribute),
        else by their order; names are for people, nothing relies on them."""
        taken = {a["name"] for a in arrays}
        base = group.source.name
        name = next(
            n
            for n in itertools.chain([base], (f"{base}#{k}" for k in itertools.count(2)))
            if n not in taken
        )
        array = {
            "name": name,
            "mesh_hash": mesh_hash,
            "matrices": group.matrices[rows],
            "visible_camera": group.visible_camera,
            "visible_shadow": group.visible_shadow,
        }
        ids = group.ids[rows]
        for level in range(ids.shape[1]):
            if len(np.unique(ids[:, level])) == len(rows):
                array["ids"] = ids[:, level].astype(np.uint32)
                break
        return array

    def _mesh(self, data, original, instanced: bool, frame, by_data, alpha=None) -> MeshData | None:
        static = not instanced and _is_static(original)
        key = original.name
        if static and key in self.static:
            return self.static[key]
        # A mesh read with one object's slots and UVs is another mesh for the daemon.
        uv_names = tuple(sorted(alpha.mesh.uvs)) if alpha and alpha.mesh else None
        data_key = (data.as_pointer(), uv_names)
        if data_key in by_data:
            return by_data[data_key]
        positions, triangles = self._arrays(data, key, instanced)
        self._extracted += 1
        if len(triangles) == 0:
            return None
        if not np.isfinite(positions).all():
            bad = int(np.flatnonzero(~np.isfinite(positions).all(axis=1))[0])
            raise ExportError(
                f"frame {frame}: object '{original.name}' has a non-finite vertex "
                f"(index {bad}: {positions[bad].tolist()})"
            )
        normals = _corner_normals(data) if self.normals else None
        slots, uv_maps = None, None
        if alpha is not None and alpha.mesh is not None:
            slots, uv_maps = alpha.mesh.material_index, alpha.mesh.uvs
        mesh = MeshData(
            name=original.name,
            positions=positions,
            triangles=triangles,
            hash=0,
            normals=normals,
            material_slots=slots,
            uv_maps=uv_maps,
        )
        mesh.hash = self.client.mesh_hash(**mesh.arrays())
        by_data[data_key] = mesh
        if static:
            self.static[key] = mesh
        return mesh

    def _arrays(self, mesh, key: str, instanced: bool) -> tuple[np.ndarray, np.ndarray]:
        if instanced:
            # Instances share evaluated meshes; only objects of their own keep a topology.
            positions = _positions(mesh)
            return positions, _triangles(mesh, None, positions)[0]
        positions = _positions(mesh)
        triangles, topology = _triangles(mesh, self.topology.get(key), positions)
        if topology is None:
            self.topology.pop(key, None)
        else:
            self.topology[key] = topology
        return positions, triangles
