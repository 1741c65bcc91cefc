"""The Blender side of ``test_alpha_cycles.py``: builds the leaf-card garden
(``leaf_cards_scene.py``, one variant), renders it with Cycles once per light (object-index and
shadow-catcher passes) and with antumbra (the add-on's exporter, alpha materials included, and
an in-process ``antumbra.LocalSession``), and saves both as arrays.

    blender -b --factory-startup -noaudio -P tests/blender/leaf_cards_agreement.py -- \\
        --out DIR --variant clip|fractional [--size 256]
    python tests/blender/leaf_cards_agreement.py -- --out DIR ...   # the bpy module

Output in DIR: ``cycles_sun.exr`` and ``cycles_lamp.exr`` (Blender's multilayer EXR, every
pass), ``antumbra.npz`` (``object_ids``, ``mask_sun``, ``mask_lamp``: float32 (size, size),
rows top to bottom; ``mask_sun_opaque``, ``mask_lamp_opaque``: the same with alpha off) and
``scene.json`` (object names in export order, the ground's index, Blender's version, the
export's warnings, the size).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
from pathlib import Path

import bpy
import numpy as np

HERE = Path(__file__).resolve().parent
ADDON = HERE.parents[1] / "blender_addon" / "antumbra"


def _module(name: str, path: Path, package: list[str] | None = None):
    spec = importlib.util.spec_from_file_location(name, path, submodule_search_locations=package)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def load_exporter():
    """The add-on's ``export.exporter``, loaded as the package ``antumbra_addon`` (the add-on
    package is also called ``antumbra`` and must not shadow the client package)."""
    _module("antumbra_addon", ADDON / "__init__.py", [str(ADDON)])
    return importlib.import_module("antumbra_addon.export.exporter")


def render_antumbra(scene, client, transparent_bounces: int) -> tuple[list[str], dict, list]:
    export = load_exporter()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    session = client.LocalSession()
    exported = export.Exporter(client).frame(depsgraph, scene, scene.frame_current, 100)
    export.send(session, exported)
    arrays = {}
    # Also every card opaque (alpha off): what antumbra cast before issue 38, the sensitivity;
    # and the same frame on two levels (a tree per shared mesh, the rest in the static group).
    for suffix, alpha, structure in (
        ("", True, "flat"),
        ("_opaque", False, "flat"),
        ("_two_level", True, "two-level"),
    ):
        result = session.render(
            exported.frame,
            spp=1,
            passes=("masks", "object_ids"),
            alpha=alpha,
            transparent_bounces=transparent_bounces,
            scene_structure=structure,
        )
        arrays.setdefault("object_ids", result.object_ids)
        for light in ("Sun", "Lamp"):
            arrays[f"mask_{light.lower()}{suffix}"] = result.masks[light]
    names = [o["name"] for o in exported.objects]
    return names, arrays, exported.alpha.warnings


def main(argv: list[str]) -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--out", required=True, type=Path)
    p.add_argument("--variant", choices=("clip", "fractional"), required=True)
    p.add_argument("--size", type=int, default=256)
    a = p.parse_args(argv[argv.index("--") + 1 :] if "--" in argv else [])
    a.out.mkdir(parents=True, exist_ok=True)

    import antumbra as client

    builder = _module("leaf_cards_scene", HERE / "leaf_cards_scene.py")
    scene = builder.build(a.variant, a.size)
    names, arrays, warnings = render_antumbra(scene, client, builder.TRANSPARENT_BOUNCES)

    # Cycles' object index is pass_index; 0 is the background, so object i gets i + 1.
    for i, name in enumerate(names):
        bpy.data.objects[name].pass_index = i + 1
    scene.view_layers[0].use_pass_object_index = True
    builder.render(scene, a.out)

    np.savez(a.out / "antumbra.npz", **arrays)
    (a.out / "scene.json").write_text(
        json.dumps(
            {
                "objects": names,
                "ground": names.index("Ground"),
                "size": a.size,
                "variant": a.variant,
                "blender": bpy.app.version_string,
                "warnings": warnings,
            }
        )
    )


if __name__ == "__main__":
    main(sys.argv)
