"""The panel, in Render properties and in the 3D view's sidebar: daemon status, method settings,
the render buttons, progress and the last frame's statistics, and the Compare section."""

from __future__ import annotations

import json

import bpy

from .. import client_loader
from ..jobs import results
from ..operators.render import current_link
from ..properties import method_settings
from . import compare, trade


def _daemon_box(layout):
    box = layout.box()
    try:
        client_loader.load()
    except client_loader.ClientMissing as e:
        box.label(text="Client missing", icon="ERROR")
        box.label(text=str(e)[:80])
        return
    link = current_link()
    row = box.row()
    if link.connected():
        row.label(text=f"Daemon: {link.status()}", icon="LINKED")
        row.operator("antumbra.daemon_stop", text="", icon="CANCEL")
    else:
        row.label(text="Daemon: not running", icon="UNLINKED")
        row.operator("antumbra.daemon_start", text="Start", icon="PLAY")


def _stats_box(layout, settings):
    if not settings.last_stats:
        return
    box = layout.box()
    box.label(text=f"Frame {settings.last_frame}")
    try:
        rows = json.loads(settings.last_stats)
    except json.JSONDecodeError:
        return
    for cells in [("rays", "hit/occl.", "N_B/ray", "N_L/ray", "N_T/ray")] + [
        (
            "primary" if r["pass"] == "primary" else r["light"],
            f"{100 * r['occluded_fraction']:.1f}%",
            f"{r['nb_per_ray']:.2f}",
            f"{r['nl_per_ray']:.2f}",
            f"{r['nt_per_ray']:.2f}",
        )
        for r in rows
    ]:
        line = box.row(align=True)
        for cell in cells:
            line.label(text=cell)
    scales = [
        (name.removeprefix("antumbra heat "), bpy.data.images[name].get("antumbra_max"))
        for name in results.HEAT_PLANES.values()
        if name in bpy.data.images
    ]
    if scales:
        col = box.column(align=True)
        col.label(text="Heat maps (turbo, 0 .. max per pixel):")
        for label, top in scales:
            col.label(text=f"  {label}: 0 .. {top:g}" if top is not None else label)


def size_text(scene) -> str:
    """The size a render from the panel makes, shown under the resolution scale."""
    r = scene.render
    w, h = scene.antumbra.options().size(r.resolution_x, r.resolution_y, r.resolution_percentage)
    return f"Renders {w} x {h} px"


def draw_panel(layout, context):
    settings = context.scene.antumbra
    _daemon_box(layout)
    if getattr(settings, "method", None) is not None:
        method_settings.draw(layout, settings.method)
    col = layout.column(align=True)
    col.prop(settings, "resolution_scale")
    col.label(text=size_text(context.scene))
    col.prop(settings, "heat_maps")
    col.prop(settings, "view_as_values")
    if settings.saved_view:  # say whose view is on, and that the user's comes back
        saved = json.loads(settings.saved_view).get("view_transform", "")
        col.label(text=f"Standard view while antumbra renders ({saved} with other engines)")
    row = layout.row(align=True)  # the engine's warm-up (a farm's chunk)
    row.prop(settings, "use_animation_start", text="")
    sub = row.row()
    sub.active = settings.use_animation_start
    sub.prop(settings, "animation_start")
    col = layout.column(align=True)
    col.prop(settings, "output_dir")
    col.prop(settings, "save_files")
    row = layout.row(align=True)
    row.enabled = not settings.running
    row.operator(
        "antumbra.render", text="Render shadow pass", icon="RENDER_STILL"
    ).animation = False
    row.operator(
        "antumbra.render", text="Render animation", icon="RENDER_ANIMATION"
    ).animation = True
    if settings.running or settings.status:
        col = layout.column()
        if settings.running:
            col.prop(settings, "progress", text="Progress", slider=True)
        col.label(text=settings.status)
    _stats_box(layout, settings)
    if getattr(settings, "method", None) is not None:
        compare.draw(layout, settings)
        trade.draw(layout, settings)


class ANTUMBRA_PT_render(bpy.types.Panel):
    bl_label = "antumbra"
    bl_idname = "ANTUMBRA_PT_render"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"

    def draw(self, context):
        draw_panel(self.layout, context)


class ANTUMBRA_PT_sidebar(bpy.types.Panel):
    bl_label = "antumbra"
    bl_idname = "ANTUMBRA_PT_sidebar"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "antumbra"

    def draw(self, context):
        draw_panel(self.layout, context)


CLASSES = (ANTUMBRA_PT_render, ANTUMBRA_PT_sidebar)
