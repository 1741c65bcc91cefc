"""The panel (Render properties and the 3D view's sidebar) and its Compare and Trade sections."""

import bpy

from . import compare, panel, trade

CLASSES = (*compare.CLASSES, *trade.CLASSES, *panel.CLASSES)

# Registered in order, unregistered in reverse.
register, unregister = bpy.utils.register_classes_factory(CLASSES)
