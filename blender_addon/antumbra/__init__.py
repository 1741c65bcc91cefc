"""antumbra for Blender: sends the evaluated scene to the antumbra daemon frame by frame and brings
its shadow passes, traversal heat maps and statistics back into the Image Editor and into files;
also one of Blender's render engines (``engine``), whose passes fill the Render Result.

Installs as a legacy add-on (``bl_info``, Blender 3.4 to 4.1) or as an extension
(``blender_manifest.toml``, 4.2 and later). The client package it talks through is the
``antumbra`` wheel (Rust, pyo3): bundled under ``wheels/`` for the extension and unpacked under
``_vendor/`` for the legacy add-on; see ``client_loader``.
"""

from . import daemon, engine, exit_hook, operators, properties, ui

bl_info = {
    "name": "antumbra",
    "author": "antumbra developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Render engine antumbra; Properties > Render > antumbra; 3D View > Sidebar",
    "description": "Shadow passes and BVH traversal heat maps from the antumbra daemon",
    "category": "Render",
}

# Properties first: the operators, the panel and the engine read them.
_MODULES = (properties, operators, ui, engine)


def register():
    for module in _MODULES:
        module.register()
    exit_hook.install(__name__, unregister)


def unregister():
    exit_hook.removed()
    daemon.shutdown_link()
    for module in reversed(_MODULES):
        module.unregister()
