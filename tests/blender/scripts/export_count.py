"""Exports one frame of a scene of text, curve, surface, metaball and mesh objects (some of them
also instanced through a collection) with the add-on's exporter, and writes what it sent beside
Blender's own count of evaluated triangles. Runs in Debian's Blender (``blender -b -P
export_count.py -- ARGS``) and with the bpy module (``python export_count.py -- ARGS``).

Writes OUT (JSON): ``triangles`` (sent), ``blender`` (each object's evaluated mesh counted once
per placement), ``names`` (the objects sent).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
from pathlib import Path

import bpy


def args():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--addon", required=True, help="the add-on's source folder (blender_addon)")
    p.add_argument("--out", required=True)
    return p.parse_args(argv)


def load_addon(folder: Path):
    init = folder / "antumbra" / "__init__.py"
    spec = importlib.util.spec_from_file_location(
        "antumbra_addon", init, submodule_search_locations=[str(init.parent)]
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules["antumbra_addon"] = module
    spec.loader.exec_module(module)
    from antumbra_addon import client_loader
    from antumbra_addon.export import exporter as export

    return client_loader.load(), export


def build_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, -20.0, 8.0)
    camera.rotation_euler = (1.2, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    bpy.ops.object.text_add(location=(0, 0, 0))
    bpy.context.object.data.extrude = 0.1
    bpy.ops.curve.primitive_bezier_circle_add(location=(4, 0, 0))
    bpy.context.object.data.bevel_depth = 0.1
    bpy.context.object.name = "Circle"  # "BezierCircle" in 3.4, "BézierCircle" in 5.0
    bpy.ops.surface.primitive_nurbs_surface_sphere_add(location=(-4, 0, 0))
    bpy.ops.object.metaball_add(type="BALL", location=(0, 4, 0))
    bpy.ops.object.metaball_add(type="BALL", location=(0.6, 4, 0))
    bpy.ops.mesh.primitive_cube_add(location=(0, -4, 0))
    # A text and a curve placed twice more through a collection instance.
    letters = bpy.data.collections.new("Letters")
    scene.collection.children.link(letters)
    word = bpy.data.objects.new("Word", bpy.data.curves.new("Word", "FONT"))
    word.data.body = "Word"
    word.data.extrude = 0.05
    letters.objects.link(word)
    for i in range(2):
        empty = bpy.data.objects.new(f"Letters.{i}", None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = letters
        empty.location = (0, 8 + 3 * i, 0)
        scene.collection.objects.link(empty)
    return scene


def evaluated_triangles(obj, depsgraph) -> int:
    """Triangles of one object's evaluated mesh, read from the object itself."""
    if obj.type not in {"MESH", "CURVE", "SURFACE", "META", "FONT"}:
        return 0
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        return 0 if mesh is None else len(mesh.loop_triangles)
    finally:
        evaluated.to_mesh_clear()


def blender_count(scene, depsgraph) -> int:
    """Each object once where it stands, and each collection instance's objects once more."""
    total = 0
    for obj in scene.objects:
        total += evaluated_triangles(obj, depsgraph)
        if obj.instance_type == "COLLECTION" and obj.instance_collection:
            total += sum(
                evaluated_triangles(o, depsgraph) for o in obj.instance_collection.all_objects
            )
    return total


def main():
    a = args()
    client, export = load_addon(Path(a.addon))
    scene = build_scene()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    sent = export.Exporter(client).frame(depsgraph, scene, scene.frame_current, 100)
    result = {
        "triangles": sent.triangles,
        "blender": blender_count(scene, depsgraph),
        "names": sorted(
            [o["name"] for o in sent.objects]
            + [
                f"{a['name']}[{i}]"
                for a in sent.instances
                for i in a.get("ids", range(len(a["matrices"])))
            ]
        ),
        "version": list(bpy.app.version),
    }
    Path(a.out).write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
