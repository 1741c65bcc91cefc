"""The panel's Compare section: the list of methods (label and settings, editable), the
baseline and repeat, the Compare buttons, and the last comparison's per-method table."""

from __future__ import annotations

import json

import bpy


class ANTUMBRA_UL_compare_methods(bpy.types.UIList):
    """One row per method: its label and the settings it changes."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname):
        row = layout.row(align=True)
        baseline = data.compare_baseline_label() if len(data.compare_methods) else ""
        row.prop(
            item, "name", text="", emboss=False, icon="PINNED" if item.name == baseline else "NONE"
        )
        row.prop(item, "settings", text="", emboss=False)


def _table_box(layout, settings):
    if not settings.compare_table:
        return
    try:
        table = json.loads(settings.compare_table)
    except json.JSONDecodeError:
        return
    box = layout.box()
    box.label(text=f"{table['frames']} frame(s), against {table['baseline']}")
    header = ("method", "N_B/ray", "ratio", "frame ms", "answers")
    for cells in [header] + [
        (
            m["label"],
            f"{m['nb_per_ray']:.2f}",
            f"{m['nb_ratio']:.3f}",
            f"{m['frame_ms']:.2f}",
            "match" if m["matched"] else "DIFFER",
        )
        for m in table["methods"]
    ]:
        line = box.row(align=True)
        line.alert = cells[-1] == "DIFFER"
        for cell in cells:
            line.label(text=cell)


def draw(layout, settings) -> None:
    box = layout.box()
    box.label(text="Compare methods", icon="SORTSIZE")
    row = box.row()
    row.template_list(
        "ANTUMBRA_UL_compare_methods", "", settings, "compare_methods", settings, "compare_index"
    )
    col = row.column(align=True)
    col.operator("antumbra.compare_method_add", text="", icon="ADD")
    col.operator("antumbra.compare_method_remove", text="", icon="REMOVE")
    col.separator()
    col.operator("antumbra.compare_defaults", text="", icon="LOOP_BACK")
    methods = settings.compare_methods
    if 0 <= settings.compare_index < len(methods):
        item = methods[settings.compare_index]
        col = box.column(align=True)
        col.prop(item, "name", text="Label")
        col.prop(item, "settings")
    row = box.row(align=True)
    row.prop_search(settings, "compare_baseline", settings, "compare_methods")
    row.prop(settings, "compare_repeat")
    row = box.row(align=True)
    row.enabled = not settings.running
    row.operator("antumbra.compare", text="Compare frame", icon="RENDER_STILL").animation = False
    row.operator(
        "antumbra.compare", text="Compare animation", icon="RENDER_ANIMATION"
    ).animation = True
    _table_box(box, settings)


CLASSES = (ANTUMBRA_UL_compare_methods,)
