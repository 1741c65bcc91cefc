"""A rendered frame into Blender and onto disk: images in ``bpy.data.images`` (loaded with
``pixels.foreach_set``, shown in open Image Editors), per-frame files, and the statistics tables
(``stats.csv``, ``stats.json``) of every finished frame."""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
from pathlib import Path

import bpy
import numpy as np

from .. import client_loader

#: The heat maps' planes and how their images are called.
HEAT_PLANES = {
    "primary.N_B": "antumbra heat primary node visits",
    "primary.N_L": "antumbra heat primary leaf visits",
    "primary.N_T": "antumbra heat primary triangle tests",
    "shadow.N_B": "antumbra heat shadow node visits",
    "shadow.N_L": "antumbra heat shadow leaf visits",
    "shadow.N_T": "antumbra heat shadow triangle tests",
}
COMBINED_IMAGE = "antumbra combined"


def mask_image_name(light: str) -> str:
    return f"antumbra {light} shadow"


def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    # Float images hold linear values; the heat maps' colours are sRGB like their PNGs.
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _image(name: str, width: int, height: int, data: bool):
    image = bpy.data.images.get(name)
    if image is not None and tuple(image.size) != (width, height):
        image.scale(width, height)
    if image is None:
        image = bpy.data.images.new(name, width, height, alpha=False, float_buffer=True)
    if data:
        image.colorspace_settings.name = "Non-Color"
    return image


def _load(image, rgb: np.ndarray):
    """rgb: float32 (h, w, 3) or (h, w), rows top to bottom."""
    h, w = rgb.shape[:2]
    rgba = np.ones((h, w, 4), dtype=np.float32)
    rgba[..., :3] = rgb[::-1, :, None] if rgb.ndim == 2 else rgb[::-1]
    image.pixels.foreach_set(rgba.ravel())
    image.update()


def load_images(client, result) -> dict[str, str]:
    """Puts the frame's images into ``bpy.data.images``; returns {plane: image name}. Masks and
    the combined pass are stored as they are (1 lit, 0 shadowed); heat maps as the turbo
    colours of the PNGs, with the value of the top colour in the image's ``antumbra_max``."""
    names: dict[str, str] = {}
    # The daemon's order: masks (shadow.<light>, light order), combined, then the heat maps.
    combined_at = [plane for plane, _ in result.planes].index("combined")
    for index, (plane, array) in enumerate(result.planes):
        if index < combined_at:
            name = mask_image_name(plane.removeprefix("shadow."))
            _load(_image(name, result.width, result.height, data=True), array)
        elif index == combined_at:
            name = COMBINED_IMAGE
            _load(_image(name, result.width, result.height, data=True), array)
        elif plane in HEAT_PLANES:
            name = HEAT_PLANES[plane]
            rgb8, top = client.colorize_heat(array)
            image = _image(name, result.width, result.height, data=False)
            _load(image, _srgb_to_linear(rgb8.astype(np.float32) / 255.0))
            image["antumbra_max"] = float(top)
        else:
            continue  # a pass the add-on does not show (e.g. object ids)
        image = bpy.data.images[name]
        image["antumbra_frame"] = result.frame
        names[plane] = name
    return names


def show_in_image_editors(name: str) -> int:
    """Shows image ``name`` in every open Image Editor; returns how many."""
    image = bpy.data.images.get(name)
    shown = 0
    wm = bpy.context.window_manager
    if image is None or wm is None:
        return 0
    for window in wm.windows:
        for area in window.screen.areas:
            if area.type == "IMAGE_EDITOR":
                area.spaces.active.image = image
                area.tag_redraw()
                shown += 1
    return shown


def stats_summary(rows: list[dict]) -> list[str]:
    """One line per pass: what the panel and the batch print."""
    lines = []
    for r in rows:
        primary = r["pass"] == "primary"
        # For camera rays the fraction counts rays that hit something.
        what = "hit" if primary else "occluded"
        lines.append(
            f"{'primary' if primary else r['light']}: {r['rays']} rays, "
            f"{100 * r['occluded_fraction']:.1f}% {what}, "
            f"N_B {r['nb_per_ray']:.2f} N_L {r['nl_per_ray']:.2f} N_T {r['nt_per_ray']:.2f}"
            " per ray"
        )
    return lines


def _write_atomic(path: Path, text: str):
    # The client's Rust writer: a unique temporary file, synced, renamed (two writers never race).
    client_loader.load().write_file_atomic(path, text.encode())


def run_key(blend: str, options) -> str:
    """What decides a frame's pixels besides the frame number: the .blend (path and modification
    time) and the render options. A batch resumes only frames recorded with the same key."""
    mtime = os.stat(blend).st_mtime_ns if blend and os.path.exists(blend) else 0
    what = [blend, mtime, options.render_kwargs(), options.resolution_scale]
    return hashlib.sha1(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()[:16]


def frame_record(done, key: str | None = None) -> dict:
    """What a finished frame leaves in ``frame_NNNN.stats.json``: its timing and size, the run
    key it was made with, and the daemon's statistics rows (one per pass: primary, then each
    shadow-casting light)."""
    return {
        "frame": done.frame,
        "key": key,
        "seconds": done.seconds,
        "export_seconds": done.export_seconds,
        "objects": done.objects,
        "triangles": done.triangles,
        "rows": done.result.stats,
    }


def write_frame_stats(out_dir: Path, record: dict) -> Path:
    """``frame_NNNN.stats.json``, written last, so its presence means the frame's files are
    complete (a batch resumes after it)."""
    path = out_dir / f"frame_{record['frame']:04d}.stats.json"
    _write_atomic(path, json.dumps(record, indent=1))
    return path


def finished_frames(out_dir: Path, key: str | None = None) -> dict[int, dict]:
    """The records of the frames whose files are complete in ``out_dir`` (made with run key
    ``key``, if given)."""
    done = {}
    for path in sorted(out_dir.glob("frame_*.stats.json")):
        try:
            record = json.loads(path.read_text())
            if key is None or record.get("key") == key:
                done[int(record["frame"])] = record
        except (ValueError, KeyError, TypeError, json.JSONDecodeError):
            continue  # a foreign or damaged file: the frame is rendered again
    return done


def frame_summary(record: dict) -> dict:
    """One row per frame: timing, size, and the shadow rays' work summed over lights.

    Two triangle counts, which differ: ``triangles_sent`` is every triangle the exporter sent
    (each object's evaluated mesh once per placement, what Blender counts), and
    ``primary_triangles`` the camera rays' tree (``stats.csv``'s ``triangles`` on the primary
    row): objects hidden from the camera and degenerate triangles left out."""
    rows = record["rows"]
    primary = next((r for r in rows if r["pass"] == "primary"), None)
    shadow = [r for r in rows if r["pass"] == "shadow"]
    rays = sum(r["rays"] for r in shadow)

    def per_ray(key: str) -> float:
        return sum(r[key] * r["rays"] for r in shadow) / rays if rays else 0.0

    return {
        "frame": record["frame"],
        "seconds": round(record["seconds"], 6),
        "export_seconds": round(record["export_seconds"], 6),
        "objects": record["objects"],
        "triangles_sent": record["triangles"],
        "primary_triangles": primary["triangles"] if primary else 0,
        "primary_rays": primary["rays"] if primary else 0,
        "primary_nb_per_ray": primary["nb_per_ray"] if primary else 0.0,
        "shadow_rays": rays,
        "shadow_occluded_fraction": per_ray("occluded_fraction"),
        "shadow_nb_per_ray": per_ray("nb_per_ray"),
        "shadow_nl_per_ray": per_ray("nl_per_ray"),
        "shadow_nt_per_ray": per_ray("nt_per_ray"),
        "build_ms": primary["build_ms"] if primary else 0.0,
    }


def _write_csv(path: Path, rows: list[dict]):
    columns: list[str] = []
    for row in rows:
        columns.extend(k for k in row if k not in columns)
    text = io.StringIO(newline="")
    writer = csv.DictWriter(text, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    _write_atomic(path, text.getvalue())


def write_tables(out_dir: Path) -> tuple[Path, int]:
    """The tables of every finished frame, in frame order, rebuilt from the per-frame files (so
    a resumed run never repeats a row): ``frames.csv`` (one row per frame), ``stats.csv`` and
    ``stats.json`` (one row per pass and frame). Returns the frames table and its row count."""
    records = finished_frames(out_dir)
    rows = [row for f in sorted(records) for row in records[f]["rows"]]
    # The statistics through the client's Rust writers: the same bytes as `antumbra render`.
    client = client_loader.load()
    client.write_stats_json(out_dir / "stats.json", rows)
    client.write_stats_csv(out_dir / "stats.csv", rows)
    _write_csv(out_dir / "frames.csv", [frame_summary(records[f]) for f in sorted(records)])
    return out_dir / "frames.csv", len(records)
