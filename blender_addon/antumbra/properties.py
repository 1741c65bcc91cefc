"""Per-scene settings of the panel, and the state it shows (daemon status, progress, last
frame's statistics)."""

from __future__ import annotations

import bpy

from .options import BUILDS, ORDERS, VISIBILITIES, WIDTHS, RenderOptions

_BUILD_TEXT = {
    "sah": ("SAH", "Binned surface area heuristic"),
    "sbvh": ("SBVH", "SAH with spatial splits"),
    "abvh": ("ABVH", "Spatial splits only where the visible triangles are"),
    "osah": ("OSAH", "Occlusion heuristic from the visible triangles"),
    "vsah": ("VSAH", "SAH over the visible triangles only (a reference)"),
}
_ORDER_TEXT = {
    "fbto": ("Front to back", "Nearer child first"),
    "stored": ("Stored", "Children in build order"),
    "sato": ("SATO", "Largest surface area first"),
    "rtsah": ("RTSAH", "By estimated termination cost"),
    "random": ("Random", "Seeded random order"),
    "sorted": ("Sorted per light", "Sorted from the light's own representative shadow rays"),
    "srdh": ("SRDH per light", "A shadow-ray BVH with traversal kernels per mostly-occluded light"),
}
_VISIBILITY_TEXT = {
    "previous": ("Previous frame", "The triangles the previous frame's camera saw"),
    "exact": ("This frame", "This frame's own visible triangles (two passes)"),
    "prepass": ("Prepass", "Previous frame, a low-resolution prepass on the first frame"),
}


def _items(keys, text):
    return [(k, *text.get(k, (k, k))) for k in keys]


class AntumbraSettings(bpy.types.PropertyGroup):
    build: bpy.props.EnumProperty(name="Build", items=_items(BUILDS, _BUILD_TEXT))
    width: bpy.props.EnumProperty(
        name="Width",
        description="Children per BVH node",
        items=[(str(w), str(w), f"{w}-wide BVH") for w in WIDTHS],
    )
    order: bpy.props.EnumProperty(
        name="Shadow order", items=_items(ORDERS, _ORDER_TEXT), description="Child order"
    )
    sample_budget: bpy.props.FloatProperty(
        name="Sample budget",
        description="Share of each light's shadow rays that decide its sorted order",
        default=0.05,
        min=0.001,
        max=1.0,
    )
    visibility: bpy.props.EnumProperty(
        name="Visibility", items=_items(VISIBILITIES, _VISIBILITY_TEXT)
    )
    min_leaf_size: bpy.props.IntProperty(
        name="Smallest leaf",
        description=(
            "Nodes of at most this many triangles become leaves without a split search: "
            "faster rebuilds, more triangle tests per ray"
        ),
        default=1,
        min=1,
        max=8,
    )
    spp: bpy.props.IntProperty(
        name="Samples",
        description="Shadow samples per pixel for soft lights (hard lights take one ray)",
        default=4,
        min=1,
        max=4096,
    )
    seed: bpy.props.IntProperty(name="Seed", default=0, min=0)
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
        return RenderOptions(
            build=self.build,
            width=int(self.width),
            order=self.order,
            sample_budget=self.sample_budget,
            visibility=self.visibility,
            min_leaf_size=self.min_leaf_size,
            spp=self.spp,
            seed=self.seed,
            resolution_scale=self.resolution_scale,
            heat_maps=self.heat_maps,
            save_exr=self.save_files,
            save_png=self.save_files,
        )


def register():
    bpy.utils.register_class(AntumbraSettings)
    bpy.types.Scene.antumbra = bpy.props.PointerProperty(type=AntumbraSettings)


def unregister():
    del bpy.types.Scene.antumbra
    bpy.utils.unregister_class(AntumbraSettings)
