"""Installs the add-on as a user would and runs its Compare operator: "Compare animation" over
the first frames with the default methods (prefilled in the list), then "Compare frame" with two
methods whose answers differ. Runs in Debian's Blender (``blender -b -P operator_compare.py --
ARGS``, legacy zip) and with the bpy 5.0 module (``python operator_compare.py -- ARGS``,
extension zip). Writes what it saw to OUT/report.json."""

from __future__ import annotations

import argparse
import json
import os
import sys
import traceback

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from operator_render import install


def args():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--zip", required=True)
    p.add_argument("--kind", choices=("legacy", "extension"), required=True)
    p.add_argument("--blend", required=True)
    p.add_argument("--frames", type=int, required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--binary", required=True)
    p.add_argument("--socket", required=True)
    return p.parse_args(argv)


def run(operator, **kw) -> dict:
    try:
        result, error = sorted(operator(**kw)), None
    except RuntimeError as e:  # an operator's ERROR report
        result, error = ["ERROR"], str(e)
    settings = bpy.context.scene.antumbra
    return {
        "result": result,
        "error": error,
        "status": settings.status,
        "table": json.loads(settings.compare_table) if settings.compare_table else None,
    }


def images() -> dict:
    return {
        image.name: {
            "size": list(image.size),
            "max": image.get("antumbra_max"),
            "scale": image.get("antumbra_scale"),
            "frame": image.get("antumbra_frame"),
        }
        for image in bpy.data.images
        if image.name.startswith("antumbra ")
    }


def main():
    a = args()
    os.makedirs(a.out, exist_ok=True)
    report = {"version": bpy.app.version_string}
    module_name = install(a.kind, a.zip)
    bpy.ops.wm.open_mainfile(filepath=a.blend)
    prefs = bpy.context.preferences.addons[module_name].preferences
    prefs.binary_path, prefs.socket_path = a.binary, a.socket
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, a.frames
    scene.frame_set(1)
    settings = scene.antumbra
    report["methods"] = [m.spec() for m in settings.compare_methods]
    settings.method.spp = 1
    settings.resolution_scale = 0.5
    settings.compare_repeat = 1
    settings.output_dir = os.path.join(a.out, "files")
    report["animation"] = run(bpy.ops.antumbra.compare, animation=True)
    report["images"] = images()

    # Two methods that draw different light samples: their masks differ.
    settings.output_dir = os.path.join(a.out, "differ")
    settings.compare_methods.clear()
    for label, text in (("a", "seed=1"), ("b", "seed=2")):
        item = settings.compare_methods.add()
        item.name, item.settings = label, text
    settings.compare_baseline = "a"
    settings.method.spp = 4
    scene.frame_set(2)
    report["differ"] = run(bpy.ops.antumbra.compare, animation=False)
    addon = sys.modules[module_name]
    addon.operators.current_link().stop()
    with open(os.path.join(a.out, "report.json"), "w") as f:
        json.dump(report, f, indent=1)


if __name__ == "__main__":
    try:
        main()
        code = 0
    except Exception:  # noqa: BLE001 - the test reads the traceback
        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
