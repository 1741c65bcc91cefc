"""The Blender side of ``test_cycles_agreement.py``: builds a test scene, renders it with Cycles
(object-index and shadow-catcher passes) and with antumbra (the add-on's exporter and an
in-process ``antumbra.LocalSession``), and saves both as arrays.

Runs inside Blender, in either of the two Blenders the add-on supports:

    blender -b --factory-startup -noaudio -P tests/blender/cycles_scene.py -- --out DIR
    python tests/blender/cycles_scene.py -- --out DIR     # a Python with the bpy 5.0 module

Needs numpy and the antumbra client package importable (the test puts it on PYTHONPATH).

Output in DIR: ``cycles.exr`` (Blender's multilayer EXR of the render with every pass),
``antumbra.npz`` (``object_ids``, ``mask``: float32 (height, width), rows top to bottom) and
``scene.json`` (the object names in export order, the resolution, Blender's version).

The scene: a ground plane (a 16 x 16 grid, the shadow catcher) with boxes of several sizes and
rotations, a UV sphere and a tall slab on it, a hard sun (angle 0) low enough for long shadows,
a world that emits nothing, a camera that also sees the sky above the horizon.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
from pathlib import Path

import bpy
import numpy as np

REPO = Path(__file__).resolve().parents[2]
ADDON = REPO / "blender_addon" / "antumbra"

WIDTH, HEIGHT = 240, 135

#: (name, location, rotation about z in degrees, size (x, y, z)) of the boxes.
BOXES = [
    ("Box.Big", (0.0, 0.0, 0.75), 20.0, (1.5, 1.5, 1.5)),
    ("Box.Small", (2.4, -1.6, 0.3), -35.0, (0.6, 0.6, 0.6)),
    ("Box.Far", (-2.5, 3.0, 0.5), 50.0, (1.0, 2.0, 1.0)),
    ("Slab", (-2.8, -1.2, 1.1), 10.0, (0.25, 1.6, 2.2)),
]


def script_args(argv: list[str]) -> list[str]:
    return argv[argv.index("--") + 1 :] if "--" in argv else []


def load_exporter():
    """The add-on's ``export.exporter`` module, loaded from its folder as the package
    ``antumbra_addon``: the add-on package is also called ``antumbra`` and must not shadow the
    client package."""
    init = ADDON / "__init__.py"
    spec = importlib.util.spec_from_file_location(
        "antumbra_addon", init, submodule_search_locations=[str(ADDON)]
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules["antumbra_addon"] = module
    spec.loader.exec_module(module)
    return importlib.import_module("antumbra_addon.export.exporter")


def build_scene(width: int, height: int):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene

    bpy.ops.mesh.primitive_grid_add(x_subdivisions=16, y_subdivisions=16, size=14.0)
    ground = bpy.context.active_object
    ground.name = "Ground"
    ground.is_shadow_catcher = True

    for name, location, angle, size in BOXES:
        bpy.ops.mesh.primitive_cube_add(size=1.0, location=location)
        ob = bpy.context.active_object
        ob.name = name
        ob.rotation_euler = (0.0, 0.0, math.radians(angle))
        ob.scale = size
    bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12, radius=0.7)
    sphere = bpy.context.active_object
    sphere.name = "Sphere"
    sphere.location = (2.0, 2.2, 0.7)

    bpy.ops.object.camera_add(location=(9.0, -9.0, 5.5))
    cam = bpy.context.active_object
    cam.name = "Camera"
    direction = -cam.location.normalized()
    # Aim a little above the origin so the top rows see the (empty) sky.
    direction.z += 0.12
    cam.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 30.0
    scene.camera = cam

    bpy.ops.object.light_add(type="SUN", rotation=(math.radians(55.0), 0.0, math.radians(-75.0)))
    sun = bpy.context.active_object
    sun.name = "Sun"
    sun.data.angle = 0.0
    sun.data.energy = 3.0

    # A world that emits nothing: the sun is the only light (5.0 gives new worlds a grey
    # Background node, which would light shadowed ground).
    world = bpy.data.worlds.new("Black")
    world.color = (0.0, 0.0, 0.0)
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    for node in world.node_tree.nodes if world.node_tree else ():
        if node.type == "BACKGROUND":
            node.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
            node.inputs["Strength"].default_value = 0.0
    scene.world = world

    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    return scene


def configure_cycles(scene):
    """``cycles_settings.py``'s Cycles (no transparent bounces), with the object-index pass."""
    path = Path(__file__).resolve().with_name("cycles_settings.py")
    spec = importlib.util.spec_from_file_location("cycles_settings", path)
    settings = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(settings)
    settings.configure_cycles(scene, transparent_bounces=0)
    scene.view_layers[0].use_pass_object_index = True


def render_antumbra(scene, client):
    """Exports the evaluated scene with the add-on's exporter and renders it in process."""
    export = load_exporter()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    session = client.LocalSession()
    exported = export.Exporter(client).frame(depsgraph, scene, scene.frame_current, 100)
    missing = session.frame_update(
        exported.frame,
        exported.objects,
        exported.camera,
        exported.lights,
        exported.resolution,
        exported.instances,
    )
    for h in missing:
        m = exported.meshes[h]
        session.upload_mesh(m.name, m.positions, m.triangles)
    result = session.render(exported.frame, spp=1, passes=("masks", "object_ids"))
    names = [o["name"] for o in exported.objects]
    return names, result.object_ids, result.masks["Sun"]


def sun_towards(scene):
    sun = scene.objects["Sun"]
    return sun.matrix_world.to_3x3().col[2].normalized()


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--width", type=int, default=WIDTH)
    parser.add_argument("--height", type=int, default=HEIGHT)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    import antumbra as client

    scene = build_scene(args.width, args.height)
    configure_cycles(scene)
    names, object_ids, mask = render_antumbra(scene, client)

    # Cycles' object index is pass_index; 0 is the background, so object i gets i + 1.
    for i, name in enumerate(names):
        bpy.data.objects[name].pass_index = i + 1
    scene.render.filepath = str(args.out / "cycles.exr")
    bpy.ops.render.render(write_still=True)

    np.savez(args.out / "antumbra.npz", object_ids=object_ids, mask=mask)
    (args.out / "scene.json").write_text(
        json.dumps(
            {
                "objects": names,
                "width": args.width,
                "height": args.height,
                "blender": bpy.app.version_string,
                # The ground's normal (world +Z) dotted with the direction towards the sun (the
                # sun's local +Z): > 0 means the whole ground faces the sun.
                "ground_n_dot_l": float(sun_towards(scene).z),
            }
        )
    )


if __name__ == "__main__":
    main(script_args(sys.argv))
