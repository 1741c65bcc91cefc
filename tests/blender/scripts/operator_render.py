"""Installs the add-on as a user would, renders one frame through its operator, and dumps the
images it made. Runs in Debian's Blender (``blender -b -P operator_render.py -- ARGS``, legacy
add-on zip) and with the bpy 5.0 module (``python operator_render.py -- ARGS``, extension zip).

Writes OUT/images.npz (every ``antumbra ...`` image as float32 (h, w, 4), Blender's row order)
and OUT/report.json (operator result, scene state, add-on module name).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import traceback

import bpy
import numpy as np


def args():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--zip", required=True)
    p.add_argument("--kind", choices=("legacy", "extension"), required=True)
    p.add_argument("--blend", required=True)
    p.add_argument("--frame", type=int, required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--binary", required=True)
    p.add_argument("--socket", required=True)
    p.add_argument("--spp", type=int, default=2)
    p.add_argument("--record", default="")
    return p.parse_args(argv)


def install(kind: str, zip_path: str) -> str:
    if kind == "legacy":
        import addon_utils

        bpy.ops.preferences.addon_install(filepath=zip_path)
        addon_utils.enable("antumbra", default_set=True)
        return "antumbra"
    bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo="user_default", enable_on_install=True
    )
    return "bl_ext.user_default.antumbra"


def main():
    a = args()
    os.makedirs(a.out, exist_ok=True)
    report = {"version": bpy.app.version_string}
    module_name = install(a.kind, a.zip)
    report["module"] = module_name
    report["enabled"] = module_name in bpy.context.preferences.addons
    bpy.ops.wm.open_mainfile(filepath=a.blend)
    prefs = bpy.context.preferences.addons[module_name].preferences
    prefs.binary_path = a.binary
    prefs.socket_path = a.socket
    scene = bpy.context.scene
    scene.frame_set(a.frame)
    settings = scene.antumbra
    settings.method.spp = a.spp
    # The resolution scale is left at its default: the images must be the scene's size.
    settings.output_dir = os.path.join(a.out, "files")
    addon = sys.modules[module_name]
    link = addon.operators.current_link()
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
    try:
        main()
        code = 0
    except Exception:  # noqa: BLE001 - the test reads the traceback
        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
