"""Alpha materials through the protocol (version 5, issue 38), against a real daemon: meshes with
material slots and UV maps, alpha images uploaded once by hash, frames with the exporter's
material contracts; missing images reported and named; the daemon's own recording of the
session reads back with the images and materials (so the scenes it built carry the alpha); bad
input named, and the daemon keeps serving. What the renderer makes of alpha is
test_alpha_render.py's."""

from __future__ import annotations

import numpy as np
import pytest

import antumbra
from conftest import RESOLUTION, camera, grid, lights, translation

LEAVES = 8  # the card's triangles: a 2x2 grid


def card() -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """A 2x2 ground card: positions, triangles, slots (0 and 1 alternating), UV map Leaves."""
    positions, triangles = grid(2, 4.0)
    slots = (np.arange(len(triangles)) % 2).astype(np.uint32)
    uv = (positions[triangles][:, :, :2] / 4.0 + 0.5).astype(np.float32)
    return positions, triangles, slots, {"Leaves": uv}


def leaf_image(seed: float = 0.0) -> np.ndarray:
    """A 4 (high) x 8 (wide) alpha image, rows bottom first."""
    return (np.arange(32, dtype=np.float32).reshape(4, 8) / 31.0 + seed).astype(np.float32)


MATERIALS_OF_CARD = [0, 1]


def materials(image: int) -> list[dict]:
    return [
        {"name": "Glass", "kind": "constant", "alpha": 0.5},
        {
            "name": "Leaf",
            "kind": "texture",
            "image": image,
            "channel": "alpha",
            "uv_map": "Leaves",
            "interpolation": "Smart",
            "extension": "CLIP",
            "ops": [["MULTIPLY", 2.0], ["ONE_MINUS"], ["CLAMP"]],
        },
    ]


def objects(card_hash: int, mats=MATERIALS_OF_CARD) -> list[dict]:
    return [
        {
            "name": "Card",
            "mesh_hash": card_hash,
            "matrix_world": translation(0.0, 0.0, 1.0),
            "materials": mats,
        }
    ]


def upload_card(session) -> int:
    positions, triangles, slots, uv_maps = card()
    return session.upload_mesh("Card", positions, triangles, None, slots, uv_maps)


def send(session, frame: int, card_hash: int, image: int, **kw):
    return session.frame_update(
        frame,
        objects(card_hash, **kw),
        camera(frame),
        lights(),
        RESOLUTION,
        alpha_materials=materials(image),
    )


@pytest.fixture
def recorded(antumbra_bin, short_tmp):
    """A client of a daemon that records its sessions to short_tmp/rec."""
    rec = short_tmp / "rec"
    rec.mkdir()
    client = antumbra.Client.spawn(
        antumbra_bin, socket_path=short_tmp / "d.sock", args=["--record", str(rec)], timeout=30
    )
    yield client, rec
    client.close()


def test_hashes_cover_slots_uvs_and_texels():
    positions, triangles, slots, uv_maps = card()
    plain = antumbra.mesh_hash(positions, triangles)
    with_slots = antumbra.mesh_hash(positions, triangles, None, slots)
    with_all = antumbra.mesh_hash(positions, triangles, None, slots, uv_maps)
    assert len({plain, with_slots, with_all}) == 3
    assert antumbra.image_hash(leaf_image()) != antumbra.image_hash(leaf_image(0.5))
    # The same texels in another shape are another image.
    assert antumbra.image_hash(leaf_image()) != antumbra.image_hash(leaf_image().reshape(8, 4))


def test_alpha_frame_on_a_daemon_and_its_recording(recorded):
    client, rec = recorded
    assert client.protocol_version == 6
    card_hash = upload_card(client)
    positions, triangles, slots, uv_maps = card()
    assert card_hash == antumbra.mesh_hash(positions, triangles, None, slots, uv_maps)

    image = client.upload_image(leaf_image())
    assert image == antumbra.image_hash(leaf_image())
    # Held now: a second upload sends nothing.
    sent = client.bytes_sent
    assert client.upload_image(leaf_image()) == image
    assert client.bytes_sent == sent
    other = antumbra.image_hash(leaf_image(0.25))
    assert client.missing_images([image, other]) == [other]

    missing = send(client, 1, card_hash, image)
    assert list(missing) == [] and missing.images == []
    result = client.render(1, spp=1, passes=["combined"])
    assert result.images["combined"].shape == (RESOLUTION["y"], RESOLUTION["x"])

    # A frame whose material reads an image the daemon lacks: accepted, the image reported,
    # and a render refused naming the frame, the material and the image.
    missing = send(client, 2, card_hash, other)
    assert list(missing) == [] and missing.images == [other]
    with pytest.raises(antumbra.RequestError) as e:
        client.render(2, spp=1, passes=["combined"])
    assert e.value.code == "UnknownImage"
    assert "frame 2" in str(e.value) and "'Leaf'" in str(e.value)
    assert e.value.session_usable
    assert client.upload_image(leaf_image(0.25)) == other
    client.render(2, spp=1, passes=["combined"])
    stats = client.stats()
    assert stats["images_cached"] == 2

    client.close()
    (path,) = rec.glob("*.antrec")
    recording = antumbra.read_recording(str(path))
    assert set(recording["images"]) == {image, other}
    assert np.array_equal(recording["images"][image], leaf_image())
    mesh = recording["meshes"][card_hash]
    assert np.array_equal(mesh["material_slots"], slots)
    assert np.array_equal(mesh["uv_maps"]["Leaves"], uv_maps["Leaves"])
    frames = recording["frames"]
    assert [f["frame"] for f in frames] == [1, 2]
    glass, leaf = frames[0]["alpha_materials"]
    assert glass == {"name": "Glass", "kind": "constant", "alpha": 0.5, "ops": []}
    assert leaf["image"] == image and leaf["uv_map"] == "Leaves"
    assert (leaf["interpolation"], leaf["extension"]) == ("Cubic", "CLIP")  # Smart is Cubic
    assert leaf["ops"] == [["MULTIPLY", 2.0], ["ONE_MINUS"], ["CLAMP"]]
    assert frames[0]["objects"][0]["materials"] == MATERIALS_OF_CARD
    assert frames[1]["alpha_materials"][1]["image"] == other

    # What was read back is what frame_update takes: it replays in process.
    local = antumbra.LocalSession()
    for h, m in recording["meshes"].items():
        assert (
            local.upload_mesh(
                m["name"], m["positions"], m["triangles"], None, m["material_slots"], m["uv_maps"]
            )
            == h
        )
    for h, texels in recording["images"].items():
        assert local.upload_image(texels) == h
    for f in frames:
        missing = local.frame_update(**f)
        assert list(missing) == [] and missing.images == []
        local.render(f["frame"], spp=1, passes=["combined"])


def test_instance_arrays_carry_materials(daemon):
    card_hash = upload_card(daemon)
    image = daemon.upload_image(leaf_image())
    matrices = np.stack([translation(float(i), 0.0, 1.0) for i in range(3)])
    array = {"name": "Cards", "mesh_hash": card_hash, "matrices": matrices, "materials": [1]}
    missing = daemon.frame_update(
        1, [], camera(1), lights(), RESOLUTION, [array], alpha_materials=materials(image)
    )
    assert list(missing) == [] and missing.images == []
    daemon.render(1, spp=1, passes=["combined"])
    bad = {**array, "materials": [None, 5]}
    with pytest.raises(antumbra.InvalidInput, match=r"instances\[0\] 'Cards'\.materials\[1\]"):
        daemon.frame_update(
            2, [], camera(1), lights(), RESOLUTION, [bad], alpha_materials=materials(image)
        )


@pytest.mark.parametrize(
    ("change", "pattern"),
    [
        ({"kind": "glossy"}, r"alpha_materials\[1\] 'Leaf'\.kind"),
        ({"interpolation": "Bilinear"}, r"'Leaf'\.interpolation"),
        ({"extension": "WRAP"}, r"'Leaf'\.extension"),
        ({"channel": "red"}, r"'Leaf'\.channel"),
        ({"ops": [["DIVIDE", 2.0]]}, r"'Leaf'\.ops\[0\]\[0\]"),
        ({"ops": [["MULTIPLY"]]}, r"'Leaf'\.ops\[0\].*one constant"),
        ({"ops": [["ADD", float("nan")]]}, r"'Leaf'\.ops\[0\]\[1\].*finite"),
        ({"ops": [["CLAMP"]] * 65}, r"max_alpha_ops"),
        ({"alpha": 0.5}, r"'Leaf'\.alpha: not a field of a material of kind 'texture'"),
        ({"image": -1}, r"'Leaf'\.image"),
        ({"shininess": 1}, r"unknown field 'shininess'"),
    ],
)
def test_bad_materials_are_named(daemon, change, pattern):
    card_hash = upload_card(daemon)
    image = daemon.upload_image(leaf_image())
    mats = materials(image)
    mats[1] = {**mats[1], **change}
    with pytest.raises(antumbra.InvalidInput, match=pattern):
        daemon.frame_update(
            1, objects(card_hash), camera(1), lights(), RESOLUTION, alpha_materials=mats
        )
    # The session goes on.
    assert send(daemon, 1, card_hash, image) == []
    daemon.render(1, spp=1, passes=["combined"])


def test_bad_meshes_images_and_slots_are_named(daemon):
    positions, triangles, slots, uv_maps = card()
    with pytest.raises(antumbra.InvalidInput, match=r"mesh 'Card'\.material_slots"):
        daemon.upload_mesh("Card", positions, triangles, None, slots[:3])
    with pytest.raises(antumbra.InvalidInput, match=r"mesh 'Card'\.material_slots\[0\]"):
        daemon.upload_mesh("Card", positions, triangles, None, slots.astype(np.int64) - 1)
    nan_uv = {"Leaves": uv_maps["Leaves"].copy()}
    nan_uv["Leaves"][5, 1, 0] = np.nan
    with pytest.raises(antumbra.InvalidInput, match=r"'Card'.*UV map 'Leaves'.*5"):
        daemon.upload_mesh("Card", positions, triangles, None, slots, nan_uv)
    with pytest.raises(antumbra.InvalidInput, match=r"uv_maps\['Leaves'\].*\(m, 3, 2\)"):
        daemon.upload_mesh("Card", positions, triangles, None, slots, {"Leaves": np.zeros((8, 3))})
    with pytest.raises(antumbra.InvalidInput, match=r"uv_maps\['Leaves'\]"):
        daemon.upload_mesh(
            "Card", positions, triangles, None, slots, {"Leaves": uv_maps["Leaves"][:2]}
        )
    bad = leaf_image()
    bad[1, 2] = np.inf
    with pytest.raises(
        antumbra.InvalidInput, match=r"texels of image 0x[0-9a-f]+ .*\(inf\) at index 10"
    ):
        daemon.upload_image(bad)
    with pytest.raises(antumbra.InvalidInput, match=r"texels: expected a float32"):
        daemon.upload_image(leaf_image().astype(np.float64))
    with pytest.raises(antumbra.InvalidInput, match=r"max_image_texels"):
        daemon.upload_image(np.zeros((8193, 8192), dtype=np.float32))

    card_hash = upload_card(daemon)
    image = daemon.upload_image(leaf_image())
    with pytest.raises(antumbra.InvalidInput, match=r"objects\[0\] 'Card'\.materials\[1\]"):
        send(daemon, 1, card_hash, image, mats=[0, 2])
    with pytest.raises(antumbra.InvalidInput, match=r"objects\[0\] 'Card'\.materials\[0\]"):
        send(daemon, 1, card_hash, image, mats=["Leaf"])
    # A NaN constant never reaches the daemon; the frame after it renders.
    mats = materials(image)
    mats[0]["alpha"] = float("nan")
    with pytest.raises(antumbra.InvalidInput, match=r"'Glass'\.alpha: must be finite"):
        daemon.frame_update(
            1, objects(card_hash), camera(1), lights(), RESOLUTION, alpha_materials=mats
        )
    assert send(daemon, 1, card_hash, image) == []
    daemon.render(1, spp=1, passes=["combined"])


def test_local_session_takes_the_same_calls():
    local = antumbra.LocalSession()
    card_hash = upload_card(local)
    image = local.upload_image(leaf_image())
    other = antumbra.image_hash(leaf_image(0.5))
    assert local.missing_images([image, other]) == [other]
    missing = send(local, 1, card_hash, other)
    assert missing.images == [other]
    with pytest.raises(antumbra.RequestError, match="'Leaf'") as e:
        local.render(1, spp=1, passes=["combined"])
    assert e.value.code == "UnknownImage"
    assert send(local, 1, card_hash, image).images == []
    local.render(1, spp=1, passes=["combined"])
    assert local.stats()["images_cached"] == 1
