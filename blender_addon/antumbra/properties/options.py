"""What one render asks of the daemon, as plain values shared by the panel and batches: the
method settings by name (as the client's settings schema names them) and the add-on's own
output options."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class RenderOptions:
    #: Render settings by name (``antumbra.settings_schema()``); the rest take their defaults.
    settings: dict = field(default_factory=dict)
    #: Multiplies the scene's resolution percentage (a quick preview at 0.25); the default, 1,
    #: renders the scene's own size, in the panel as in batches.
    resolution_scale: float = 1.0
    heat_maps: bool = True
    #: Per-frame files in the output folder (``frame_NNNN.exr`` and PNGs).
    save_exr: bool = True
    save_png: bool = True

    def wants_normals(self) -> bool:
        """Whether the settings read shading normals (``facing="shading"``, docs/facing.md)."""
        return self.settings.get("facing") == "shading"

    def settings_kwargs(self) -> dict:
        """The render settings, as ``render()`` and ``antumbra.render_settings()`` take them."""
        return dict(self.settings)

    def render_kwargs(self) -> dict:
        passes = ["masks", "combined"] + (["heat_maps"] if self.heat_maps else [])
        return {**self.settings_kwargs(), "passes": tuple(passes)}

    def percentage(self, scene_percentage: int) -> int:
        return max(1, min(10000, round(scene_percentage * self.resolution_scale)))

    def size(self, x: int, y: int, scene_percentage: int) -> tuple[int, int]:
        """The image's pixels, as the daemon sizes them (rust/core/src/scene/camera.rs)."""
        p = self.percentage(scene_percentage)
        return max(1, x * p // 100), max(1, y * p // 100)

    def describe(self, defaults: dict | None = None) -> str:
        """The settings that differ from ``defaults`` (all given ones without it)."""
        defaults = defaults or {}
        shown = {k: v for k, v in self.settings.items() if defaults.get(k, object()) != v}
        return " ".join(f"{k}={v}" for k, v in shown.items()) or "default settings"
