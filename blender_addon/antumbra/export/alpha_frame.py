"""A frame's alpha materials and images as the client sends them (issue 38).

Each object's material slots become indices into one list of materials per frame (equal
materials shared, by name and contract), opaque slots ``None``; each image array the frame's
textures read is listed once, by the content hash a texture names it by (``image_hash``). The
job uploads those the session lacks (``exporter.send``). Warnings (unsupported nodes,
unreadable images, absent UV maps) are gathered once per frame, each said once.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # alpha_object imports the exporter's readers, and the exporter this module
    from .alpha_object import ObjectAlpha


@dataclass
class FrameAlpha:
    #: The protocol's alpha materials: ``name`` plus the contract, a texture's ``image`` its
    #: array's content hash.
    materials: list[dict] = field(default_factory=list)
    #: content hash -> float32 (height, width), rows bottom first: the arrays the frame reads.
    images: dict[int, np.ndarray] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    _index: dict[str, int] = field(default_factory=dict)

    def slots(self, found: ObjectAlpha, cache: dict, hashes: dict) -> list[int | None]:
        """FOUND's slots as indices into ``materials`` (None: opaque). CACHE is the
        ``object_alpha`` image cache, key -> (width, height, values); HASHES, key -> content
        hash, of the same arrays."""
        for w in found.warnings:
            if w not in self.warnings:
                self.warnings.append(w)
        out: list[int | None] = []
        for name, contract, key in zip(found.names, found.slots, found.image_keys, strict=True):
            if contract["kind"] == "opaque":
                out.append(None)
                continue
            material = {"name": name, **contract}
            if contract["kind"] == "texture":
                material.pop("channel")  # the array of KEY already holds the channel read
                material["image"] = hashes[key]
                self.images[hashes[key]] = cache[key][2]
            tag = json.dumps(material, sort_keys=True)
            if tag not in self._index:
                self._index[tag] = len(self.materials)
                self.materials.append(material)
            out.append(self._index[tag])
        return out
