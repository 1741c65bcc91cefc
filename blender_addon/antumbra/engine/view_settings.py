"""Masks and heat maps are data: the engine's passes reach the user as their values, shown and
saved through Blender's Standard view (a lit pixel 1.0 is 255 in a PNG; a heat map's colours
are its legend's). A new scene's view transform (Filmic, AgX) would bend them (1.0 becomes 207).

While the scene's engine is antumbra (from its render's start, or as soon as the user picks
it in the UI), the scene's view settings are Standard, and the user's own are kept in
``scene.antumbra.saved_view``; they come back when the scene renders with, or is switched to,
another engine. ``scene.antumbra.view_as_values`` off leaves the user's view alone.
"""

from __future__ import annotations

import json

import bpy

#: The view settings under which a pass's value is its pixel: sRGB's curve and nothing else.
VALUES = {
    "view_transform": "Standard",
    "look": "None",
    "exposure": 0.0,
    "gamma": 1.0,
    "use_curve_mapping": False,
}
#: Who the engine-change subscription belongs to (to clear it).
_OWNER = object()


def shows_values(view) -> bool:
    return all(getattr(view, k) == v for k, v in VALUES.items())


def take(scene) -> bool:
    """Standard view for antumbra's values, the user's view kept; True if it changed."""
    settings = scene.antumbra
    if not settings.view_as_values or shows_values(scene.view_settings):
        return False
    view = scene.view_settings
    if not settings.saved_view:
        settings.saved_view = json.dumps({k: getattr(view, k) for k in VALUES})
    for key, value in VALUES.items():
        setattr(view, key, value)
    return True


def give_back(scene) -> bool:
    """The user's own view settings again (another engine); True if there were some."""
    settings = scene.antumbra
    if not settings.saved_view:
        return False
    saved = json.loads(settings.saved_view)
    settings.saved_view = ""
    for key, value in saved.items():
        try:
            setattr(scene.view_settings, key, value)
        except (TypeError, ValueError):
            pass  # a look or transform this Blender lacks (a file from another version)
    return True


def follow_engine(scene, engine_id: str) -> None:
    """Standard view while the scene renders with antumbra, the user's with any other."""
    if scene.render.engine == engine_id:
        take(scene)
    else:
        give_back(scene)


def _engine_changed(engine_id: str):
    for scene in bpy.data.scenes:
        follow_engine(scene, engine_id)


def register(engine_id: str) -> None:
    # Persistent: a file load keeps it (a dropped subscription's function would outlive Python).
    bpy.msgbus.subscribe_rna(
        key=(bpy.types.RenderSettings, "engine"),
        owner=_OWNER,
        args=(engine_id,),
        notify=_engine_changed,
        options={"PERSISTENT"},
    )


def unregister() -> None:
    bpy.msgbus.clear_by_owner(_OWNER)
