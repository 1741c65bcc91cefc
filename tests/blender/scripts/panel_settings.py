"""In a real Blender window (under Xvfb): installs the add-on, unfolds every settings group of
its panel in Render properties, lets Blender draw it, and writes the settings the panel drew and
the schema's names as JSON (and a screenshot beside it).

    xvfb-run blender --factory-startup -noaudio -P panel_settings.py -- --zip Z --out OUT.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import addon_utils
import bpy

argv = sys.argv[sys.argv.index("--") + 1 :]
p = argparse.ArgumentParser()
p.add_argument("--zip", required=True)
p.add_argument("--out", required=True)
ARGS = p.parse_args(argv)


def setup():
    bpy.ops.preferences.addon_install(filepath=os.path.abspath(ARGS.zip))
    addon_utils.enable("antumbra", default_set=True)
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_WORKBENCH"  # fewer render panels above ours
    for name in dir(scene.antumbra.method):
        if name.startswith("show_"):
            setattr(scene.antumbra.method, name, True)
    window = bpy.context.window_manager.windows[0]
    for area in window.screen.areas:
        if area.type == "PROPERTIES":
            area.spaces.active.context = "RENDER"
            area.tag_redraw()
    bpy.app.timers.register(report, first_interval=1.5)


def report():
    method_settings = sys.modules["antumbra.properties.method_settings"]
    window = bpy.context.window_manager.windows[0]
    with bpy.context.temp_override(window=window, screen=window.screen):
        bpy.ops.screen.screenshot(filepath=os.path.abspath(ARGS.out) + ".png")
    with open(ARGS.out, "w") as f:
        json.dump(
            {
                "drawn": list(method_settings.LAST_DRAWN),
                "schema": [s["name"] for s in method_settings.schema()],
            },
            f,
        )
    bpy.ops.wm.quit_blender()


bpy.app.timers.register(setup, first_interval=0.5)
