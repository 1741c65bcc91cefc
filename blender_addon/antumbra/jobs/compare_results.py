"""A comparison's results for people: the per-method table (shadow N_B per ray and its ratio to
the baseline, frame time, whether the answers matched), the lines the batch prints, and the
per-method heat maps and difference images in ``bpy.data.images``."""

from __future__ import annotations

import numpy as np

from .results import _image, _load, _srgb_to_linear


def heat_image_name(label: str) -> str:
    """A method's shadow-ray node visits per pixel."""
    return f"antumbra {label} N_B"


def difference_image_name(label: str, baseline: str) -> str:
    """A method's shadow-ray node visits per pixel minus the baseline's."""
    return f"antumbra {label} - {baseline} N_B"


def _srgb8(image, rgb8: np.ndarray):
    _load(image, _srgb_to_linear(rgb8.astype(np.float32) / 255.0))


def load_images(client, compared) -> dict[str, str]:
    """Puts one frame's heat maps (turbo, 0 .. ``antumbra_max``) and difference images
    (diverging, blue -``antumbra_scale`` .. white 0 .. red +``antumbra_scale``) into
    ``bpy.data.images``; returns {what: image name}."""
    names: dict[str, str] = {}
    for label, heat in compared.heat.items():
        h, w = heat.shape
        name = heat_image_name(label)
        rgb8, top = client.colorize_heat(heat)
        image = _image(name, w, h, data=False)
        _srgb8(image, rgb8)
        image["antumbra_max"] = float(top)
        image["antumbra_frame"] = compared.frame
        names[f"{label}.N_B"] = name
    for label, difference in compared.difference.items():
        if label == compared.baseline:
            continue  # the baseline minus itself: nothing to see
        h, w = difference.shape
        name = difference_image_name(label, compared.baseline)
        rgb8, scale = client.colorize_difference(difference)
        image = _image(name, w, h, data=False)
        _srgb8(image, rgb8)
        image["antumbra_scale"] = float(scale)
        image["antumbra_frame"] = compared.frame
        names[f"{label} - {compared.baseline}.N_B"] = name
    return names


def table(rows: list[dict], baseline: str, mismatches: list[dict]) -> list[dict]:
    """One entry per method, in the rows' order: label, shadow N_B per ray over every frame and
    light, its ratio to the baseline's, the mean frame time (ms) and whether every frame's
    answers matched the baseline's."""
    methods: dict[str, dict] = {}
    for r in rows:
        m = methods.setdefault(r["label"], {"rays": 0, "nodes": 0.0, "frames": {}})
        if r["pass"] == "shadow":
            m["rays"] += r["rays"]
            m["nodes"] += r["nb_per_ray"] * r["rays"]
        m["frames"].setdefault(r["frame"], r["frame_ms"])
    differing = {m["label"] for m in mismatches}

    def nb(m: dict) -> float:
        return m["nodes"] / m["rays"] if m["rays"] else 0.0

    base = nb(methods[baseline]) if baseline in methods else 0.0
    return [
        {
            "label": label,
            "nb_per_ray": nb(m),
            "nb_ratio": nb(m) / base if base else 0.0,
            "frame_ms": sum(m["frames"].values()) / len(m["frames"]),
            "frames": len(m["frames"]),
            "matched": label not in differing,
        }
        for label, m in methods.items()
    ]


def frame_lines(rows: list[dict], baseline: str, mismatches: list[dict] = ()) -> list[str]:
    """One line per method of one frame: what the batch prints."""
    return [
        f"{t['label']}: N_B {t['nb_per_ray']:.2f}/ray ({t['nb_ratio']:.3f}x) "
        f"{t['frame_ms']:.2f} ms" + ("" if t["matched"] else " DIFFERS")
        for t in table(rows, baseline, list(mismatches))
    ]
