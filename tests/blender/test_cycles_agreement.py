"""Blender's Cycles and antumbra agree on what the camera sees and on hard sun shadows.

``cycles_scene.py`` builds a test scene in Blender (a ground grid, boxes, a slab and a sphere, a
hard sun), renders it with Cycles at antumbra's resolution, and renders the same frame with
antumbra through the add-on's exporter (a ``LocalSession``). This test compares the two:

- **Object ids**: Cycles' Object Index pass (each object's ``pass_index`` is its index in the
  export + 1, 0 is the background) against antumbra's ``object_ids`` pass (the index, -1 for
  the background), over every pixel. Cycles takes 1 sample per pixel with a 0.01-pixel box
  filter, so its camera ray goes within 0.005 px of the pixel centre, where antumbra's goes.
- **Hard shadows**: Cycles' Shadow Catcher pass (the ground is the shadow catcher; bounces 0,
  a world that emits nothing, so the pass is exactly 0 in the shadow of other objects and 1 in
  light) against antumbra's mask of the sun (0 shadowed, 1 lit), over the pixels where both
  renderers see the ground. Excluded, and reported: the background, pixels of other objects
  (Cycles' pass is 1 there by definition: only a catcher catches shadows, and catchers do not
  shadow each other), pixels the renderers assign to different objects, and ground pixels that
  face away from the sun (N.L <= 0: antumbra calls them shadowed, Cycles' catcher 1; none in
  this scene, the ground faces the sun).

Why a subprocess per Blender: Blender's state is process-wide (``read_factory_settings`` would
reset any other test's scene), and the same script then runs unchanged in both Blenders the
add-on supports: the ``bpy`` module, 5.0 or 5.3 (``python cycles_scene.py`` with the Python running
pytest) and Debian's Blender 3.4 (``blender -b -P``). A missing Blender fails its variant (never
a skip). The passes come back as Blender's own multilayer EXR, read with ``antumbra.read_exr``.

    pytest tests/blender/test_cycles_agreement.py -s    # prints the agreement figures
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import antumbra

HERE = Path(__file__).resolve().parent
SCRIPT = HERE / "cycles_scene.py"

OBJECT_ID_THRESHOLD = 0.995
SHADOW_THRESHOLD = 0.99


def _blender_command(kind: str, out: Path) -> list[str]:
    args = ["--", "--out", str(out)]
    if kind == "bpy":
        return [sys.executable, str(SCRIPT), *args]
    return ["blender", "-b", "--factory-startup", "-noaudio", "-P", str(SCRIPT), *args]


def run_blender(kind: str, tmp: Path) -> Path:
    """Runs cycles_scene.py in a fresh Blender; returns its output directory."""
    out = tmp / "out"
    home = tmp / "home"
    home.mkdir()
    # Blender sees only the client package of this Python, not the rest of its site-packages.
    client_dir = tmp / "client"
    client_dir.mkdir()
    (client_dir / "antumbra").symlink_to(Path(antumbra.__file__).resolve().parent)
    env = dict(os.environ, HOME=str(home), PYTHONPATH=str(client_dir))
    start = time.perf_counter()
    proc = subprocess.run(
        _blender_command(kind, out), env=env, capture_output=True, text=True, timeout=300
    )
    seconds = time.perf_counter() - start
    log = (proc.stdout + proc.stderr)[-4000:]
    assert proc.returncode == 0, f"{kind} exited with {proc.returncode}:\n{log}"
    assert (out / "cycles.exr").is_file() and (out / "antumbra.npz").is_file(), log
    print(f"\n[{kind}] Blender + Cycles + antumbra took {seconds:.1f} s")
    return out


def channel(planes: dict[str, np.ndarray], pass_names: tuple[str, ...], ch: str) -> np.ndarray:
    """A channel of Blender's multilayer EXR whatever the version's naming: 3.4 writes
    ``ViewLayer.IndexOB.X``, 5.0 ``ViewLayer.Object Index.ViewLayer.Object Index.X``."""
    for name, data in planes.items():
        parts = name.split(".")
        if parts[-1] == ch and any(f".{p}." in f".{name}" for p in pass_names):
            return data
    raise KeyError(f"no {pass_names} {ch} channel in {sorted(planes)}")


def compare(out: Path) -> dict:
    meta = json.loads((out / "scene.json").read_text())
    planes = dict(antumbra.read_exr(str(out / "cycles.exr")))
    ours = np.load(out / "antumbra.npz")
    width, height = meta["width"], meta["height"]

    # Both rows top to bottom: EXR stores the top row first, antumbra.read_exr keeps that order.
    cycles_index = channel(planes, ("IndexOB", "Object Index"), "X")
    catcher = channel(planes, ("Shadow Catcher",), "R")
    assert cycles_index.shape == catcher.shape == (height, width)
    cycles_ids = cycles_index.astype(np.int64) - 1  # pass_index = export index + 1
    ant_ids = ours["object_ids"].astype(np.int64)
    mask = ours["mask"]
    assert ant_ids.shape == mask.shape == (height, width)
    n = width * height

    ids_equal = cycles_ids == ant_ids
    ground = meta["objects"].index("Ground")
    both_ground = (cycles_ids == ground) & (ant_ids == ground)
    facing = meta["ground_n_dot_l"] > 0.0  # a plane: one N.L for all its pixels
    region = both_ground & facing
    cycles_shadow = catcher < 0.5
    ant_shadow = mask < 0.5
    shadow_equal = (cycles_shadow == ant_shadow) & region
    r = {
        "blender": meta["blender"],
        "size": f"{width}x{height}",
        "pixels": n,
        "objects": len(meta["objects"]),
        "id_agreement": ids_equal.mean(),
        "id_mismatches": int((~ids_equal).sum()),
        "background_pixels": int(((cycles_ids < 0) & (ant_ids < 0)).sum()),
        "distinct_ids": len(np.unique(ant_ids)),
        "shadow_region": int(region.sum()),
        "shadow_agreement": shadow_equal.sum() / max(int(region.sum()), 1),
        "shadow_mismatches": int((region & ~shadow_equal).sum()),
        "shadowed_in_region": int((region & cycles_shadow).sum()),
        "excluded_background": int(((cycles_ids < 0) | (ant_ids < 0)).sum()),
        "excluded_other_objects": int(
            ((cycles_ids >= 0) & (ant_ids >= 0) & ~both_ground & ids_equal).sum()
        ),
        "excluded_id_disagreement": int(((cycles_ids >= 0) & (ant_ids >= 0) & ~ids_equal).sum()),
        "excluded_back_facing": int((both_ground & (not facing)).sum()),
        # Sensitivity: the same comparisons with antumbra's ids mirrored (left-right, upside
        # down) and its mask inverted or upside down.
        "id_agreement_mirrored": (cycles_ids == ant_ids[:, ::-1]).mean(),
        "id_agreement_flipped": (cycles_ids == ant_ids[::-1]).mean(),
        "shadow_agreement_inverted": ((cycles_shadow != ant_shadow) & region).sum()
        / max(int(region.sum()), 1),
        "shadow_agreement_flipped": ((cycles_shadow == ant_shadow[::-1]) & region).sum()
        / max(int(region.sum()), 1),
    }
    excluded = (
        r["excluded_background"]
        + r["excluded_other_objects"]
        + r["excluded_id_disagreement"]
        + r["excluded_back_facing"]
    )
    assert excluded + r["shadow_region"] == n
    # Outside the catcher Cycles' pass is 1 (nothing to catch): the exclusion is by definition.
    assert (catcher[~both_ground & (cycles_ids != ground)] == 1.0).all()
    return r


def report(kind: str, r: dict) -> None:
    print(
        f"[{kind}] Blender {r['blender']}, {r['size']} ({r['pixels']} pixels, "
        f"{r['objects']} objects)\n"
        f"  object ids: {100 * r['id_agreement']:.3f}% equal ({r['id_mismatches']} pixels "
        f"differ; {r['background_pixels']} background pixels; {r['distinct_ids']} distinct ids)\n"
        f"  sun shadows on the ground: {100 * r['shadow_agreement']:.3f}% equal over "
        f"{r['shadow_region']} pixels ({r['shadow_mismatches']} differ; "
        f"{r['shadowed_in_region']} shadowed in Cycles)\n"
        f"  excluded: {r['excluded_background']} background, {r['excluded_other_objects']} "
        f"other objects, {r['excluded_id_disagreement']} ids differ, "
        f"{r['excluded_back_facing']} ground facing away from the sun\n"
        f"  sensitivity: ids vs antumbra's mirrored left-right "
        f"{100 * r['id_agreement_mirrored']:.2f}%, upside down "
        f"{100 * r['id_agreement_flipped']:.2f}%; shadows vs antumbra's mask inverted "
        f"{100 * r['shadow_agreement_inverted']:.2f}%, upside down "
        f"{100 * r['shadow_agreement_flipped']:.2f}%"
    )


def test_cycles_agrees_with_antumbra(blender_kind, tmp_path):
    out = run_blender(blender_kind, tmp_path)
    r = compare(out)
    report(blender_kind, r)
    # The scene means something: sky, ground, every object in view, real shadows.
    assert r["background_pixels"] > 0.05 * r["pixels"]
    assert r["distinct_ids"] == r["objects"] + 1
    assert r["shadowed_in_region"] > 0.05 * r["shadow_region"]
    assert r["shadow_region"] > 0.3 * r["pixels"]
    # The requirement.
    assert r["id_agreement"] >= OBJECT_ID_THRESHOLD, r
    assert r["shadow_agreement"] >= SHADOW_THRESHOLD, r
    # And the comparison would notice a mirrored image or an inverted mask.
    assert r["id_agreement_mirrored"] < OBJECT_ID_THRESHOLD
    assert r["id_agreement_flipped"] < OBJECT_ID_THRESHOLD
    assert r["shadow_agreement_inverted"] < SHADOW_THRESHOLD
    assert r["shadow_agreement_flipped"] < SHADOW_THRESHOLD
