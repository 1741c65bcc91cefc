"""Per-scene settings of the panel, and the state it shows (daemon status, progress, last
frame's statistics, the last comparison's and trade's tables); the methods a comparison runs
and the knobs a trade sweeps."""

from __future__ import annotations

import bpy

from .. import client_loader
from . import method_settings
from .options import RenderOptions


class AntumbraCompareMethod(bpy.types.PropertyGroup):
    """One method of a comparison: its label is the item's ``name``."""

    settings: bpy.props.StringProperty(
        name="Settings",
        description="The settings this method changes, NAME=VALUE,... with the settings' own "
        "names (e.g. build=osah,visibility=previous,width=8,order=sorted); the others take the "
        "panel's values",
    )

    def spec(self) -> str:
        """``LABEL=NAME=VALUE,...``, as ``compare`` takes a method."""
        return f"{self.name}={self.settings}"


class AntumbraTradeKnob(bpy.types.PropertyGroup):
    """One knob of the client's ``KNOBS``: its name is the item's ``name``."""

    use: bpy.props.BoolProperty(name="Sweep", description="Sweep this knob", default=False)
    values: bpy.props.StringProperty(
        name="Values",
        description="The values to sweep, V1,V2,... (empty: the knob's own; the default is "
        "added when missing)",
    )

    def text(self) -> str:
        """``NAME`` or ``NAME=V1,V2,...``, as ``trade_frame`` takes a knob."""
        return f"{self.name}={self.values}" if self.values.strip() else self.name


class AntumbraSettings(bpy.types.PropertyGroup):
    # `method` (the render settings, one property per schema setting) is added at registration,
    # from the client's schema.
    resolution_scale: bpy.props.FloatProperty(
        name="Resolution scale",
        description="Multiplies the render resolution percentage (1: the scene's own size, as "
        "batches render it)",
        default=RenderOptions.resolution_scale,
        min=0.01,
        max=1.0,
        subtype="FACTOR",
    )
    heat_maps: bpy.props.BoolProperty(
        name="Heat maps", description="Node, leaf and triangle work per pixel", default=True
    )
    view_as_values: bpy.props.BoolProperty(
        name="Show values as values",
        description="While antumbra renders this scene, show and save its passes through the "
        "Standard view (a lit pixel is 255, a heat map has its legend's colours); your view "
        "transform and look come back with another engine",
        default=True,
    )
    saved_view: bpy.props.StringProperty(
        description="The view settings antumbra's Standard view replaced (JSON)",
        options={"HIDDEN"},
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
    use_animation_start: bpy.props.BoolProperty(
        name="Animation start",
        description="Render frames as one run from Animation start would (a farm's task "
        "renders -s A -e B of a longer animation; a resumed render): the render engine first "
        "warms the daemon up on the frames before each frame it has not just rendered",
        default=False,
    )
    animation_start: bpy.props.IntProperty(
        name="Animation start",
        description="The animation's first frame: a render of frames after it warms up on up "
        "to two frames before its first (their trees and visible sets: no shadow rays, no "
        "files), so its frames equal those of one run from here",
        default=1,
    )
    compare_methods: bpy.props.CollectionProperty(type=AntumbraCompareMethod)
    compare_index: bpy.props.IntProperty(name="Method", min=0)
    compare_baseline: bpy.props.StringProperty(
        name="Baseline",
        description="The method the others are checked and measured against (default: the first)",
    )
    compare_repeat: bpy.props.IntProperty(
        name="Repeat",
        description="Timed passes per method and frame, interleaved across methods (the "
        "timings are their median)",
        default=3,
        min=1,
        max=100,
    )
    trade_knobs: bpy.props.CollectionProperty(type=AntumbraTradeKnob)
    trade_index: bpy.props.IntProperty(name="Knob", min=0)
    trade_repeat: bpy.props.IntProperty(
        name="Repeat",
        description="Timed passes per knob value and frame, interleaved across the values",
        default=3,
        min=1,
        max=100,
    )
    # State shown by the panel; written by the operators.
    compare_table: bpy.props.StringProperty(options={"SKIP_SAVE"})
    trade_table: bpy.props.StringProperty(options={"SKIP_SAVE"})
    last_stats: bpy.props.StringProperty(options={"SKIP_SAVE"})
    last_frame: bpy.props.IntProperty(options={"SKIP_SAVE"})
    status: bpy.props.StringProperty(options={"SKIP_SAVE"})
    progress: bpy.props.FloatProperty(min=0.0, max=1.0, subtype="FACTOR", options={"SKIP_SAVE"})
    running: bpy.props.BoolProperty(options={"SKIP_SAVE"})

    def options(self) -> RenderOptions:
        method = getattr(self, "method", None)
        return RenderOptions(
            settings=method_settings.values(method) if method is not None else {},
            resolution_scale=self.resolution_scale,
            heat_maps=self.heat_maps,
            save_exr=self.save_files,
            save_png=self.save_files,
        )

    def first_frame(self) -> int | None:
        """Where the animation starts, for the engine's warm-up (None: no warm-up)."""
        return self.animation_start if self.use_animation_start else None

    def compare_specs(self) -> list[str]:
        """The comparison's methods as ``LABEL=NAME=VALUE,...`` (the defaults if none)."""
        if not self.compare_methods:
            fill_default_methods(self)
        return [m.spec() for m in self.compare_methods]

    def compare_baseline_label(self) -> str:
        labels = [m.name for m in self.compare_methods]
        return self.compare_baseline if self.compare_baseline in labels else labels[0]

    def trade_texts(self) -> list[str]:
        """The knobs ticked, as ``NAME`` or ``NAME=V1,...`` (none ticked: [], every knob)."""
        return [k.text() for k in self.trade_knobs if k.use]


_method_class = None


def fill_knobs(settings) -> None:
    """Lists the client's knobs (``KNOBS``), keeping the ticks and values of those listed."""
    kept = {k.name: (k.use, k.values) for k in settings.trade_knobs}
    settings.trade_knobs.clear()
    for knob in client_loader.load().KNOBS:
        item = settings.trade_knobs.add()
        item.name = knob["name"]
        item.use, item.values = kept.get(knob["name"], (False, ""))


def fill_default_methods(settings) -> None:
    """Replaces the comparison's methods with the client's defaults (baseline first)."""
    settings.compare_methods.clear()
    for spec in client_loader.load().DEFAULT_METHODS:
        label, _, rest = spec.partition("=")
        item = settings.compare_methods.add()
        item.name, item.settings = label, rest
    settings.compare_index = 0
    settings.compare_baseline = settings.compare_methods[0].name


@bpy.app.handlers.persistent
def _prefill_methods(*_args):
    """Gives every scene without methods the defaults (a new add-on, a loaded .blend)."""
    try:
        client_loader.load()
    except client_loader.ClientMissing:
        return
    for scene in bpy.data.scenes:
        if not scene.antumbra.compare_methods:
            fill_default_methods(scene.antumbra)
        if not scene.antumbra.trade_knobs:
            fill_knobs(scene.antumbra)


def register():
    global _method_class
    try:
        client_loader.load()
    except client_loader.ClientMissing:
        # The panel says what is missing; the method settings need the client's schema.
        _method_class = None
    else:
        _method_class = method_settings.property_group()
        bpy.utils.register_class(_method_class)
        AntumbraSettings.__annotations__["method"] = bpy.props.PointerProperty(type=_method_class)
    bpy.utils.register_class(AntumbraCompareMethod)
    bpy.utils.register_class(AntumbraTradeKnob)
    bpy.utils.register_class(AntumbraSettings)
    bpy.types.Scene.antumbra = bpy.props.PointerProperty(type=AntumbraSettings)
    bpy.app.handlers.load_post.append(_prefill_methods)
    # The scenes open now (enabling the add-on); bpy.data is read-only inside register().
    # Persistent: a file loaded before it ran (the bpy module runs no timer) would drop it and
    # Blender would keep its function, and with it bpy, alive past Python (exit_hook).
    bpy.app.timers.register(_prefill_methods, first_interval=0.0, persistent=True)


def unregister():
    if _prefill_methods in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_prefill_methods)
    if bpy.app.timers.is_registered(_prefill_methods):
        bpy.app.timers.unregister(_prefill_methods)
    del bpy.types.Scene.antumbra
    bpy.utils.unregister_class(AntumbraSettings)
    bpy.utils.unregister_class(AntumbraTradeKnob)
    bpy.utils.unregister_class(AntumbraCompareMethod)
    AntumbraSettings.__annotations__.pop("method", None)
    if _method_class is not None:
        bpy.utils.unregister_class(_method_class)
