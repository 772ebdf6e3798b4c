"""Bragg's law and the parameter trends of the paper (Fig. 4, 7, 8)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from labcut import Labradorite


@settings(max_examples=40)
@given(
    d_a=st.floats(50.0, 110.0),
    d_b=st.floats(50.0, 110.0),
    sigma=st.floats(0.0, 12.0),
    angle=st.floats(0.0, 40.0),
)
def test_first_order_peak_follows_bragg_within_2nm(d_a, d_b, sigma, angle):
    lab = Labradorite(d_a=d_a, d_b=d_b, sigma_a=sigma, sigma_b=sigma)
    c = math.cos(math.radians(angle))
    bragg = 2.0 * c * (lab.n_a * d_a + lab.n_b * d_b)  # DESIGN.md §2, no Snell correction
    assert abs(lab.peak_wavelength(c) - bragg) < 2.0


def test_peak_moves_to_longer_wavelengths_as_lamellae_thicken():
    peaks = [Labradorite(d_a=d, d_b=d).peak_wavelength() for d in (60.0, 70.0, 80.0, 90.0, 100.0)]
    assert np.all(np.diff(peaks) > 25.0)


def test_growing_sigma_keeps_position_loses_height_and_saturation():
    # paper Fig. 8: sigma_a grows, sigma_b fixed at 16 nm
    labs = [Labradorite(sigma_a=s, sigma_b=16.0) for s in (1.0, 5.0, 10.0, 15.0, 20.0)]
    peaks = np.array([lab.peak_wavelength() for lab in labs])
    heights = np.array([lab.peak_reflectance() for lab in labs])
    purity = np.array([lab.flash_colour().purity for lab in labs])
    assert np.ptp(peaks) < 4.0  # position kept (within 1 % of 485 nm)
    assert np.all(np.diff(heights) < 0) and heights[-1] < 0.6 * heights[0]
    assert np.all(np.diff(purity) < 0)
    # and far out the stone turns grey: purity collapses
    assert Labradorite(sigma_a=80.0, sigma_b=16.0).flash_colour().purity < 0.1 * purity[0]


def test_tilt_shifts_the_peak_to_shorter_wavelengths():
    lab = Labradorite.preset("green")
    peaks = [lab.peak_wavelength(math.cos(math.radians(a))) for a in (0.0, 10.0, 20.0, 30.0, 40.0)]
    assert np.all(np.diff(peaks) < 0)
    # second order in the tilt near normal incidence: lambda(theta) ~ lambda0 cos(theta)
    assert abs(peaks[2] / peaks[0] - math.cos(math.radians(20.0))) < 0.01


def test_more_anorthite_is_redder():
    dominant = [Labradorite.from_anorthite(an).dominant_wavelength() for an in (46.0, 48.0, 50.0, 52.0, 54.0)]
    assert np.all(np.diff(dominant) > 0)


def test_presets_peak_where_named():
    for name, nm in Labradorite.PRESETS.items():
        lab = Labradorite.preset(name)
        assert abs(lab.peak_wavelength() - nm) < 0.05
        assert lab.name == name
    order = [Labradorite.preset(n).dominant_wavelength() for n in ("blue", "green", "gold", "red")]
    assert np.all(np.diff(order) > 0)


def test_from_peak_wavelength_round_trip():
    for nm in (420.0, 505.0, 611.0, 700.0):
        assert abs(Labradorite.from_peak_wavelength(nm).peak_wavelength() - nm) < 0.05


def test_perfect_thin_stack_matches_dynamical_theory():
    # sigma = 0, quarter-wave-like equal phases: R = tanh²(2 N r) at the Bragg peak
    for pairs in (10, 100, 300):
        lab = Labradorite(sigma_a=0.0, sigma_b=0.0, pairs=pairs)
        r = (lab.n_b - lab.n_a) / (lab.n_a + lab.n_b)
        expected = math.tanh(2 * pairs * abs(r)) ** 2
        assert abs(lab.peak_reflectance() - expected) < 2e-3 * max(expected, 1e-3) + 1e-6


def test_no_peak_for_a_grey_stone_is_nan_not_a_wrong_number():
    grey = Labradorite(sigma_a=100.0, sigma_b=100.0)
    assert math.isnan(grey.peak_wavelength())
    assert math.isnan(grey.peak_reflectance())
