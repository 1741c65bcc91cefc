"""What operator_compare.py and operator_trade.py share: their arguments, the add-on installed
and the .blend opened with the daemon set, cheap settings, each operator run recorded with the
panel's table, and the report written and the exit status set at the end."""

from __future__ import annotations

import argparse
import json
import os
import sys
import traceback

import bpy
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


def open_scene(a) -> tuple[dict, str, object]:
    """Installs the add-on, opens the .blend (frames 1 to ``--frames``, at 1) with the daemon
    set; the report begun, the add-on's module name and the scene's settings."""
    os.makedirs(a.out, exist_ok=True)
    report = {"version": bpy.app.version_string}
    module_name = install(a.kind, a.zip)
    bpy.ops.wm.open_mainfile(filepath=a.blend)
    prefs = bpy.context.preferences.addons[module_name].preferences
    prefs.binary_path, prefs.socket_path = a.binary, a.socket
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, a.frames
    scene.frame_set(1)
    return report, module_name, scene.antumbra


def cheap(settings, out: str, repeat_property: str) -> None:
    """One sample at half resolution, one timed pass, files under OUT/files: quick runs."""
    settings.method.spp = 1
    settings.resolution_scale = 0.5
    setattr(settings, repeat_property, 1)
    settings.output_dir = os.path.join(out, "files")


def run(operator, table_property: str, **kw) -> dict:
    """The operator's result (or its ERROR report), the status and the panel's table after it."""
    try:
        result, error = sorted(operator(**kw)), None
    except RuntimeError as e:  # an operator's ERROR report
        result, error = ["ERROR"], str(e)
    settings = bpy.context.scene.antumbra
    table = getattr(settings, table_property)
    return {
        "result": result,
        "error": error,
        "status": settings.status,
        "table": json.loads(table) if table else None,
    }


def finish(a, report: dict, module_name: str) -> None:
    """Stops the daemon and writes OUT/report.json."""
    sys.modules[module_name].operators.current_link().stop()
    with open(os.path.join(a.out, "report.json"), "w") as f:
        json.dump(report, f, indent=1)


def exit_after(main) -> None:
    """Runs ``main`` and exits 1 on any exception (Blender would exit 0 after a -P script)."""
    try:
        main()
        code = 0
    except Exception:  # noqa: BLE001 - the test reads the traceback
        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
