"""Shadows through alpha rendered end to end (issue 38): a frame with alpha materials sent over
a real daemon's socket (and to an in-process LocalSession) casts Cycles' transparent shadows.

The scene, seen from straight above with a hard sun at 45 degrees along +x: an opaque ground;
pane A, a 2 x 2 glass quad of alpha 0.5 at height 1; panes B1 and B2, two such quads at heights
1 and 2 (their shadows overlap over half their width); card C, a quad at height 1 whose image
is opaque on its left half and transparent on its right (Closest, Clip). The camera's clip
(0.6) lets camera rays through the glass and the card's transparent half, so the ground is
what most pixels show: lit by 0.5 under A and where B's shadows do not overlap (8 units of
area), 0.25 where they do (2), 0 under the card's opaque half (2).
"""

from __future__ import annotations

import numpy as np
import pytest

import antumbra
from conftest import grid, look_at, translation

SIZE = {"x": 96, "y": 96, "percentage": 100}
CAMERA = {
    "matrix_world": look_at((0.0, 0.0, 12.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0)),
    "lens": 35.0,
    "sensor_width": 36.0,
    "sensor_height": 36.0,
    "clip_start": 0.1,
    "clip_end": 100.0,
}
SUN = [
    {
        "name": "Sun",
        "type": "SUN",
        "matrix_world": look_at((10.0, 0.0, 10.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0)),
        "angle": 0.0,
    }
]
#: Image of card C: 2 texels wide, 1 high: opaque left, transparent right.
CARD_IMAGE = np.array([[1.0, 0.0]], dtype=np.float32)


def quad_uvs(triangles: np.ndarray, positions: np.ndarray, size: float) -> np.ndarray:
    return (positions[triangles][:, :, :2] / size + 0.5).astype(np.float32)


def send_scene(session) -> None:
    ground = session.upload_mesh("Ground", *grid(1, 20.0))
    positions, triangles = grid(1, 2.0)
    pane = session.upload_mesh("Pane", positions, triangles)
    card = session.upload_mesh(
        "Card",
        positions,
        triangles,
        material_slots=np.zeros(len(triangles), dtype=np.uint32),
        uv_maps={"UVMap": quad_uvs(triangles, positions, 2.0)},
    )
    image = session.upload_image(CARD_IMAGE)
    materials = [
        {"name": "Glass", "kind": "constant", "alpha": 0.5},
        {
            "name": "Leaf",
            "kind": "texture",
            "image": image,
            "uv_map": "UVMap",
            "interpolation": "Closest",
            "extension": "CLIP",
        },
    ]

    def placed(name, mesh, x, y, z, slots=None):
        o = {"name": name, "mesh_hash": mesh, "matrix_world": translation(x, y, z)}
        if slots is not None:
            o["materials"] = slots
        return o

    objects = [
        placed("Ground", ground, 0.0, 0.0, 0.0),
        placed("A", pane, -3.0, 0.0, 1.0, [0]),
        placed("B1", pane, 3.0, 0.0, 1.0, [0]),
        placed("B2", pane, 3.0, 0.0, 2.0, [0]),
        placed("C", card, 0.0, 3.0, 1.0, [1]),
    ]
    missing = session.frame_update(1, objects, CAMERA, SUN, SIZE, alpha_materials=materials)
    assert list(missing) == [] and list(missing.images) == []


def ground_masks(session, **settings) -> tuple[np.ndarray, np.ndarray]:
    r = session.render(1, spp=1, passes=("masks", "object_ids"), alpha_clip=0.6, **settings)
    return r.masks["Sun"], r.object_ids == 0


@pytest.fixture(params=["daemon", "local"])
def session(request, daemon):
    if request.param == "daemon":
        yield daemon
    else:
        with antumbra.LocalSession() as local:
            yield local


def test_glass_and_cut_out_cards_cast_cycles_transparent_shadows(session):
    send_scene(session)
    mask, ground = ground_masks(session)
    values, counts = np.unique(mask[ground], return_counts=True)
    seen = dict(zip(values.tolist(), counts.tolist(), strict=True))
    # Exactly these transmissions: lit, one pane, two panes, the card's opaque half.
    assert set(seen) == {0.0, 0.25, 0.5, 1.0}, seen
    assert min(seen[0.25], seen[0.5], seen[0.0]) > 50, seen
    # Areas 8 (0.5), 2 (0.25) and 2 (0): the card's transparent half lets the sun through.
    assert 0.15 * seen[0.5] < seen[0.0] < 0.35 * seen[0.5], seen
    assert 0.15 * seen[0.5] < seen[0.25] < 0.35 * seen[0.5], seen

    # Alpha off: every pane and the whole card cast black.
    opaque, ground_opaque = ground_masks(session, alpha=False)
    values = set(np.unique(opaque[ground_opaque]).tolist())
    assert values == {0.0, 1.0}, values

    # One transparent hit allowed (Transparent bounces 2): the stacked panes turn black.
    limited, _ = ground_masks(session, transparent_bounces=2)
    assert 0.25 not in set(np.unique(limited[ground]).tolist())
    assert np.count_nonzero(limited[ground] == 0.5) == seen[0.5]
    assert np.count_nonzero(limited[ground] == 0.0) == seen[0.0] + seen[0.25]


def test_daemon_and_local_session_agree_bit_for_bit(daemon):
    send_scene(daemon)
    with antumbra.LocalSession() as local:
        send_scene(local)
        for settings in ({}, {"transparent_bounces": 2}):
            a, _ = ground_masks(daemon, **settings)
            b, _ = ground_masks(local, **settings)
            assert np.array_equal(a, b), settings
