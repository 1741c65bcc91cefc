"""The output format antumbra's frames are written in by Blender: 32-bit multilayer OpenEXR, set
the way each Blender takes it (5.0 chooses the media type first; 3.4 to 4.5 have no media type).
Defined once for the farm's chunks and the tests."""

from __future__ import annotations


def set_multilayer_exr(image_settings) -> None:
    """Every pass of a frame into one 32-bit multilayer EXR."""
    if hasattr(image_settings, "media_type"):  # Blender 5.0: the format follows the media type
        image_settings.media_type = "MULTI_LAYER_IMAGE"
    image_settings.file_format = "OPEN_EXR_MULTILAYER"
    image_settings.color_depth = "32"
