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

import bpy

#: The add-on's unregister while it is registered, else None.
_unregister = None
#: The add-on's package name (``antumbra``, or ``bl_ext.REPO.antumbra`` as an extension).
_package = ""
_installed = False


def install(package: str, unregister) -> None:
    """The add-on is registered: ``unregister`` runs at Python's exit unless it ran before."""
    global _unregister, _package, _installed
    _unregister, _package = unregister, package
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
        for cls in _classes_of(_package):
            _strip(cls)


def _classes_of(package: str) -> list[type]:
    """Every Blender class the package defined, also those made anew at each registration (the
    panel's settings group) that no module refers to any more."""
    found, todo = [], [bpy.types.bpy_struct]
    while todo:
        cls = todo.pop()
        todo.extend(cls.__subclasses__())
        module = getattr(cls, "__module__", "") or ""
        if module == package or module.startswith(package + "."):
            found.append(cls)
    return found


def _strip(cls: type) -> None:
    for attr, member in list(vars(cls).items()):
        if callable(member) or isinstance(member, (staticmethod, classmethod, property)):
            delattr(cls, attr)
    cls.__annotations__ = {}
