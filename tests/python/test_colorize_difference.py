"""``colorize_difference``: the comparison's diverging colour map (the diff PNGs' colours):
blue at -scale, white at 0, red at +scale, the scale the largest absolute difference (at
least 1) unless given."""

from __future__ import annotations

import numpy as np
import pytest

import antumbra

COOL, CENTRE, WARM = [59, 76, 192], [247, 247, 247], [180, 4, 38]


def test_ends_centre_and_scale():
    rgb, scale = antumbra.colorize_difference(np.array([[-4, 0, 4, 1]], dtype=np.float32))
    assert scale == 4.0 and rgb.dtype == np.uint8 and rgb.shape == (1, 4, 3)
    assert rgb[0, :3].tolist() == [COOL, CENTRE, WARM]
    assert rgb[0, 3].tolist() == [int(247 + (c - 247) / 4 + 0.5) for c in WARM]


def test_all_equal_is_white_and_scale_given():
    rgb, scale = antumbra.colorize_difference(np.zeros((2, 3), dtype=np.float32))
    assert scale == 1.0 and (rgb == 247).all()
    rgb, scale = antumbra.colorize_difference(np.array([[10.0]], dtype=np.float32), scale=5)
    assert scale == 5.0 and rgb[0, 0].tolist() == WARM  # clamped at the end


def test_bad_input_is_refused():
    with pytest.raises(antumbra.InvalidInput):
        antumbra.colorize_difference(np.zeros(3, dtype=np.float32))
    with pytest.raises(antumbra.InvalidInput):
        antumbra.colorize_difference(np.zeros((1, 1), dtype=np.float32), scale=0)
