"""Blender's command line over the ``bpy`` module, for the parts a farm task uses: so the farm
job (``farm/template.yaml``) runs in the bpy module's Blender (4.2, 4.5, 5.x) as it runs in a
Blender executable.

    python bpy_blender.py -b [--factory-startup] [-noaudio] FILE [--python-exit-code N]
        [-P SCRIPT | -E ENGINE | -s N | -e N | -a ...] [-- ARGS]

Each option acts in order, as Blender's do; ``sys.argv`` is the whole command line, as in
Blender. The exit status is Python's own exit (so a crash or hang at exit is seen), or N after a
script that raised.
"""

from __future__ import annotations

import runpy
import sys
import traceback

import bpy


def main(args: list[str]) -> int:
    exit_code_on_error = 0
    i = 0
    while i < len(args):
        arg = args[i]
        i += 1
        if arg == "--":
            break
        if arg in ("-b", "-noaudio", "--factory-startup"):
            continue  # the module runs in the background, silent, on factory settings already
        if arg == "--python-exit-code":
            exit_code_on_error, i = int(args[i]), i + 1
        elif arg == "-P":
            script, i = args[i], i + 1
            try:
                runpy.run_path(script, run_name="__main__")
            except SystemExit:
                raise
            except Exception:  # noqa: BLE001 - as Blender: the traceback, then the exit code
                traceback.print_exc()
                if exit_code_on_error:
                    return exit_code_on_error
        elif arg == "-E":
            bpy.context.scene.render.engine, i = args[i], i + 1
        elif arg == "-s":
            bpy.context.scene.frame_start, i = int(args[i]), i + 1
        elif arg == "-e":
            bpy.context.scene.frame_end, i = int(args[i]), i + 1
        elif arg == "-a":
            bpy.ops.render.render(animation=True)
        elif arg.endswith(".blend"):
            bpy.ops.wm.open_mainfile(filepath=arg)
        else:
            print(f"bpy_blender: {arg}: not one of the options it knows", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
