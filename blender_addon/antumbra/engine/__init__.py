"""antumbra as one of Blender's render engines: the engine class and its job across frames, its
passes, the view and output settings its frames are shown and written with."""

from .render_engine import ENGINE_ID, register, unregister

__all__ = ["ENGINE_ID", "register", "unregister"]
