"""One object's alpha data, as the exporter will send it (issue 38): its slots' contracts, its
mesh's slots and UVs, and the images they read; every failure a warning and an opaque slot.

``object_alpha(obj_eval, mesh, images)`` returns an ``ObjectAlpha``:

- ``slots``: one contract per material slot, in slot order (``materials``' dicts);
- ``mesh``: ``alpha_mesh.mesh_alpha``'s ``MeshAlpha``, or None when no slot needs alpha (the
  object travels exactly as today);
- ``warnings``: ``material_alpha``'s, ``mesh_alpha``'s, and one per image that cannot be read
  (``object 'O', material 'M', node 'N': image 'I': file '...' is missing; exported opaque``:
  what Cycles casts too, as it renders a missing image opaque magenta).

IMAGES is the caller's cache across objects of a frame (or a job): ``image_key(source)`` to
``(width, height, values)``, filled here for each texture read for the first time, so an image
is read once however many objects use it. Nothing here raises for bad input.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .alpha_image import AlphaError, source_image
from .alpha_mesh import MeshAlpha, mesh_alpha
from .materials import AlphaSource, material_alpha


def image_key(source: AlphaSource) -> str:
    """The image array a texture source reads: one per image, channel and association."""
    return f"{source.image}|{source.channel}|{int(source.unassociate)}"


@dataclass
class ObjectAlpha:
    slots: list[dict]
    mesh: MeshAlpha | None
    warnings: list[str] = field(default_factory=list)
    #: Per slot: its material's name ("" for an empty slot) and, for a texture, the
    #: ``image_key`` of the array it reads in the caller's IMAGES (else None).
    names: list[str] = field(default_factory=list)
    image_keys: list[str | None] = field(default_factory=list)


def object_alpha(
    obj_eval, mesh, images: dict, read_mesh: bool = True, known: dict | None = None
) -> ObjectAlpha:
    """With READ_MESH false, ``mesh`` stays None (the caller holds the mesh's slots and UVs
    from an earlier frame). KNOWN memoises ``material_alpha`` by material within a frame (a
    thousand objects of one material walk its graph once)."""
    warnings: list[str] = []
    sources: list[tuple[str, AlphaSource]] = []
    for slot in obj_eval.material_slots:
        material = slot.material
        key = material.as_pointer() if material is not None else 0
        if known is not None and key in known:
            source = known[key]
        else:
            source = material_alpha(material)
            if known is not None:
                known[key] = source
        warnings += source.warnings
        if source.kind == "texture" and image_key(source) not in images:
            try:
                images[image_key(source)] = source_image(source, material.name, obj_eval.name)
            except AlphaError as e:
                warnings.append(f"{e}; exported opaque")
                source = AlphaSource(modes=source.modes)
        sources.append((material.name if material else "", source))
    found = mesh_alpha(obj_eval, mesh, sources) if read_mesh else None
    if found is not None:
        warnings += found.warnings
    return ObjectAlpha(
        slots=[s.contract() for _, s in sources],
        mesh=found,
        warnings=warnings,
        names=[name for name, _ in sources],
        image_keys=[image_key(s) if s.kind == "texture" else None for _, s in sources],
    )
