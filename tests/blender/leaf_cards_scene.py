"""Builds the leaf-card scene of issue 38 as a .blend: a garden of alpha-textured leaf cards and
a fence, for the alpha export's tests, the Cycles agreement test to come and the demo.

    blender -b --factory-startup -noaudio -P tests/blender/leaf_cards_scene.py -- \\
        --out leaf_cards.blend [--variant clip|fractional] [--render DIR --size 256]
    python tests/blender/leaf_cards_scene.py -- --out leaf_cards.blend   # the bpy module

The scene (the same in every Blender, seeded):

- ``Ground``: a 24 x 24 plane, Cycles' shadow catcher;
- three trees: ``Trunk.N`` (an opaque box) and ``Crown.N``, one mesh of 60 leaf cards (quads of
  UV (0, 0)-(1, 1), random orientations) using the ``Leaf`` material;
- ``Fence``: 12 planks, each a quad whose UVs repeat the ``Picket`` image twice across it;
- ``Glass``: a box of Principled Alpha 0.5 (a shadow ray through two faces keeps 0.25);
- ``Sun`` (angle 0) and ``Lamp`` (a point light of radius 0): hard lights; a camera.

Images are made here with numpy (no download) and packed into the .blend as PNG (8 bits):
``Leaf`` (64 x 64: a pointed leaf, alpha 1 inside, a band of fractional alpha at its rim, 0
outside) and ``Picket`` (32 x 64: a pointed picket, the same kind of rim).

``--variant``: ``clip`` puts a Math Greater Than 0.5 between the texture's alpha and the
Principled BSDF's Alpha (cards are cut out), ``fractional`` links the alpha straight (the rim
lets light partly through). Cycles is set for transparent shadows: ``transparent_max_bounces``
64, direct light only, one sample at each pixel centre as ``cycles_scene.py`` does, and the
shadow catcher pass on; the render is ``--size`` pixels square. ``--render DIR`` also renders
it with Cycles, one multilayer EXR of every pass per light (``DIR/cycles_sun.exr``,
``DIR/cycles_lamp.exr``, the other light hidden from render).

For the agreement test to come: shadow rays through fractional alpha are deterministic in
Cycles (transmission multiplied), but camera rays pass a fractional surface stochastically
(at 1 sample the glass box and the leaves' rims look speckled in the Combined pass), so compare
shadows where the camera sees the ground itself.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import sys
from pathlib import Path

import bpy
import numpy as np

LEAF_SIZE = (64, 64)
PICKET_SIZE = (32, 64)
#: (location of the trunk's foot, crown radius, crown height) of each tree.
TREES = [((-3.0, 1.5, 0.0), 1.6, 3.2), ((1.5, 3.0, 0.0), 1.3, 2.6), ((3.5, -1.0, 0.0), 1.1, 2.2)]
CARDS_PER_TREE = 60
CARD_SIZE = 0.8
PLANKS = 12
TRANSPARENT_BOUNCES = 64


def script_args(argv: list[str]) -> argparse.Namespace:
    argv = argv[argv.index("--") + 1 :] if "--" in argv else []
    p = argparse.ArgumentParser()
    p.add_argument("--out", required=True, type=Path, help="the .blend to write")
    p.add_argument("--variant", choices=("clip", "fractional"), default="clip")
    p.add_argument("--render", type=Path, help="also render with Cycles into this folder")
    p.add_argument("--size", type=int, default=256)
    return p.parse_args(argv)


# Images --------------------------------------------------------------------------------------


def rim_alpha(distance: np.ndarray, band: float = 0.25) -> np.ndarray:
    """1 inside (distance <= 1 - band), 0 outside (>= 1), a linear ramp across the band."""
    return np.clip((1.0 - distance) / band, 0.0, 1.0)


def leaf_alpha(width: int, height: int) -> np.ndarray:
    """A pointed leaf along v, bottom row first (Blender's order): its half-width at height v is
    0.42 sin(pi v) ** 0.7; the alpha falls off over the outer quarter of it."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    uu, vv = np.meshgrid(u, v)
    half = 0.42 * np.sin(np.pi * vv) ** 0.7
    return rim_alpha(np.abs(uu - 0.5) / np.maximum(half, 1e-6))


def picket_alpha(width: int, height: int) -> np.ndarray:
    """A picket: a bar of 60% of the width with a pointed top (the top fifth), bottom row first."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    uu, vv = np.meshgrid(u, v)
    half = np.where(vv < 0.8, 0.3, 0.3 * np.clip((1.0 - vv) / 0.2, 0.0, 1.0))
    return rim_alpha(np.abs(uu - 0.5) / np.maximum(half, 1e-6), band=0.3)


def packed_image(name: str, size: tuple[int, int], alpha: np.ndarray, rgb) -> object:
    """A generated image of ALPHA (height, width; bottom row first) and a flat colour, packed
    into the .blend as an 8-bit PNG."""
    width, height = size
    pixels = np.empty((height, width, 4), dtype=np.float32)
    pixels[..., :3] = rgb
    pixels[..., 3] = alpha
    image = bpy.data.images.new(name, width, height, alpha=True)
    image.pixels.foreach_set(pixels.ravel())
    image.pack()
    return image


# Materials -----------------------------------------------------------------------------------


def principled(name: str):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    return material, tree, bsdf


def alpha_material(name: str, image, variant: str, colour):
    """Principled BSDF whose Alpha is IMAGE's alpha, clipped at 0.5 or fractional; EEVEE set to
    match (3.4: clip or hashed blend and shadows; 4.2+: dithered, transparent shadows)."""
    material, tree, bsdf = principled(name)
    bsdf.inputs["Base Color"].default_value = colour
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.name = texture.label = f"{name} Image"
    texture.image = image
    texture.interpolation = "Linear"
    alpha = texture.outputs["Alpha"]
    if variant == "clip":
        clip = tree.nodes.new("ShaderNodeMath")
        clip.name = "Clip"
        clip.operation = "GREATER_THAN"
        clip.inputs[1].default_value = 0.5
        tree.links.new(alpha, clip.inputs[0])
        alpha = clip.outputs[0]
    tree.links.new(alpha, bsdf.inputs["Alpha"])
    _eevee_modes(material, variant)
    return material


def _eevee_modes(material, variant: str) -> None:
    """EEVEE's own alpha settings (Cycles ignores them), so the viewport looks like the render."""
    if hasattr(material, "surface_render_method"):  # 4.2+
        material.surface_render_method = "DITHERED"
        material.use_transparent_shadow = True
        return
    material.blend_method = "CLIP" if variant == "clip" else "HASHED"
    material.shadow_method = "CLIP" if variant == "clip" else "HASHED"


def opaque_material(name: str, colour):
    material, _, bsdf = principled(name)
    bsdf.inputs["Base Color"].default_value = colour
    return material


def glass_material():
    material, _, bsdf = principled("Glass")
    bsdf.inputs["Alpha"].default_value = 0.5
    _eevee_modes(material, "fractional")
    return material


# Geometry ------------------------------------------------------------------------------------


def mesh_object(name: str, verts, faces, uvs=None, material=None):
    """An object of a mesh from lists; UVS, one (u, v) per corner in face order, as ``UVMap``."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in verts], [], [tuple(f) for f in faces])
    if uvs is not None:
        layer = mesh.uv_layers.new(name="UVMap")
        layer.data.foreach_set("uv", np.asarray(uvs, dtype=np.float32).ravel())
    if material is not None:
        mesh.materials.append(material)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def box(name: str, centre, size, material):
    cx, cy, cz = centre
    sx, sy, sz = (s / 2 for s in size)
    verts = [
        (cx + x * sx, cy + y * sy, cz + z * sz) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)
    ]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return mesh_object(name, verts, faces, material=material)


def card_corners(rng, centre, size: float) -> np.ndarray:
    """A square card of SIZE at CENTRE, randomly oriented: corners (4, 3) in UV order (0, 0),
    (1, 0), (1, 1), (0, 1)."""
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    helper = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    s = np.cross(axis, helper)
    s /= np.linalg.norm(s)
    t = np.cross(axis, s)
    h = size / 2
    return np.array([centre + h * (a * s + b * t) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))])


def tree(index: int, foot, radius: float, height: float, leaf, bark, rng) -> None:
    x, y, _ = foot
    box(f"Trunk.{index}", (x, y, height / 2), (0.25, 0.25, height), bark)
    centre = np.array([x, y, height])
    # Card centres spread through a ball of RADIUS around the top of the trunk.
    offsets = rng.normal(size=(CARDS_PER_TREE, 3))
    offsets *= (radius * rng.random(CARDS_PER_TREE) ** (1 / 3))[:, None] / np.linalg.norm(
        offsets, axis=1, keepdims=True
    )
    verts = np.concatenate([card_corners(rng, centre + o, CARD_SIZE) for o in offsets])
    faces = np.arange(4 * CARDS_PER_TREE).reshape(-1, 4)
    uvs = np.tile([(0, 0), (1, 0), (1, 1), (0, 1)], (CARDS_PER_TREE, 1))
    mesh_object(f"Crown.{index}", verts, faces, uvs, leaf)


def fence(picket) -> None:
    """PLANKS planks along x at y = -3.5, each 0.5 wide and 1.2 tall, two pickets per plank
    (u from 0 to 2: the image repeats)."""
    verts, faces, uvs = [], [], []
    for i in range(PLANKS):
        x0 = -4.0 + 0.55 * i
        base = len(verts)
        verts += [(x0, -3.5, 0), (x0 + 0.5, -3.5, 0), (x0 + 0.5, -3.5, 1.2), (x0, -3.5, 1.2)]
        faces.append((base, base + 1, base + 2, base + 3))
        uvs += [(0, 0), (2, 0), (2, 1), (0, 1)]
    mesh_object("Fence", verts, faces, uvs, picket)


# Scene ---------------------------------------------------------------------------------------


def build(variant: str, size: int):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    rng = np.random.default_rng(38)
    leaf_image = packed_image("Leaf", LEAF_SIZE, leaf_alpha(*LEAF_SIZE), (0.1, 0.4, 0.05))
    picket_image = packed_image("Picket", PICKET_SIZE, picket_alpha(*PICKET_SIZE), (0.6, 0.5, 0.3))
    leaf = alpha_material("Leaf", leaf_image, variant, (0.1, 0.4, 0.05, 1.0))
    picket = alpha_material("Picket", picket_image, variant, (0.6, 0.5, 0.3, 1.0))
    bark = opaque_material("Bark", (0.2, 0.1, 0.05, 1.0))

    ground = mesh_object(
        "Ground", [(-12, -12, 0), (12, -12, 0), (12, 12, 0), (-12, 12, 0)], [(0, 1, 2, 3)]
    )
    ground.is_shadow_catcher = True
    for i, (foot, radius, height) in enumerate(TREES):
        tree(i, foot, radius, height, leaf, bark, rng)
    fence(picket)
    box("Glass", (-0.5, -1.5, 0.6), (1.0, 1.0, 1.2), glass_material())

    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (5.5, -8.5, 5.5)
    from mathutils import Vector

    camera.rotation_euler = (
        (Vector((0.0, 1.0, 0.8)) - camera.location).to_track_quat("-Z", "Y").to_euler()
    )
    camera.data.lens = 26.0
    scene.collection.objects.link(camera)
    scene.camera = camera

    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (math.radians(55.0), 0.0, math.radians(-30.0))
    sun.data.angle = 0.0
    sun.data.energy = 3.0
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
    lamp.location = (-1.0, -5.0, 5.0)
    lamp.data.shadow_soft_size = 0.0
    lamp.data.energy = 1000.0
    for light in (sun, lamp):
        scene.collection.objects.link(light)

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
    r.resolution_x = r.resolution_y = size
    r.resolution_percentage = 100
    configure_cycles(scene)
    return scene


def configure_cycles(scene) -> None:
    """``cycles_settings.py``'s Cycles, casting transparent shadows through the cards."""
    path = Path(__file__).resolve().with_name("cycles_settings.py")
    spec = importlib.util.spec_from_file_location("cycles_settings", path)
    settings = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(settings)
    settings.configure_cycles(scene, transparent_bounces=TRANSPARENT_BOUNCES)


def render(scene, folder: Path) -> None:
    """One Cycles render per light (the other hidden), so each shadow is compared alone."""
    folder.mkdir(parents=True, exist_ok=True)
    lights = {"sun": scene.objects["Sun"], "lamp": scene.objects["Lamp"]}
    for name, light in lights.items():
        for other in lights.values():
            other.hide_render = other is not light
        scene.render.filepath = str(folder / f"cycles_{name}.exr")
        bpy.ops.render.render(write_still=True)
    for light in lights.values():
        light.hide_render = False


def main() -> None:
    a = script_args(sys.argv)
    scene = build(a.variant, a.size)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(a.out))
    if a.render is not None:
        render(scene, a.render)


if __name__ == "__main__":
    main()
