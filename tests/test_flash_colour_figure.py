"""The flash in its own colour (issue 33, item 3): figures that encode flash colour paint each
wavelength in the colour of that light, not on a rainbow scale (turbo painted a 477 nm flash lime)."""

from __future__ import annotations

import numpy as np
import pytest

import labcut
from labcut.colour import spectral_srgb
from labcut.reports.figures import colour_map_rgba, spectral_colormap, wavelength_range


@pytest.mark.parametrize(("nm", "channel"), [(450, 2), (477, 2), (530, 1), (620, 0), (700, 0)])
def test_each_wavelength_in_its_own_colour(nm, channel):
    rgb = spectral_srgb(nm)
    assert rgb.shape == (3,) and rgb[channel] == pytest.approx(1.0) and np.all((rgb >= 0) & (rgb <= 1))
    assert np.argmax(rgb) == channel


def test_outside_the_tables_is_grey_and_the_bar_runs_blue_to_red():
    assert np.allclose(spectral_srgb([np.nan, 100.0, 1000.0]), 0.5)
    cmap = spectral_colormap(450.0, 650.0)
    lo, hi = np.asarray(cmap(0.0))[:3], np.asarray(cmap(1.0))[:3]
    assert np.argmax(lo) == 2 and np.argmax(hi) == 0


def test_the_blue_presets_flash_colour_map_is_blue():
    cmp = labcut.compare_cuts(["cab:oval,16x12,low,res=48"], "blue", quality="draft", resolution=32, spp=2)
    fm = cmp.cuts[0].scenarios["bench"].colour
    assert 460 < fm.stats["dominant_wavelength_nm"] < 495  # the blue preset's flash
    rgba = colour_map_rgba(fm, *wavelength_range(cmp))
    flashing = fm.mask & (fm.level >= 1.0)
    assert flashing.any()
    r, g, b = rgba[flashing][:, :3].mean(axis=0)
    assert b > g > r, (r, g, b)
