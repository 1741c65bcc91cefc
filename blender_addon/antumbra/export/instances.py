"""The frame's mesh instances grouped by source mesh: one (N, 4, 4) float64 array of world
matrices and one (N, 8) int32 array of persistent ids per group, without a Python step per
instance where Blender allows it.

Two routes give the same instances and bit-for-bit the same matrices:

- ``geometry_set`` (Blender 4.3 and later, ``bpy.types.GeometrySet``): one step per object of
  the view layer and per object of an instanced collection; a geometry-nodes instancer's
  transforms and reference indices are read with ``foreach_get`` and multiplied by the
  instancer's matrix in numpy, in float32 and in the order Blender's ``mul_m4_m4m4`` adds
  (pairwise), so the product is Blender's own to the bit.
- ``depsgraph`` (every Blender): the ``depsgraph.object_instances`` loop, the exporter's
  reference. Taken as a whole whenever the scene holds something the first route does not read
  yet (collections instanced inside instanced collections or by node trees, vertex/face
  instancing, particles, curve/text/surface/metaball objects, node-tree geometry holding
  instances itself, instancers outputting other components beside instances, non-unique ``id``
  attributes), so the result is never a mix of the two.

The exporter sends what ``read_instances`` finds: each group's objects placed as themselves as
objects, its instances as one instance array (protocol 4). See docs/instances_export.md for the
measurements.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

#: The depsgraph's "no index" in an instance's persistent id.
NO_INDEX = 0x7FFFFFFF
#: Length of ``DepsgraphObjectInstance.persistent_id`` (Blender's MAX_DUPLI_RECUR).
ID_LENGTH = 8
#: Object types with no geometry of their own and no instances to list.
_NO_GEOMETRY = {"EMPTY", "LIGHT", "CAMERA", "ARMATURE", "LATTICE", "SPEAKER", "LIGHT_PROBE"}
_NO_GEOMETRY |= {"LIGHTPROBE"}
_NOT_INSTANCED = (0,) * ID_LENGTH
#: Components a mesh object's evaluated geometry may carry besides its mesh and instances.
_OTHER_COMPONENTS = ("volume", "curves", "pointcloud", "grease_pencil")


@dataclass
class InstanceGroup:
    """Every placement of one evaluated mesh with one pair of ray-visibility flags."""

    #: The evaluated mesh to read (valid while the depsgraph and the ``Instances`` live).
    mesh: object
    #: The first original object found with this mesh and flags (for a geometry-nodes
    #: instance of geometry, the instancer, as in the depsgraph loop); linked duplicates share
    #: a group.
    source: object
    visible_camera: bool
    visible_shadow: bool
    #: World matrices (N, 4, 4) float64, exactly Blender's float32 values.
    matrices: np.ndarray
    #: Persistent ids (N, 8) int32 as ``DepsgraphObjectInstance.persistent_id``; all zero for
    #: an object placed as itself.
    ids: np.ndarray
    #: True for placements through instancing (``is_instance``), per row.
    is_instance: np.ndarray
    #: Who placed the rows, run-length: (rows, parent name, object name, parent is the object
    #: itself), so a row's name is made only where one is needed (see ``name_of``).
    labels: list[tuple[int, str, str, bool]] = field(default_factory=list)

    def label_of(self, row: int) -> tuple[str, str, bool]:
        start = 0
        for count, parent, name, itself in self.labels:
            if row < start + count:
                return parent, name, itself
            start += count
        raise IndexError(f"row {row} of a group of {start}")

    def as_itself(self) -> np.ndarray:
        """Per row: placed as itself (not through instancing, or the evaluated mesh of a text,
        curve, surface or metaball object placed by that object)."""
        itself = np.repeat([label[3] for label in self.labels], [n for n, *_ in self.labels])
        first_only = (self.ids[:, 0] == 0) & (self.ids[:, 1:] == NO_INDEX).all(axis=1)
        return ~self.is_instance | (itself & first_only)

    def name_of(self, row: int) -> str:
        return placement_name(*self.label_of(row), self.ids[row], bool(self.is_instance[row]))


def placement_name(parent: str, name: str, itself: bool, ids, is_instance: bool) -> str:
    """A placement's object name as the exporter has always named them: the object's own
    name, or ``parent/object[ids]`` for an instance (the parent's name for the evaluated mesh
    of a text, curve, surface or metaball object, placed by itself)."""
    if not is_instance:
        return name
    ids = [int(i) for i in ids if i != NO_INDEX]
    if ids == [0] and itself:
        return parent
    return f"{parent}/{name}[{'.'.join(map(str, ids))}]"


@dataclass
class Instances:
    """``read_instances``'s answer: groups keyed by (mesh pointer, visible_camera,
    visible_shadow), as the exporter keys evaluated meshes within a frame by pointer."""

    groups: dict[tuple[int, bool, bool], InstanceGroup]
    #: "geometry_set" or "depsgraph".
    route: str
    #: The lights shown: (name as the exporter names placements, evaluated light object,
    #: world matrix as rows).
    lights: list = field(default_factory=list)
    #: Why the depsgraph route was taken, when it was.
    reason: str = ""
    #: Geometry sets whose meshes the groups point into; freed with this object.
    keep: list = field(default_factory=list)

    def count(self) -> int:
        return sum(len(g.matrices) for g in self.groups.values())


class _Unsupported(Exception):
    """Something the geometry-set route does not read: the depsgraph route takes the frame."""


def _visibility(original) -> tuple[bool, bool]:
    # Cycles' ray visibility (Object Properties > Visibility), as the exporter reads it.
    return bool(getattr(original, "visible_camera", True)), bool(
        getattr(original, "visible_shadow", True)
    )


def _mul(parent: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``parent @ local`` for a (4, 4) float32 matrix and local matrices given as Blender
    stores them, (N, 4, 4) float32 columns first. Summed as Blender's SSE ``mul_m4_m4m4``,
    (p0 + p1) + (p2 + p3) in float32, so every bit agrees with the depsgraph's."""
    out = np.empty(columns.shape, dtype=np.float32)
    a = np.empty(columns.shape[:2], dtype=np.float32)
    b = np.empty_like(a)
    for i in range(4):
        row = out[:, i, :]
        # Row k of the local matrices is column k of Blender's layout.
        np.multiply(columns[:, :, 0], parent[i, 0], out=row)
        np.multiply(columns[:, :, 1], parent[i, 1], out=a)
        row += a
        np.multiply(columns[:, :, 2], parent[i, 2], out=a)
        np.multiply(columns[:, :, 3], parent[i, 3], out=b)
        a += b
        row += a
    return out


class _Collector:
    def __init__(self):
        self.parts: dict[tuple, tuple[object, object, list, list, list, list]] = {}
        self.lights: list = []

    def add(self, mesh, source, matrices, ids, is_instance, label: tuple[str, str, bool]):
        camera, shadow = _visibility(source)
        key = (mesh.as_pointer(), camera, shadow)
        part = self.parts.setdefault(key, (mesh, source, [], [], [], []))
        part[2].append(matrices)
        part[3].append(ids)
        part[4].append(np.full(len(matrices), is_instance, dtype=bool))
        part[5].append((len(matrices), *label))

    def groups(self) -> dict:
        out = {}
        for key, (mesh, source, matrices, ids, flags, labels) in self.parts.items():
            out[key] = InstanceGroup(
                mesh=mesh,
                source=source,
                visible_camera=key[1],
                visible_shadow=key[2],
                matrices=np.concatenate(matrices).astype(np.float64),
                ids=np.concatenate(ids),
                is_instance=np.concatenate(flags),
                labels=labels,
            )
        return out


def _ids(*columns) -> np.ndarray:
    """Persistent ids from their leading columns (arrays or one value each)."""
    n = max(len(c) for c in columns if isinstance(c, np.ndarray))
    ids = np.full((n, ID_LENGTH), NO_INDEX, dtype=np.int32)
    for i, column in enumerate(columns):
        ids[:, i] = column
    return ids


def _read_attribute(pointcloud, name: str, dtype, width: int) -> np.ndarray | None:
    attribute = pointcloud.attributes.get(name)
    if attribute is None:
        return None
    values = np.empty(len(pointcloud.points) * width, dtype=dtype)
    key = "vector" if attribute.data_type == "FLOAT_VECTOR" else "value"
    attribute.data.foreach_get(key, values)
    return values


def _hidden(original) -> bool:
    return bool(original.hide_render)


def _geometry_nodes_instances(
    bpy, obj, collector: _Collector, keep: list, space=None, outer: tuple = (), parent=None
) -> None:
    """The instances a geometry-nodes modifier put on OBJ (evaluated), in bulk. Inside a
    collection instance, SPACE is the collection's matrix (applied last, as Blender's
    ``space_mat``) and OUTER the collection's ids, appended to each persistent id."""
    geometry = bpy.types.GeometrySet.from_evaluated_object(obj)
    cloud = geometry.instances_pointcloud()
    if cloud is None or len(cloud.points) == 0:
        return
    if any(getattr(geometry, kind, None) is not None for kind in _OTHER_COMPONENTS):
        # Blender then lists those first and numbers the instances one level deeper.
        raise _Unsupported(f"'{obj.name}': instances beside non-mesh geometry")
    keep.append(geometry)
    n = len(cloud.points)
    transforms = _read_attribute(cloud, "instance_transform", np.float32, 16)
    references = _read_attribute(cloud, ".reference_index", np.int32, 1)
    if transforms is None or references is None:
        raise _Unsupported(f"'{obj.name}': instances without transforms or references")
    stable = _read_attribute(cloud, "id", np.int32, 1)
    if stable is None:
        stable = np.arange(n, dtype=np.int32)
    elif len(np.unique(stable)) != n:
        raise _Unsupported(f"'{obj.name}': an id attribute with repeated values")
    world = _mul(np.array(obj.matrix_world, dtype=np.float32), transforms.reshape(n, 4, 4))
    if space is not None:
        world = _mul(space, world.transpose(0, 2, 1))
    instancer = obj.original
    # The depsgraph names an instance's parent by the outermost instancer.
    parent = obj.name if parent is None else parent
    references_list = geometry.instance_references()
    keep.append(references_list)  # each GeometrySet frees its mesh with itself
    for index, reference in enumerate(references_list):
        rows = np.flatnonzero(references == index)
        if len(rows) == 0 or reference is None:
            continue
        if isinstance(reference, bpy.types.Object):
            if not _plain_mesh(reference):
                raise _Unsupported(f"'{obj.name}' instances object '{reference.name}'")
            if _hidden(reference.original):
                continue
            ids = _ids(stable[rows], *outer)
            label = (parent, reference.name, False)
            collector.add(reference.data, reference.original, world[rows], ids, True, label)
        elif isinstance(reference, bpy.types.GeometrySet):
            if reference.instances_pointcloud() is not None:
                raise _Unsupported(f"'{obj.name}' instances nested instances")
            if reference.mesh is not None and not _hidden(instancer):
                ids = _ids(0, stable[rows], *outer)
                label = (parent, obj.name, False)
                collector.add(reference.mesh, instancer, world[rows], ids, True, label)
        else:
            raise _Unsupported(f"'{obj.name}' instances a {type(reference).__name__}")


def _plain_mesh(obj) -> bool:
    """A mesh object that puts nothing but its own mesh into the frame."""
    original = obj.original
    return (
        obj.type == "MESH"
        and original.instance_type == "NONE"
        and not original.particle_systems
        and not any(m.type == "NODES" for m in original.modifiers)
    )


def _collection_objects(collection, mode: str):
    """(index, object) for each object a collection instance shows, indexed as Blender's
    collection object cache counts them (the collection's own objects, then its children's,
    each object once) and shown as that cache's flags and the object's say."""
    hide = "hide_viewport" if mode == "VIEWPORT" else "hide_render"
    order: dict[int, list] = {}

    def fill(c, hidden: bool):
        hidden = hidden or getattr(c, hide)
        for obj in c.objects:
            entry = order.setdefault(obj.as_pointer(), [obj, False])
            entry[1] = entry[1] or not hidden
        for child in c.children:
            fill(child, hidden)

    fill(collection, False)
    for index, (obj, enabled) in enumerate(order.values()):
        if enabled and not getattr(obj, hide):
            yield index, obj


def _collection_instance(bpy, depsgraph, empty, collector: _Collector, keep: list) -> None:
    """The placements of an empty instancing a collection: ``C = world @ translate(-offset)``,
    each shown object at ``C @ its world`` (id ``[n]``), its node-tree instances at
    ``C @ (its world @ transform)`` (ids ``[id, n]``, ``[0, id, n]``)."""
    collection = empty.original.instance_collection
    if collection is None:
        return
    offset = np.identity(4, dtype=np.float32)
    offset[:3, 3] = -np.array(collection.instance_offset, dtype=np.float32)
    space = _mul(np.array(empty.matrix_world, dtype=np.float32), offset.T[None])[0]
    hidden = _hidden(empty.original)
    for index, original in _collection_objects(collection, depsgraph.mode):
        if original == empty.original:
            continue
        obj = original.evaluated_get(depsgraph)
        if obj.type == "LIGHT" and original.instance_type == "NONE":
            if not (hidden or _hidden(original)):
                world = _mul(space, np.array(obj.matrix_world, dtype=np.float32).T[None])[0]
                name = f"{empty.name}/{obj.name}[{index}]"
                collector.lights.append((name, obj, world.astype(np.float64)))
            continue
        if obj.type in _NO_GEOMETRY and original.instance_type == "NONE":
            continue
        if obj.type != "MESH" or original.instance_type != "NONE" or original.particle_systems:
            raise _Unsupported(f"'{empty.name}' instances '{obj.name}' ({obj.type})")
        if not (hidden or _hidden(original)):
            world = np.array(obj.matrix_world, dtype=np.float32)
            placed = _mul(space, world.T[None])
            label = (empty.name, obj.name, False)
            collector.add(obj.data, original, placed, _ids(np.array([index])), True, label)
        if any(m.type == "NODES" for m in original.modifiers):
            # The instances' own hide flags are checked where they are read; the empty's here.
            if not hidden:
                _geometry_nodes_instances(
                    bpy, obj, collector, keep, space, (index,), parent=empty.name
                )


def _geometry_set_route(bpy, depsgraph) -> Instances:
    collector, keep = _Collector(), []
    for obj in depsgraph.objects:
        original = obj.original
        if obj.type == "EMPTY" and original.instance_type == "COLLECTION":
            _collection_instance(bpy, depsgraph, obj, collector, keep)
            continue
        if obj.type == "LIGHT" and original.instance_type == "NONE":
            if not _hidden(original):
                world = np.array(obj.matrix_world, dtype=np.float32).astype(np.float64)
                collector.lights.append((obj.name, obj, world))
            continue
        if obj.type in _NO_GEOMETRY and original.instance_type == "NONE":
            continue
        if obj.type != "MESH" or original.instance_type != "NONE" or original.particle_systems:
            raise _Unsupported(f"'{obj.name}' ({obj.type}, instancing {original.instance_type})")
        if _hidden(original):
            continue
        identity = np.zeros((1, ID_LENGTH), dtype=np.int32)
        world = np.array(obj.matrix_world, dtype=np.float32)[None]
        collector.add(obj.data, original, world, identity, False, ("", obj.name, False))
        if any(m.type == "NODES" for m in original.modifiers):
            _geometry_nodes_instances(bpy, obj, collector, keep)
    found = Instances(collector.groups(), "geometry_set", keep=keep)
    found.lights = collector.lights
    return found


def _part(parts: dict, obj, parent) -> tuple | None:
    """The group an instance of OBJ placed by PARENT (None: placed as itself) joins ("LIGHT"
    for a light) with its label, or None for one the exporter leaves out (hidden from render,
    neither a mesh nor a light)."""
    original = obj.original
    if original.hide_render or (parent is not None and parent.original.hide_render):
        return None
    if obj.type not in {"MESH", "LIGHT"}:
        return None
    label = (parent.name if parent else "", obj.name)
    label += (parent is not None and parent.original == original,)
    if obj.type == "LIGHT":
        return "LIGHT", label
    camera, shadow = _visibility(original)
    key = (obj.data.as_pointer(), camera, shadow)
    if key not in parts:
        parts[key] = (obj.data, original, [], [], [], [])
    return parts[key], label


def read_instances_loop(depsgraph) -> Instances:
    """The reference: one step of ``depsgraph.object_instances`` per instance, keeping what the
    exporter keeps (mesh objects and lights not hidden from render; other types left out).
    Matrices and ids stay Python objects until one ``np.fromiter`` per group at the end."""
    parts: dict[tuple, tuple] = {}
    lights: list = []
    # What an (object, mesh, parent) triple contributes, decided once: its group or None. The
    # attribute reads behind it cost more than the matrix.
    decided: dict[tuple[int, int, int], tuple | None] = {}
    for instance in depsgraph.object_instances:
        obj = instance.object
        data = obj.data
        parent = instance.parent
        triple = (
            obj.as_pointer(),
            data.as_pointer() if data is not None else 0,
            parent.as_pointer() if parent is not None else 0,
        )
        decision = decided.get(triple, False)
        if decision is False:
            decision = decided[triple] = _part(parts, obj, parent)
        if decision is None:
            continue
        part, label = decision
        if part == "LIGHT":
            # Lights are few: named and kept here as the exporter names placements.
            name = placement_name(*label, instance.persistent_id, instance.is_instance)
            matrix = np.array(instance.matrix_world, dtype=np.float32).astype(np.float64)
            lights.append((name, obj, matrix))
            continue
        # Both read through the iterator's current instance: copied before it steps on.
        part[2].append(instance.matrix_world.copy())
        if instance.is_instance:
            part[3].append(tuple(instance.persistent_id))
            part[4].append(True)
        else:
            part[3].append(_NOT_INSTANCED)
            part[4].append(False)
        part[5].append(label)
    chain = itertools.chain.from_iterable
    groups = {}
    for key, (mesh, source, matrices, ids, flags, labels) in parts.items():
        n = len(matrices)
        groups[key] = InstanceGroup(
            mesh=mesh,
            source=source,
            visible_camera=key[1],
            visible_shadow=key[2],
            matrices=np.fromiter(chain(chain(matrices)), np.float32, 16 * n)
            .reshape(n, 4, 4)
            .astype(np.float64),
            ids=np.fromiter(chain(ids), np.int32, ID_LENGTH * n).reshape(n, ID_LENGTH),
            is_instance=np.array(flags, dtype=bool),
            labels=[(len(list(run)), *label) for label, run in itertools.groupby(labels)],
        )
    return Instances(groups, "depsgraph", lights=lights)


def read_instances(depsgraph, route: str = "auto") -> Instances:
    """Every mesh placement of the evaluated frame, grouped by source mesh and ray visibility.
    ``route``: "auto" (the geometry-set route where Blender has it and it reads the whole
    scene, the depsgraph loop otherwise), "geometry_set" (raises ``ValueError`` where it cannot)
    or "depsgraph"."""
    import bpy

    if route == "depsgraph":
        return read_instances_loop(depsgraph)
    if not hasattr(bpy.types, "GeometrySet"):
        if route == "geometry_set":
            raise ValueError(f"Blender {bpy.app.version_string} has no bpy.types.GeometrySet")
        loop = read_instances_loop(depsgraph)
        loop.reason = "no GeometrySet"
        return loop
    try:
        return _geometry_set_route(bpy, depsgraph)
    except _Unsupported as why:
        if route == "geometry_set":
            raise ValueError(str(why)) from None
        loop = read_instances_loop(depsgraph)
        loop.reason = str(why)
        return loop
