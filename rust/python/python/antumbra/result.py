"""One rendered frame as numpy arrays: :class:`Result`."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import _native

__all__ = [
    "OBJECT_PLANE",
    "Result",
]

#: The image of the ``object_ids`` pass.
OBJECT_PLANE = "primary.object"


@dataclass(frozen=True, eq=False)
class Result:
    """One rendered frame.

    Attributes:
        frame, width, height: the frame number and the image size in pixels.
        request_id: the render's request id.
        planes: every image in the daemon's order, as (name, array) pairs: the masks
            ``shadow.<light>`` (light order), ``combined``, ``primary.N_B|N_L|N_T``,
            ``shadow.N_B|N_L|N_T``; each a float32 array of shape (height, width), rows top to
            bottom.
        images: the planes by name; every name is unique (a light named like a heat map, or
            like an earlier light, gets ``#2``, ``#3``, ... after its name).
        masks: the shadow mask of each shadow-casting light (1 lit, 0 shadowed), by the light's
            part of its plane name: the light's name, made unique as in ``images``.
        stats: one dict per pass (the primary pass, then each shadow-casting light) with the
            columns of ``antumbra_core::stats::StatsRow``.
        visible: the visible set, a uint32 array of shape (k, 2) of (object index, triangle
            index) rows, sorted; None unless the ``visible`` pass was asked for.
        object_ids: (property) the ``primary.object`` plane of the ``object_ids`` pass.
    """

    frame: int
    width: int
    height: int
    request_id: int
    planes: list[tuple[str, np.ndarray]]
    stats: list[dict[str, Any]]
    visible: np.ndarray | None
    images: dict[str, np.ndarray] = field(default_factory=dict)
    masks: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def _from_native(cls, raw: dict[str, Any], passes: Sequence[str]) -> Result:
        planes = list(raw["images"])
        stats = list(raw["stats"])
        masks: dict[str, np.ndarray] = {}
        if "masks" in passes:
            # The masks come first, one per shadow row, named shadow.<unique light name>.
            count = sum(1 for row in stats if row["pass"] == "shadow")
            masks = {name.removeprefix("shadow."): array for name, array in planes[:count]}
        return cls(
            frame=raw["frame"],
            width=raw["width"],
            height=raw["height"],
            request_id=raw["request_id"],
            planes=planes,
            stats=stats,
            visible=raw["visible"],
            images=dict(planes),
            masks=masks,
        )

    @property
    def combined(self) -> np.ndarray | None:
        """The mean of the masks (None unless the ``combined`` pass was asked for)."""
        return self.images.get("combined")

    @property
    def object_ids(self) -> np.ndarray | None:
        """The ``object_ids`` pass (plane ``primary.object``): float32 (height, width), rows top
        to bottom, per pixel the index of the object the camera ray hit in the frame's object
        list (the order of :meth:`frame_update`'s ``objects``), -1 where it hit nothing. None
        unless the pass was asked for."""
        return self.images.get(OBJECT_PLANE)

    def save(
        self, directory: str | os.PathLike[str], *, exr: bool = True, png: bool = True
    ) -> list[str]:
        """Writes the frame's files into ``directory`` as ``antumbra render`` does (same Rust
        writer, so the same bytes for the same images): ``frame_NNNN.exr`` with every plane,
        mask PNGs and turbo heat-map PNGs with their scale. Needs the ``masks`` and
        ``combined`` passes. The ``object_ids`` plane is not written. Returns the file names
        written."""
        planes = [(name, array) for name, array in self.planes if name != OBJECT_PLANE]
        return _native.save_frame(
            os.fspath(directory), self.frame, self.width, self.height, planes, exr, png
        )

    def __repr__(self) -> str:
        names = ", ".join(name for name, _ in self.planes)
        return (
            f"<antumbra.Result frame={self.frame} {self.width}x{self.height} "
            f"images=[{names}] stats={len(self.stats)} rows>"
        )
