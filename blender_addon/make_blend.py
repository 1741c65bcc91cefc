"""Turns a recording (``.antrec``, e.g. a built-in scene from ``antumbra record``) into a
``.blend``: one mesh per recorded mesh, objects, camera and lights keyframed per frame, the
frame range and resolution of the recording, Cycles as the render engine.

    blender -b --factory-startup -P blender_addon/make_blend.py -- \
        --recording IN.antrec --out OUT.blend

Objects that do not move get no keyframes. Needs the client package (``blender_addon/build.py``
unpacks it next to the add-on).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix

sys.path.insert(0, str(Path(__file__).resolve().parent))
from antumbra import client_loader

LIGHT_ENERGY = {"SUN": 3.0, "POINT": 1000.0, "SPOT": 1000.0, "AREA": 200.0}


def script_args(argv: list[str]) -> list[str]:
    return argv[argv.index("--") + 1 :] if "--" in argv else []


def new_mesh(name: str, positions: np.ndarray, triangles: np.ndarray):
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", positions.astype(np.float32).ravel())
    mesh.loops.add(3 * len(triangles))
    mesh.loops.foreach_set("vertex_index", triangles.astype(np.int32).ravel())
    mesh.polygons.add(len(triangles))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(triangles), 3, dtype=np.int32))
    if bpy.app.version < (4, 0, 0):
        mesh.polygons.foreach_set("loop_total", np.full(len(triangles), 3, dtype=np.int32))
    mesh.update()
    return mesh


def keyframe_transforms(obj, matrices: list[tuple[int, list]]):
    """Sets the object's transform per frame; keyframes only if it changes."""
    first = matrices[0][1]
    obj.rotation_mode = "QUATERNION"
    obj.matrix_world = Matrix(first)
    if all(m == first for _, m in matrices):
        return
    for frame, m in matrices:
        obj.matrix_world = Matrix(m)
        for path in ("location", "rotation_quaternion", "scale"):
            obj.keyframe_insert(path, frame=frame)
    for curve in obj.animation_data.action.fcurves:
        for key in curve.keyframe_points:
            key.interpolation = "LINEAR"


def build(recording: dict, out: Path, engine: str):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    frames = recording["frames"]
    if not frames:
        raise SystemExit("the recording has no frames")
    first = frames[0]
    scene.frame_start = frames[0]["frame"]
    scene.frame_end = frames[-1]["frame"]
    scene.frame_current = scene.frame_start
    res = first["resolution"]
    scene.render.resolution_x, scene.render.resolution_y = res["x"], res["y"]
    scene.render.resolution_percentage = res["percentage"]
    scene.render.pixel_aspect_x = res["pixel_aspect_x"]
    scene.render.pixel_aspect_y = res["pixel_aspect_y"]
    scene.render.engine = engine

    meshes = {
        h: new_mesh(m["name"], m["positions"], m["triangles"])
        for h, m in recording["meshes"].items()
    }
    tracks: dict[str, list] = {}
    for f in frames:
        for o in f["objects"]:
            tracks.setdefault(o["name"], []).append((f["frame"], o))
    for name, track in tracks.items():
        if len(track) != len(frames):
            raise SystemExit(f"object '{name}' is not in every frame; not supported here")
        o = track[0][1]
        obj = bpy.data.objects.new(name, meshes[o["mesh_hash"]])
        scene.collection.objects.link(obj)
        obj.visible_camera = o["visible_camera"]
        obj.visible_shadow = o["visible_shadow"]
        keyframe_transforms(obj, [(frame, o["matrix_world"]) for frame, o in track])

    cam = first["camera"]
    camera = bpy.data.cameras.new("Camera")
    camera.lens = cam["lens"]
    camera.sensor_width = cam["sensor_width"]
    camera.sensor_height = cam["sensor_height"]
    camera.sensor_fit = cam["sensor_fit"]
    camera.shift_x, camera.shift_y = cam["shift_x"], cam["shift_y"]
    camera.clip_start, camera.clip_end = cam["clip_start"], cam["clip_end"]
    camera_object = bpy.data.objects.new("Camera", camera)
    scene.collection.objects.link(camera_object)
    scene.camera = camera_object
    keyframe_transforms(camera_object, [(f["frame"], f["camera"]["matrix_world"]) for f in frames])
    lens = [(f["frame"], f["camera"]["lens"]) for f in frames]
    if any(v != lens[0][1] for _, v in lens):
        for frame, v in lens:
            camera.lens = v
            camera.keyframe_insert("lens", frame=frame)

    for index, light in enumerate(first["lights"]):
        data = bpy.data.lights.new(light["name"], light["type"])
        data.energy = LIGHT_ENERGY[light["type"]]
        data.use_shadow = light["use_shadow"]
        if light["type"] in {"POINT", "SPOT"}:
            data.shadow_soft_size = light["shadow_soft_size"]
        if light["type"] == "SPOT":
            data.spot_size, data.spot_blend = light["spot_size"], light["spot_blend"]
        if light["type"] == "SUN":
            data.angle = light["angle"]
        if light["type"] == "AREA":
            data.shape, data.size, data.size_y = light["shape"], light["size"], light["size_y"]
        obj = bpy.data.objects.new(light["name"], data)
        scene.collection.objects.link(obj)
        keyframe_transforms(obj, [(f["frame"], f["lights"][index]["matrix_world"]) for f in frames])

    world = bpy.data.worlds.new("World")
    scene.world = world
    scene.frame_set(scene.frame_start)
    out.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(out), compress=False)


def main() -> int:
    parser = argparse.ArgumentParser(prog="make_blend.py", description=__doc__.splitlines()[0])
    parser.add_argument("--recording", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--engine", default="CYCLES")
    args = parser.parse_args(script_args(sys.argv))
    client = client_loader.load()
    recording = client.read_recording(args.recording)
    build(recording, args.out.resolve(), args.engine)
    objects = sum(1 for o in bpy.data.objects if o.type == "MESH")
    triangles = sum(len(m["triangles"]) for m in recording["meshes"].values())
    print(
        f"antumbra: wrote {args.out} ({len(recording['frames'])} frames, {objects} objects, "
        f"{triangles} mesh triangles)"
    )
    return 0


if __name__ == "__main__":
    try:
        code = main()
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else 1
        if not isinstance(e.code, int):
            print(f"antumbra: error: {e.code}", file=sys.stderr)
    except Exception as e:  # noqa: BLE001 - a script's failure is its exit code
        print(f"antumbra: error: {e}", file=sys.stderr)
        code = 1
    sys.stdout.flush()
    if code:
        # Blender ignores a -P script's exceptions; only an explicit exit sets its status.
        import os

        os._exit(code)
