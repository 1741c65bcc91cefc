"""The evaluated scene of one frame as the daemon's input: meshes (numpy arrays, by content hash),
objects, the camera and lights in Blender's own terms, and the camera path of a frame range.

Everything is read from the evaluated depsgraph, so modifiers, shape keys, armatures and
geometry-node instances (``depsgraph.object_instances``) are what gets rendered. Bulk data goes
through ``foreach_get`` into numpy; nothing loops over vertices in Python.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import bpy
import numpy as np

#: Object types whose evaluated geometry is a mesh.
GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "META", "FONT"}


class ExportError(ValueError):
    """A scene the daemon cannot take; the message names the object and frame."""


@dataclass
class MeshData:
    name: str
    positions: np.ndarray
    triangles: np.ndarray
    hash: int


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


def _matrix(m) -> list[list[float]]:
    return [list(row) for row in m]


def _mesh_arrays(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Positions float32 (n, 3) and triangles uint32 (m, 3) of an evaluated mesh."""
    if hasattr(mesh, "calc_loop_triangles") and not mesh.loop_triangles:
        mesh.calc_loop_triangles()
    n = len(mesh.vertices)
    positions = np.empty(n * 3, dtype=np.float32)
    attribute = mesh.attributes.get("position") if hasattr(mesh, "attributes") else None
    if attribute is not None and attribute.data_type == "FLOAT_VECTOR":
        attribute.data.foreach_get("vector", positions)
    else:
        mesh.vertices.foreach_get("co", positions)
    triangles = np.empty(len(mesh.loop_triangles) * 3, dtype=np.uint32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    return positions.reshape(-1, 3), triangles.reshape(-1, 3)


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


def _instance_name(instance, obj) -> str:
    if not instance.is_instance:
        return obj.name
    parent = instance.parent.name if instance.parent else ""
    ids = ".".join(str(i) for i in instance.persistent_id if i != 0x7FFFFFFF)
    return f"{parent}/{obj.name}[{ids}]"


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
class Exporter:
    """Exports frames; keeps the meshes of static objects between frames of one job, so a
    1M-triangle set that only moves is read from Blender once."""

    client: object
    static: dict[str, MeshData] = field(default_factory=dict)
    _extracted: int = 0

    def frame(self, depsgraph, scene, frame: int, percentage: int) -> FrameExport:
        start = time.perf_counter()
        if scene.camera is None:
            raise ExportError(f"frame {frame}: scene '{scene.name}' has no camera")
        camera = camera_dict(scene.camera.evaluated_get(depsgraph), frame)
        objects: list[dict] = []
        lights: list[dict] = []
        meshes: dict[int, MeshData] = {}
        # Evaluated meshes shared by several instances are read once per frame.
        by_data: dict[int, MeshData] = {}
        self._extracted = 0
        triangles = 0
        for instance in depsgraph.object_instances:
            obj = instance.object
            original = obj.original
            hidden = original.hide_render or (
                instance.is_instance and instance.parent and instance.parent.original.hide_render
            )
            if hidden:
                continue
            name = _instance_name(instance, obj)
            if obj.type == "LIGHT":
                lights.append(light_dict(name, obj, instance.matrix_world))
                continue
            if obj.type not in GEOMETRY_TYPES:
                continue
            visible_camera, visible_shadow = _ray_visibility(original)
            if not (visible_camera or visible_shadow):
                continue
            mesh = self._mesh(instance, obj, original, frame, by_data)
            if mesh is None:
                continue
            if mesh.hash not in meshes:
                meshes[mesh.hash] = mesh
            triangles += len(mesh.triangles)
            objects.append(
                {
                    "name": name,
                    "mesh_hash": mesh.hash,
                    "matrix_world": _matrix(instance.matrix_world),
                    "visible_camera": visible_camera,
                    "visible_shadow": visible_shadow,
                }
            )
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
        )

    def _mesh(self, instance, obj, original, frame, by_data) -> MeshData | None:
        static = not instance.is_instance and _is_static(original)
        key = original.name
        if static and key in self.static:
            return self.static[key]
        data_key = obj.data.as_pointer() if obj.type == "MESH" and obj.data else None
        if data_key is not None and data_key in by_data:
            return by_data[data_key]
        if obj.type == "MESH":
            positions, triangles = _mesh_arrays(obj.data)
        else:
            temporary = obj.to_mesh()
            try:
                if temporary is None:
                    return None
                positions, triangles = _mesh_arrays(temporary)
            finally:
                obj.to_mesh_clear()
        self._extracted += 1
        if len(triangles) == 0:
            return None
        if not np.isfinite(positions).all():
            bad = int(np.flatnonzero(~np.isfinite(positions).all(axis=1))[0])
            raise ExportError(
                f"frame {frame}: object '{original.name}' has a non-finite vertex "
                f"(index {bad}: {positions[bad].tolist()})"
            )
        mesh = MeshData(
            name=original.name,
            positions=positions,
            triangles=triangles,
            hash=self.client.mesh_hash(positions, triangles),
        )
        if data_key is not None:
            by_data[data_key] = mesh
        if static:
            self.static[key] = mesh
        return mesh


def camera_path(scene, frames) -> tuple[dict[int, dict], float]:
    """The camera of every frame in ``frames`` (the scene's frame is restored). Evaluates each
    frame, so it costs what stepping through the frames costs; returns the seconds it took."""
    start = time.perf_counter()
    current = scene.frame_current
    path = {}
    try:
        for f in frames:
            scene.frame_set(f)
            depsgraph = bpy.context.evaluated_depsgraph_get()
            if scene.camera is None:
                raise ExportError(f"frame {f}: scene '{scene.name}' has no camera")
            path[f] = camera_dict(scene.camera.evaluated_get(depsgraph), f)
    finally:
        scene.frame_set(current)
    return path, time.perf_counter() - start
