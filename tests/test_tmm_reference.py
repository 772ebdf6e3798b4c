"""The exact references themselves: characteristic matrices (tests) and Rouard's recursion
(benchmarks/tmm.py) on known answers, and against each other."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from labcut import Labradorite
from tmm_reference import random_stack, stack_rt

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import tmm as rouard  # noqa: E402

N_S = 1.56


def fresnel_textbook(n1: float, n2: float, theta1_deg: float) -> tuple[float, float]:
    """|r_s|², |r_p|² from the angles (Hecht's form), for a single n1|n2 interface."""
    t1 = math.radians(theta1_deg)
    t2 = math.asin(n1 * math.sin(t1) / n2)
    rs = (n1 * math.cos(t1) - n2 * math.cos(t2)) / (n1 * math.cos(t1) + n2 * math.cos(t2))
    rp = (n2 * math.cos(t1) - n1 * math.cos(t2)) / (n2 * math.cos(t1) + n1 * math.cos(t2))
    return rs * rs, rp * rp


@pytest.mark.parametrize("theta", [0.0, 20.0, 45.0, 60.0, 75.0])
def test_single_interface_is_fresnel(theta):
    n1, n2 = 1.555, 1.9
    theta1 = math.degrees(math.asin(N_S * math.sin(math.radians(theta)) / n1))
    for pol, expected in zip("sp", fresnel_textbook(n1, n2, theta1)):
        r, t = stack_rt([500.0], theta, n1, n2, [], pol, N_S)
        assert float(r[0, 0]) == pytest.approx(expected, rel=1e-10)
        assert float(r[0, 0] + t[0, 0]) == pytest.approx(1.0, abs=1e-12)
    # Rouard's amplitude is the same Fresnel coefficient
    q1, q2 = rouard.kz(n1, N_S * math.sin(math.radians(theta))), rouard.kz(n2, N_S * math.sin(math.radians(theta)))
    for pol, expected in zip("sp", fresnel_textbook(n1, n2, theta1)):
        assert abs(rouard.interface_amplitude(n1, n2, q1, q2, pol)) ** 2 == pytest.approx(expected, rel=1e-10)


@pytest.mark.parametrize("pol", ["s", "p"])
def test_energy_is_conserved_in_random_lossless_stacks(pol):
    lab = Labradorite(pairs=300, sigma_a=20.0, sigma_b=20.0, n_a=1.5, n_b=1.7)
    wl = np.linspace(380, 780, 41)
    for theta in (0.0, 35.0, 60.0):
        r, t = stack_rt(wl, theta, lab.n_a, lab.n_a, random_stack(lab, 8, 1), pol, N_S)
        assert np.allclose(r + t, 1.0, atol=1e-9)


@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0])
@pytest.mark.parametrize("pol", ["s", "p"])
def test_quarter_wave_stack_is_tanh_squared(theta, pol):
    """2N quarter-wave layers (b, a) x N between phase a: R = tanh²(N ln(η_b/η_a)) with the
    tilted admittances η (s: n cos θ_x, p: n / cos θ_x); at 0° that is tanh²(N ln(n_b/n_a))."""
    n_a, n_b, wl, pairs = 1.555, 1.7, 550.0, 12
    kappa = N_S * math.sin(math.radians(theta))
    q = {x: math.sqrt(n * n - kappa * kappa) for x, n in (("a", n_a), ("b", n_b))}
    eta = {x: (q[x] if pol == "s" else n * n / q[x]) for x, n in (("a", n_a), ("b", n_b))}
    layers = []
    for _ in range(pairs):
        layers += [(n_b, np.array([[wl / (4 * q["b"])]])), (n_a, np.array([[wl / (4 * q["a"])]]))]
    r, _ = stack_rt([wl], theta, n_a, n_a, layers, pol, N_S)
    expected = math.tanh(pairs * math.log(eta["b"] / eta["a"])) ** 2
    assert float(r[0, 0]) == pytest.approx(expected, rel=1e-9)
    if theta == 0.0:
        assert expected == pytest.approx(math.tanh(pairs * math.log(n_b / n_a)) ** 2)


@pytest.mark.parametrize("theta, pol", [(0.0, "s"), (30.0, "s"), (30.0, "p"), (60.0, "p")])
def test_rouard_and_characteristic_matrices_agree(theta, pol):
    lab = Labradorite(pairs=400, sigma_a=16.0, sigma_b=16.0)
    wl = np.linspace(380, 780, 21)
    r_abeles, _ = stack_rt(wl, theta, lab.n_a, lab.n_a, random_stack(lab, 4, 7), pol, N_S)
    r_rouard = rouard.stack_reflectance(wl, theta, lab.n_a, lab.n_b, lab.d_a, lab.d_b, lab.sigma_a, lab.sigma_b,
                                        lab.pairs, N_S, pol, realisations=4, seed=7)
    assert np.allclose(r_abeles, r_rouard, atol=1e-10)
