"""Builds the leaf-card scene (``tests/blender/leaf_cards_scene.py``) in both variants, saves it,
reopens the .blend and reads it with the add-on's alpha export, as the exporter will. Runs in
Debian's Blender (``blender -b -P leaf_cards_check.py -- ARGS``) and with the bpy module.

Also renders each variant with Cycles at 96 x 96 (``clip/cycles_sun.exr`` ... beside OUT).

Writes OUT (JSON), per variant: each material's contract and warnings, each image's packed
state, size and alpha statistics, and per object ``mesh_alpha``'s triangle count, slots, UV
range and warnings (None where no slot needs alpha).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
from pathlib import Path

import bpy

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from materials_check import load  # noqa: E402 - the same loader of the export package

RENDER_SIZE = 96


def args():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--addon", required=True, help="the add-on's source folder (blender_addon)")
    p.add_argument("--out", required=True)
    return p.parse_args(argv)


def builder():
    spec = importlib.util.spec_from_file_location(
        "leaf_cards_scene", HERE.parent / "leaf_cards_scene.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def read(materials, ai, am) -> dict:
    out = {"materials": {}, "images": {}, "objects": {}}
    for material in bpy.data.materials:
        source = materials.material_alpha(material)
        out["materials"][material.name] = {
            "contract": source.contract(),
            "warnings": source.warnings,
        }
    for image in bpy.data.images:
        w, h, alpha = ai.alpha_image(image, "alpha")
        out["images"][image.name] = {
            "packed": image.packed_file is not None,
            "size": [w, h],
            "fractional": float(((alpha > 0) & (alpha < 1)).mean()),
            "opaque": float((alpha == 1).mean()),
            # The middle row, left to right: 0 outside, a ramp, 1 inside, and back.
            "middle_row": alpha[h // 2].tolist(),
            "corner": float(alpha[0, 0]),
        }
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for obj in bpy.context.scene.objects:
        if obj.type != "MESH":
            continue
        evaluated = obj.evaluated_get(depsgraph)
        sources = [
            (slot.material.name if slot.material else "", materials.material_alpha(slot.material))
            for slot in evaluated.material_slots
        ]
        found = am.mesh_alpha(evaluated, evaluated.data, sources)
        if found is None:
            out["objects"][obj.name] = None
            continue
        entry = out["objects"][obj.name] = {
            "triangles": len(found.material_index),
            "slots": sorted(set(found.material_index.tolist())),
            "uv_maps": sorted(found.uvs),
            "warnings": found.warnings,
        }
        if "" in found.uvs:
            entry["uv_min"] = found.uvs[""].reshape(-1, 2).min(axis=0).tolist()
            entry["uv_max"] = found.uvs[""].reshape(-1, 2).max(axis=0).tolist()
    return out


def main():
    a = args()
    materials, ai, am, _ = load(Path(a.addon))
    scene_builder = builder()
    folder = Path(a.out).parent
    result = {}
    for variant in ("clip", "fractional"):
        blend = folder / f"leaf_cards_{variant}.blend"
        scene = scene_builder.build(variant, RENDER_SIZE)
        bpy.ops.wm.save_as_mainfile(filepath=str(blend))
        # Cycles' shadow catcher per light, for the test to see transparent shadows at work.
        scene_builder.render(scene, folder / variant)
        bpy.ops.wm.read_factory_settings(use_empty=True)
        bpy.ops.wm.open_mainfile(filepath=str(blend))
        result[variant] = read(materials, ai, am)
        cycles = bpy.context.scene.cycles
        result[variant]["cycles"] = {
            "engine": bpy.context.scene.render.engine,
            "transparent_max_bounces": cycles.transparent_max_bounces,
            "shadow_catcher": bpy.data.objects["Ground"].is_shadow_catcher,
        }
    Path(a.out).write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
