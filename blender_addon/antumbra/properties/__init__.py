"""What the add-on keeps in Blender: the preferences (binary, socket), the per-scene settings and
panel state, the method settings made from the client's schema, and one render's options."""

from . import preferences, scene

_MODULES = (preferences, scene)


def register():
    for module in _MODULES:
        module.register()


def unregister():
    for module in reversed(_MODULES):
        module.unregister()
