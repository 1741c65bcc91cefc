"""Cycles' transparent shadows of alpha cards, beside what the alpha export says of them, so the
contract's meaning (ops, 1 - Fac, luminance, row order, interpolation, extension) is checked
against Cycles itself. Runs in Debian's Blender (``blender -b -P alpha_cycles_check.py --
ARGS``) and with the bpy module.

The scene: a ground plane (the shadow catcher) seen straight down by an orthographic camera; a
sun straight down (angle 0); a grid of horizontal cards 1 above the ground, hidden from the
camera, each with one material and UVs from -0.5 to 1.5 across it (so extension matters) in
its render UV map, mirrored (u -> 1 - u) in another, the active one. Under
a card the catcher pass is the card's transmission, 1 - alpha(u, v); elsewhere 1.

Writes in OUT's folder ``cycles.exr`` (the render) and OUT (JSON): the camera's span, the
resolution, per card its rectangle, UV range and ``material_alpha``'s contract and warnings,
and per image and channel ``alpha_image``'s values.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import bpy

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))
from cycles_settings import configure_cycles  # noqa: E402
from materials_check import math, new_material, texture, write_png  # noqa: E402

#: A 4 x 4 RGBA image, rows top first (PNG order): every texel a different alpha, colours
#: that differ from their alpha, texels of alpha 0 with a colour.
IMAGE_ROWS = [
    [(255, 255, 255, 255), (200, 40, 40, 230), (0, 0, 0, 0), (90, 200, 30, 128)],
    [(30, 60, 250, 20), (255, 255, 255, 0), (128, 128, 128, 255), (10, 240, 120, 180)],
    [(250, 250, 0, 64), (60, 60, 60, 200), (255, 0, 255, 100), (200, 200, 200, 40)],
    [(0, 0, 0, 255), (120, 30, 200, 150), (255, 128, 0, 10), (40, 40, 40, 255)],
]
SIZE = 240
SPAN = 12.0
GRID = (5, 4)
CARD = 2.0
UV_RANGE = (-0.5, 1.5)


def args():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--addon", required=True, help="the add-on's source folder (blender_addon)")
    p.add_argument("--out", required=True)
    return p.parse_args(argv)


def cards_materials(image, packed) -> list:
    """The materials the cards carry, one card each."""
    made = []

    def simple(material, channel="Alpha", source=None, **tex):
        m, tree, p, _ = new_material(material)
        read = texture(tree, image if source is None else (source or None), **tex)
        tree.links.new(read.outputs[channel], p.inputs["Alpha"])
        made.append(m)

    simple("Linear Repeat")
    simple("Closest Extend", interpolation="Closest", extension="EXTEND")
    simple("Linear Clip", extension="CLIP")
    simple("Luminance Closest", channel="Color", interpolation="Closest")
    simple("Luminance Packed", channel="Color", source=packed, interpolation="Closest")

    # Color to Alpha with the Alpha output used too (here on Roughness): Cycles unassociates.
    m, tree, p, _ = new_material("Luminance Unassociated")
    tex = texture(tree, image, interpolation="Closest")
    tree.links.new(tex.outputs["Color"], p.inputs["Alpha"])
    tree.links.new(tex.outputs["Alpha"], p.inputs["Roughness"])
    made.append(m)

    simple("Luminance Linear", channel="Color")

    m, tree, p, _ = new_material("Clip 0.5")
    clip = math(tree, "GREATER_THAN", texture(tree, image).outputs["Alpha"], 0.5)
    tree.links.new(clip.outputs[0], p.inputs["Alpha"])
    made.append(m)

    m, tree, p, _ = new_material("Chain")
    doubled = math(tree, "MULTIPLY", texture(tree, image).outputs["Alpha"], 1.6, clamp=True)
    inverted = math(tree, "SUBTRACT", 1.0, doubled.outputs[0])
    squared = math(tree, "POWER", inverted.outputs[0], 2.0)
    tree.links.new(squared.outputs[0], p.inputs["Alpha"])
    made.append(m)

    m, tree, p, out = new_material("Transparent Second")
    tex = texture(tree, image, interpolation="Closest")
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(tex.outputs["Alpha"], mix.inputs[0])
    tree.links.new(p.outputs[0], mix.inputs[1])
    tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    made.append(m)

    m, tree, p, out = new_material("Nested Half")
    tree.links.new(texture(tree, image).outputs["Alpha"], p.inputs["Alpha"])
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs[0].default_value = 0.5
    tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[1])
    tree.links.new(p.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    made.append(m)

    m, tree, p, _ = new_material("Constant")
    p.inputs["Alpha"].default_value = 0.3
    made.append(m)

    # Out of [0, 1] before the Principled BSDF (3x - 1) and before a Mix's Fac (2x - 0.5): both
    # are clamped, by the contract's end and by the mix's CLAMP.
    m, tree, p, _ = new_material("Overshoot")
    tripled = math(tree, "MULTIPLY", texture(tree, image).outputs["Alpha"], 3.0)
    tree.links.new(math(tree, "SUBTRACT", tripled.outputs[0], 1.0).outputs[0], p.inputs["Alpha"])
    made.append(m)

    m, tree, p, out = new_material("Mix Overshoot")
    doubled = math(tree, "MULTIPLY", texture(tree, image).outputs["Alpha"], 2.0)
    shifted = math(tree, "SUBTRACT", doubled.outputs[0], 0.5)
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(shifted.outputs[0], mix.inputs[0])
    tree.links.new(p.outputs[0], mix.inputs[1])
    tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    made.append(m)

    # A UV Map node naming the mirrored map, and one naming a map no card has (Cycles reads
    # UV (0, 0) there; Closest would sit on a texel edge, so Linear).
    for material, uv_map, interpolation in (
        ("UV Map Node", "Mirrored", "Closest"),
        ("Absent UV Map", "Absent", "Linear"),
    ):
        m, tree, p, _ = new_material(material)
        tex = texture(tree, image, interpolation=interpolation)
        node = tree.nodes.new("ShaderNodeUVMap")
        node.uv_map = uv_map
        tree.links.new(node.outputs["UV"], tex.inputs["Vector"])
        tree.links.new(tex.outputs["Alpha"], p.inputs["Alpha"])
        made.append(m)

    # An Image Texture without an image: Cycles reads magenta, alpha 1.
    simple("No Image Color", channel="Color", source=False)
    simple("No Image Alpha", source=False)

    m, tree, p, _ = new_material("Invert Add")
    invert = tree.nodes.new("ShaderNodeInvert")
    tree.links.new(texture(tree, image).outputs["Alpha"], invert.inputs["Color"])
    added = math(tree, "ADD", invert.outputs[0], 0.1)
    tree.links.new(added.outputs[0], p.inputs["Alpha"])
    made.append(m)
    return made


def card(name: str, x0: float, y0: float, material):
    """A horizontal quad at z = 1 from (x0, y0), UVs UV_RANGE across it both ways in
    ``UVMap``, the render map; ``Mirrored`` (u -> 1 - u) comes first, so it is the active
    (edit) map but not the one Cycles renders with."""
    a, b = UV_RANGE
    mesh = bpy.data.meshes.new(name)
    verts = [(x0, y0, 1), (x0 + CARD, y0, 1), (x0 + CARD, y0 + CARD, 1), (x0, y0 + CARD, 1)]
    mesh.from_pydata(verts, [], [(0, 1, 2, 3)])
    mirrored = mesh.uv_layers.new(name="Mirrored")
    uv = mesh.uv_layers.new(name="UVMap")
    for i, (u, v) in enumerate([(a, a), (b, a), (b, b), (a, b)]):
        uv.data[i].uv = (u, v)
        mirrored.data[i].uv = (1.0 - u, v)
    uv.active_render = True
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    obj.visible_camera = False
    bpy.context.scene.collection.objects.link(obj)
    return obj


def build(image_path: Path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    image = bpy.data.images.load(str(image_path))
    image.name = "Texels"
    # The same file packed: Cycles reads it through Blender, not from the file.
    packed = bpy.data.images.load(str(image_path), check_existing=False)
    packed.name = "Texels Packed"
    packed.pack()
    ground = bpy.data.meshes.new("Ground")
    h = SPAN
    ground.from_pydata([(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], [], [(0, 1, 2, 3)])
    ground_obj = bpy.data.objects.new("Ground", ground)
    ground_obj.is_shadow_catcher = True
    scene.collection.objects.link(ground_obj)
    cards = []
    cell = SPAN / GRID[0]
    for k, material in enumerate(cards_materials(image, packed)):
        col, row = k % GRID[0], k // GRID[0]
        x0 = -SPAN / 2 + col * cell + (cell - CARD) / 2
        # A third of a pixel up, so the quad's diagonal passes between pixel centres: Cycles'
        # shadow ray through a shared edge records both triangles (twice the transmission).
        y0 = SPAN / 2 - (row + 1) * cell + (cell - CARD) / 2 + SPAN / SIZE / 3
        cards.append((card(f"Card.{k}", x0, y0, material), x0, y0, material))

    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = SPAN
    camera.location = (0.0, 0.0, 10.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.angle = 0.0
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("Black")
    world.color = (0.0, 0.0, 0.0)
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    for node in world.node_tree.nodes if world.node_tree else ():
        if node.type == "BACKGROUND":
            node.inputs["Strength"].default_value = 0.0
    scene.world = world

    r = scene.render
    r.resolution_x = r.resolution_y = SIZE
    r.resolution_percentage = 100
    configure_cycles(scene, transparent_bounces=8)
    return scene, image, cards


def main():
    a = args()
    from materials_check import load

    materials, ai, _, _ = load(Path(a.addon))
    folder = Path(a.out).parent
    png = folder / "texels.png"
    write_png(png, IMAGE_ROWS)
    scene, _, cards = build(png)
    result = {"size": SIZE, "span": SPAN, "uv_range": UV_RANGE, "card": CARD, "cards": []}
    for _, x0, y0, material in cards:
        source = materials.material_alpha(material)
        result["cards"].append(
            {
                "name": material.name,
                "rect": [x0, y0, x0 + CARD, y0 + CARD],
                "contract": source.contract(),
                "unassociate": source.unassociate,
                "warnings": source.warnings,
            }
        )
    result["images"] = {
        name: {
            "alpha": ai.alpha_image(bpy.data.images[name], "alpha")[2].tolist(),
            "luminance": ai.alpha_image(bpy.data.images[name], "luminance")[2].tolist(),
            "unassociated": ai.alpha_image(bpy.data.images[name], "luminance", "", True)[
                2
            ].tolist(),
        }
        for name in ("Texels", "Texels Packed")
    }
    scene.render.filepath = str(folder / "cycles.exr")
    bpy.ops.render.render(write_still=True)
    Path(a.out).write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
