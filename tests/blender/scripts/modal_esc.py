"""Runs the add-on's modal "Render animation" in a real Blender window (Xvfb) and presses Esc
(``Window.event_simulate``, Blender started with ``--enable-event-simulate``) once the first frame
is done; writes what it saw to OUT/report.json. Needs the legacy add-on zip."""

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
STATE = {"phase": "setup", "t": time.monotonic(), "pressed": None}


def fail(message):
    print(f"modal_esc: {message}", file=sys.stderr)
    sys.stderr.flush()
    os._exit(1)


def step():
    try:
        return PHASES[STATE["phase"]]()
    except Exception:  # noqa: BLE001 - the test reads the traceback
        traceback.print_exc()
        os._exit(1)


def setup():
    bpy.ops.preferences.addon_install(filepath=ARGS.zip)
    addon_utils.enable("antumbra", default_set=True)
    prefs = bpy.context.preferences.addons["antumbra"].preferences
    prefs.binary_path, prefs.socket_path = ARGS.binary, ARGS.socket
    scene = bpy.context.scene
    scene.antumbra.output_dir = os.path.join(ARGS.out, "files")
    scene.antumbra.method.spp = 1
    # Start mid-range: the job steps through the range and must put the frame back.
    scene.frame_set(scene.frame_start + 4)
    STATE["start_frame"] = scene.frame_current
    window = bpy.context.window_manager.windows[0]
    area = max(window.screen.areas, key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.antumbra.render("INVOKE_DEFAULT", animation=True)
    STATE["phase"] = "wait_first"
    return 0.1


def wait_first():
    settings = bpy.context.scene.antumbra
    if time.monotonic() - STATE["t"] > 120:
        fail(f"no frame after 120 s: {settings.status}")
    if settings.last_frame == 0 or not settings.running:
        return 0.05
    window = bpy.context.window_manager.windows[0]
    # Esc over the window: the modal operator's handler sees it.
    x, y = window.width // 2, window.height // 2
    window.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
    window.event_simulate(type="ESC", value="PRESS", x=x, y=y)
    window.event_simulate(type="ESC", value="RELEASE", x=x, y=y)
    STATE["pressed"] = settings.last_frame
    STATE["phase"] = "wait_end"
    return 0.05


def wait_end():
    scene = bpy.context.scene
    settings = scene.antumbra
    if settings.running:
        if time.monotonic() - STATE["t"] > 240:
            fail(f"still running 240 s after start: {settings.status}")
        return 0.05
    files = os.path.join(ARGS.out, "files")
    report = {
        "status": settings.status,
        "pressed_after_frame": STATE["pressed"],
        "last_frame": settings.last_frame,
        "frame_current": scene.frame_current,
        "start_frame": STATE["start_frame"],
        "frame_range": [scene.frame_start, scene.frame_end],
        "combined_frame": bpy.data.images["antumbra combined"].get("antumbra_frame"),
        "records": sorted(f for f in os.listdir(files) if f.endswith(".stats.json")),
    }
    with open(os.path.join(ARGS.out, "report.json"), "w") as f:
        json.dump(report, f)
    bpy.ops.antumbra.daemon_stop()
    sys.stdout.flush()
    os._exit(0)


PHASES = {"setup": setup, "wait_first": wait_first, "wait_end": wait_end}
bpy.app.timers.register(step, first_interval=0.5)
