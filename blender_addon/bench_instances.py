"""Reading 100,000 geometry-node instances per frame: ``depsgraph.object_instances`` against
Blender 4.3+'s ``bpy.types.GeometrySet`` (issue 37).

    .venv/bin/python blender_addon/bench_instances.py                   # a bpy module
    blender -b --factory-startup -P blender_addon/bench_instances.py    # Debian's Blender 3.4
    ... -- --count 100000 --repeat 5

Two scenes: a geometry-nodes modifier scatters COUNT instances (random position, rotation and
scale) of (a) one mesh (Object Info) and (b) three meshes (Collection Info, "Pick Instance").
Each method is timed on the evaluated frame (median of REPEAT, seconds per frame); the arrays
it ends with are counted in bytes. docs/instances_export.md has the results.
"""

from __future__ import annotations

import argparse
import itertools
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

if "bpy" not in sys.modules:
    os.environ.setdefault("HOME", tempfile.mkdtemp(prefix="antumbra-bench-home-"))

import bpy
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent / "antumbra" / "export"))
import instances as inst_mod  # the add-on's module, without the add-on's client

CUBE_V = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (0, 1)]
CUBE_F = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]


def _socket(tree, name: str, in_out: str, kind: str):
    if hasattr(tree, "interface"):  # Blender 4.0 and later
        tree.interface.new_socket(name, in_out=in_out, socket_type=kind)
    elif in_out == "INPUT":
        tree.inputs.new(kind, name)
    else:
        tree.outputs.new(kind, name)


def mesh_object(collection, name: str, vertices, faces, location=(0, 0, 0)):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], faces)
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    collection.objects.link(obj)
    return obj


def _random(tree, kind: str, low, high, seed: int):
    """A Random Value node of KIND and its output. Before Blender 5.3 it has sockets of every
    type under the same names, so the enabled ones of KIND's socket type are taken."""
    node = tree.nodes.new("FunctionNodeRandomValue")
    node.data_type = kind
    socket_type = {"FLOAT_VECTOR": "VECTOR", "FLOAT": "VALUE", "INT": "INT"}[kind]
    low_in, high_in = (s for s in node.inputs if s.name in ("Min", "Max") and s.type == socket_type)
    low_in.default_value, high_in.default_value = low, high
    node.inputs["Seed"].default_value = seed
    return next(s for s in node.outputs if s.type == socket_type)


def meshes_from(source) -> bool:
    return isinstance(source, bpy.types.Collection)


def scatter(
    collection, name: str, count: int, source, seed: int = 0, size: float = 50.0, with_points=False
):
    """A one-vertex mesh object whose geometry-nodes modifier puts COUNT instances of SOURCE at
    random points, rotations and scales: an object (Object Info: one mesh) or a collection
    (Collection Info, separate children, one picked per point). WITH_POINTS outputs the point cloud
    too."""
    points = mesh_object(collection, name, [(0, 0, 0)], [])
    tree = bpy.data.node_groups.new(name, "GeometryNodeTree")
    _socket(tree, "Geometry", "INPUT", "NodeSocketGeometry")
    _socket(tree, "Geometry", "OUTPUT", "NodeSocketGeometry")
    link = tree.links.new
    cloud = tree.nodes.new("GeometryNodePoints")
    cloud.inputs["Count"].default_value = count
    link(_random(tree, "FLOAT_VECTOR", (-size, -size, 0), (size, size, size / 10), seed),
         cloud.inputs["Position"])  # fmt: skip
    on_points = tree.nodes.new("GeometryNodeInstanceOnPoints")
    link(cloud.outputs[0], on_points.inputs["Points"])
    link(_random(tree, "FLOAT_VECTOR", (0, 0, 0), (3.1, 3.1, 3.1), seed + 1),
         on_points.inputs["Rotation"])  # fmt: skip
    link(_random(tree, "FLOAT", 0.5, 1.5, seed + 2), on_points.inputs["Scale"])
    if isinstance(source, bpy.types.Collection):
        info = tree.nodes.new("GeometryNodeCollectionInfo")
        info.inputs["Collection"].default_value = source
        info.inputs["Separate Children"].default_value = True
        info.inputs["Reset Children"].default_value = True
        on_points.inputs["Pick Instance"].default_value = True
        pick = _random(tree, "INT", 0, len(source.objects) - 1, seed + 3)
        link(pick, on_points.inputs["Instance Index"])
    else:
        info = tree.nodes.new("GeometryNodeObjectInfo")
        info.inputs["Object"].default_value = source
    link(info.outputs[0 if meshes_from(source) else "Geometry"], on_points.inputs["Instance"])
    output = on_points.outputs[0]
    if with_points:
        join = tree.nodes.new("GeometryNodeJoinGeometry")
        link(cloud.outputs[0], join.inputs[0])
        link(on_points.outputs[0], join.inputs[0])
        output = join.outputs[0]
    link(output, tree.nodes.new("NodeGroupOutput").inputs[0])
    points.modifiers.new("Scatter", "NODES").node_group = tree
    return points


def library(name: str, meshes: int):
    """A collection (not in the scene) of MESHES cubes of different widths."""
    lib = bpy.data.collections.new(name)
    for i in range(meshes):
        vertices = [(x * (i + 1), y, z) for x, y, z in CUBE_V]
        mesh_object(lib, f"{name}{i}", vertices, CUBE_F)
    return lib


def scene_with(count: int, meshes: int):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    lib = library("Source", meshes)
    source = lib.objects[0] if meshes == 1 else lib
    obj = scatter(scene.collection, "Scatter", count, source)
    obj.location = (0.25, -1.5, 0.125)
    obj.rotation_euler = (0.1, 0.2, 0.3)
    return scene


# The methods: each takes the evaluated depsgraph and returns the arrays it read.


def loop_exporter(depsgraph):
    """Today's exporter loop body: object, original, hide flags, is_instance, parent,
    persistent_id and the matrix per instance, into numpy."""
    matrices, ids, objects = [], [], []
    for instance in depsgraph.object_instances:
        obj = instance.object
        original = obj.original
        if original.hide_render or (
            instance.is_instance and instance.parent and instance.parent.original.hide_render
        ):
            continue
        if obj.type != "MESH":
            continue
        objects.append(obj.data.as_pointer())
        ids.append(tuple(instance.persistent_id))
        matrices.append(np.array(instance.matrix_world, dtype=np.float32))
    return np.array(matrices), np.array(ids, dtype=np.int32), np.array(objects)


def loop_bare(depsgraph):
    """The floor of any loop: one step of the iterator, nothing read."""
    n = 0
    for _ in depsgraph.object_instances:
        n += 1
    return (np.empty(0),)


def loop_matrix_np(depsgraph):
    """The matrix only, one ``np.array`` per instance."""
    return (
        np.array([np.array(i.matrix_world, dtype=np.float32) for i in depsgraph.object_instances]),
    )


def loop_matrix_fromiter(depsgraph):
    """The matrix only, flattened by ``itertools`` into one ``np.fromiter`` (no per-instance
    array; ``object_instances`` is an iterator, so it has no ``foreach_get``)."""
    chain = itertools.chain.from_iterable
    rows = chain(i.matrix_world for i in depsgraph.object_instances)
    return (np.fromiter(chain(rows), dtype=np.float32).reshape(-1, 4, 4),)


def geometry_set_raw(depsgraph):
    """Blender 4.3+: the instancer's instance transforms and reference indices, two
    ``foreach_get`` calls, local to the instancer (no world matrices)."""
    out = []
    for obj in depsgraph.objects:
        if not any(m.type == "NODES" for m in obj.original.modifiers):
            continue
        geometry = bpy.types.GeometrySet.from_evaluated_object(obj)
        cloud = geometry.instances_pointcloud()
        n = len(cloud.points)
        transforms = np.empty(n * 16, dtype=np.float32)
        cloud.attributes["instance_transform"].data.foreach_get("value", transforms)
        references = np.empty(n, dtype=np.int32)
        cloud.attributes[".reference_index"].data.foreach_get("value", references)
        out += [transforms.reshape(n, 4, 4), references, geometry.instance_references()]
    return tuple(a for a in out if isinstance(a, np.ndarray))


def read_instances_auto(depsgraph):
    """The add-on's ``read_instances``: world matrices (float64) and ids grouped by mesh."""
    found = read_instances_auto.last = inst_mod.read_instances(depsgraph)
    return tuple(a for g in found.groups.values() for a in (g.matrices, g.ids))


def read_instances_loop(depsgraph):
    """``read_instances``' depsgraph route (its fallback), for the same arrays."""
    found = inst_mod.read_instances_loop(depsgraph)
    return tuple(a for g in found.groups.values() for a in (g.matrices, g.ids))


METHODS = [
    ("object_instances: exporter's body", loop_exporter),
    ("object_instances: nothing read", loop_bare),
    ("object_instances: matrix, np.array each", loop_matrix_np),
    ("object_instances: matrix, np.fromiter", loop_matrix_fromiter),
    ("read_instances, depsgraph route", read_instances_loop),
]
GEOMETRY_SET = [
    ("GeometrySet: foreach_get (local)", geometry_set_raw),
    ("read_instances, auto", read_instances_auto),
]


def main():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
    p = argparse.ArgumentParser()
    p.add_argument("--count", type=int, default=100_000)
    p.add_argument("--repeat", type=int, default=5)
    a = p.parse_args(argv)
    methods = METHODS + (GEOMETRY_SET if hasattr(bpy.types, "GeometrySet") else [])
    print(f"Blender {bpy.app.version_string}, numpy {np.__version__}, {a.count} instances")
    for meshes in (1, 3):
        scene = scene_with(a.count, meshes)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        print(f"-- {meshes} mesh(es)")
        for label, method in methods:
            times, arrays = [], ()
            for _ in range(a.repeat):
                start = time.perf_counter()
                arrays = method(depsgraph)
                times.append(time.perf_counter() - start)
            size = sum(x.nbytes for x in arrays)
            print(
                f"{label:42} {statistics.median(times) * 1e3:9.1f} ms/frame "
                f"(min {min(times) * 1e3:.1f})  {size / 1e6:6.2f} MB"
            )
        if hasattr(read_instances_auto, "last"):
            found = read_instances_auto.last
            print(f"read_instances route: {found.route} {found.reason}; {found.count()} placements")
            del read_instances_auto.last, found  # its geometry sets, before Blender frees
        del scene


if __name__ == "__main__":
    main()
