"""What one render asks of the daemon, as plain values shared by the panel and batches."""

from __future__ import annotations

from dataclasses import dataclass

#: BVH builders (``antumbra render --build``): binned SAH, spatial splits, and the
#: visibility-driven ABVH, OSAH and the VSAH reference.
BUILDS = ("sah", "sbvh", "abvh", "osah", "vsah")
#: Children per BVH node.
WIDTHS = (2, 4, 8)
#: Child orders of shadow rays (``--order``); "sorted" sorts per light from a budget of its rays;
#: "srdh" builds a shadow-ray BVH per mostly-occluded light from a 16x16 prepass of its rays.
ORDERS = ("fbto", "stored", "sato", "rtsah", "random", "sorted", "srdh")
#: Where ABVH/OSAH/VSAH take the visible triangles from.
VISIBILITIES = ("previous", "exact", "prepass")


@dataclass
class RenderOptions:
    build: str = "sah"
    width: int = 2
    order: str = "fbto"
    #: Share of a light's shadow rays that log occlusion for the sorted order (0..1].
    sample_budget: float = 0.05
    visibility: str = "previous"
    #: The first frame's primary prepass size for ``visibility="prepass"``.
    prepass: int = 32
    #: Nodes of at most this many triangles become leaves without a split search: a faster
    #: rebuild per frame for larger leaves (``antumbra render --min-leaf-size``; 1 to 8).
    min_leaf_size: int = 1
    spp: int = 4
    seed: int = 0
    #: Multiplies the scene's resolution percentage (a quick preview at 0.25).
    resolution_scale: float = 1.0
    heat_maps: bool = True
    #: Per-frame files in the output folder (``frame_NNNN.exr`` and PNGs).
    save_exr: bool = True
    save_png: bool = True

    def order_spec(self) -> str:
        """The order as ``--order`` spells it."""
        if self.order == "sorted":
            return f"sorted:budget={self.sample_budget:g}"
        return self.order

    def visibility_spec(self) -> str:
        if self.visibility == "prepass":
            return f"prepass:{self.prepass}x{self.prepass}"
        return self.visibility

    def settings_kwargs(self) -> dict:
        """The render settings, as ``render()`` and ``antumbra.render_settings()`` take them."""
        return {
            "spp": self.spp,
            "seed": self.seed,
            "build": self.build,
            "order": self.order_spec(),
            "width": self.width,
            "visibility": self.visibility_spec(),
            "min_leaf_size": self.min_leaf_size,
        }

    def render_kwargs(self) -> dict:
        passes = ["masks", "combined"] + (["heat_maps"] if self.heat_maps else [])
        return {**self.settings_kwargs(), "passes": tuple(passes)}

    def percentage(self, scene_percentage: int) -> int:
        return max(1, min(10000, round(scene_percentage * self.resolution_scale)))

    def describe(self) -> str:
        text = f"build={self.build} width={self.width} order={self.order_spec()} spp={self.spp}"
        if self.build in {"abvh", "osah", "vsah"}:
            text += f" visibility={self.visibility_spec()}"
        if self.min_leaf_size > 1:
            text += f" min_leaf_size={self.min_leaf_size}"
        return text
