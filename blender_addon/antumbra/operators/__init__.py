"""The add-on's operators: render, compare and trade (their jobs stepped from a timer or run to the
end), the method list and knob list, the daemon's start and stop."""

import bpy

from . import compare, render, trade

CLASSES = (*render.CLASSES, *compare.CLASSES, *trade.CLASSES)

# Registered in order, unregistered in reverse.
register, unregister = bpy.utils.register_classes_factory(CLASSES)
