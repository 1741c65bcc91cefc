"""Builds materials, images and meshes and reads them with the add-on's alpha export
(``materials``, ``alpha_image``, ``alpha_mesh``; issue 38). Runs in Debian's Blender
(``blender -b -P materials_check.py -- ARGS``) and with the bpy module
(``python materials_check.py -- ARGS``).

Writes OUT (JSON):

- ``blender``: the version; ``luminance``: the coefficients used;
- ``materials``: per material built here, ``material_alpha``'s contract, warnings and modes;
- ``images``: per image case, what ``alpha_image`` returned (size, values as lists, or the
  error message), with the PNG's own rows (top first) beside;
- ``meshes``: per mesh, ``mesh_alpha`` against a per-element reference walk of
  ``loop_triangles`` and the exporter's triangles;
- ``bad``: the messages of the bad inputs.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import struct
import sys
import zlib
from pathlib import Path

import bpy
import numpy as np


def args():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--addon", required=True, help="the add-on's source folder (blender_addon)")
    p.add_argument("--out", required=True)
    return p.parse_args(argv)


def load(addon: Path):
    """The add-on's export folder as a package of its own: the add-on's package is called
    ``antumbra`` like the client, and its ``__init__`` registers things this script needs not."""
    folder = addon / "antumbra" / "export"
    spec = importlib.util.spec_from_file_location(
        "alpha_export", folder / "__init__.py", submodule_search_locations=[str(folder)]
    )
    package = importlib.util.module_from_spec(spec)
    sys.modules["alpha_export"] = package
    spec.loader.exec_module(package)
    import alpha_export.alpha_image as alpha_image
    import alpha_export.alpha_mesh as alpha_mesh
    import alpha_export.exporter as exporter
    import alpha_export.materials as materials

    return materials, alpha_image, alpha_mesh, exporter


def load_object_alpha(addon: Path):
    """``alpha_object``, from the package ``load`` made."""
    load(addon)
    import alpha_export.alpha_object as alpha_object

    return alpha_object


# Images ------------------------------------------------------------------------------------

#: A 4 x 2 RGBA PNG, rows top first as PNG stores them: (r, g, b, a) bytes.
PNG_ROWS = [
    [(255, 255, 255, 255), (255, 0, 0, 255), (0, 0, 0, 0), (128, 128, 128, 0)],
    [(0, 0, 0, 0), (64, 64, 64, 51), (255, 255, 255, 102), (0, 255, 0, 255)],
]


def write_png(path: Path, rows) -> None:
    """An 8-bit RGBA PNG written by hand, so the row order is the file's, not Blender's."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    height, width = len(rows), len(rows[0])
    raw = b"".join(b"\0" + bytes(v for px in row for v in px) for row in rows)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(raw))
        + chunk(b"IEND", b"")
    )


def image_cases(ai, folder: Path) -> dict:
    png = folder / "rows.png"
    write_png(png, PNG_ROWS)
    image = bpy.data.images.load(str(png))
    image.name = "Rows"
    out = {"png_rows": PNG_ROWS}
    for channel in ("alpha", "luminance"):
        w, h, values = ai.alpha_image(image, channel)
        out[channel] = {"size": [w, h], "values": values.tolist(), "dtype": str(values.dtype)}
    image.colorspace_settings.name = "Non-Color"
    out["luminance_non_color"] = ai.alpha_image(image, "luminance")[2].tolist()
    image.colorspace_settings.name = "sRGB"
    image.pack()
    out["packed_alpha"] = ai.alpha_image(image, "alpha")[2].tolist()

    def error(make) -> str:
        try:
            ai.alpha_image(make(), "alpha", "object 'Card', material 'Leaf', node 'Leaf Image': ")
        except ai.AlphaError as e:
            return str(e)
        return "no error"

    def missing():
        img = bpy.data.images.new("Gone", 4, 4)
        img.source = "FILE"
        img.filepath = str(folder / "no_such_file.png")
        return img

    def empty():
        (folder / "empty.png").write_bytes(b"")
        img = bpy.data.images.new("Empty", 4, 4)
        img.source = "FILE"
        img.filepath = str(folder / "empty.png")
        return img

    out["missing"] = error(missing)
    out["empty"] = error(empty)
    return out


# Materials ---------------------------------------------------------------------------------


def new_material(name: str):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    principled = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    return material, tree, principled, output


def texture(tree, image, name="Leaf Image", interpolation="Linear", extension="REPEAT"):
    node = tree.nodes.new("ShaderNodeTexImage")
    node.name = name
    node.image = image
    node.interpolation = interpolation
    node.extension = extension
    return node


def math(tree, operation, a, b, clamp=False):
    """A Math node; A and B each an output socket to link or a number."""
    node = tree.nodes.new("ShaderNodeMath")
    node.operation = operation
    node.use_clamp = clamp
    for socket, value in zip(node.inputs[:2], (a, b), strict=True):
        if isinstance(value, float | int):
            socket.default_value = value
        else:
            tree.links.new(value, socket)
    return node


def mix_with_transparent(name, image, transparent_first: bool):
    material, tree, principled, output = new_material(name)
    tex = texture(tree, image)
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.name = "Mix"
    transparent = tree.nodes.new("ShaderNodeBsdfTransparent")
    first, second = (transparent, principled) if transparent_first else (principled, transparent)
    tree.links.new(tex.outputs["Alpha"], mix.inputs[0])
    tree.links.new(first.outputs[0], mix.inputs[1])
    tree.links.new(second.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], output.inputs["Surface"])
    return material


def build_materials(image) -> dict:
    """Materials by name; each name's expected result is in test_materials.py."""
    made = {"Empty slot": None}
    made["Default"] = new_material("Default")[0]

    m, tree, p, _ = new_material("Const")
    p.inputs["Alpha"].default_value = 0.5
    made["Const"] = m

    m, tree, p, _ = new_material("TexAlpha")
    tree.links.new(texture(tree, image).outputs["Alpha"], p.inputs["Alpha"])
    made["TexAlpha"] = m

    m, tree, p, _ = new_material("TexColor")
    tex = texture(tree, image, interpolation="Closest", extension="EXTEND")
    tree.links.new(tex.outputs["Color"], p.inputs["Alpha"])
    made["TexColor"] = m

    m, tree, p, _ = new_material("Clip")
    clip = math(tree, "GREATER_THAN", texture(tree, image).outputs["Alpha"], 0.5)
    tree.links.new(clip.outputs[0], p.inputs["Alpha"])
    made["Clip"] = m

    # x * 2 (clamped) -> reroute -> 1 - x -> x ** 2
    m, tree, p, _ = new_material("Chain")
    doubled = math(tree, "MULTIPLY", texture(tree, image).outputs["Alpha"], 2.0, clamp=True)
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(doubled.outputs[0], reroute.inputs[0])
    inverted = math(tree, "SUBTRACT", 1.0, reroute.outputs[0])
    squared = math(tree, "POWER", inverted.outputs[0], 2.0)
    tree.links.new(squared.outputs[0], p.inputs["Alpha"])
    made["Chain"] = m

    # Invert -> x + 0.1 -> 0.3 < x, then 0.8 - x, then x < 0.25
    m, tree, p, _ = new_material("Chain2")
    invert = tree.nodes.new("ShaderNodeInvert")
    tree.links.new(texture(tree, image).outputs["Alpha"], invert.inputs["Color"])
    added = math(tree, "ADD", invert.outputs[0], 0.1)
    above = math(tree, "LESS_THAN", 0.3, added.outputs[0])
    less = math(tree, "SUBTRACT", 0.8, above.outputs[0])
    below = math(tree, "LESS_THAN", less.outputs[0], 0.25)
    tree.links.new(below.outputs[0], p.inputs["Alpha"])
    made["Chain2"] = m

    made["MixFirst"] = mix_with_transparent("MixFirst", image, True)
    made["MixSecond"] = mix_with_transparent("MixSecond", image, False)

    m, tree, p, _ = new_material("UVNode")
    tex = texture(tree, image)
    uv = tree.nodes.new("ShaderNodeUVMap")
    uv.uv_map = "Leaves"
    tree.links.new(uv.outputs["UV"], tex.inputs["Vector"])
    tree.links.new(tex.outputs["Alpha"], p.inputs["Alpha"])
    made["UVNode"] = m

    m, tree, p, _ = new_material("TexCoordUV")
    tex = texture(tree, image)
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["UV"], tex.inputs["Vector"])
    tree.links.new(tex.outputs["Alpha"], p.inputs["Alpha"])
    made["TexCoordUV"] = m

    # Mix(0.5, Transparent, Principled with a textured alpha): half the texture's alpha.
    m, tree, p, out = new_material("Nested")
    tree.links.new(texture(tree, image).outputs["Alpha"], p.inputs["Alpha"])
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs[0].default_value = 0.5
    tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[1])
    tree.links.new(p.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    made["Nested"] = m

    # Glass of alpha 0.5 as a Mix(0.5, Transparent, Diffuse).
    m, tree, p, out = new_material("HalfMix")
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs[0].default_value = 0.5
    tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[1])
    tree.links.new(tree.nodes.new("ShaderNodeBsdfDiffuse").outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    made["HalfMix"] = m

    m, tree, p, out = new_material("TransparentOnly")
    tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], out.inputs["Surface"])
    made["TransparentOnly"] = m

    # Unsupported graphs: each names its node.
    m, tree, p, _ = new_material("Noise")
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.name = "Noise Texture"
    tree.links.new(noise.outputs["Fac"], p.inputs["Alpha"])
    made["Noise"] = m

    m, tree, p, _ = new_material("Mapped")
    tex = texture(tree, image)
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.name = "Mapping"
    tree.links.new(mapping.outputs[0], tex.inputs["Vector"])
    tree.links.new(tex.outputs["Alpha"], p.inputs["Alpha"])
    made["Mapped"] = m

    m, tree, p, _ = new_material("Generated")
    tex = texture(tree, image)
    coords = tree.nodes.new("ShaderNodeTexCoord")
    coords.name = "Texture Coordinate"
    tree.links.new(coords.outputs["Generated"], tex.inputs["Vector"])
    tree.links.new(tex.outputs["Alpha"], p.inputs["Alpha"])
    made["Generated"] = m

    m, tree, p, _ = new_material("Sine")
    sine = math(tree, "SINE", texture(tree, image).outputs["Alpha"], 0.0)
    sine.name = "Sine"
    tree.links.new(sine.outputs[0], p.inputs["Alpha"])
    made["Sine"] = m

    m, tree, p, _ = new_material("TwoTextures")
    both = math(
        tree,
        "MULTIPLY",
        texture(tree, image, "A").outputs["Alpha"],
        texture(tree, image, "B").outputs["Alpha"],
    )
    both.name = "Both"
    tree.links.new(both.outputs[0], p.inputs["Alpha"])
    made["TwoTextures"] = m

    m, tree, p, _ = new_material("Tiled")
    tiles = bpy.data.images.new("Tiles", 4, 4, alpha=True, tiled=True)
    tree.links.new(texture(tree, tiles, "UDIM").outputs["Alpha"], p.inputs["Alpha"])
    made["Tiled"] = m

    m, tree, p, _ = new_material("Box")
    tex = texture(tree, image, "Box Image")
    tex.projection = "BOX"
    tree.links.new(tex.outputs["Alpha"], p.inputs["Alpha"])
    made["Box"] = m

    m, tree, p, _ = new_material("Muted")
    muted = math(tree, "MULTIPLY", texture(tree, image).outputs["Alpha"], 2.0)
    muted.name = "Muted Math"
    muted.mute = True
    tree.links.new(muted.outputs[0], p.inputs["Alpha"])
    made["Muted"] = m

    m, tree, p, out = new_material("AddShader")
    add = tree.nodes.new("ShaderNodeAddShader")
    add.name = "Add Shader"
    tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], add.inputs[0])
    tree.links.new(p.outputs[0], add.inputs[1])
    tree.links.new(add.outputs[0], out.inputs["Surface"])
    made["AddShader"] = m
    return made


def material_cases(materials, image) -> dict:
    out = {}
    for name, material in build_materials(image).items():
        source = materials.material_alpha(material)
        out[name] = {
            "contract": source.contract(),
            "warnings": source.warnings,
            "modes": source.modes,
            "node": source.node,
            "image_info": source.image_info,
            "json": json.loads(json.dumps(source.contract())) == source.contract(),
        }
    return out


# Meshes ------------------------------------------------------------------------------------

#: A triangle, a convex quad, a dart whose diagonal 0-2 lies outside it (Blender splits it
#: along 1-3), a pentagon; and the slot each face uses (5 is past the last slot: clamped).
MIXED_VERTS = [
    (0, 0, 0), (1, 0, 0), (0, 1, 0),
    (2, 0, 0), (3, 0, 0), (3, 1, 0), (2, 1, 0),
    (4, 0, 0), (4.5, 0.4, 0), (5, 0, 0), (4.5, 1, 0),
    (6, 0, 0), (7, 0, 0), (7.5, 0.8, 0), (6.5, 1.5, 0), (5.8, 0.8, 0),
]  # fmt: skip
MIXED_FACES = [(0, 1, 2), (3, 4, 5, 6), (7, 8, 9, 10), (11, 12, 13, 14, 15)]
MIXED_SLOTS = [0, 1, 2, 5]
QUAD_VERTS = [
    (0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2.1, 0.1, 0), (2, 1, 0),
    (4, 0, 0), (4.5, 0.4, 0), (5, 0, 0), (4.5, 1, 0),
]  # fmt: skip
#: Three convex quads and a dart whose corner 1 is reflex (its 0-2 diagonal lies outside).
QUAD_FACES = [(0, 1, 2, 3), (1, 4, 5, 2), (2, 5, 6, 3), (7, 8, 9, 10)]


def make_mesh(name, verts, faces, slots=None):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    if slots is not None:
        mesh.polygons.foreach_set("material_index", slots)
    mesh.update()
    return mesh


def set_uvs(mesh, name, values: np.ndarray, active_render=False):
    layer = mesh.uv_layers.new(name=name)
    layer.data.foreach_set("uv", values.astype(np.float32).ravel())
    if active_render:
        layer.active_render = True
    return layer


def reference(mesh, obj, slots: int) -> dict:
    """mesh_alpha's expected output, walked per element in Python."""
    rows = {"material_index": [], "loops": [], "uv": {}}
    names = {layer.name: layer for layer in mesh.uv_layers}
    render = next(layer.name for layer in mesh.uv_layers if layer.active_render)
    for tri in mesh.loop_triangles:
        rows["material_index"].append(
            min(mesh.polygons[tri.polygon_index].material_index, slots - 1)
        )
        rows["loops"].append(list(tri.loops))
        for key, layer_name in (("", render), ("Leaves", "Leaves")):
            layer = names[layer_name]
            rows["uv"].setdefault(key, []).append([list(layer.data[i].uv) for i in tri.loops])
    return rows


def exporter_order(am, exporter, mesh) -> dict:
    """mesh_alpha's corners against the exporter's triangles (their vertices, row for row) and
    against ``loop_triangles`` (the same corners), and its faces against the loop triangles'."""
    positions = exporter._positions(mesh)
    triangles = exporter._triangles(mesh, None, positions)[0]
    corner_vert = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", corner_vert)
    loops, faces = am.triangle_loops(mesh)
    blender = [list(t.loops) for t in mesh.loop_triangles]
    return {
        "exporter": bool(np.array_equal(triangles, corner_vert[loops])),
        "loop_triangles": loops.tolist() == blender,
        "faces": faces.tolist() == [t.polygon_index for t in mesh.loop_triangles],
        "dtype": str(loops.dtype),
        "loops": loops.tolist(),
    }


def mesh_cases(materials, am, exporter, made) -> dict:
    scene = bpy.context.scene
    out = {}
    mesh = make_mesh("Mixed", MIXED_VERTS, MIXED_FACES, MIXED_SLOTS)
    corners = len(mesh.loops)
    # The render map differs from the first (active) one, so "" must mean active_render.
    set_uvs(mesh, "UVMap", np.zeros((corners, 2)))
    set_uvs(mesh, "Render", np.stack([np.arange(corners) * 0.01, np.full(corners, 0.5)], 1), True)
    corner_vert = np.empty(corners, dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", corner_vert)
    xy = np.array(MIXED_VERTS, dtype=np.float32)[corner_vert, :2]
    set_uvs(mesh, "Leaves", xy)
    obj = bpy.data.objects.new("Mixed", mesh)
    scene.collection.objects.link(obj)
    slot_materials = [made["Default"], made["TexAlpha"], made["UVNode"]]
    for material in slot_materials:
        obj.data.materials.append(material)
    sources = [(m.name, materials.material_alpha(m)) for m in slot_materials]
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    found = am.mesh_alpha(evaluated, evaluated.data, sources)
    out["mixed"] = {
        "material_index": found.material_index.tolist(),
        "dtype": [str(found.material_index.dtype), str(found.uvs[""].dtype)],
        "loops": found.loops.tolist(),
        "uv": {k: v.tolist() for k, v in found.uvs.items()},
        "warnings": found.warnings,
        "reference": reference(evaluated.data, evaluated, len(slot_materials)),
    }
    out["opaque_only"] = am.mesh_alpha(evaluated, evaluated.data, sources[:1]) is None

    # The exporter's triangle order, on each of its three routes.
    tris = [(0, 1, 2), (0, 2, 3), (1, 4, 5), (5, 6, 3)]
    out["exporter_order"] = {
        "mixed": exporter_order(am, exporter, mesh),
        "quads": exporter_order(am, exporter, make_mesh("Quads", QUAD_VERTS, QUAD_FACES)),
        "triangles": exporter_order(am, exporter, make_mesh("Tris", QUAD_VERTS, tris)),
    }

    # Bad input: a UV map named but absent, non-finite UVs.
    bad = make_mesh("Bad", QUAD_VERTS, QUAD_FACES)
    uv = np.tile([[0.25, 0.75]], (len(bad.loops), 1))
    uv[5] = (np.nan, 0.0)
    set_uvs(bad, "UVMap", uv, True)
    obj = bpy.data.objects.new("BadCard", bad)
    scene.collection.objects.link(obj)
    sources = [("UVNode", materials.material_alpha(made["UVNode"]))]
    sources.append(("TexAlpha", materials.material_alpha(made["TexAlpha"])))
    found = am.mesh_alpha(obj, bad, sources)
    out["bad"] = {
        "warnings": found.warnings,
        "absent_uvs": found.uvs["Leaves"].tolist(),
        "nan_uvs": found.uvs[""].tolist(),
        "loops": found.loops.tolist(),
    }
    return out


def driven_case(materials) -> dict:
    """A Principled Alpha driven by the frame (frame / 100), read from the evaluated object's
    slot at frame 30: the driver's value, 0.3."""
    mesh = make_mesh("Driven", QUAD_VERTS[:4], [(0, 1, 2, 3)])
    material, _, p, _ = new_material("Driven")
    mesh.materials.append(material)
    obj = bpy.data.objects.new("Driven", mesh)
    bpy.context.scene.collection.objects.link(obj)
    curve = p.inputs["Alpha"].driver_add("default_value")
    curve.driver.expression = "frame / 100"  # a simple expression: no Python auto-run needed
    bpy.context.scene.frame_set(30)
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    return materials.material_alpha(evaluated.material_slots[0].material).contract()


def object_case(alpha_object, made) -> dict:
    """object_alpha on a card with a textured, a missing-image and a constant slot, and on one
    whose only alpha slot's image is missing; a shared image cache."""
    gone = bpy.data.images.new("Gone Leaf", 4, 4)
    gone.source = "FILE"
    gone.filepath = "//no_such_leaf.png"
    material, tree, p, _ = new_material("MissingImage")
    tree.links.new(texture(tree, gone, "Gone Node").outputs["Alpha"], p.inputs["Alpha"])
    out = {}
    images = {}
    for name, slots in (
        ("Card", [made["TexAlpha"], material, made["Const"]]),
        ("OnlyMissing", [material]),
        ("SecondCard", [made["Clip"]]),
    ):
        mesh = make_mesh(name, QUAD_VERTS[:4], [(0, 1, 2, 3)])
        set_uvs(mesh, "UVMap", np.zeros((4, 2)), True)
        for slot in slots:
            mesh.materials.append(slot)
        obj = bpy.data.objects.new(name, mesh)
        bpy.context.scene.collection.objects.link(obj)
        evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        found = alpha_object.object_alpha(evaluated, evaluated.data, images)
        out[name] = {
            "slots": found.slots,
            "mesh": None if found.mesh is None else found.mesh.material_index.tolist(),
            "warnings": found.warnings,
        }
    out["images"] = {key: [w, h, list(v.shape)] for key, (w, h, v) in images.items()}
    return out


def main():
    a = args()
    materials, ai, am, exporter = load(Path(a.addon))
    folder = Path(a.out).parent
    bpy.ops.wm.read_factory_settings(use_empty=True)
    result = {
        "blender": list(bpy.app.version),
        "luminance": list(materials.luminance_coefficients()),
    }
    result["images"] = image_cases(ai, folder)
    image = bpy.data.images["Rows"]
    result["materials"] = made = material_cases(materials, image)
    del made
    built = {m.name: m for m in bpy.data.materials}
    built["Empty slot"] = None
    result["meshes"] = mesh_cases(materials, am, exporter, built)
    result["driven"] = driven_case(materials)
    result["object"] = object_case(load_object_alpha(Path(a.addon)), built)
    # Errors of a texture source named as the exporter would name them.
    leaf = materials.material_alpha(built["TexAlpha"])
    leaf.image = "No such image"
    try:
        ai.source_image(leaf, "TexAlpha", "Card")
        result["source_image_error"] = "no error"
    except ai.AlphaError as e:
        result["source_image_error"] = str(e)
    Path(a.out).write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
