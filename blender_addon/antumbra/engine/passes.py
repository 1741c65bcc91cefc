"""The render engine's passes: one per plane of the core (``shadow.<light>``, ``combined``, the
heat maps), named as the core names the plane (``combined`` is Blender's ``Combined``), with the
lights' unique names asked of the core itself, so no second naming scheme exists."""

from __future__ import annotations

import functools
import hashlib

import numpy as np

from .. import client_loader
from ..export.exporter import light_dict

#: Blender's own pass of every engine, where the mean of the masks goes.
COMBINED = "Combined"
#: The planes the engine leaves out (object ids are a comparison tool, not an image).
SKIPPED = ("primary.object",)
#: Blender keeps this many bytes of a pass's name (``RenderPass.name`` is 64 with its NUL), and
#: of a multilayer EXR's channel name, ``<layer>.<pass>.<channel>`` (``EXR_TOT_MAXNAME``).
MAX_NAME_BYTES = 63
#: Hex digits of the hash that keeps a shortened name unique.
DIGEST = 8


def pass_name(plane: str, layer: str) -> str:
    """The pass of a plane in view layer ``layer``: its name, ``Combined`` for ``combined``, and
    a name that would not fit Blender's names (a light with a long name) cut at a whole letter
    and ended with ``~`` and a hash of the whole name, so that two long names sharing their
    start stay two passes, in the Render Result and in the EXR's channels."""
    if plane == "combined":
        return COMBINED
    raw = plane.encode()
    # The EXR's channel adds the layer's name and a dot before, a dot and one letter after.
    fits = min(MAX_NAME_BYTES, MAX_NAME_BYTES - len(layer.encode()) - 3)
    if len(raw) <= fits:
        return plane
    digest = hashlib.sha1(raw).hexdigest()[:DIGEST]
    head = raw[: max(0, fits - DIGEST - 1)].decode("utf-8", errors="ignore")
    return f"{head}~{digest}"


def channels(name: str) -> tuple[int, str, str]:
    """(channels, channel ids, socket type) of a pass, as ``register_pass`` takes them."""
    return (4, "RGBA", "COLOR") if name == COMBINED else (1, "X", "VALUE")


def result_passes(heat_maps: bool) -> tuple[str, ...]:
    """What the engine asks the daemon for."""
    return ("masks", "combined", "heat_maps") if heat_maps else ("masks", "combined")


@functools.lru_cache(maxsize=64)
def _planes(lights: tuple[tuple[str, str, bool], ...], heat_maps: bool) -> tuple[str, ...]:
    # The core names the planes of a frame (rust/core/src/output/names.rs): render an empty 1x1
    # frame with these lights in this process and read the names back (well under a millisecond).
    client = client_loader.load()
    identity = np.eye(4).tolist()
    session = client.LocalSession(client_name="antumbra-passes")
    try:
        camera = {"matrix_world": identity}
        sent = [
            {"name": n, "type": t, "matrix_world": identity, "use_shadow": s} for n, t, s in lights
        ]
        session.frame_update(0, [], camera, sent, (1, 1))
        result = session.render(0, passes=result_passes(heat_maps), spp=1)
    finally:
        session.close()
    return tuple(p for p, _ in result.planes if p not in SKIPPED)


def planes(lights: list[dict], heat_maps: bool) -> tuple[str, ...]:
    """The core's plane names of a frame with these lights (the exporter's light dicts)."""
    key = tuple((d["name"], d["type"], bool(d.get("use_shadow", True))) for d in lights)
    return _planes(key, heat_maps)


def view_layer_lights(view_layer) -> list[dict]:
    """The lights a render of this view layer exports, as far as the original scene tells before
    evaluation (instanced lights appear at render time and get their passes then)."""
    return [
        light_dict(obj.name, obj, obj.matrix_world)
        for obj in view_layer.objects
        if obj.type == "LIGHT" and not obj.hide_render
    ]


def names(view_layer, heat_maps: bool) -> list[str]:
    """The passes of a view layer, Combined first."""
    lights = view_layer_lights(view_layer)
    out = [pass_name(p, view_layer.name) for p in planes(lights, heat_maps)]
    return [COMBINED] + [n for n in out if n != COMBINED]


def pixels(name: str, array: np.ndarray) -> np.ndarray:
    """A plane (rows top to bottom) as a pass's flat pixels (rows bottom to top); the combined
    pass is grey with alpha 1."""
    rows = np.ascontiguousarray(array[::-1], dtype=np.float32)
    if name != COMBINED:
        return rows.ravel()
    rgba = np.ones((*rows.shape, 4), dtype=np.float32)
    rgba[..., :3] = rows[..., None]
    return rgba.ravel()


def fill(layer, result) -> list[str]:
    """Writes every plane of ``result`` into the pass of its name in ``layer`` (a RenderLayer of
    ``begin_result``); returns the passes written."""
    by_name = {p.name: p for p in layer.passes}
    written = []
    for plane, array in result.planes:
        name = pass_name(plane, layer.name)
        target = by_name.get(name)
        if target is None or plane in SKIPPED:
            continue
        flat = pixels(name, array)
        try:
            target.rect.foreach_set(flat)
        except (AttributeError, TypeError):
            # Blenders whose pass arrays lack foreach_set take a (pixels, channels) sequence.
            target.rect = flat.reshape(-1, target.channels)
        written.append(name)
    return written
