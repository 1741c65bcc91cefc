"""Installs the add-on as a user would, renders one frame through its operator, and dumps the
images it made. Runs in Debian's Blender (``blender -b -P operator_render.py -- ARGS``, legacy
add-on zip) and with the bpy 5.0 module (``python operator_render.py -- ARGS``, extension zip).

Writes OUT/images.npz (every ``antumbra ...`` image as float32 (h, w, 4), Blender's row order)
and OUT/report.json (operator result, scene state, add-on module name).
"""

from __future__ import annotations

import json
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from addon_script import exit_after, install, open_blend, parse_args


def more_args(p) -> None:
    p.add_argument("--frame", type=int, required=True)
    p.add_argument("--spp", type=int, default=2)
    p.add_argument("--record", default="")


def main():
    a = parse_args(more_args)
    os.makedirs(a.out, exist_ok=True)
    report = {"version": bpy.app.version_string}
    module_name = install(a.kind, a.zip)
    report["module"] = module_name
    report["enabled"] = module_name in bpy.context.preferences.addons
    scene = open_blend(a, module_name)
    scene.frame_set(a.frame)
    settings = scene.antumbra
    settings.method.spp = a.spp
    # The resolution scale is left at its default: the images must be the scene's size.
    settings.output_dir = os.path.join(a.out, "files")
    addon = sys.modules[module_name]
    link = addon.operators.render.current_link()
    if a.record:
        link.session().start_recording(a.record)
    try:
        report["result"] = sorted(bpy.ops.antumbra.render())
    except RuntimeError as e:
        report["result"] = ["ERROR"]
        report["error"] = str(e)
    if a.record:
        report["recorded"] = list(link.session().stop_recording())
    report["status"] = settings.status
    report["frame_current"] = scene.frame_current
    report["last_frame"] = settings.last_frame
    report["last_stats"] = json.loads(settings.last_stats) if settings.last_stats else None
    report["daemon"] = link.status()
    images = {}
    for image in bpy.data.images:
        if image.name.startswith("antumbra "):
            w, h = image.size
            pixels = np.empty(w * h * 4, dtype=np.float32)
            image.pixels.foreach_get(pixels)
            images[image.name] = pixels.reshape(h, w, 4)
    report["images"] = sorted(images)
    np.savez(os.path.join(a.out, "images.npz"), **images)
    link.stop()
    with open(os.path.join(a.out, "report.json"), "w") as f:
        json.dump(report, f, indent=1)


if __name__ == "__main__":
    exit_after(main)
