"""Reflectance of the labradorite lamella stack (Bolton et al. 1966; DESIGN.md §2).

Written once against :mod:`labcut.physics.ops`, so every function here accepts numpy
arrays (float64, broadcasting; the API and the tests) or Dr.Jit arrays (float32,
inside Mitsuba kernels). The functions do no validation and no host-side
branching; :class:`labcut.Labradorite` validates parameters before calling them.

Frames and units
----------------
* ``wavelength_nm``: vacuum wavelength in nm.
* ``cos_theta``: cosine of the angle between the ray and the lamella NORMAL,
  measured in the medium of index ``n_medium`` (the bulk stone). The lamella
  orientation is axial, so ``|cos_theta|`` is used. Inside phase x the angle
  follows Snell's law, ``n_x sin(theta_x) = n_medium sin(theta)``.
* thicknesses ``d_x`` and their standard deviations ``sigma_x`` in nm.

The intensity per lamella pair, ``I = <|V|^2> / (2 N r^2)``, is (DESIGN.md §2)::

    I = [(1 - a²b²) - a(1 - b²) cos φa - b(1 - a²) cos φb]
        / [(1 - ab)² + 4ab sin²((φa + φb)/2)]

with ``a = exp(-α_a)``, ``α_x = (p_x σ_x)²/2``, ``φ_x = p_x d_x`` and
``p_x = 4π n_x cos(θ_x)/λ``. Evaluated as printed it cancels catastrophically when
``σ → 0`` and at grazing incidence. Writing ``cos φ = 1 - 2 sin²(φ/2)`` and using
``(1 - a²b²) - a(1 - b²) - b(1 - a²) = (1 - a)(1 - b)(1 - ab)`` gives a sum of
non-negative terms::

    I = [(1-a)(1-b)(1-ab) + 2a(1-b²) sin²(φa/2) + 2b(1-a²) sin²(φb/2)]
        / [(1-ab)² + 4ab sin²((φa+φb)/2)]

in which every ``1 - e^{-x}`` is computed as ``-expm1(-x)``: no subtraction of
nearly equal numbers is left (docs/physics.md has the derivation).
"""

from __future__ import annotations

import math
from typing import Any

from .ops import ops_for

FOUR_PI = 4.0 * math.pi


def _phase_cosine(ops: Any, cos_theta: Any, n_medium: Any, n_x: Any) -> Any:
    """cos(theta_x) inside phase x by Snell's law; 0 beyond total internal reflection."""
    c = ops.abs(cos_theta)
    ratio = n_medium / n_x
    return ops.safe_sqrt(1.0 - ratio * ratio * (1.0 - c * c))


def _one_minus_exp(ops: Any, x: Any) -> Any:
    """1 - exp(-x) without cancellation for small x >= 0."""
    return -ops.expm1(-x)


def lamella_intensity(
    wavelength_nm: Any,
    cos_theta: Any,
    n_a: Any,
    n_b: Any,
    d_a: Any,
    d_b: Any,
    sigma_a: Any,
    sigma_b: Any,
    *,
    n_medium: Any = None,
    pairs: Any = None,
) -> Any:
    """Intensity per lamella pair ``I = <|V|²>/(2 N r²)`` of a random two-phase stack.

    Parameters
    ----------
    wavelength_nm, cos_theta:
        Vacuum wavelength (nm) and cosine of the angle to the lamella normal in the
        medium of index ``n_medium``; broadcast against each other.
    n_a, n_b:
        Refractive indices of the two lamella phases.
    d_a, d_b, sigma_a, sigma_b:
        Mean thickness and thickness standard deviation (absolute, nm) of each phase.
    n_medium:
        Index of the medium in which ``cos_theta`` is measured; default
        ``(n_a + n_b) / 2``.
    pairs:
        Number of lamella pairs N. ``None`` is the infinite stack of the formula;
        a finite N adds a coherence damping ``1/N`` to each ``α``, which keeps a
        perfect stack (``σ = 0``) finite: at a first-order Bragg peak of equal
        optical thicknesses it gives ``2 N r² I = 4 N² r²``, the coherent sum of
        the 2N interface amplitudes. Negligible whenever ``σ`` is not tiny.

    Returns
    -------
    I >= 0, finite; 0 at grazing incidence. Unitless.
    """
    ops = ops_for(wavelength_nm, cos_theta, n_a, n_b, d_a, d_b, sigma_a, sigma_b, n_medium, pairs)
    if n_medium is None:
        n_medium = 0.5 * (n_a + n_b)
    k = FOUR_PI / wavelength_nm
    p_a = k * n_a * _phase_cosine(ops, cos_theta, n_medium, n_a)
    p_b = k * n_b * _phase_cosine(ops, cos_theta, n_medium, n_b)
    phi_a = p_a * d_a
    phi_b = p_b * d_b
    alpha_a = 0.5 * (p_a * sigma_a) ** 2
    alpha_b = 0.5 * (p_b * sigma_b) ** 2
    if pairs is not None:
        alpha_a = alpha_a + 1.0 / pairs
        alpha_b = alpha_b + 1.0 / pairs
    a = ops.exp(-alpha_a)
    b = ops.exp(-alpha_b)
    one_a = _one_minus_exp(ops, alpha_a)  # 1 - a
    one_b = _one_minus_exp(ops, alpha_b)  # 1 - b
    one_ab = _one_minus_exp(ops, alpha_a + alpha_b)  # 1 - ab
    one_a2 = _one_minus_exp(ops, 2.0 * alpha_a)  # 1 - a²
    one_b2 = _one_minus_exp(ops, 2.0 * alpha_b)  # 1 - b²
    s_a = ops.sin(0.5 * phi_a)
    s_b = ops.sin(0.5 * phi_b)
    s_m = ops.sin(0.5 * (phi_a + phi_b))
    numerator = one_a * one_b * one_ab + 2.0 * a * one_b2 * s_a * s_a + 2.0 * b * one_a2 * s_b * s_b
    denominator = one_ab * one_ab + 4.0 * a * b * s_m * s_m
    return numerator / ops.maximum(denominator, ops.tiny)


def interface_reflectance(cos_theta: Any, n_a: Any, n_b: Any, *, n_medium: Any = None) -> Any:
    """Unpolarised power reflectance ``r² = (r_s² + r_p²)/2`` of one a|b interface.

    ``cos_theta`` is measured in the medium of index ``n_medium`` (default the mean
    of ``n_a`` and ``n_b``); beyond total internal reflection in a phase, 1.
    """
    ops = ops_for(cos_theta, n_a, n_b, n_medium)
    if n_medium is None:
        n_medium = 0.5 * (n_a + n_b)
    c_a = _phase_cosine(ops, cos_theta, n_medium, n_a)
    c_b = _phase_cosine(ops, cos_theta, n_medium, n_b)
    r_s = (n_a * c_a - n_b * c_b) / ops.maximum(n_a * c_a + n_b * c_b, ops.tiny)
    r_p = (n_b * c_a - n_a * c_b) / ops.maximum(n_b * c_a + n_a * c_b, ops.tiny)
    return ops.minimum(0.5 * (r_s * r_s + r_p * r_p), 1.0)


def saturate(r_kin: Any) -> Any:
    """Map a kinematic reflectance ``R_kin >= 0`` into [0, 1]: ``tanh²(√R_kin)``.

    Exact in both limits: ``R ≈ R_kin`` for ``R_kin << 1`` (kinematic theory) and
    ``tanh²(2Nr)`` at the Bragg peak of a perfect stack (dynamical theory).
    """
    ops = ops_for(r_kin)
    t = ops.tanh(ops.safe_sqrt(r_kin))
    return t * t


def stack_reflectance(
    wavelength_nm: Any,
    cos_theta: Any,
    n_a: Any,
    n_b: Any,
    d_a: Any,
    d_b: Any,
    sigma_a: Any,
    sigma_b: Any,
    pairs: Any,
    *,
    n_medium: Any = None,
) -> Any:
    """Reflectance in [0, 1] of a stack of ``pairs`` lamella pairs (unpolarised).

    ``R = tanh²(√R_kin)``, ``R_kin = 2 N r²(θ) I(λ, θ)``, with ``r²`` the interface
    reflectance of :func:`interface_reflectance` at that angle and ``I`` from
    :func:`lamella_intensity`. Arguments as there.
    """
    intensity = lamella_intensity(
        wavelength_nm, cos_theta, n_a, n_b, d_a, d_b, sigma_a, sigma_b, n_medium=n_medium, pairs=pairs
    )
    r2 = interface_reflectance(cos_theta, n_a, n_b, n_medium=n_medium)
    return saturate(2.0 * pairs * r2 * intensity)


def bragg_wavelength(cos_theta: Any, n_a: Any, n_b: Any, d_a: Any, d_b: Any, order: int = 1, *, n_medium: Any = None) -> Any:
    """Bragg peak ``λ_k = 2 (n_a d_a cos θ_a + n_b d_b cos θ_b) / k`` in nm.

    Equals ``2 cos θ (n_a d_a + n_b d_b) / k`` when the phases match the medium.
    """
    ops = ops_for(cos_theta, n_a, n_b, d_a, d_b, n_medium)
    if n_medium is None:
        n_medium = 0.5 * (n_a + n_b)
    c_a = _phase_cosine(ops, cos_theta, n_medium, n_a)
    c_b = _phase_cosine(ops, cos_theta, n_medium, n_b)
    return 2.0 * (n_a * d_a * c_a + n_b * d_b * c_b) / order
