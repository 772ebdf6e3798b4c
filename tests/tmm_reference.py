"""An independent exact reference for the tests: Abelès characteristic matrices of thin-film stacks.

A different algorithm from ``benchmarks/tmm.py`` (Rouard's recursion), so each checks the
other. Lossless, isotropic layers; the angle is given in a medium of index ``n0_ref``
(the bulk stone), κ = n0_ref sin θ is conserved. Tilted admittances: s: η = q = n cos θ_x,
p: η = n²/q. Returns reflectance and transmittance (power), so R + T = 1 can be checked.
"""

from __future__ import annotations

import math

import numpy as np


def _q(n: float, kappa: float) -> complex:
    return complex(n * n - kappa * kappa) ** 0.5


def _eta(n: float, q: complex, pol: str) -> complex:
    return q if pol == "s" else n * n / q


def stack_rt(wavelength_nm, theta_deg: float, n_in: float, n_out: float, layers: list[tuple[float, np.ndarray]],
             pol: str, n0_ref: float = 1.56) -> tuple[np.ndarray, np.ndarray]:
    """(R, T) of ``layers`` [(index, thickness nm (array over realisations, shape (M, 1)))] between
    semi-infinite ``n_in`` (light comes from here) and ``n_out``; arrays (M, W) over realisations
    and wavelengths."""
    wl = np.atleast_1d(np.asarray(wavelength_nm, dtype=np.float64))[None, :]
    kappa = n0_ref * math.sin(math.radians(theta_deg))
    m = layers[0][1].shape[0] if layers else 1
    m11 = np.ones((m, wl.shape[1]), complex)
    m12 = np.zeros_like(m11)
    m21 = np.zeros_like(m11)
    m22 = np.ones_like(m11)
    for n, t in layers:
        q = _q(n, kappa)
        eta = _eta(n, q, pol)
        delta = 2.0 * math.pi * q * t / wl
        c, s = np.cos(delta), np.sin(delta)
        a11, a12, a21, a22 = c, 1j * s / eta, 1j * eta * s, c
        m11, m12, m21, m22 = m11 * a11 + m12 * a21, m11 * a12 + m12 * a22, m21 * a11 + m22 * a21, m21 * a12 + m22 * a22
    e0 = _eta(n_in, _q(n_in, kappa), pol)
    es = _eta(n_out, _q(n_out, kappa), pol)
    b = m11 + m12 * es
    cc = m21 + m22 * es
    r = (e0 * b - cc) / (e0 * b + cc)
    t = 2.0 * e0 / (e0 * b + cc)
    return np.abs(r) ** 2, (es.real / e0.real) * np.abs(t) ** 2


def random_stack(lab, realisations: int, seed: int) -> list[tuple[float, np.ndarray]]:
    """The 2N - 1 inner layers b, a, ..., b of a random stack (between phase a above and below)."""
    rng = np.random.default_rng(seed)
    out = []
    for j in range(2 * lab.pairs - 1):
        n, d, sig = (lab.n_b, lab.d_b, lab.sigma_b) if j % 2 == 0 else (lab.n_a, lab.d_a, lab.sigma_a)
        t = np.maximum(d + sig * rng.standard_normal((realisations, 1)), 0.0) if sig > 0 else np.full((realisations, 1), d)
        out.append((n, t))
    return out
