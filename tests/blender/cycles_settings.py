"""Cycles set up as a ray caster for the agreement tests (``cycles_scene.py``,
``leaf_cards_scene.py``, ``scripts/alpha_cycles_check.py``): one sample at each pixel centre,
direct light only, the shadow catcher pass, a multilayer EXR of 32-bit floats. Loaded by those
scripts from this folder."""

from __future__ import annotations


def configure_cycles(scene, transparent_bounces: int = 0) -> None:
    """Cycles as a ray caster: one sample per pixel at the pixel centre, direct light only;
    ``transparent_bounces`` transparent hits a shadow ray may pass (0: none, every surface is
    opaque to it)."""
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = 1
    c.use_adaptive_sampling = False
    c.use_denoising = False
    # Pixel filter importance sampling draws the sample's offset from the filter: a 0.01-pixel
    # box puts every camera ray within 0.005 px of the pixel centre, where antumbra's rays go.
    c.pixel_filter_type = "BOX"
    c.filter_width = 0.01
    c.max_bounces = 0
    for attribute in ("diffuse_bounces", "glossy_bounces", "transmission_bounces"):
        setattr(c, attribute, 0)
    c.volume_bounces = 0
    c.transparent_max_bounces = transparent_bounces
    if hasattr(c, "use_transparent_shadows"):  # gone in 4.x: always on there
        c.use_transparent_shadows = True
    c.caustics_reflective = c.caustics_refractive = False
    c.seed = 0
    scene.render.film_transparent = True
    scene.render.use_compositing = False
    scene.render.use_sequencer = False
    scene.view_layers[0].cycles.use_pass_shadow_catcher = True
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):  # 5.0: choose multilayer before the format
        settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.color_depth = "32"
    settings.exr_codec = "ZIP"
