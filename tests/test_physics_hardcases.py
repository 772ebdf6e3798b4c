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

from labcut import Labradorite, ParameterError
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


# ---------------------------------------------------------------------- pinned by mutation testing (docs/testing.md)
def _random_medium_reference(x: float) -> float:
    """``1 - e^{-x/4} / √(1 + 1.5 x + 0.2325 x² + 0.02848 x³)`` without cancellation (expm1 and
    log1p in double precision: about 1e-16 relative at every x), the law saturate_random states."""
    p = x * (1.5 + x * (0.2325 + 0.02848 * x))
    return -math.expm1(-x / 4.0 - 0.5 * math.log1p(p))


@pytest.mark.parametrize("x", [1e-7, 1e-5, 3e-4, 2e-3, 5e-3, 9.9e-3, 0.0101, 0.05, 0.5, 3.0, 30.0, 300.0])
def test_the_random_medium_law_holds_in_both_branches(x):
    """Below SERIES_BELOW its Taylor series (truncation ~x⁴, 1.2e-6 relative at the switch), above
    the closed form: each is the stated law to its documented accuracy, in numpy and in Dr.Jit."""
    from labcut.physics.lamella import SERIES_BELOW, saturate_random

    ref = _random_medium_reference(x)
    tol = 2e-6 if x < SERIES_BELOW else 1e-9 + 1e-11 / x
    assert float(saturate_random(np.float64(x))) == pytest.approx(ref, rel=tol)
    assert float(np.array(saturate_random(Float([x])))[0]) == pytest.approx(ref, rel=2e-5)


@pytest.mark.parametrize("slot", range(9))
def test_a_drjit_value_in_any_argument_takes_the_drjit_path(slot):
    """lamella_intensity(wavelength, cos θ, n_a, n_b, d_a, d_b, σ_a, σ_b, pairs=): whichever one
    argument is a Dr.Jit array (the BSDF's cosines, a zoning's thicknesses, a fitted index), the
    answer is a Dr.Jit array and the float64 numpy value to float32 rounding."""
    from labcut.physics.ops import is_drjit

    args = [470.0, 0.9, 1.555, 1.562, 77.5, 77.5, 16.0, 16.0, 6000.0]
    expected = float(lamella_intensity(*args[:8], pairs=args[8]))
    mixed = list(args)
    mixed[slot] = Float([float(args[slot])])
    got = lamella_intensity(*mixed[:8], pairs=mixed[8])
    assert is_drjit(got)
    assert float(np.array(got)[0]) == pytest.approx(expected, rel=2e-4)


@pytest.mark.parametrize("slot", ["wavelength", "cos"])
def test_the_stacks_reflectance_takes_the_drjit_path_from_either_input(slot):
    from labcut.physics.lamella import stack_reflectance_sp
    from labcut.physics.ops import is_drjit

    stack = Labradorite.preset("blue").stack
    wl, c = 480.0, 0.8
    r_s, r_p, _ = stack_reflectance_sp(wl, c, stack)
    got = stack_reflectance_sp(Float([wl]) if slot == "wavelength" else wl, Float([c]) if slot == "cos" else c, stack)
    assert is_drjit(got[0]) and is_drjit(got[1])
    assert float(np.array(got[0])[0]) == pytest.approx(float(r_s), rel=2e-4)
    assert float(np.array(got[1])[0]) == pytest.approx(float(r_p), rel=2e-4)


def test_one_interface_reflects_the_hand_computed_share():
    from labcut.physics.lamella import interface_amplitudes, interface_reflectance

    expected = ((1.562 - 1.555) / (1.555 + 1.562)) ** 2  # 5.04e-6: the docstring's 5.0e-6
    assert interface_reflectance(1.555, 1.562) == pytest.approx(expected, rel=1e-12)
    assert interface_reflectance(1.562, 1.555) == pytest.approx(expected, rel=1e-12)
    r_s, r_p = interface_amplitudes(1.555, 1.562, 1.555, 1.562)  # normal incidence: q_x = n_x
    assert r_s * r_s == pytest.approx(expected, rel=1e-12) and r_p == pytest.approx(-r_s, rel=1e-12)


def test_bragg_wavelength_by_hand_and_by_order():
    from labcut.physics.lamella import bragg_wavelength

    first = 2.0 * 0.8 * (1.555 * 75.0 + 1.562 * 80.0)
    assert bragg_wavelength(0.8, 1.555, 1.562, 75.0, 80.0) == pytest.approx(first, rel=1e-12)
    assert bragg_wavelength(-0.8, 1.555, 1.562, 75.0, 80.0, order=2) == pytest.approx(first / 2.0, rel=1e-12)
    assert bragg_wavelength(0.8, 1.555, 1.562, 75.0, 80.0, order=3) == pytest.approx(first / 3.0, rel=1e-12)


@pytest.mark.parametrize("slot", range(5))
def test_bragg_wavelength_takes_the_drjit_path_from_any_input(slot):
    from labcut.physics.lamella import bragg_wavelength
    from labcut.physics.ops import is_drjit

    args = [0.8, 1.555, 1.562, 75.0, 80.0]
    mixed = list(args)
    mixed[slot] = Float([args[slot]])
    got = bragg_wavelength(*mixed)
    assert is_drjit(got) and float(np.array(got)[0]) == pytest.approx(bragg_wavelength(*args), rel=1e-6)


@pytest.mark.parametrize("slot", range(4))
def test_phase_wavenumbers_take_the_drjit_path_from_any_input(slot):
    from labcut.physics.lamella import phase_wavenumbers
    from labcut.physics.ops import is_drjit

    args = [0.6, 1.555, 1.562, 1.56]
    expected = phase_wavenumbers(*args)
    mixed = list(args)
    mixed[slot] = Float([args[slot]])
    got = phase_wavenumbers(*mixed)
    assert all(is_drjit(q) for q in got)
    assert [float(np.array(q)[0]) for q in got] == pytest.approx([float(q) for q in expected], rel=1e-6)
    # Snell in each phase by hand: the tangential invariant kept
    kappa2 = 1.56 ** 2 * (1.0 - 0.6 ** 2)
    assert [float(q) for q in expected] == pytest.approx([math.sqrt(1.555 ** 2 - kappa2), math.sqrt(1.562 ** 2 - kappa2)], rel=1e-12)


def test_lamella_intensity_refracts_into_the_phases_when_given_the_stones_index():
    from labcut.physics.lamella import _intensity_q, phase_wavenumbers
    from labcut.physics.ops import NUMPY

    args = (480.0, 0.5, 1.555, 1.562, 77.5, 77.5, 16.0, 16.0)
    refracted = float(lamella_intensity(*args, pairs=6000.0, n_surface=1.56))
    q_a, q_b = phase_wavenumbers(0.5, 1.555, 1.562, 1.56)
    by_hand = float(_intensity_q(NUMPY, 480.0, q_a, q_b, 77.5, 77.5, 16.0, 16.0, 6000.0)[0])
    assert refracted == pytest.approx(by_hand, rel=1e-12)
    assert abs(refracted / float(lamella_intensity(*args, pairs=6000.0)) - 1.0) > 1e-3  # one angle in both: another value


def test_the_handedness_sign_is_minus_one_below_the_phases_brewster_angle_and_plus_one_beyond():
    from labcut.physics.lamella import stack_reflectance_sp

    stack = Labradorite.preset("blue").stack
    c = np.array([1.0, 0.95, 0.8, 0.3, 0.1])  # the phases' Brewster angle lies near 45° (cos 0.71)
    r_s, r_p, sign = stack_reflectance_sp(480.0, c, stack)
    assert sign.tolist() == [-1.0, -1.0, -1.0, 1.0, 1.0]
    d = Float(c.tolist())
    assert np.array(stack_reflectance_sp(480.0, d, stack)[2]).tolist() == [-1.0, -1.0, -1.0, 1.0, 1.0]


def test_the_stacks_methods_are_the_functions():
    from labcut.physics.lamella import stack_reflectance, stack_reflectance_sp

    stack = Labradorite.preset("gold").stack
    wl, c = np.array([[450.0], [580.0], [650.0]]), np.array([0.3, 0.7, 1.0])
    r_s, r_p, _ = stack_reflectance_sp(wl, c, stack)
    got_s, got_p = stack.reflectance_sp(wl, c)
    assert np.array_equal(got_s, r_s) and np.array_equal(got_p, r_p)
    for pol, want in ((None, 0.5 * (r_s + r_p)), ("s", r_s), ("p", r_p)):
        assert np.array_equal(stack.reflectance(wl, c, pol), want)
        assert np.array_equal(stack_reflectance(wl, c, stack, pol), want)
    with pytest.raises(ParameterError, match="polarization must be None, 's' or 'p', got 'x'"):
        stack_reflectance(wl, c, stack, "x")


@pytest.mark.parametrize("pairs", [6000, 100_000])
def test_a_perfect_stacks_float32_error_stays_that_of_the_reduced_phase(pairs):
    """The Bragg phase is reduced modulo 2π in float64 before it is narrowed (``_bragg_sine``): a
    perfect stack's float32 reflectance stays within 6e-5 of float64 over the dense grid (4.3e-5
    measured; the phase narrowed unreduced: 1.4e-4)."""
    lab = Labradorite(sigma_a=0.0, sigma_b=0.0, pairs=pairs)
    wl, c = np.meshgrid(_f32_round(np.linspace(360.0, 830.0, 941)), _f32_round(np.linspace(0.0, 1.0, 801)))
    r64 = lab.reflectance(wl.ravel(), c.ravel())
    r32 = np.array(lab.reflectance(Float(wl.ravel().astype(np.float32)), Float(c.ravel().astype(np.float32))))
    assert np.max(np.abs(r32 - r64)) < 6e-5


def test_a_drjit_value_inside_the_stack_takes_the_drjit_path():
    """A zoning's per-point thickness reaches the stack as a Dr.Jit array while the wavelength and
    the cosine are plain numbers: the stack's reflectance is still computed in Dr.Jit."""
    from labcut.physics.lamella import stack_reflectance_sp
    from labcut.physics.ops import is_drjit

    stack = Labradorite.preset("blue").stack
    r_s, r_p, _ = stack_reflectance_sp(480.0, 0.8, stack)
    got = stack_reflectance_sp(480.0, 0.8, stack._replace(d_a=Float([stack.d_a])))
    assert is_drjit(got[0]) and float(np.array(got[0])[0]) == pytest.approx(float(r_s), rel=2e-4)


# ---------------------------------------------------------------------- the schiller's pieces by hand (labcut.physics.schiller)
def test_fresnel_by_hand_normal_brewster_oblique_and_clamped():
    from labcut.physics.schiller import fresnel_reflectance, transmission

    eta = 1.56
    normal = ((eta - 1.0) / (eta + 1.0)) ** 2
    assert float(fresnel_reflectance(1.0, eta)) == pytest.approx(normal, rel=1e-12)
    # cosines a hair above 1 (rounding) and above are clamped to normal incidence; below 0 to grazing
    assert float(fresnel_reflectance(1.0 + 1e-7, eta)) == pytest.approx(normal, rel=1e-12)
    assert float(fresnel_reflectance(1.7, eta)) == pytest.approx(normal, rel=1e-12)
    assert float(fresnel_reflectance(-0.2, eta)) == pytest.approx(1.0, rel=1e-12)
    # Brewster's angle: r_p = 0, so R = r_s² / 2
    c = 1.0 / math.sqrt(1.0 + eta * eta)
    ct = math.sqrt(1.0 - (1.0 - c * c) / eta ** 2)
    rs = (c - eta * ct) / (c + eta * ct)
    assert float(fresnel_reflectance(c, eta)) == pytest.approx(0.5 * rs * rs, rel=1e-12)
    # 60° by the textbook formulas
    c = 0.5
    ct = math.sqrt(1.0 - (1.0 - c * c) / eta ** 2)
    rs, rp = (c - eta * ct) / (c + eta * ct), (eta * c - ct) / (eta * c + ct)
    assert float(fresnel_reflectance(c, eta)) == pytest.approx(0.5 * (rs * rs + rp * rp), rel=1e-12)
    assert float(transmission(c, eta)) == pytest.approx(1.0 - 0.5 * (rs * rs + rp * rp), rel=1e-12)


@pytest.mark.parametrize("slot", ["cos", "eta"])
def test_fresnel_takes_the_drjit_path_from_either_input(slot):
    from labcut.physics.ops import is_drjit
    from labcut.physics.schiller import fresnel_reflectance, lobe_density

    got = fresnel_reflectance(Float([0.5]) if slot == "cos" else 0.5, Float([1.56]) if slot == "eta" else 1.56)
    assert is_drjit(got) and float(np.array(got)[0]) == pytest.approx(float(fresnel_reflectance(0.5, 1.56)), rel=2e-5)  # float32
    dens = lobe_density(Float([0.99]), 300.0, 2.0)
    assert is_drjit(dens) and float(np.array(dens)[0]) == pytest.approx(2.0 * math.exp(300.0 * (0.99 - 1.0)), rel=2e-5)
    assert float(lobe_density(-0.99, 300.0, 2.0)) == pytest.approx(2.0 * math.exp(-3.0), rel=1e-12)  # axial


def test_the_schiller_factor_and_pdf_by_hand_at_grazing_geometry():
    """Well inside their floors (1e-12): the factor T_l T_v / (η² 4 cos_l max(a·n, b·n)) and the
    pdf q cos_v / (4 cos_l η² b·n), at a geometry whose denominators are below 1."""
    from labcut.physics.ops import NUMPY
    from labcut.physics.schiller import schiller_factor, schiller_pdf

    eta = 1.56
    assert schiller_factor(0.9, 0.8, 0.2, 0.5, eta, NUMPY) == pytest.approx(0.9 * 0.8 / (eta * eta * 4 * 0.2 * 0.5), rel=1e-12)
    assert schiller_pdf(3.0, 0.2, 0.3, 0.7, eta, NUMPY) == pytest.approx(3.0 * 0.7 / (4 * 0.2 * eta * eta * 0.3), rel=1e-12)
