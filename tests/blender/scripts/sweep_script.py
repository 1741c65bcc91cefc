"""What operator_compare.py and operator_trade.py share: their arguments, the add-on installed
and the .blend opened with the daemon set, cheap settings, each operator run recorded with the
panel's table, and the report written at the end (``exit_after`` is addon_script's)."""

from __future__ import annotations

import json
import os
import sys

import bpy
from addon_script import install, open_blend, parse_args


def args():
    return parse_args(lambda p: p.add_argument("--frames", type=int, required=True))


def open_scene(a) -> tuple[dict, str, object]:
    """Installs the add-on, opens the .blend (frames 1 to ``--frames``, at 1) with the daemon
    set; the report begun, the add-on's module name and the scene's settings."""
    os.makedirs(a.out, exist_ok=True)
    report = {"version": bpy.app.version_string}
    module_name = install(a.kind, a.zip)
    scene = open_blend(a, module_name)
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
    sys.modules[module_name].operators.render.current_link().stop()
    with open(os.path.join(a.out, "report.json"), "w") as f:
        json.dump(report, f, indent=1)
