"""Exports a smooth sphere, a flat cube and a square with custom normals with the add-on's
exporter, with and without corner normals, and writes what it sent. Runs in Debian's Blender
(``blender -b -P export_normals.py -- ARGS``) and with the bpy module (``python ... -- ARGS``).

Writes OUT (JSON) per mesh: ``normals`` (rows sent, or null), ``radial`` (the sphere: largest
angle in degrees between a corner normal and its vertex's direction from the centre), ``lean``
(the square: its corner normals' mean), ``same_hash`` (the export without normals hashes as the
client's ``mesh_hash`` of positions and triangles alone).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import bpy
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from export_count import args, load_addon

LEAN = (0.6, 0.0, 0.8)


def build_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    bpy.ops.mesh.primitive_uv_sphere_add(location=(0, 0, 0))
    bpy.context.object.name = "Sphere"
    for polygon in bpy.context.object.data.polygons:
        polygon.use_smooth = True
    bpy.ops.mesh.primitive_cube_add(location=(4, 0, 0))
    bpy.context.object.name = "Cube"
    bpy.ops.mesh.primitive_plane_add(location=(-4, 0, 0))
    bpy.context.object.name = "Square"
    square = bpy.context.object.data
    if hasattr(square, "use_auto_smooth"):  # needed for custom normals before Blender 4.1
        square.use_auto_smooth = True
    square.normals_split_custom_set([LEAN] * len(square.loops))
    return scene


def main():
    a = args()
    client, export = load_addon(Path(a.addon))
    scene = build_scene()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    frame = scene.frame_current
    with_normals = export.Exporter(client, normals=True).frame(depsgraph, scene, frame, 100)
    plain = export.Exporter(client).frame(depsgraph, scene, frame, 100)
    result = {}
    for sent in (with_normals, plain):
        for obj in sent.objects:
            mesh = sent.meshes[obj["mesh_hash"]]
            key = obj["name"] + ("" if sent is with_normals else " plain")
            entry = {
                "triangles": len(mesh.triangles),
                "normals": None if mesh.normals is None else list(mesh.normals.shape),
                "same_hash": mesh.hash == client.mesh_hash(mesh.positions, mesh.triangles),
            }
            if mesh.normals is not None and obj["name"] == "Sphere":
                corners = mesh.positions[mesh.triangles.reshape(-1)]
                radial = corners / np.linalg.norm(corners, axis=1, keepdims=True)
                cos = np.clip((radial * mesh.normals).sum(axis=1), -1.0, 1.0)
                entry["radial"] = float(np.degrees(np.arccos(cos)).max())
            if mesh.normals is not None and obj["name"] == "Square":
                entry["lean"] = mesh.normals.mean(axis=0).round(4).tolist()
            result[key] = entry
    result["version"] = list(bpy.app.version)
    Path(a.out).write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
