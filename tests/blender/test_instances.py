"""``read_instances`` (the add-on's bulk read of instances, issue 37) against the exporter's
``depsgraph.object_instances`` loop, in Debian's Blender 3.4 (``blender -b``, the loop route)
and in the bpy module of this Python (the GeometrySet route from Blender 4.3): linked
duplicates, collection instances, a geometry-nodes scatter of three meshes, a collection
holding a scatter instanced twice, and objects hidden from render, camera or shadow rays. The
same placements, ids and matrices to the bit, whichever route ran."""

from __future__ import annotations

import pytest
from test_export_count import KINDS, run_script

#: Scenes the GeometrySet route reads itself; the rest fall back to the loop as a whole.
GEOMETRY_SET_SCENES = {"linked_duplicates", "scatter_three", "visibility_flags"}


@pytest.mark.parametrize("kind", KINDS)
def test_read_instances_equals_the_depsgraph_loop(kind, addon_zips, short_tmp):
    found = run_script(kind, "instances_compare.py", short_tmp)
    for name, scene in found.items():
        assert scene["same"], (name, scene["diff"])
        assert scene["exporter"] == scene["loop_shown"], (name, scene)
    assert found["scatter_three"]["placements"] == 3000 + 1000 + 2  # and the two instancers
    assert found["nested"]["placements"] == 2 * (500 + 1)
    if kind == "blender":  # Blender 3.4: no GeometrySet
        assert {s["route"] for s in found.values()} == {"depsgraph"}
    else:
        routes = {name: s["route"] for name, s in found.items()}
        assert {n for n, r in routes.items() if r == "geometry_set"} == GEOMETRY_SET_SCENES, found
