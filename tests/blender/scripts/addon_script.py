"""What the scripts that drive the installed add-on share: their common arguments, installing
the add-on as a user would (legacy zip or extension), opening the .blend with the daemon set in
the add-on's preferences, and exiting with the script's status (Blender would exit 0 after a
-P script whatever happened)."""

from __future__ import annotations

import argparse
import os
import sys
import threading
import traceback

import bpy


def parse_args(add_more=None) -> argparse.Namespace:
    """``--zip``, ``--kind``, ``--blend``, ``--out``, ``--binary``, ``--socket`` and what
    ``add_more(parser)`` adds, from the arguments after ``--``."""
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--zip", required=True)
    p.add_argument("--kind", choices=("legacy", "extension"), required=True)
    p.add_argument("--blend", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--binary", required=True)
    p.add_argument("--socket", required=True)
    if add_more is not None:
        add_more(p)
    return p.parse_args(argv)


def install(kind: str, zip_path: str) -> str:
    """Installs and enables the add-on; its module name."""
    if kind == "legacy":
        import addon_utils

        bpy.ops.preferences.addon_install(filepath=zip_path)
        addon_utils.enable("antumbra", default_set=True)
        return "antumbra"
    bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo="user_default", enable_on_install=True
    )
    return "bl_ext.user_default.antumbra"


def open_blend(a: argparse.Namespace, module_name: str):
    """Opens ``--blend`` with the daemon's binary and socket set; its scene."""
    bpy.ops.wm.open_mainfile(filepath=a.blend)
    prefs = bpy.context.preferences.addons[module_name].preferences
    prefs.binary_path, prefs.socket_path = a.binary, a.socket
    return bpy.context.scene


def exit_after(main) -> None:
    """Runs ``main`` and exits 1 on any exception, 0 otherwise.

    In the ``bpy`` module the script ends through Python's own exit, as any user's script does,
    so a crash or hang at exit (Blender 4.2 and 4.5 with add-ons left registered) fails the
    test; a Python thread still running then is an error too. Blender's binary exits 0 after a
    ``-P`` script whatever happened, so there the status is set by ``os._exit``."""
    try:
        main()
        code = 0
    except Exception:  # noqa: BLE001 - the test reads the traceback
        traceback.print_exc()
        code = 1
    if not bpy.app.binary_path:  # the bpy module
        left = [t.name for t in threading.enumerate() if t is not threading.main_thread()]
        if left:
            print(f"addon_script: threads left at exit: {left}", file=sys.stderr)
            code = code or 1
        sys.stdout.flush()
        sys.exit(code)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
