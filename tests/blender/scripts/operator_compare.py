"""Installs the add-on as a user would and runs its Compare operator: "Compare animation" over
the first frames with the default methods (prefilled in the list), then "Compare frame" with two
methods whose answers differ. Runs in Debian's Blender (``blender -b -P operator_compare.py --
ARGS``, legacy zip) and with the bpy 5.0 module (``python operator_compare.py -- ARGS``,
extension zip). Writes what it saw to OUT/report.json."""

from __future__ import annotations

import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from addon_script import exit_after
from sweep_script import args, cheap, finish, open_scene, run


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
    report, module_name, settings = open_scene(a)
    report["methods"] = [m.spec() for m in settings.compare_methods]
    cheap(settings, a.out, "compare_repeat")
    report["animation"] = run(bpy.ops.antumbra.compare, "compare_table", animation=True)
    report["images"] = images()

    # Two methods that draw different light samples: their masks differ.
    settings.output_dir = os.path.join(a.out, "differ")
    settings.compare_methods.clear()
    for label, text in (("a", "seed=1"), ("b", "seed=2")):
        item = settings.compare_methods.add()
        item.name, item.settings = label, text
    settings.compare_baseline = "a"
    settings.method.spp = 4
    bpy.context.scene.frame_set(2)
    report["differ"] = run(bpy.ops.antumbra.compare, "compare_table", animation=False)
    finish(a, report, module_name)


if __name__ == "__main__":
    exit_after(main)
