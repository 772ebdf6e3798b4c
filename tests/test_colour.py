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


# ----------------------------------------------------------------- the spectra's Dr.Jit float64 path
PERFECT = Labradorite(sigma_a=0.0, sigma_b=0.0, pairs=20000)  # a narrow, saturated band: float32 would miss it


@pytest.mark.parametrize("material", [Labradorite(), Labradorite.preset("gold"), Labradorite.from_peak_wavelength(611.0),
                                      PERFECT], ids=["blue", "gold", "611nm", "perfect"])
@pytest.mark.parametrize("polarization", [None, "s", "p"])
def test_the_tables_spectra_by_drjit_are_numpys_in_float64(material, polarization):
    """The colour tables' spectra (:func:`labcut.colour.stack_spectra`) come from one Dr.Jit kernel
    in float64: numpy's reference path to about 1e-13, at grazing and normal incidence alike. A
    float32 step anywhere (its relative error ~6e-8, far more on a perfect stack's narrow band)
    fails this."""
    from labcut.colour import stack_spectra

    c = np.concatenate([np.linspace(0.0, 1.0, 97), [1e-6, 0.5 + 1e-9]])
    want = stack_spectra(material.stack, c, polarization, jit=False)
    got = stack_spectra(material.stack, c, polarization)
    assert got.shape == want.shape == (c.size, tables().wavelengths.size) and got.dtype == np.float64
    assert np.all(np.isfinite(got)) and np.all((got >= 0.0) & (got <= 1.0))
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)


def test_the_s_and_p_spectra_from_one_kernel_are_each_polarisations_own():
    from labcut.colour import stack_spectra, stack_spectra_sp

    m = Labradorite.preset("green")
    c = np.linspace(0.05, 1.0, 13)
    r_s, r_p = stack_spectra_sp(m.stack, c)
    assert np.array_equal(r_s, stack_spectra(m.stack, c, "s")) and np.array_equal(r_p, stack_spectra(m.stack, c, "p"))
    np.testing.assert_allclose(r_s, stack_spectra_sp(m.stack, c, jit=False)[0], rtol=1e-12, atol=1e-15)


def test_one_spectra_kernel_serves_every_material():
    """The stack's parameters reach the kernel as opaque values: a new material (a flash peak never
    asked before) runs the kernel compiled for the last one instead of compiling its own."""
    from mitsuba_helpers import launched

    from labcut.colour import stack_spectra

    # every field takes two values or more among these (a field left a literal would compile a kernel of its own)
    materials = [Labradorite.from_peak_wavelength(497.0), PERFECT,
                 Labradorite(n_a=1.551, n_b=1.567, d_a=70.0, d_b=90.0, sigma_a=9.0, sigma_b=21.0, pairs=3001,
                             n_surface=1.553)]
    assert all(len({m.stack[i] for m in materials}) >= 2 for i in range(len(materials[0].stack)))
    grid = np.linspace(0.0, 1.0, 40)
    stack_spectra(Labradorite().stack, grid[:33])  # compiled (or loaded) here
    # views of the grid at other offsets: numpy's buffers fall on other alignments
    _, kernels = launched(lambda: [stack_spectra(m.stack, grid[k:k + 33]) for k, m in enumerate(materials)])
    tables_kernels = [k for k in kernels if k.get("size") == 33 * tables().wavelengths.size]
    assert len(tables_kernels) == 3 and len({k["hash"] for k in tables_kernels}) == 1


def test_a_stack_of_arrays_takes_numpys_path():
    """Only a material's stack of plain numbers goes to the kernel; a stack of arrays (a zoning row's
    parameters) is evaluated by the reference path, and gives the same numbers."""
    from labcut.physics.lamella import Stack

    s = Labradorite().stack
    arrays = Stack(*s[:-1], np.array([1.56]))
    assert s.plain and Stack(*(np.float64(f) for f in s)).plain and not arrays.plain
    c = np.linspace(0.1, 1.0, 5)
    wl = tables().wavelengths
    np.testing.assert_allclose(arrays.spectra(wl, c)[0], s.spectra(wl, c)[0], rtol=1e-12, atol=1e-15)
    with pytest.raises(ParameterError, match="polarization"):
        s.spectra(wl, c, ("x",))


def test_dr_jit_float64_arguments_get_the_float64_namespace_and_any_float32_one_the_float32():
    """``ops_for``: numpy for numpy; Dr.Jit's float64 namespace only when every Dr.Jit argument is
    float64 (the tables' kernel); one float32 argument (the BSDF's wavelengths, a kernel's cosines)
    keeps the whole expression in float32, as before the float64 namespace existed."""
    from labcut.backend import ad_types
    from labcut.physics.ops import NUMPY, drjit_ops, ops_for

    _, t = ad_types()
    f32, f64 = t.Float([0.5]), t.Float64([0.5])
    assert ops_for(np.ones(2), 1.0) is NUMPY
    assert ops_for(f64, 2.0, f64) is drjit_ops(double=True) and drjit_ops(double=True).name == "drjit64"
    assert ops_for(f32, f64) is drjit_ops() and ops_for(f64, f32) is drjit_ops() and ops_for(f32) is drjit_ops()
    assert drjit_ops().tiny == 1e-30 and drjit_ops(double=True).tiny == 1e-300


def test_the_grid_has_the_cosines_shape_then_the_wavelengths_on_both_paths():
    s = Labradorite().stack
    wl = np.array([[450.0, 500.0], [550.0, 600.0]])
    for c in (0.7, np.array([0.2, 0.9]), np.linspace(0.1, 1.0, 6).reshape(3, 2)):
        want = s.spectra(wl, c, ("s",), jit=False)[0]
        got = s.spectra(wl, c, ("s",))[0]
        assert want.shape == got.shape == np.shape(c) + wl.shape
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
