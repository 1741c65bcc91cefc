"""Files and images as antumbra writes and reads them, through the same Rust writers and readers
as the command line: recordings, atomic writes, statistics tables, EXRs and colour maps.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from . import _native

__all__ = [
    "colorize_difference",
    "colorize_heat",
    "read_exr",
    "read_recording",
    "write_file_atomic",
    "write_stats_csv",
    "write_stats_json",
]


def read_recording(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The meshes and frames of a recording (``.antrec``, from ``start_recording``,
    ``antumbra serve --record`` or ``antumbra record``).

    Returns ``{"meshes": {hash: {"name", "positions", "triangles"}}, "frames": [dict, ...]}``:
    positions float32 (n, 3) and triangles uint32 (m, 3) numpy arrays, checked as the daemon
    checks an upload; each frame a dict with ``frame``, ``objects``, ``camera``, ``lights`` and
    ``resolution`` in the form ``frame_update`` takes (Blender's field names, row-major 4x4
    matrices as nested lists).
    """
    return _native.read_recording(os.fspath(path))


def write_file_atomic(path: str | os.PathLike[str], data: bytes) -> None:
    """Writes ``data`` to ``path`` as every antumbra file is written: into a uniquely named
    temporary file beside it, synced to disk, then renamed over ``path`` (so a reader never sees
    half a file, and two writers never share a temporary file). The file gets the mode the
    umask gives any new file (0644 under umask 022)."""
    _native.write_file_atomic(os.fspath(path), bytes(data))


def write_stats_csv(path: str | os.PathLike[str], rows: list[dict[str, Any]]) -> None:
    """Writes statistics rows (``Result.stats`` dicts, or those dicts read back from JSON) as
    ``stats.csv``, with the Rust writer ``antumbra render`` uses: the same bytes for the same
    rows, written atomically."""
    _native.write_stats(os.fspath(path), list(rows), "csv")


def write_stats_json(path: str | os.PathLike[str], rows: list[dict[str, Any]]) -> None:
    """Writes statistics rows as ``stats.json``, as ``antumbra render`` does (atomically)."""
    _native.write_stats(os.fspath(path), list(rows), "json")


def colorize_heat(array: np.ndarray, max: float | None = None) -> tuple[np.ndarray, float]:
    """A heat map (float32 (h, w)) through the turbo colour map as the PNGs draw it: 0 is the
    first colour, ``max`` (default: the image's largest value) the last. Returns the sRGB uint8
    array of shape (h, w, 3) and the max used."""
    return _native.colorize_heat(array, max)


def colorize_difference(array: np.ndarray, scale: float | None = None) -> tuple[np.ndarray, float]:
    """A difference image (float32 (h, w), e.g. one method's node visits minus the baseline's)
    as the comparison's PNGs draw it: blue at ``-scale``, white at 0, red at ``+scale``
    (default: the largest absolute difference, at least 1). Returns the sRGB uint8 array of
    shape (h, w, 3) and the scale used."""
    return _native.colorize_difference(array, scale)


def read_exr(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """Every channel of an EXR file (such as ``frame_NNNN.exr`` from ``antumbra render`` or
    :meth:`Result.save`) as float32 arrays of shape (height, width), rows top to bottom."""
    return _native.read_exr(os.fspath(path))
