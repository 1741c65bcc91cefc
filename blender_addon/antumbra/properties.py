"""Per-scene settings of the panel, and the state it shows (daemon status, progress, last
frame's statistics)."""

from __future__ import annotations

import bpy

from . import client_loader, settings_ui
from .options import RenderOptions


class AntumbraSettings(bpy.types.PropertyGroup):
    # `method` (the render settings, one property per schema setting) is added at registration,
    # from the client's schema.
    resolution_scale: bpy.props.FloatProperty(
        name="Resolution scale",
        description="Multiplies the render resolution percentage",
        default=0.5,
        min=0.01,
        max=1.0,
        subtype="FACTOR",
    )
    heat_maps: bpy.props.BoolProperty(
        name="Heat maps", description="Node, leaf and triangle work per pixel", default=True
    )
    output_dir: bpy.props.StringProperty(
        name="Output",
        description="Folder for per-frame EXR/PNG files and the statistics tables",
        default="//antumbra/",
        subtype="DIR_PATH",
    )
    save_files: bpy.props.BoolProperty(
        name="Save files", description="Write frame_NNNN.exr and PNGs per frame", default=True
    )
    # State shown by the panel; written by the operators.
    last_stats: bpy.props.StringProperty(options={"SKIP_SAVE"})
    last_frame: bpy.props.IntProperty(options={"SKIP_SAVE"})
    status: bpy.props.StringProperty(options={"SKIP_SAVE"})
    progress: bpy.props.FloatProperty(min=0.0, max=1.0, subtype="FACTOR", options={"SKIP_SAVE"})
    running: bpy.props.BoolProperty(options={"SKIP_SAVE"})

    def options(self) -> RenderOptions:
        method = getattr(self, "method", None)
        return RenderOptions(
            settings=settings_ui.values(method) if method is not None else {},
            resolution_scale=self.resolution_scale,
            heat_maps=self.heat_maps,
            save_exr=self.save_files,
            save_png=self.save_files,
        )


_method_class = None


def register():
    global _method_class
    try:
        client_loader.load()
    except client_loader.ClientMissing:
        # The panel says what is missing; the method settings need the client's schema.
        _method_class = None
    else:
        _method_class = settings_ui.property_group()
        bpy.utils.register_class(_method_class)
        AntumbraSettings.__annotations__["method"] = bpy.props.PointerProperty(type=_method_class)
    bpy.utils.register_class(AntumbraSettings)
    bpy.types.Scene.antumbra = bpy.props.PointerProperty(type=AntumbraSettings)


def unregister():
    del bpy.types.Scene.antumbra
    bpy.utils.unregister_class(AntumbraSettings)
    AntumbraSettings.__annotations__.pop("method", None)
    if _method_class is not None:
        bpy.utils.unregister_class(_method_class)
