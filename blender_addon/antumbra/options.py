"""What one render asks of the daemon, as plain values shared by the panel and batches."""

from __future__ import annotations

from dataclasses import dataclass, field

#: BVH builders the daemon offers (``--build``).
BUILDS = ("sah",)
#: Child orders of the shadow-ray traversal (``--order``).
ORDERS = ("near", "stored")


@dataclass
class RenderOptions:
    build: str = "sah"
    order: str = "near"
    spp: int = 4
    seed: int = 0
    #: Multiplies the scene's resolution percentage (a quick preview at 0.25).
    resolution_scale: float = 1.0
    heat_maps: bool = True
    #: Per-frame files in the output folder (``frame_NNNN.exr`` and PNGs).
    save_exr: bool = True
    save_png: bool = True
    extra: dict = field(default_factory=dict)

    def render_kwargs(self) -> dict:
        passes = ["masks", "combined"] + (["heat_maps"] if self.heat_maps else [])
        return {
            "spp": self.spp,
            "seed": self.seed,
            "build": self.build,
            "order": self.order,
            "passes": tuple(passes),
            **self.extra,
        }

    def percentage(self, scene_percentage: int) -> int:
        return max(1, min(10000, round(scene_percentage * self.resolution_scale)))

    def describe(self) -> str:
        return f"build={self.build} order={self.order} spp={self.spp}"
