"""``read_instances`` (the add-on's bulk read of instances, issue 37) against the exporter's
``depsgraph.object_instances`` walk, in Debian's Blender 3.4 (``blender -b``) and in the bpy
module of this Python (the GeometrySet route from Blender 4.3; 3.4 and 4.2 have the loop only):
linked duplicates, collection instances, geometry-nodes scatters of three meshes (one with
``id`` attributes), a collection holding a scatter instanced twice, objects hidden from render,
camera or shadow rays, and a scatter that outputs its points too. The same placements, ids and
matrices to the bit, whichever route ran."""

from __future__ import annotations

import pytest
from test_export_count import KINDS, run_script

#: Scenes the GeometrySet route reads itself; the rest fall back to the loop as a whole.
GEOMETRY_SET_SCENES = {
    "linked_duplicates",
    "collection_instances",
    "scatter_three",
    "nested",
    "visibility_flags",
}


@pytest.mark.parametrize("kind", KINDS)
def test_read_instances_equals_the_depsgraph_loop(kind, addon_zips, short_tmp):
    found = run_script(kind, "instances_compare.py", short_tmp)
    scenes = found["scenes"]
    for name, scene in scenes.items():
        assert scene["same"], (name, scene["diff"], scene["loop_diff"])
        assert scene["exporter"] == scene["loop_shown"], (name, scene)
    assert scenes["scatter_three"]["placements"] > 3000 + 1000 + 3  # and the distributed ones
    # Two shown empties, each: the scatters with their instancers (the exporter, like the
    # depsgraph's viewport mode, keeps the hidden scatter's instances of shown objects).
    assert scenes["nested"]["placements"] == 2 * (501 + 41 + 50)
    assert scenes["beside_points"]["placements"] == 700 + 1
    routes = {name: scene["route"] for name, scene in scenes.items()}
    fast = {name for name, route in routes.items() if route == "geometry_set"}
    if kind == "blender" or not found["geometry_set_api"]:  # Blender 3.4 and 4.2
        assert fast == set(), routes
    else:
        assert fast == GEOMETRY_SET_SCENES, routes
