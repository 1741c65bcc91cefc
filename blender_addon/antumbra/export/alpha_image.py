"""An image's alpha (or luminance) as one float32 array, for the core's alpha lookups (issue 38).

``alpha_image(image, channel)`` returns ``(width, height, values)``: ``values`` is float32
(height, width) in Blender's row order, row 0 the bottom row, so texel (i, j) is centred on UV
((i + 0.5) / width, (j + 0.5) / height) and UV (0, 0) is the image's bottom-left corner, as
Cycles samples it. Pixels come out of Blender with one ``foreach_get``; nothing loops over
texels in Python.

The values are what Cycles' Image Texture outputs at each texel (checked against Cycles'
shadows in tests/blender/test_materials.py):

- ``alpha``: the alpha channel (1 for an image of 3 channels or alpha mode None).
- ``luminance``: the Color output converted to a float (``materials.luminance_coefficients``).
  Cycles holds colour premultiplied by alpha (not for Non-Color, Channel Packed or None
  images) and divides it again only when the node's Alpha output is linked too
  (``unassociate``): a leaf texture's colour through Principled Alpha is dark where it is
  transparent. Byte sRGB images are decoded to linear after that, as Cycles decodes them.
  Cycles interpolates the encoded colour and decodes it afterwards; decoding per texel is
  exact for Closest, but between texels of different colour Linear differs (up to 0.29
  between white and black texels; ``materials`` warns of it).

An image that cannot give pixels raises ``AlphaError`` naming it (and WHERE: the object,
material and node, as the caller knows them): a file that is missing, an image of 0 pixels.
"""

from __future__ import annotations

import os

import numpy as np

from .materials import luminance_coefficients


class AlphaError(ValueError):
    """An image the alpha export cannot read; the message names the object, material and node
    as far as the caller knows them, and the image."""


def _packed(image) -> bool:
    return image.packed_file is not None or bool(getattr(image, "packed_files", ()))


def _missing_file(image) -> str | None:
    """The absolute path of an unpacked file image whose file is absent; None otherwise."""
    if image.source != "FILE" or _packed(image):
        return None
    import bpy

    path = bpy.path.abspath(image.filepath, library=image.library)
    return None if os.path.isfile(path) else path


def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def associates(image) -> bool:
    """Whether Cycles holds IMAGE's colour premultiplied by its alpha (it does unless the image
    is data, Channel Packed or ignores its alpha)."""
    return not (image.colorspace_settings.is_data or image.alpha_mode in {"CHANNEL_PACKED", "NONE"})


def _luminance(image, rgba: np.ndarray, unassociate: bool, where: str) -> np.ndarray:
    """The Color output as a float, per texel, as Cycles computes it: the colour premultiplied
    by alpha (Blender's byte buffers are straight: premultiplied here in bytes, as Cycles' image
    loading does), divided by alpha again only when UNASSOCIATE (Cycles does when the node's
    Alpha output is linked too), decoded from sRGB after that (Cycles' order), then weighted by
    luminance."""
    colorspace = image.colorspace_settings
    divide = unassociate and associates(image)
    alpha = rgba[..., 3:4]
    keep = (alpha > 0) & (alpha < 1)
    rgb = rgba[..., :3]
    if image.is_float:  # scene linear, premultiplied unless channel packed
        if divide:
            rgb = np.divide(rgb, alpha, out=rgb.copy(), where=keep)
    else:
        srgb = colorspace.name == "sRGB"
        if not (srgb or colorspace.is_data or "linear" in colorspace.name.lower()):
            raise AlphaError(
                f"{where}image '{image.name}': colour space '{colorspace.name}' is not "
                "supported for alpha from colour (sRGB, linear and Non-Color are)"
            )
        if associates(image):
            byte = np.rint(rgba * 255.0).astype(np.int32)
            rgb = ((byte[..., :3] * byte[..., 3:4]) // 255).astype(np.float32) / 255.0
            if divide:
                rgb = np.divide(rgb, alpha, out=rgb.copy(), where=keep)
        if srgb:
            rgb = _srgb_to_linear(rgb)
    weights = np.asarray(luminance_coefficients(), dtype=np.float32)
    return (rgb @ weights).astype(np.float32)


def alpha_image(
    image, channel: str = "alpha", where: str = "", unassociate: bool = False
) -> tuple[int, int, np.ndarray]:
    """(width, height, float32 (height, width) values, bottom row first) of IMAGE's CHANNEL
    ("alpha" or "luminance"). WHERE prefixes error messages ("object 'A', material 'B', node
    'C': ")."""
    missing = _missing_file(image)
    if missing is not None:
        raise AlphaError(f"{where}image '{image.name}': file '{missing}' is missing")
    width, height = int(image.size[0]), int(image.size[1])
    channels = int(image.channels)
    if width * height == 0 or channels == 0:
        raise AlphaError(
            f"{where}image '{image.name}' has 0 pixels ({width}x{height}): Blender could not "
            f"read '{image.filepath}'"
        )
    pixels = np.empty(width * height * channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    pixels = pixels.reshape(height, width, channels)
    if channels < 4:
        pad = np.ones((height, width, 4 - channels), dtype=np.float32)
        pixels = np.concatenate([pixels, pad], axis=2)  # grey or RGB: opaque
        if channels == 1:
            pixels[..., 1:3] = pixels[..., :1]
    if channel == "alpha":
        values = pixels[..., 3] if image.alpha_mode != "NONE" else np.ones_like(pixels[..., 3])
    elif channel == "luminance":
        values = _luminance(image, pixels, unassociate, where)
    else:
        raise ValueError(f"channel {channel!r}: alpha or luminance")
    # Non-finite texels (a float file's NaN) read as 0, not as an alpha the core cannot order.
    values = np.nan_to_num(values, nan=0.0, posinf=1.0, neginf=0.0)
    return width, height, np.ascontiguousarray(values, dtype=np.float32)


def source_image(source, material: str, obj: str = "") -> tuple[int, int, np.ndarray]:
    """``alpha_image`` of a texture ``AlphaSource``, its errors naming the object (when given),
    the material and the Image Texture node."""
    import bpy

    where = (f"object '{obj}', " if obj else "") + f"material '{material}', node '{source.node}': "
    image = bpy.data.images.get(source.image)
    if image is None:
        raise AlphaError(f"{where}image '{source.image}' is not in this file")
    return alpha_image(image, source.channel, where, source.unassociate)
