"""Leaves Blender nothing of this add-on's when Python exits.

Run as the ``bpy`` module, Blender 4.2 and 4.5 tear themselves down only when Python frees the
``bpy`` module. Registered classes outlive Python (Blender keeps PropertyGroups and add-on
preferences even once unregistered), and their functions hold this package's module globals,
which hold ``bpy``: ``bpy`` is never freed, Blender's exit never runs, and 4.2 then crashes
(freeing its panels after Python) or 4.5 hangs. So at Python's exit the add-on unregisters if it
is still registered, and its classes drop their functions and property definitions.
"""

from __future__ import annotations

import atexit
import sys

import bpy

#: The add-on's unregister while it is registered, else None.
_unregister = None
#: The add-on's modules, as they were when it was last registered.
_modules: list = []
_installed = False


def install(package: str, unregister) -> None:
    """The add-on is registered: ``unregister`` runs at Python's exit unless it ran before."""
    global _unregister, _modules, _installed
    _unregister = unregister
    _modules = [m for n, m in sys.modules.items() if n == package or n.startswith(package + ".")]
    if not _installed:
        atexit.register(_at_exit)
        _installed = True


def removed() -> None:
    """The add-on was unregistered."""
    global _unregister
    _unregister = None


def _at_exit() -> None:
    try:
        if _unregister is not None:
            _unregister()
    finally:
        for module in _modules:
            _strip_classes(module)


def _strip_classes(module) -> None:
    for value in list(vars(module).values()):
        if isinstance(value, type) and issubclass(value, bpy.types.bpy_struct):
            for attr, member in list(vars(value).items()):
                if callable(member) or isinstance(member, (staticmethod, classmethod, property)):
                    delattr(value, attr)
            value.__annotations__ = {}
