"""F12 in a real Blender window (Xvfb): chooses the antumbra engine, starts Blender's render job
(``render.render`` invoked as the key does, the render runs on Blender's render thread) and, once
``render_complete`` fired, writes what the Render Result holds to OUT/report.json. Needs the
legacy add-on zip."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import traceback

import addon_utils
import bpy

argv = sys.argv[sys.argv.index("--") + 1 :]
p = argparse.ArgumentParser()
p.add_argument("--zip", required=True)
p.add_argument("--binary", required=True)
p.add_argument("--socket", required=True)
p.add_argument("--out", required=True)
ARGS = p.parse_args(argv)
STATE = {"phase": "setup", "t": time.monotonic(), "complete": 0}


def step():
    try:
        return PHASES[STATE["phase"]]()
    except Exception:  # noqa: BLE001 - the test reads the traceback
        traceback.print_exc()
        os._exit(1)


def complete(*_args):
    STATE["complete"] += 1


def setup():
    bpy.ops.preferences.addon_install(filepath=ARGS.zip)
    addon_utils.enable("antumbra", default_set=True)
    prefs = bpy.context.preferences.addons["antumbra"].preferences
    prefs.binary_path, prefs.socket_path = ARGS.binary, ARGS.socket
    scene = bpy.context.scene
    scene.render.engine = "ANTUMBRA"
    scene.antumbra.method.spp = 2
    bpy.app.handlers.render_complete.append(complete)
    window = bpy.context.window_manager.windows[0]
    area = max(window.screen.areas, key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.render.render("INVOKE_DEFAULT")
    STATE["phase"] = "wait"
    return 0.1


def wait():
    if not STATE["complete"]:
        if time.monotonic() - STATE["t"] > 120:
            print("engine_f12: no render_complete after 120 s", file=sys.stderr)
            os._exit(1)
        return 0.05
    result = bpy.data.images["Render Result"]
    path = os.path.join(ARGS.out, "f12.exr")
    settings = bpy.context.scene.render.image_settings
    settings.file_format, settings.color_depth = "OPEN_EXR_MULTILAYER", "32"
    result.save_render(filepath=path)
    report = {"complete": STATE["complete"], "frame": bpy.context.scene.frame_current}
    with open(os.path.join(ARGS.out, "report.json"), "w") as f:
        json.dump(report, f)
    sys.stdout.flush()
    os._exit(0)


PHASES = {"setup": setup, "wait": wait}
bpy.app.timers.register(step, first_interval=0.5)
