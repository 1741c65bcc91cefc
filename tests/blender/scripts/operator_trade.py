"""Installs the add-on as a user would and runs its Trade operator: the knob list filled from
the client's KNOBS, two knobs ticked (one with its own values), "Trade animation" over the first
frames; then a knob with a bad value. Runs in Debian's Blender (``blender -b -P
operator_trade.py -- ARGS``, legacy zip) and with the bpy module (``python operator_trade.py --
ARGS``, extension zip). Writes what it saw to OUT/report.json."""

from __future__ import annotations

import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from addon_script import exit_after
from sweep_script import args, cheap, finish, open_scene, run


def tick(settings, values: dict[str, str]) -> None:
    for knob in settings.trade_knobs:
        knob.use = knob.name in values
        knob.values = values.get(knob.name, "")


def main():
    a = args()
    report, module_name, settings = open_scene(a)
    report["knobs"] = [k.name for k in settings.trade_knobs]
    cheap(settings, a.out, "trade_repeat")
    tick(settings, {"width": "2,8", "spp": ""})
    report["ticked"] = settings.trade_texts()
    report["animation"] = run(bpy.ops.antumbra.trade, "trade_table", animation=True)

    settings.output_dir = os.path.join(a.out, "bad")
    tick(settings, {"osah_w": "2"})
    report["bad"] = run(bpy.ops.antumbra.trade, "trade_table", animation=False)
    finish(a, report, module_name)


if __name__ == "__main__":
    exit_after(main)
