"""Exact wave optics of lamella stacks: Rouard's recursion through explicit random stacks.

The reference that labcut's closed-form stack reflectance is measured against
(``benchmarks/physics_accuracy.py``, docs/physics-accuracy.md). Nothing here is
approximated beyond the stack itself: every layer refracts by Snell's law (the
invariant κ = n_surface sin θ), every interface reflects with the exact Fresnel
amplitudes for s and p, and all multiple reflections are summed.

Geometry: ``pairs`` pairs of layers a, b (the 2N-1 inner layers b, a, b, ..., b
between semi-infinite phase a above and below, as in the model: 2N interfaces),
thicknesses ``d_x + σ_x g`` with g standard normal, clipped at 0, one realisation
per row. ``theta_deg`` is the angle to the lamella normal in the bulk stone (index
``n_surface``); beyond a phase's critical angle its wave is evanescent (complex q).

``tests/tmm_reference.py`` is an independent characteristic-matrix implementation
used by the tests; the two agree to rounding.
"""

from __future__ import annotations

import math

import numpy as np


def kz(n: float, kappa: float) -> complex:
    """Normal wavenumber factor q = sqrt(n² - κ²) (principal branch: evanescent waves decay)."""
    return complex(n * n - kappa * kappa) ** 0.5


def interface_amplitude(n1: float, n2: float, q1: complex, q2: complex, pol: str) -> complex:
    """Fresnel amplitude reflection coefficient from medium 1 onto medium 2 (s or p)."""
    if pol == "s":
        return (q1 - q2) / (q1 + q2)
    return (n2 * n2 * q1 - n1 * n1 * q2) / (n2 * n2 * q1 + n1 * n1 * q2)


def stack_reflectance(wavelength_nm, theta_deg: float, n_a: float, n_b: float, d_a: float, d_b: float,
                      sigma_a: float, sigma_b: float, pairs: int, n_surface: float = 1.56, pol: str = "s",
                      realisations: int = 1, seed: int = 0) -> np.ndarray:
    """|r|² of ``realisations`` random stacks (rows) at each wavelength (columns), polarisation ``pol``."""
    if pol not in ("s", "p"):
        raise ValueError("pol must be 's' or 'p'")
    wl = np.atleast_1d(np.asarray(wavelength_nm, dtype=np.float64))[None, :]
    kappa = n_surface * math.sin(math.radians(theta_deg))
    n = {"a": n_a, "b": n_b}
    q = {x: kz(n[x], kappa) for x in n}
    r_ab = interface_amplitude(n_a, n_b, q["a"], q["b"], pol)
    r_ba = interface_amplitude(n_b, n_a, q["b"], q["a"], pol)
    rng = np.random.default_rng(seed)
    gamma = np.full((realisations, wl.shape[1]), r_ba, dtype=np.complex128)  # the bottom interface b|a
    for j in range(2 * pairs - 1):  # layers from the bottom: b, a, b, ..., b
        x, d, sig, r = ("b", d_b, sigma_b, r_ab) if j % 2 == 0 else ("a", d_a, sigma_a, r_ba)
        t = np.maximum(d + sig * rng.standard_normal((realisations, 1)), 0.0) if sig > 0 else np.full((realisations, 1), d)
        ge = gamma * np.exp((4j * math.pi * q[x] / wl) * t)
        gamma = (r + ge) / (1.0 + r * ge)
    return np.abs(gamma) ** 2


def ensemble_mean(wavelength_nm, theta_deg: float, lab, pol: str, realisations: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Mean |r|² over random stacks of a :class:`labcut.Labradorite`, and its standard error.
    ``pol`` is ``'s'``, ``'p'`` or ``'u'`` (unpolarised: the mean of s and p on the same stacks)."""
    args = (lab.n_a, lab.n_b, lab.d_a, lab.d_b, lab.sigma_a, lab.sigma_b, lab.pairs, lab.n_surface)
    if pol == "u":
        r = 0.5 * (stack_reflectance(wavelength_nm, theta_deg, *args, pol="s", realisations=realisations, seed=seed)
                   + stack_reflectance(wavelength_nm, theta_deg, *args, pol="p", realisations=realisations, seed=seed))
    else:
        r = stack_reflectance(wavelength_nm, theta_deg, *args, pol=pol, realisations=realisations, seed=seed)
    return r.mean(axis=0), r.std(axis=0) / math.sqrt(realisations)


def smooth3(x: np.ndarray) -> np.ndarray:
    """3-point moving average (edges: 2-point), the same for model and exact curves."""
    x = np.asarray(x, dtype=np.float64)
    out = np.convolve(x, np.ones(3) / 3.0, mode="same")
    out[0], out[-1] = 0.5 * (x[0] + x[1]), 0.5 * (x[-2] + x[-1])
    return out


def peak_position(wl: np.ndarray, r: np.ndarray, level: float = 0.9) -> float:
    """Centroid (nm) of the part of a smoothed spectrum within ``level`` of its maximum: robust to
    the flat tops of saturated peaks and to the ensemble's noise."""
    s = smooth3(r)
    i = int(np.argmax(s))
    lo = i
    while lo > 0 and s[lo - 1] >= level * s[i]:
        lo -= 1
    hi = i
    while hi < len(s) - 1 and s[hi + 1] >= level * s[i]:
        hi += 1
    w = s[lo : hi + 1]
    return float((wl[lo : hi + 1] * w).sum() / w.sum())


def compare(model: np.ndarray, exact: np.ndarray, se: np.ndarray, wl: np.ndarray) -> dict:
    """How a model spectrum compares with an exact ensemble mean (and its standard error):
    peak heights of the 3-point smoothed curves (noise of the smoothed exact peak ≈ SE/√3),
    peak positions (:func:`peak_position`), integrals, and the worst pointwise difference and
    its excess over 3 SE. The definitions the tests and the report share."""
    sm, se_ = smooth3(model), smooth3(exact)
    i = int(np.argmax(se_))
    peak_se = float(se[max(i - 1, 0) : i + 2].mean()) / math.sqrt(3.0)
    diff = np.abs(model - exact)
    return {
        "exact_peak": float(se_[i]),
        "model_peak": float(sm.max()),
        "peak": float(sm.max() / se_[i]) if se_[i] > 0 else float("nan"),
        "peak_se": peak_se,
        "position_nm": peak_position(wl, model) - peak_position(wl, exact),
        "integral": float(model.sum() / exact.sum()) if exact.sum() > 0 else float("nan"),
        "integral_se": float(np.sqrt((se**2).sum()) / exact.sum()) if exact.sum() > 0 else float("nan"),
        "pointwise": float(diff.max()),
        "excess": float(np.max(diff - 3.0 * se)),
    }
