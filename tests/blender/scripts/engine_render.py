"""Installs the add-on as a user would, chooses the antumbra render engine, renders frames through
Blender's own render operator (``bpy.ops.render.render``, multilayer EXR output) and lists the
passes a compositor's Render Layers node shows. Runs in Debian's Blender (``blender -b -P
engine_render.py -- ARGS``, legacy zip) and in the bpy module (``python engine_render.py --
ARGS``, extension zip). Writes OUT/report.json.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import traceback

import bpy


def args():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--zip", required=True)
    p.add_argument("--kind", choices=("legacy", "extension"), required=True)
    p.add_argument("--blend", required=True)
    p.add_argument("--frames", required=True, help="A-B")
    p.add_argument("--out", required=True)
    p.add_argument("--binary", required=True)
    p.add_argument("--socket", required=True)
    p.add_argument("--spp", type=int, default=2)
    return p.parse_args(argv)


def install(kind: str, zip_path: str) -> str:
    if kind == "legacy":
        import addon_utils

        bpy.ops.preferences.addon_install(filepath=zip_path)
        addon_utils.enable("antumbra", default_set=True)
        return "antumbra"
    bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo="user_default", enable_on_install=True
    )
    return "bl_ext.user_default.antumbra"


def render_layers_outputs(scene) -> list[str]:
    """The outputs a new Render Layers node of the compositor offers for this scene."""
    if hasattr(scene, "compositing_node_group"):  # Blender 5.0 and later
        tree = bpy.data.node_groups.new("antumbra passes", "CompositorNodeTree")
        scene.compositing_node_group = tree
    else:
        scene.use_nodes = True
        tree = scene.node_tree
    node = tree.nodes.new("CompositorNodeRLayers")
    node.scene = scene
    node.layer = scene.view_layers[0].name
    return [o.name for o in node.outputs if o.enabled]


def main():
    a = args()
    os.makedirs(a.out, exist_ok=True)
    report = {"version": bpy.app.version_string}
    module_name = install(a.kind, a.zip)
    bpy.ops.wm.open_mainfile(filepath=a.blend)
    prefs = bpy.context.preferences.addons[module_name].preferences
    prefs.binary_path, prefs.socket_path = a.binary, a.socket
    scene = bpy.context.scene
    scene.render.engine = "ANTUMBRA"
    first, last = (int(f) for f in a.frames.split("-"))
    scene.frame_start, scene.frame_end = first, last
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):  # Blender 5.0: the format follows the media type
        settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.color_depth = "32"
    scene.render.filepath = os.path.join(a.out, "frame_####")
    scene.antumbra.method.spp = a.spp
    report["engine"] = scene.render.engine
    report["render"] = sorted(bpy.ops.render.render(animation=True))
    report["outputs"] = render_layers_outputs(scene)
    with open(os.path.join(a.out, "report.json"), "w") as f:
        json.dump(report, f, indent=1)


if __name__ == "__main__":
    try:
        main()
        code = 0
    except Exception:  # noqa: BLE001 - the test reads the traceback
        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
