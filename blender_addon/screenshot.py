"""Drives Blender's UI (under Xvfb) through the add-on's modal operator and takes a screenshot of
the panel beside an Image Editor showing a heat map: the picture in docs/, and a check that the
modal path (timer, worker thread, progress, images) runs in a real window.

    xvfb-run -s "-screen 0 1600x900x24" blender --factory-startup -noaudio SCENE.blend \\
        -P blender_addon/screenshot.py -- --zip dist/antumbra-addon-0.1.0.zip \\
        --binary target/release/antumbra --out docs/blender-panel.png [--image NAME]

Exits 0 once the screenshot is written, 1 if the render failed or took over two minutes.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import addon_utils
import bpy


def parse():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="screenshot.py")
    p.add_argument("--zip", required=True)
    p.add_argument("--binary", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--image", default="antumbra heat shadow node visits")
    p.add_argument("--socket", default="")
    return p.parse_args(argv)


ARGS = parse()
STATE = {"phase": "setup", "started": None}


def main_window():
    window = bpy.context.window_manager.windows[0]
    return window, window.screen


def largest(screen, kind):
    areas = [a for a in screen.areas if a.type == kind]
    return max(areas, key=lambda a: a.width * a.height) if areas else None


def setup():
    bpy.ops.preferences.addon_install(filepath=os.path.abspath(ARGS.zip))
    addon_utils.enable("antumbra", default_set=True)
    prefs = bpy.context.preferences.addons["antumbra"].preferences
    prefs.binary_path = os.path.abspath(ARGS.binary)
    prefs.socket_path = ARGS.socket
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_WORKBENCH"  # fewer render panels above ours
    scene.antumbra.resolution_scale = 1.0
    scene.antumbra.method.spp = 4
    scene.antumbra.method.width = "8"
    scene.antumbra.method.order = "sorted:budget=0.05"
    window, screen = main_window()
    view = largest(screen, "VIEW_3D")
    with bpy.context.temp_override(window=window, screen=screen, area=view):
        bpy.ops.screen.area_split(direction="VERTICAL", factor=0.62)
    views = sorted((a for a in screen.areas if a.type == "VIEW_3D"), key=lambda a: a.x)
    views[0].type = "IMAGE_EDITOR"
    views[1].type = "PROPERTIES"
    STATE["phase"] = "invoke"
    return 0.5


def invoke():
    # The new editors exist once the window has redrawn: a tick after setup.
    window, screen = main_window()
    properties = largest(screen, "PROPERTIES")
    properties.spaces.active.context = "RENDER"
    region = next(r for r in properties.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=window, screen=screen, area=properties, region=region):
        bpy.ops.antumbra.render("INVOKE_DEFAULT")
    STATE["started"] = time.monotonic()
    STATE["phase"] = "wait"
    return 0.5


def wait_for_render():
    scene = bpy.context.scene
    if scene.antumbra.running:
        if time.monotonic() - STATE["started"] > 120:
            print("screenshot: the render did not finish in 120 s", file=sys.stderr)
            os._exit(1)
        return 0.25
    if not scene.antumbra.status.startswith("1 frame"):
        print(f"screenshot: render failed: {scene.antumbra.status}", file=sys.stderr)
        os._exit(1)
    window, screen = main_window()
    editor = largest(screen, "IMAGE_EDITOR")
    editor.spaces.active.image = bpy.data.images[ARGS.image]
    for region in editor.regions:
        if region.type == "WINDOW":
            with bpy.context.temp_override(
                window=window, screen=screen, area=editor, region=region
            ):
                bpy.ops.image.view_all(fit_view=True)
    properties = largest(screen, "PROPERTIES")
    for region in properties.regions:
        if region.type == "WINDOW":
            # The add-on's panel comes after the engine's: scroll it into view.
            with bpy.context.temp_override(
                window=window, screen=screen, area=properties, region=region
            ):
                bpy.ops.view2d.scroll_down(deltay=2000)
    STATE["phase"] = "shoot"
    bpy.app.timers.register(shoot, first_interval=1.0)
    return None


def shoot():
    try:
        take()
    except Exception:  # noqa: BLE001 - a failed step ends the run with its traceback
        import traceback

        traceback.print_exc()
        os._exit(1)


def take():
    window, screen = main_window()
    with bpy.context.temp_override(window=window, screen=screen):
        bpy.ops.screen.screenshot(filepath=os.path.abspath(ARGS.out))
    print(f"screenshot: wrote {ARGS.out} ({bpy.context.scene.antumbra.status})")
    bpy.ops.antumbra.daemon_stop()
    sys.stdout.flush()
    os._exit(0)


def step():
    try:
        return {"setup": setup, "invoke": invoke, "wait": wait_for_render}[STATE["phase"]]()
    except Exception:  # noqa: BLE001 - a failed step ends the run with its traceback
        import traceback

        traceback.print_exc()
        os._exit(1)


bpy.app.timers.register(step, first_interval=1.0)
