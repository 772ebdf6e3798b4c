"""Hard cases of DESIGN.md §2, in float64 (numpy) and float32 (Dr.Jit)."""

from __future__ import annotations

import math

import drjit as dr
import numpy as np
import pytest
from drjit.llvm import Float
from drjit.llvm.ad import Float as ADFloat
from hypothesis import given, settings
from hypothesis import strategies as st

from labcut import Labradorite
from labcut.physics import lamella_intensity

rng = np.random.default_rng(7)


def _f32_round(x: np.ndarray) -> np.ndarray:
    """The float32 value the kernel sees, back in float64 (input rounding is not an error)."""
    return np.asarray(x, dtype=np.float32).astype(np.float64)


materials = st.builds(
    dict,
    d_a=st.floats(5.0, 400.0),
    d_b=st.floats(5.0, 400.0),
    sigma_a=st.floats(0.0, 100.0),
    sigma_b=st.floats(0.0, 100.0),
    pairs=st.integers(1, 100_000),
    n_a=st.floats(1.3, 2.0),
    n_b=st.floats(1.3, 2.0),
)


@settings(max_examples=150)
@given(params=materials, wl=st.floats(200.0, 2000.0), c=st.floats(0.0, 1.0))
def test_reflectance_is_finite_and_in_unit_interval(params, wl, c):
    lab = Labradorite(**params)
    r = float(lab.reflectance(wl, c))
    assert math.isfinite(r) and 0.0 <= r <= 1.0
    i = float(lab.intensity(wl, c))
    assert math.isfinite(i) and i >= 0.0


@settings(max_examples=60)
@given(params=materials)
def test_float32_drjit_agrees_with_float64_numpy(params):
    lab = Labradorite(**params)
    wl = _f32_round(rng.uniform(360.0, 830.0, 20000))
    c = _f32_round(np.concatenate([rng.uniform(0.0, 1.0, 19000), rng.uniform(0.0, 1e-3, 500), np.ones(250), np.zeros(250)]))
    r64 = lab.reflectance(wl, c)
    r32 = np.array(lab.reflectance(Float(wl.astype(np.float32)), Float(c.astype(np.float32))))
    assert np.all(np.isfinite(r32)) and r32.min() >= 0.0 and r32.max() <= 1.0
    assert np.max(np.abs(r32 - r64)) < 1e-3


@pytest.mark.parametrize("pairs", [1, 6000, 100_000])
@pytest.mark.parametrize("sigma", [0.0, 16.0, 100.0])
def test_worst_case_float32_error_on_dense_grid(pairs, sigma):
    lab = Labradorite(sigma_a=sigma, sigma_b=0.6 * sigma, pairs=pairs)
    wl, c = np.meshgrid(_f32_round(np.linspace(360.0, 830.0, 941)), _f32_round(np.linspace(0.0, 1.0, 801)))
    r64 = lab.reflectance(wl.ravel(), c.ravel())
    r32 = np.array(lab.reflectance(Float(wl.ravel().astype(np.float32)), Float(c.ravel().astype(np.float32))))
    assert np.max(np.abs(r32 - r64)) < 1e-3


def test_sigma_to_zero_limit_is_smooth():
    lab0 = Labradorite(sigma_a=0.0, sigma_b=0.0)
    wl = np.linspace(380.0, 780.0, 801)
    for c in (1.0, 0.8, 0.3):
        r0 = lab0.reflectance(wl, c)
        previous = None
        for s in (1e-1, 1e-2, 1e-3, 1e-4, 1e-6):
            err = np.max(np.abs(Labradorite(sigma_a=s, sigma_b=s).reflectance(wl, c) - r0))
            if previous is not None:
                assert err <= previous + 1e-12
            previous = err
        assert previous < 1e-6
        # float32 reaches the same limit
        r32 = np.array(lab0.reflectance(Float(wl.astype(np.float32)), Float(c)))
        assert np.max(np.abs(r32 - lab0.reflectance(_f32_round(wl), c))) < 1e-3


def test_exact_bragg_peak_of_perfect_thick_stack_saturates_to_at_most_one():
    lab = Labradorite(sigma_a=0.0, sigma_b=0.0, pairs=100_000)
    peak = lab.bragg_wavelength(1.0)
    r = float(lab.reflectance(peak, 1.0))
    assert 0.999 < r <= 1.0
    i = float(lamella_intensity(peak, 1.0, lab.n_a, lab.n_b, lab.d_a, lab.d_b, 0.0, 0.0, pairs=lab.pairs))
    assert math.isfinite(i)


@pytest.mark.parametrize("sigma", [0.0, 16.0, 100.0])
def test_grazing_limit_is_finite_and_flat_beyond_the_critical_angle(sigma):
    """Snell in each phase: beyond the critical angle of the lower-index phase (85.4° for
    1.555 in 1.56) κ² is clamped, so R is finite, in [0, 1] and constant out to grazing
    (docs/physics.md says what exact optics does there); the one-angle intensity still goes to 0."""
    lab = Labradorite(sigma_a=sigma, sigma_b=sigma, pairs=100_000)
    c = np.array([0.0, 1e-12, 1e-9, 1e-6, 1e-4, 1e-3, 0.05])
    crit = math.sqrt(1.0 - (lab.n_a / lab.n_surface) ** 2)
    assert c[-1] < crit
    for wl in (400.0, 550.0, 700.0):
        for pol in (None, "s", "p"):
            r = lab.reflectance(wl, c, pol)
            assert np.all(np.isfinite(r)) and np.all((r >= 0) & (r <= 1))
            assert np.ptp(r) < 1e-9  # κ is clamped there: one value
        r32 = np.array(lab.reflectance(Float([wl] * c.size), Float(c.astype(np.float32))))
        assert np.all(np.isfinite(r32)) and np.all((r32 >= 0) & (r32 <= 1))
        assert float(lamella_intensity(wl, 0.0, lab.n_a, lab.n_b, lab.d_a, lab.d_b, sigma, sigma, pairs=lab.pairs)) == 0.0


def test_reflectance_is_continuous_in_angle_everywhere():
    lab = Labradorite(sigma_a=4.0, sigma_b=4.0, pairs=20000)
    c = np.linspace(0.0, 1.0, 200001)
    r = lab.reflectance(550.0, c)
    assert np.all(np.isfinite(r)) and np.max(np.abs(np.diff(r))) < 0.02


def test_huge_sigma_is_incoherent_grey():
    # a, b -> 0: I -> 1 at every wavelength (incoherent sum), so R is flat
    i = lamella_intensity(np.linspace(380, 780, 50), 1.0, 1.555, 1.562, 75.0, 75.0, 1e4, 1e4)
    assert np.allclose(i, 1.0, atol=1e-9)


def test_wavelengths_outside_the_visible_are_fine():
    r = Labradorite().reflectance(np.array([100.0, 300.0, 900.0, 5000.0, 1e5]), 0.9)
    assert np.all(np.isfinite(r)) and np.all((r >= 0) & (r <= 1))


def test_reflectance_broadcasts():
    r = Labradorite().reflectance(np.linspace(400, 700, 7)[:, None], np.array([1.0, 0.5, 0.0]))
    assert r.shape == (7, 3)


def test_axial_symmetry():
    lab = Labradorite()
    assert np.allclose(lab.reflectance(500.0, -0.7), lab.reflectance(500.0, 0.7))


def test_drjit_gradient_matches_finite_difference():
    """AD through the float32 path (incl. the float64 Bragg phase) is finite and correct."""
    lab = Labradorite()
    c = ADFloat([0.3, 0.6, 0.85, 0.95, 0.999])
    dr.enable_grad(c)
    r = lab.reflectance(ADFloat(480.0), c)
    dr.backward(dr.sum(r))
    grad = np.array(dr.grad(c))
    c0 = np.array([0.3, 0.6, 0.85, 0.95, 0.999])
    h = 1e-6
    fd = (lab.reflectance(480.0, c0 + h) - lab.reflectance(480.0, c0 - h)) / (2 * h)
    assert np.all(np.isfinite(grad))
    assert np.allclose(grad, fd, rtol=2e-2, atol=1e-2)


def test_drjit_gradient_is_finite_at_the_limits():
    lab = Labradorite(sigma_a=0.0, sigma_b=0.0)
    c = ADFloat([0.0, 1e-8, 0.08, 1.0])
    dr.enable_grad(c)
    dr.backward(dr.sum(lab.reflectance(ADFloat(483.135), c)))
    assert np.all(np.isfinite(np.array(dr.grad(c))))
