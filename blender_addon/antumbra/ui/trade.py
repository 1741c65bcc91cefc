"""The panel's Trade section: the client's knobs (tick those to sweep, values optional), the
repeat, the Trade buttons, and the last trade's recommendation per knob."""

from __future__ import annotations

import json

import bpy


class ANTUMBRA_UL_trade_knobs(bpy.types.UIList):
    """One row per knob: ticked to sweep it, its name, the values given."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname):
        row = layout.row(align=True)
        row.prop(item, "use", text="")
        row.label(text=item.name)
        row.prop(item, "values", text="", emboss=False)


def _table_box(layout, settings):
    if not settings.trade_table:
        return
    try:
        table = json.loads(settings.trade_table)
    except json.JSONDecodeError:
        return
    box = layout.box()
    box.label(text=f"{table['frames']} frame(s), in {table['folder']}")
    for cells in [("knob", "default", "recommended")] + [
        (r["knob"], r["default"], r["recommended"]) for r in table["recommendations"]
    ]:
        line = box.row(align=True)
        for cell in cells:
            line.label(text=cell)


def draw(layout, settings) -> None:
    box = layout.box()
    box.label(text="Trade speed against accuracy", icon="PREFERENCES")
    row = box.row()
    row.template_list(
        "ANTUMBRA_UL_trade_knobs", "", settings, "trade_knobs", settings, "trade_index", rows=4
    )
    row.column(align=True).operator("antumbra.trade_knobs_reset", text="", icon="LOOP_BACK")
    ticked = settings.trade_texts()
    box.label(text="knobs: " + (", ".join(ticked) if ticked else "every knob (none ticked)"))
    box.prop(settings, "trade_repeat")
    row = box.row(align=True)
    row.enabled = not settings.running
    row.operator("antumbra.trade", text="Trade frame", icon="RENDER_STILL").animation = False
    row.operator("antumbra.trade", text="Trade animation", icon="RENDER_ANIMATION").animation = True
    _table_box(box, settings)


CLASSES = (ANTUMBRA_UL_trade_knobs,)
