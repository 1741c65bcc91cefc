"""Installs the add-on as a user would, chooses the antumbra render engine, renders frames through
Blender's own render operator (``bpy.ops.render.render``, multilayer EXR output) and lists the
passes a compositor's Render Layers node shows. Runs in Debian's Blender (``blender -b -P
engine_render.py -- ARGS``, legacy zip) and in the bpy module (``python engine_render.py --
ARGS``, extension zip). Writes OUT/report.json.
"""

from __future__ import annotations

import json
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from addon_script import exit_after, install, open_blend, parse_args


def more_args(p) -> None:
    p.add_argument("--frames", required=True, help="A-B")
    p.add_argument("--spp", type=int, default=2)


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
    a = parse_args(more_args)
    os.makedirs(a.out, exist_ok=True)
    report = {"version": bpy.app.version_string}
    scene = open_blend(a, install(a.kind, a.zip))
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
    exit_after(main)
