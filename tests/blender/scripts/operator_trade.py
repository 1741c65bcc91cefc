"""Installs the add-on as a user would and runs its Trade operator: the knob list filled from
the client's KNOBS, two knobs ticked (one with its own values), "Trade animation" over the first
frames; then a knob with a bad value. Runs in Debian's Blender (``blender -b -P
operator_trade.py -- ARGS``, legacy zip) and with the bpy module (``python operator_trade.py --
ARGS``, extension zip). Writes what it saw to OUT/report.json."""

from __future__ import annotations

import json
import os
import sys
import traceback

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from operator_compare import args
from operator_render import install


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
        "table": json.loads(settings.trade_table) if settings.trade_table else None,
    }


def tick(settings, values: dict[str, str]) -> None:
    for knob in settings.trade_knobs:
        knob.use = knob.name in values
        knob.values = values.get(knob.name, "")


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
    report["knobs"] = [k.name for k in settings.trade_knobs]
    settings.method.spp = 1
    settings.resolution_scale = 0.5
    settings.trade_repeat = 1
    settings.output_dir = os.path.join(a.out, "files")
    tick(settings, {"width": "2,8", "spp": ""})
    report["ticked"] = settings.trade_texts()
    report["animation"] = run(bpy.ops.antumbra.trade, animation=True)

    settings.output_dir = os.path.join(a.out, "bad")
    tick(settings, {"osah_w": "2"})
    report["bad"] = run(bpy.ops.antumbra.trade, animation=False)
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
