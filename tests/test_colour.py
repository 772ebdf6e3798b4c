"""Colour conversion against known CIE facts."""

from __future__ import annotations

import numpy as np
import pytest

from labcut import Labradorite, ParameterError
from labcut.colour import (
    colour_of_spectrum,
    dominant_text,
    dominant_wavelength,
    hue_of,
    reflectance_rgb,
    reflectance_to_xyz,
    tables,
    xyz_to_linear_srgb,
)


def test_white_reflector_is_srgb_white_under_d65():
    ones = np.ones_like(tables().wavelengths)
    xyz = reflectance_to_xyz(ones)
    assert xyz[1] == pytest.approx(1.0)
    assert np.allclose(xyz_to_linear_srgb(xyz), 1.0, atol=2e-3)
    c = colour_of_spectrum(0.5 * ones)
    assert np.isnan(c.dominant_wavelength_nm) and c.purity == 0.0


def test_d65_white_point_chromaticity():
    xyz = reflectance_to_xyz(np.ones_like(tables().wavelengths))
    x, y = xyz[0] / xyz.sum(), xyz[1] / xyz.sum()
    assert abs(x - 0.3127) < 2e-3 and abs(y - 0.3290) < 2e-3


@pytest.mark.parametrize("nm", [460.0, 490.0, 520.0, 560.0, 600.0, 650.0])
def test_narrow_band_has_its_own_dominant_wavelength_and_full_purity(nm):
    wl = tables().wavelengths
    spectrum = np.exp(-0.5 * ((wl - nm) / 1.5) ** 2)
    dom, purity = dominant_wavelength(reflectance_to_xyz(spectrum))
    assert abs(dom - nm) < 1.5
    assert purity > 0.9


def test_purple_gets_negative_complementary_wavelength():
    wl = tables().wavelengths
    spectrum = np.exp(-0.5 * ((wl - 440) / 10) ** 2) + np.exp(-0.5 * ((wl - 650) / 10) ** 2)
    dom, purity = dominant_wavelength(reflectance_to_xyz(spectrum))
    assert 490.0 < -dom < 575.0 and 0.0 < purity <= 1.0


def test_a_purple_is_named_with_its_complementary_wavelength():
    """A negative dominant wavelength is CIE shorthand for a purple; say so, and give the
    complementary wavelength as a positive number."""
    wl = tables().wavelengths
    purple = colour_of_spectrum(np.exp(-0.5 * ((wl - 440) / 10) ** 2) + np.exp(-0.5 * ((wl - 650) / 10) ** 2))
    assert purple.hue == "purple" and purple.complementary_wavelength_nm == -purple.dominant_wavelength_nm > 0
    assert dominant_text(purple.dominant_wavelength_nm) == f"c {purple.complementary_wavelength_nm:.1f} nm"
    green = colour_of_spectrum(np.exp(-0.5 * ((wl - 530) / 10) ** 2))
    assert green.hue == "spectral" and np.isnan(green.complementary_wavelength_nm)
    assert dominant_text(green.dominant_wavelength_nm) == f"{green.dominant_wavelength_nm:.1f} nm"
    grey = colour_of_spectrum(0.5 * np.ones_like(wl))
    assert grey.hue is None and hue_of(float("nan")) is None and dominant_text(float("nan")) == "—"
    assert "hue" not in purple.to_dict()  # the stored fields are unchanged


def test_preset_colours_have_the_expected_hue():
    blue = Labradorite.preset("blue").flash_colour()
    red = Labradorite.preset("red").flash_colour()
    assert blue.srgb[2] == pytest.approx(1.0) and blue.srgb[0] < 0.3
    assert red.srgb[0] == pytest.approx(1.0) and red.srgb[2] < 0.3
    assert blue.hex.startswith("#") and len(blue.hex) == 7


def test_rgb_table_matches_per_angle_colour():
    lab = Labradorite.preset("green")
    table = reflectance_rgb(lab, np.array([1.0, 0.8]))
    assert table.shape == (2, 3)
    assert np.allclose(table[0], lab.flash_colour(1.0).linear_srgb)


def test_unknown_illuminant():
    with pytest.raises(ParameterError):
        Labradorite().flash_colour(illuminant="A")


def test_the_s_and_p_luminances_from_one_evaluation_are_each_polarisations_own():
    import numpy as np

    import labcut
    from labcut.colour import reflectance_luminance, reflectance_luminance_sp

    m = labcut.Labradorite.preset("gold")
    c = np.linspace(0.05, 1.0, 37).reshape(37, 1)
    y_s, y_p = reflectance_luminance_sp(m, c)
    assert np.array_equal(y_s, reflectance_luminance(m, c, polarization="s"))
    assert np.array_equal(y_p, reflectance_luminance(m, c, polarization="p"))
    assert not np.allclose(y_s, y_p)  # away from normal incidence the two differ


def test_the_s_and_p_luminance_table_is_the_stacks_on_its_grid():
    from labcut.colour import luminance_sp_table, reflectance_luminance_sp

    lab = Labradorite.preset("green")
    c, ys, yp = luminance_sp_table(lab)
    assert c.shape == ys.shape == yp.shape == (1024,) and c[0] == 0.0 and c[-1] == 1.0
    pick = np.array([0, 100, 511, 900, 1023])
    es, ep = reflectance_luminance_sp(lab, c[pick])
    assert np.allclose(ys[pick], es, rtol=1e-12, atol=0) and np.allclose(yp[pick], ep, rtol=1e-12, atol=0)
    assert not np.allclose(ys, yp)  # two polarisations, not one twice
