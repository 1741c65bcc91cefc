"""A plain numpy evaluation of the alpha contract (docs/alpha_export.md), as Cycles samples an
Image Texture: the reference ``test_materials.py`` holds Cycles' own shadows against, and the
spelling out of what the Rust core computes per hit.

    alpha = evaluate(contract, values, u, v)    # values: alpha_image's (height, width) array

Sampling (Cycles' CPU image kernel, ``kernel/device/cpu/image.h``): texel (i, j) is centred on
UV ((i + 0.5) / width, (j + 0.5) / height), row j = 0 the bottom one.

- Closest: texel (floor(u * width), floor(v * height)).
- Linear: x = u * width - 0.5, ix = floor(x), tx = x - ix (and so for y); the four texels
  (ix, iy), (ix + 1, iy), (ix, iy + 1), (ix + 1, iy + 1) blended by tx, ty.
- Extension, per texel index: REPEAT wraps (i mod width), EXTEND clamps to [0, width - 1],
  CLIP reads 0 for a texel outside the image (Closest: 0 outside UV [0, 1)).

Cubic, Smart and MIRROR are not modelled here.
"""

from __future__ import annotations

import numpy as np


def _index(i: np.ndarray, size: int, extension: str) -> tuple[np.ndarray, np.ndarray]:
    """Texel indices in range, and whether each reads the image (False: CLIP's outside)."""
    if extension == "REPEAT":
        return np.mod(i, size), np.ones(i.shape, dtype=bool)
    if extension == "EXTEND":
        return np.clip(i, 0, size - 1), np.ones(i.shape, dtype=bool)
    if extension == "CLIP":
        inside = (i >= 0) & (i < size)
        return np.clip(i, 0, size - 1), inside
    raise ValueError(f"extension {extension} is not modelled")


def _texel(values, ix, iy, extension):
    h, w = values.shape
    x, x_in = _index(ix, w, extension)
    y, y_in = _index(iy, h, extension)
    return np.where(x_in & y_in, values[y, x], 0.0)


def sample(values: np.ndarray, u, v, interpolation: str, extension: str) -> np.ndarray:
    h, w = values.shape
    u, v = np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64)
    if interpolation == "Closest":
        return _texel(values, np.floor(u * w).astype(int), np.floor(v * h).astype(int), extension)
    if interpolation != "Linear":
        raise ValueError(f"interpolation {interpolation} is not modelled")
    x, y = u * w - 0.5, v * h - 0.5
    ix, iy = np.floor(x).astype(int), np.floor(y).astype(int)
    tx, ty = x - ix, y - iy
    return (1 - ty) * (
        (1 - tx) * _texel(values, ix, iy, extension) + tx * _texel(values, ix + 1, iy, extension)
    ) + ty * (
        (1 - tx) * _texel(values, ix, iy + 1, extension)
        + tx * _texel(values, ix + 1, iy + 1, extension)
    )


def apply_ops(x: np.ndarray, ops: list) -> np.ndarray:
    """The contract's ops in order, as Cycles' SVM math computes them."""
    for op, *arg in ops:
        if op == "MULTIPLY":
            x = x * arg[0]
        elif op == "ADD":
            x = x + arg[0]
        elif op == "SUBTRACT":
            x = x - arg[0]
        elif op == "POWER":  # safe_powf: a negative base to a non-integer power is 0
            bad = (x < 0) & (arg[0] != int(arg[0]))
            x = np.where(bad, 0.0, np.power(np.where(bad, 1.0, x), arg[0]))
        elif op == "GREATER_THAN":
            x = (x > arg[0]).astype(np.float64)
        elif op == "LESS_THAN":
            x = (x < arg[0]).astype(np.float64)
        elif op == "ONE_MINUS":
            x = 1.0 - x
        elif op == "CLAMP":
            x = np.clip(x, 0.0, 1.0)
        else:
            raise ValueError(op)
    return x


def evaluate(contract: dict, values, u, v) -> np.ndarray:
    """The opacity the contract gives at UV (u, v); VALUES the image's channel (textures)."""
    shape = np.shape(u)
    if contract["kind"] == "opaque":
        return np.ones(shape)
    if contract["kind"] == "constant":
        return np.full(shape, contract["alpha"])
    x = sample(np.asarray(values), u, v, contract["interpolation"], contract["extension"])
    return np.clip(apply_ops(x, contract["ops"]), 0.0, 1.0)
