"""Builds scenes of instances and compares the add-on's ``read_instances`` (the fastest route of
this Blender) and its depsgraph loop with the exporter's ``depsgraph.object_instances`` walk.
Runs in Debian's Blender (``blender -b -P instances_compare.py -- ARGS``) and with the bpy
module (``python instances_compare.py -- ARGS``).

Writes OUT (JSON): ``geometry_set_api`` (this Blender has ``bpy.types.GeometrySet``) and per
scene: ``route`` (and ``reason``) taken, ``placements``, ``groups``,
``same`` (both routes give the groups of a plain per-instance walk, matrices equal to the bit,
same ids), ``diff`` and ``loop_diff`` (what differed), ``exporter`` (the placements the exporter
sends) beside ``loop_shown`` (the loop's placements the exporter would send).
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import json
import sys
from pathlib import Path

import bpy
import numpy as np


def args():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--addon", required=True, help="the add-on's source folder (blender_addon)")
    p.add_argument("--out", required=True)
    return p.parse_args(argv)


def load(folder: Path):
    init = folder / "antumbra" / "__init__.py"
    spec = importlib.util.spec_from_file_location(
        "antumbra_addon", init, submodule_search_locations=[str(init.parent)]
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules["antumbra_addon"] = module
    spec.loader.exec_module(module)
    sys.path.insert(0, str(folder))
    import bench_instances
    from antumbra_addon.export import exporter, instances

    return instances, exporter, bench_instances, module.client_loader.load()


def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, -40.0, 20.0)
    camera.rotation_euler = (1.1, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    return scene


def linked_duplicates(b):
    scene = empty_scene()
    first = b.mesh_object(scene.collection, "Cube", b.CUBE_V, b.CUBE_F, (1, 2, 3))
    for i in range(3):
        twin = bpy.data.objects.new(f"Twin{i}", first.data)
        twin.location = (i, -i, 0.5 * i)
        twin.rotation_euler = (0.1 * i, 0.2, 0.3)
        scene.collection.objects.link(twin)
    b.mesh_object(scene.collection, "Other", b.CUBE_V, b.CUBE_F[:3], (0, 5, 0))
    return scene


def collection_instances(b):
    """Empties instancing a collection with an offset, some of whose objects are hidden (from
    render, which the exporter skips, or from the viewport, which Blender skips but counts),
    one in a child collection hidden from the viewport."""
    scene = empty_scene()
    lib = b.library("Lib", 5)
    lib.instance_offset = (0.5, 0.25, 0)
    lib.objects[1].hide_render = True
    lib.objects[2].hide_viewport = True
    child = bpy.data.collections.new("Child")
    lib.children.link(child)
    b.mesh_object(child, "InChild", b.CUBE_V, b.CUBE_F, (0, 3, 0))
    hidden_child = bpy.data.collections.new("HiddenChild")
    hidden_child.hide_viewport = True
    lib.children.link(hidden_child)
    b.mesh_object(hidden_child, "InHiddenChild", b.CUBE_V, b.CUBE_F, (0, 4, 0))
    b.mesh_object(child, "AfterHidden", b.CUBE_V, b.CUBE_F, (0, 5, 0))
    for i in range(4):
        empty = bpy.data.objects.new(f"Put{i}", None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = lib
        empty.location = (3 * i, 0, 0)
        empty.rotation_euler = (0, 0, 0.4 * i)
        scene.collection.objects.link(empty)
    b.mesh_object(scene.collection, "Ground", b.CUBE_V, b.CUBE_F, (0, 0, -2))
    return scene


def distribute(b, collection, name: str, lib):
    """A quad whose node tree scatters the meshes of LIB on it with Distribute Points on
    Faces, which gives the instances an ``id`` attribute (their persistent ids)."""
    ground = b.mesh_object(
        collection, name, [(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)], [(0, 1, 2, 3)]
    )
    tree = bpy.data.node_groups.new(name, "GeometryNodeTree")
    b._socket(tree, "Geometry", "INPUT", "NodeSocketGeometry")
    b._socket(tree, "Geometry", "OUTPUT", "NodeSocketGeometry")
    points = tree.nodes.new("GeometryNodeDistributePointsOnFaces")
    points.inputs["Density"].default_value = 20.0
    on_points = tree.nodes.new("GeometryNodeInstanceOnPoints")
    on_points.inputs["Pick Instance"].default_value = True
    info = tree.nodes.new("GeometryNodeCollectionInfo")
    info.inputs["Collection"].default_value = lib
    info.inputs["Separate Children"].default_value = True
    link = tree.links.new
    link(tree.nodes.new("NodeGroupInput").outputs[0], points.inputs[0])
    link(points.outputs[0], on_points.inputs["Points"])
    link(info.outputs[0], on_points.inputs["Instance"])
    link(on_points.outputs[0], tree.nodes.new("NodeGroupOutput").inputs[0])
    ground.modifiers.new(name, "NODES").node_group = tree
    return ground


def scatter_three(b):
    scene = empty_scene()
    lib = b.library("Lib", 3)
    distribute(b, scene.collection, "Distributed", lib).location = (0, 0, -3)
    obj = b.scatter(scene.collection, "Scatter", 3000, lib, seed=3, size=20.0)
    obj.location = (0.3, -1.7, 0.2)
    obj.rotation_euler = (0.2, 0.1, 0.7)
    obj.scale = (1.1, 0.9, 1.2)
    one = b.scatter(scene.collection, "ScatterOne", 1000, lib.objects[1], seed=9, size=10.0)
    one.location = (5, 5, 0)
    return scene


def nested(b):
    """A collection holding geometry-nodes scatters (one hidden from render), instanced by
    three empties (one hidden from render)."""
    scene = empty_scene()
    lib = b.library("Lib", 2)
    inner = bpy.data.collections.new("Inner")
    b.scatter(inner, "InnerScatter", 500, lib, seed=4, size=5.0)
    b.scatter(inner, "HiddenScatter", 50, lib, seed=5, size=5.0).hide_render = True
    b.scatter(inner, "Beside", 40, lib.objects[0], seed=6, size=2.0).location = (0, 8, 0)
    for i in range(3):
        empty = bpy.data.objects.new(f"Put{i}", None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = inner
        empty.location = (12 * i, 0, 0)
        empty.rotation_euler = (0.1 * i, 0, 0.3 * i)
        empty.hide_render = i == 2
        scene.collection.objects.link(empty)
    return scene


def visibility_flags(b):
    scene = empty_scene()
    lib = b.library("Lib", 3)
    lib.objects[0].visible_shadow = False
    lib.objects[1].visible_camera = False
    lib.objects[2].hide_render = True
    scatter = b.scatter(scene.collection, "Scatter", 2000, lib, seed=7, size=15.0)
    scatter.visible_camera = False
    single = b.scatter(scene.collection, "Single", 300, lib.objects[0], seed=8, size=5.0)
    single.visible_shadow = False
    hidden = b.scatter(scene.collection, "Hidden", 300, lib.objects[0], seed=2, size=5.0)
    hidden.hide_render = True
    ghost = b.mesh_object(scene.collection, "Ghost", b.CUBE_V, b.CUBE_F, (0, 0, 4))
    ghost.visible_camera = ghost.visible_shadow = False
    return scene


def beside_points(b):
    """A scatter that outputs its point cloud beside the instances."""
    scene = empty_scene()
    b.scatter(
        scene.collection, "Both", 700, b.library("Lib", 3), seed=6, size=8.0, with_points=True
    )
    return scene


SCENES = {
    "linked_duplicates": linked_duplicates,
    "collection_instances": collection_instances,
    "scatter_three": scatter_three,
    "nested": nested,
    "visibility_flags": visibility_flags,
    "beside_points": beside_points,
}


def mesh_digest(mesh) -> str:
    """The mesh's content, so groups of the two routes (whose evaluated meshes may be different
    copies) are matched as the exporter's content hash would match them."""
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    loops = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", loops)
    return hashlib.sha1(co.tobytes() + loops.tobytes()).hexdigest()[:12]


def _order(matrices: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Rows by persistent id, then by matrix (objects placed as themselves all have id 0)."""
    flat = matrices.reshape(len(matrices), 16)
    return np.lexsort([*flat.T[::-1], *ids.T[::-1]])


def canonical(found) -> dict:
    """Groups by mesh content and ray visibility (meshes of equal content merged, as the
    exporter's content hash merges them), rows in persistent-id order."""
    parts: dict[tuple, list] = {}
    for key, group in found.groups.items():
        name = (mesh_digest(group.mesh), key[1], key[2])
        parts.setdefault(name, []).append((group.matrices, group.ids, group.is_instance))
    out = {}
    for name, found_parts in parts.items():
        matrices, ids, flags = (np.concatenate(x) for x in zip(*found_parts, strict=True))
        order = _order(matrices, ids)
        out[name] = (matrices[order], ids[order], flags[order])
    return out


def reference(depsgraph) -> dict:
    """The exporter's walk, written out plainly: every field read per instance, no caching."""
    rows: dict[tuple, list] = {}
    for instance in depsgraph.object_instances:
        obj = instance.object
        original = obj.original
        hidden = original.hide_render or (
            instance.is_instance and instance.parent and instance.parent.original.hide_render
        )
        if hidden or obj.type != "MESH":
            continue
        name = (mesh_digest(obj.data), bool(original.visible_camera))
        name += (bool(original.visible_shadow),)
        ids = tuple(instance.persistent_id) if instance.is_instance else (0,) * 8
        matrix = np.array([list(row) for row in instance.matrix_world], dtype=np.float32)
        rows.setdefault(name, []).append((matrix, ids, bool(instance.is_instance)))
    out = {}
    for name, found in rows.items():
        matrices = np.array([r[0] for r in found], dtype=np.float64)
        ids = np.array([r[1] for r in found], dtype=np.int32)
        flags = np.array([r[2] for r in found], dtype=bool)
        order = _order(matrices, ids)
        out[name] = (matrices[order], ids[order], flags[order])
    return out


def compare(found, expected: dict) -> list[str]:
    a, b = canonical(found), expected
    diff = [f"only in read_instances: {k}" for k in a.keys() - b.keys()]
    diff += [f"only in the loop: {k}" for k in b.keys() - a.keys()]
    for key in a.keys() & b.keys():
        for what, x, y in zip(("matrices", "ids", "is_instance"), a[key], b[key], strict=True):
            if x.shape != y.shape or not np.array_equal(x, y):
                diff.append(f"{key}: {what} differ ({x.shape} against {y.shape})")
        if a[key][0].dtype != np.float64 or np.any(a[key][0] != a[key][0].astype(np.float32)):
            diff.append(f"{key}: matrices are not float32 values in float64")
    return diff


def main():
    a = args()
    instances, exporter, bench, client = load(Path(a.addon))
    result = {"geometry_set_api": hasattr(bpy.types, "GeometrySet"), "scenes": {}}
    for name, build in SCENES.items():
        scene = build(bench)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        fast = instances.read_instances(depsgraph)
        loop = instances.read_instances_loop(depsgraph)
        expected = reference(depsgraph)
        sent = exporter.Exporter(client).frame(depsgraph, scene, scene.frame_current, 100)
        shown = sum(
            len(g.matrices)
            for g in loop.groups.values()
            if (g.visible_camera or g.visible_shadow) and len(g.mesh.polygons)
        )
        result["scenes"][name] = entry = {
            "route": fast.route,
            "reason": fast.reason,
            "placements": fast.count(),
            "groups": len(fast.groups),
            "diff": compare(fast, expected),
            "loop_diff": compare(loop, expected),
            "exporter": sent.placements(),
            "loop_shown": shown,
        }
        entry["same"] = not entry["diff"] and not entry["loop_diff"]
    Path(a.out).write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
