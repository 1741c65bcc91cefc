"""Add-on preferences: where the antumbra binary and the daemon's socket are."""

from __future__ import annotations

from dataclasses import dataclass

import bpy

#: The add-on's package (``antumbra``, or ``bl_ext.REPO.antumbra`` as an extension), which
#: Blender names its preferences by; this module lives one level below it.
ADDON_ID = __package__.rpartition(".")[0]


class AntumbraPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON_ID

    binary_path: bpy.props.StringProperty(
        name="antumbra binary",
        description=(
            "The antumbra executable that runs the daemon (empty: $ANTUMBRA_BIN, the copy "
            "bundled with the add-on, then antumbra on PATH)"
        ),
        subtype="FILE_PATH",
    )
    socket_path: bpy.props.StringProperty(
        name="Socket",
        description="The daemon's Unix socket (empty: the daemon's default path)",
        subtype="FILE_PATH",
    )
    start_automatically: bpy.props.BoolProperty(
        name="Start the daemon when needed",
        description="Start the daemon when a render finds none running",
        default=True,
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "binary_path")
        layout.prop(self, "socket_path")
        layout.prop(self, "start_automatically")


@dataclass
class Preferences:
    """The preferences as plain values, also when the add-on is not registered (batches)."""

    binary_path: str = ""
    socket_path: str = ""
    start_automatically: bool = True


def get() -> Preferences:
    addon = bpy.context.preferences.addons.get(ADDON_ID)
    if addon is None or addon.preferences is None:
        return Preferences()
    p = addon.preferences
    return Preferences(
        binary_path=bpy.path.abspath(p.binary_path) if p.binary_path else "",
        socket_path=bpy.path.abspath(p.socket_path) if p.socket_path else "",
        start_automatically=p.start_automatically,
    )


def register():
    bpy.utils.register_class(AntumbraPreferences)


def unregister():
    bpy.utils.unregister_class(AntumbraPreferences)
