"""Alpha from Blender's materials (issue 38, the Blender side): ``material_alpha``'s contract for
every graph shape it reads and a warning naming material and node for those it cannot,
``alpha_image``'s sizes, row order and values, ``mesh_alpha``'s slots and UVs against a
per-element walk and in the exporter's triangle order, and the bad inputs (a missing image
file, an image of 0 pixels, a UV map named but absent, NaN UVs). Also the leaf-card .blend
builder, reopened from disk.

Each runs in Debian's Blender 3.4 (``blender -b``) and in the bpy module of the Python running
pytest (5.0 in ``.venv``; 4.2, 4.5, 5.3 with ``-m bpy`` in their venvs), one Blender process
per variant; a missing Blender fails its variant.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import ADDON, blender_env, run_blender

HERE = Path(__file__).resolve().parent
SCRIPTS = HERE / "scripts"
KINDS = ["blender", pytest.param("bpy", marks=pytest.mark.bpy)]

TEXTURE = {
    "kind": "texture",
    "image": "Rows",
    "channel": "alpha",
    "uv_map": "",
    "interpolation": "Linear",
    "extension": "REPEAT",
    "ops": [],
}


def run(kind: str, script: Path, folder: Path, *extra: str) -> subprocess.CompletedProcess:
    args = [*extra]
    if kind == "blender":
        return run_blender(["-P", str(script), "--", *args], folder / "home", timeout=120)
    return subprocess.run(
        [sys.executable, str(script), "--", *args],
        env=blender_env(folder / "home"),
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.fixture(scope="module", params=KINDS)
def found(request, tmp_path_factory) -> dict:
    """materials_check.py's findings in one Blender."""
    folder = tmp_path_factory.mktemp(f"materials-{request.param}")
    out = folder / "out.json"
    done = run(
        request.param,
        SCRIPTS / "materials_check.py",
        folder,
        *("--addon", str(ADDON), "--out", str(out)),
    )
    assert out.is_file(), done.stdout[-3000:] + done.stderr[-3000:]
    return json.loads(out.read_text())


def contract(found, name):
    return found["materials"][name]["contract"]


def ops(found, name):
    return contract(found, name)["ops"]


def test_constants_and_opaque(found):
    m = found["materials"]
    assert contract(found, "Empty slot") == {"kind": "opaque"}
    assert contract(found, "Default") == {"kind": "opaque"}, "Principled's alpha 1 is opaque"
    assert contract(found, "Const") == {"kind": "constant", "alpha": 0.5}
    assert contract(found, "HalfMix") == {"kind": "constant", "alpha": 0.5}, "Mix(0.5, T, D)"
    assert contract(found, "TransparentOnly") == {"kind": "constant", "alpha": 0.0}
    assert all(entry["json"] for entry in m.values()), "every contract survives JSON"
    assert all(not m[n]["warnings"] for n in ("Default", "Const", "HalfMix", "TransparentOnly"))


def test_driven_alpha_is_read_at_the_frames_value(found):
    assert found["driven"] == {"kind": "constant", "alpha": pytest.approx(0.3)}


def test_texture_alpha_and_colour(found):
    assert contract(found, "TexAlpha") == TEXTURE
    assert found["materials"]["TexAlpha"]["node"] == "Leaf Image"
    info = found["materials"]["TexAlpha"]["image_info"]
    assert info["size"] == [4, 2] and info["alpha_mode"] == "STRAIGHT", info
    assert info["colorspace"] == "sRGB" and not info["is_float"], info
    assert contract(found, "TexColor") == {
        **TEXTURE,
        "channel": "luminance",
        "interpolation": "Closest",
        "extension": "EXTEND",
    }
    assert contract(found, "TexCoordUV") == TEXTURE, "a Texture Coordinate's UV: the render map"
    assert contract(found, "UVNode") == {**TEXTURE, "uv_map": "Leaves"}


def test_math_chains(found):
    assert contract(found, "Clip") == {**TEXTURE, "ops": [["GREATER_THAN", 0.5]]}
    # x * 2 clamped, then 1 - x through a reroute, then x ** 2.
    assert ops(found, "Chain") == [["MULTIPLY", 2.0], ["CLAMP"], ["ONE_MINUS"], ["POWER", 2.0]]
    # Invert, + 0.1, 0.3 < x (so x > 0.3), 0.8 - x (so (1 - x) - 0.2), x < 0.25; the
    # constants are the sockets' float32 values.
    chain = ops(found, "Chain2")
    assert [op[0] for op in chain] == [
        "ONE_MINUS",
        "ADD",
        "GREATER_THAN",
        "ONE_MINUS",
        "ADD",
        "LESS_THAN",
    ], chain
    assert [op[1:] for op in chain] == [
        [],
        [pytest.approx(0.1)],
        [pytest.approx(0.3)],
        [],
        [pytest.approx(-0.2)],
        [0.25],
    ], chain


def test_transparent_mix_both_ways_and_nested(found):
    assert contract(found, "MixFirst") == TEXTURE, "Transparent first: alpha = Fac"
    assert contract(found, "MixSecond") == {**TEXTURE, "ops": [["ONE_MINUS"]]}, "1 - Fac"
    # Mix(0.5, Transparent, Principled with the texture's alpha): half of it.
    assert contract(found, "Nested") == {**TEXTURE, "ops": [["MULTIPLY", 0.5]]}


@pytest.mark.parametrize(
    ("name", "node", "why"),
    [
        ("Noise", "node 'Noise Texture' (ShaderNodeTexNoise)", "feeding Alpha is not supported"),
        ("Mapped", "node 'Mapping' (ShaderNodeMapping)", "texture's Vector is not supported"),
        ("Generated", "node 'Texture Coordinate' (ShaderNodeTexCoord)", "Vector is not"),
        ("Sine", "node 'Sine' (ShaderNodeMath)", "operation SINE is not supported"),
        ("TwoTextures", "node 'Both' (ShaderNodeMath)", "combines two textures"),
        ("AddShader", "node 'Add Shader' (ShaderNodeAddShader)", "surface shader is not"),
        ("Tiled", "node 'UDIM' (ShaderNodeTexImage)", "reads a TILED image"),
        ("Box", "node 'Box Image' (ShaderNodeTexImage)", "has projection BOX"),
        ("Muted", "node 'Muted Math' (ShaderNodeMath)", "is muted"),
    ],
)
def test_unsupported_graphs_are_opaque_with_a_warning(found, name, node, why):
    entry = found["materials"][name]
    assert entry["contract"] == {"kind": "opaque"}
    (warning,) = entry["warnings"]
    assert warning.startswith(f"material '{name}': {node} "), warning
    assert why in warning and warning.endswith("; exported opaque"), warning


def test_noise_warning_reads_as_documented(found):
    assert found["materials"]["Noise"]["warnings"] == [
        "material 'Noise': node 'Noise Texture' (ShaderNodeTexNoise) feeding Alpha is not "
        "supported; exported opaque"
    ]


def test_modes_as_each_blender_spells_them(found):
    modes = found["materials"]["Const"]["modes"]
    if tuple(found["blender"]) < (4, 2, 0):
        assert set(modes) == {"blend_method", "shadow_method"}, modes
    else:
        assert {"surface_render_method", "use_transparent_shadow"} <= set(modes), modes
    # Cycles ignores them, so the same contract whatever they say.
    assert contract(found, "Const") == {"kind": "constant", "alpha": 0.5}


def test_luminance_coefficients_are_scene_linear_y(found):
    weights = found["luminance"]
    assert sum(weights) == pytest.approx(1.0, abs=1e-6)
    assert weights == pytest.approx([0.2126, 0.7152, 0.0722], abs=2e-4)


def srgb_to_linear(c: float) -> float:
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def test_image_size_row_order_and_values(found):
    images = found["images"]
    rows = images["png_rows"]  # the PNG's rows, top first
    bottom_up = rows[::-1]
    alpha = images["alpha"]
    assert alpha["size"] == [4, 2] and alpha["dtype"] == "float32"
    expected = [[px[3] / 255 for px in row] for row in bottom_up]
    assert np.allclose(alpha["values"], expected, atol=1e-6), "row 0 is the file's bottom row"
    assert np.allclose(images["packed_alpha"], expected, atol=1e-6), "packed: the same"
    w = found["luminance"]
    # Cycles' colour: premultiplied in bytes, then decoded from sRGB, then weighted.
    lum = [
        [
            sum(wi * srgb_to_linear((px[i] * px[3] // 255) / 255) for i, wi in enumerate(w))
            for px in row
        ]
        for row in bottom_up
    ]
    assert np.allclose(images["luminance"]["values"], lum, atol=1e-5), "premultiplied, decoded"
    raw = [[sum(wi * px[i] / 255 for i, wi in enumerate(w)) for px in row] for row in bottom_up]
    assert np.allclose(images["luminance_non_color"], raw, atol=1e-5), "data: as stored, straight"


def test_bad_images_name_object_material_node_and_file(found):
    images = found["images"]
    where = "object 'Card', material 'Leaf', node 'Leaf Image': "
    assert images["missing"].startswith(where + "image 'Gone': file '"), images["missing"]
    assert images["missing"].endswith("no_such_file.png' is missing"), images["missing"]
    assert images["empty"].startswith(where + "image 'Empty' has 0 pixels"), images["empty"]
    assert found["source_image_error"] == (
        "object 'Card', material 'TexAlpha', node 'Leaf Image': image 'No such image' is not "
        "in this file"
    )


def test_mesh_alpha_slots_and_uvs_against_a_per_element_walk(found):
    mixed = found["meshes"]["mixed"]
    ref = mixed["reference"]
    # Faces use slots 0, 1, 2 and 5 (past the last of 3 slots: clamped to 2).
    assert mixed["material_index"] == ref["material_index"] == [0, 1, 1, 2, 2, 2, 2, 2]
    assert mixed["dtype"] == ["uint32", "float32"]
    assert mixed["loops"] == ref["loops"]
    assert sorted(mixed["uv"]) == ["", "Leaves"], "one array per UV map a texture reads"
    for key in ("", "Leaves"):
        assert np.allclose(mixed["uv"][key], ref["uv"][key], atol=0), key
    # "" is the active render map (u = corner index / 100, v = 0.5), not the first one.
    assert np.allclose(mixed["uv"][""][0], [[0.0, 0.5], [0.01, 0.5], [0.02, 0.5]])
    assert mixed["warnings"] == []
    assert found["meshes"]["opaque_only"], "no alpha slot: no per-triangle data"


def test_mesh_alpha_follows_the_exporters_triangle_order(found):
    same = {"exporter": True, "loop_triangles": True, "faces": True, "dtype": "int32"}
    order = found["meshes"]["exporter_order"]
    loops = {name: route.pop("loops") for name, route in order.items()}
    assert order == {"mixed": same, "quads": same, "triangles": same}, order
    # The dart (corners 12-15 of the quads) is split along its 1-3 diagonal, in both meshes.
    assert loops["quads"][-2:] == [[12, 13, 15], [13, 14, 15]], loops["quads"]
    assert loops["mixed"][3:5] == [[7, 8, 10], [8, 9, 10]], loops["mixed"]


def test_absent_uv_map_and_nan_uvs_warn_naming_object_material_node(found):
    bad = found["meshes"]["bad"]
    absent, nan = sorted(bad["warnings"], key=lambda w: "absent" not in w)
    assert absent == (
        "object 'BadCard', material 'UVNode', node 'Leaf Image': UV map 'Leaves' is absent; "
        "read as UV (0, 0), as Cycles does"
    )
    assert nan.startswith("object 'BadCard', material 'TexAlpha', node 'Leaf Image': ")
    assert "UV map 'UVMap' has non-finite UVs on 1 triangles" in nan, nan
    assert np.all(np.asarray(bad["absent_uvs"]) == 0.0)
    uvs = np.asarray(bad["nan_uvs"])
    assert np.isfinite(uvs).all()
    loops = np.asarray(bad["loops"])
    at_nan = loops == 5  # corner 5 was NaN: now (0, 0); the rest keep (0.25, 0.75)
    assert np.all(uvs[at_nan] == 0.0) and np.allclose(uvs[~at_nan], [0.25, 0.75])


@pytest.fixture(scope="module", params=KINDS)
def leaf_cards_folder(request, tmp_path_factory) -> Path:
    """leaf_cards_check.py's folder: its reading of the leaf-card .blend (both variants) as
    ``out.json`` and Cycles' renders of it, in one Blender."""
    folder = tmp_path_factory.mktemp(f"leaf-{request.param}")
    out = folder / "out.json"
    done = run(
        request.param,
        SCRIPTS / "leaf_cards_check.py",
        folder,
        *("--addon", str(ADDON), "--out", str(out)),
    )
    assert out.is_file(), done.stdout[-3000:] + done.stderr[-3000:]
    return folder


@pytest.fixture
def leaf_cards(leaf_cards_folder) -> dict:
    return json.loads((leaf_cards_folder / "out.json").read_text())


@pytest.mark.parametrize("variant", ["clip", "fractional"])
def test_leaf_card_blend_reads_back_as_built(leaf_cards, variant):
    scene = leaf_cards[variant]
    ops = [["GREATER_THAN", 0.5]] if variant == "clip" else []
    for name in ("Leaf", "Picket"):
        assert scene["materials"][name]["contract"] == {
            **TEXTURE,
            "image": name,
            "ops": ops,
        }, name
    assert scene["materials"]["Glass"]["contract"] == {"kind": "constant", "alpha": 0.5}
    assert scene["materials"]["Bark"]["contract"] == {"kind": "opaque"}
    assert all(not m["warnings"] for m in scene["materials"].values())
    assert scene["cycles"] == {
        "engine": "CYCLES",
        "transparent_max_bounces": 64,
        "shadow_catcher": True,
    }


def test_leaf_card_images_are_packed_with_a_fractional_rim(leaf_cards):
    images = leaf_cards["fractional"]["images"]
    assert images["Leaf"]["size"] == [64, 64] and images["Picket"]["size"] == [32, 64]
    for name, image in images.items():
        assert image["packed"], name
        assert image["corner"] == 0.0, name
        assert 0.05 < image["fractional"] < 0.3 and image["opaque"] > 0.3, (name, image)
        row = np.asarray(image["middle_row"])
        assert row[0] == 0.0 and row[-1] == 0.0 and row[len(row) // 2] == 1.0, (name, row)
        assert ((row > 0) & (row < 1)).sum() >= 4, (name, row)
        assert np.allclose(row, row[::-1], atol=1 / 255), (name, "symmetric")


def test_leaf_card_meshes_carry_uvs_only_where_alpha_is_needed(leaf_cards):
    objects = leaf_cards["clip"]["objects"]
    for name in ("Ground", "Trunk.0", "Trunk.1", "Trunk.2"):
        assert objects[name] is None, name
    for i in range(3):
        crown = objects[f"Crown.{i}"]
        assert crown["triangles"] == 2 * 60 and crown["uv_maps"] == [""], crown
        assert crown["uv_min"] == [0.0, 0.0] and crown["uv_max"] == [1.0, 1.0], crown
    fence = objects["Fence"]
    assert fence["triangles"] == 2 * 12 and fence["uv_max"] == [2.0, 1.0], "two pickets a plank"
    glass = objects["Glass"]
    assert glass["triangles"] == 12 and glass["uv_maps"] == [], "a constant alpha needs no UVs"
    assert all(not (o or {"warnings": []})["warnings"] for o in objects.values())


@pytest.fixture(scope="module", params=KINDS)
def cycles_cards(request, tmp_path_factory) -> tuple[dict, np.ndarray]:
    """alpha_cycles_check.py's cards and Cycles' shadow catcher pass (rows top first)."""
    import antumbra

    folder = tmp_path_factory.mktemp(f"cycles-{request.param}")
    out = folder / "out.json"
    done = run(
        request.param,
        SCRIPTS / "alpha_cycles_check.py",
        folder,
        *("--addon", str(ADDON), "--out", str(out)),
    )
    assert out.is_file(), done.stdout[-3000:] + done.stderr[-3000:]
    planes = antumbra.read_exr(str(folder / "cycles.exr"))
    catcher = next(v for k, v in planes.items() if "Shadow Catcher" in k and k.endswith(".R"))
    return json.loads(out.read_text()), catcher.astype(np.float64)


def card_comparison(found: dict, catcher: np.ndarray) -> dict:
    """Per card: Cycles' transmission under it against 1 - the contract's alpha, evaluated by
    ``alpha_reference`` on ``alpha_image``'s values at each pixel centre's UV."""
    sys.path.insert(0, str(SCRIPTS))
    import alpha_reference

    n, span = found["size"], found["span"]
    centres = -span / 2 + (np.arange(n) + 0.5) * span / n
    x, y = np.meshgrid(centres, -centres)  # rows top first, as the EXR
    a, b = found["uv_range"]
    expected = np.ones((n, n))
    rows = {}
    for card in found["cards"]:
        x0, y0, x1, y1 = card["rect"]
        inside = (x > x0) & (x < x1) & (y > y0) & (y < y1)
        u, v = a + (x - x0) / (x1 - x0) * (b - a), a + (y - y0) / (y1 - y0) * (b - a)
        contract = card["contract"]
        if contract.get("uv_map") == "Mirrored":
            u = 1.0 - u
        if contract.get("uv_map") == "Absent":  # mesh_alpha's (0, 0), as Cycles reads it
            u, v = np.zeros_like(u), np.zeros_like(v)
        values = None
        if contract["kind"] == "texture":
            image = found["images"][contract["image"]]
            key = "unassociated" if card["unassociate"] else contract["channel"]
            values = np.asarray(image[key])
        alpha = alpha_reference.evaluate(contract, values, u, v)
        expected[inside] = 1.0 - alpha[inside]
        rows[card["name"]] = {
            "max": float(np.abs(catcher - expected)[inside].max()),
            "pixels": int(inside.sum()),
            "fractional": int(((expected > 0.01) & (expected < 0.99) & inside).sum()),
            "warnings": card["warnings"],
        }
    rows["outside"] = {"max": float(np.abs(catcher - expected)[expected == 1.0].max())}
    return rows


def test_contract_casts_the_shadows_cycles_casts(cycles_cards):
    """Every card but one: Cycles' shadow equals 1 - the contract's alpha at every pixel (ops,
    1 - Fac, nesting, extension, Linear and Closest, row order, luminance premultiplied or not,
    file or packed, "" as the render UV map, a UV Map node's map, an absent map read as UV
    (0, 0), no image)."""
    rows = card_comparison(*cycles_cards)
    assert len(rows) == 20, rows
    magenta = {card["name"]: card["contract"] for card in cycles_cards[0]["cards"]}
    assert magenta["UV Map Node"]["uv_map"] == "Mirrored"
    assert magenta["Linear Repeat"]["uv_map"] == "", "the render map, not the active one"
    assert magenta["No Image Alpha"] == {"kind": "opaque"}
    assert magenta["No Image Color"]["kind"] == "constant", "magenta's luminance, about 0.285"
    for name, row in rows.items():
        if name != "Luminance Linear":
            assert row["max"] < 1e-3, (name, row)
    assert rows["Linear Repeat"]["fractional"] > 500, "the fractional alpha is exercised"
    assert (
        rows["Clip 0.5"]["fractional"] == 0
        and rows["Constant"]["fractional"] == rows["Constant"]["pixels"] > 1000
    )
    cards = {card["name"]: card["contract"] for card in cycles_cards[0]["cards"]}
    assert cards["Mix Overshoot"]["ops"] == [
        ["MULTIPLY", 2.0],
        ["SUBTRACT", 0.5],
        ["CLAMP"],
        ["ONE_MINUS"],
    ], "the mix clamps its Fac before 1 - Fac"
    assert all(not r.get("warnings") for n, r in rows.items() if n != "Luminance Linear")


def test_linear_luminance_of_an_srgb_image_is_approximate_and_says_so(cycles_cards):
    """Cycles interpolates an sRGB texture's encoded colour and decodes it after; one array of
    luminance per texel cannot: the export warns, and agrees at texel centres only."""
    row = card_comparison(*cycles_cards)["Luminance Linear"]
    (warning,) = row["warnings"]
    assert warning.startswith("material 'Luminance Linear': node 'Leaf Image'"), warning
    assert "Linear interpolation" in warning and "Closest is exact" in warning, warning
    assert 0.05 < row["max"] < 0.3, row


def test_leaf_card_scene_casts_transparent_shadows_in_cycles(leaf_cards_folder):
    """The builder's Cycles settings cast transparent shadows: the clip variant's shadows are
    0, 1 or powers of the glass's 0.5 (cards cut out), the fractional variant's also take the
    leaves' rim values in between; both lights cast some of each."""
    import antumbra

    glass = {0.0, 1.0, 0.5, 0.25, 0.125, 0.0625}
    for light in ("sun", "lamp"):
        found = {}
        for variant in ("clip", "fractional"):
            planes = antumbra.read_exr(str(leaf_cards_folder / variant / f"cycles_{light}.exr"))
            catcher = next(
                v for k, v in planes.items() if "Shadow Catcher" in k and k.endswith(".R")
            )
            found[variant] = np.clip(catcher, 0.0, 1.0)
        clip, fractional = found["clip"], found["fractional"]
        near = np.min([np.abs(clip - g) for g in glass], axis=0)
        assert near.max() < 1e-3, (light, float(near.max()))
        assert (np.abs(clip - 0.25) < 1e-3).sum() > 5, (light, "the glass box casts 0.25")
        assert (clip < 1e-3).mean() > 0.005, (light, "the cards cast full shadow too")
        rim = np.min([np.abs(fractional - g) for g in glass], axis=0) > 0.02
        assert rim.sum() > 20, (light, "fractional alpha lets light partly through")


def test_object_alpha_turns_an_unreadable_image_into_an_opaque_slot(found):
    """object_alpha: per slot contracts, an image read once for every object, a missing image
    an opaque slot with a warning naming object, material, node and file; nothing raises."""
    objects = found["object"]
    card = objects["Card"]
    assert [slot["kind"] for slot in card["slots"]] == ["texture", "opaque", "constant"]
    assert card["mesh"] == [0, 0]
    (warning,) = card["warnings"]
    assert warning.startswith(
        "object 'Card', material 'MissingImage', node 'Gone Node': image 'Gone Leaf': file '"
    ), warning
    assert warning.endswith("no_such_leaf.png' is missing; exported opaque"), warning
    only = objects["OnlyMissing"]
    assert only["slots"] == [{"kind": "opaque"}] and only["mesh"] is None, only
    assert only["warnings"][0].startswith("object 'OnlyMissing', material 'MissingImage'")
    assert objects["SecondCard"]["warnings"] == []
    # Rows read once as alpha (Card's TexAlpha and SecondCard's Clip share it).
    assert objects["images"] == {"Rows|alpha|0": [4, 2, [2, 4]]}
