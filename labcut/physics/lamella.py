"""Reflectance of the labradorite lamella stack (Bolton et al. 1966; DESIGN.md §2).

Written once against :mod:`labcut.physics.ops`, so every function here accepts numpy
arrays (float64, broadcasting; the API and the tests) or Dr.Jit arrays (float32,
inside Mitsuba kernels). The functions do no validation and no host-side
branching; :class:`labcut.Labradorite` validates parameters before calling them.

Frames and units
----------------
* ``wavelength_nm``: vacuum wavelength in nm.
* ``cos_theta``: cosine of the angle between the ray inside the stone and the
  lamella NORMAL. The lamella orientation is axial, so ``|cos_theta|`` is used.
  Both phases see the same angle: their indices differ by 0.45 %, so refraction
  between them moves the angle by < 0.3° up to θ ≈ 49°, 1° at 75°, and the Bragg
  wavelength by 0.3 % at 60°; near grazing the weak-reflection (kinematic) model
  itself fails (docs/physics.md, "One angle for both phases").
* thicknesses ``d_x`` and their standard deviations ``sigma_x`` in nm.

The intensity per lamella pair, ``I = <|V|^2> / (2 N r^2)``, is (DESIGN.md §2)::

    I = [(1 - a²b²) - a(1 - b²) cos φa - b(1 - a²) cos φb]
        / [(1 - ab)² + 4ab sin²((φa + φb)/2)]

with ``a = exp(-α_a)``, ``α_x = (p_x σ_x)²/2``, ``φ_x = p_x d_x`` and
``p_x = 4π n_x cos(θ)/λ``. Evaluated as printed it cancels catastrophically when
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


def _one_minus_exp(ops: Any, x: Any) -> Any:
    """1 - exp(-x) without cancellation for small x >= 0."""
    return -ops.expm1(-x)


def _bragg_sine(ops: Any, wavelength_nm: Any, cos_theta: Any, n_a: Any, n_b: Any, d_a: Any, d_b: Any) -> Any:
    """sin((φa + φb)/2), the Bragg term, with the phase reduced modulo 2π in float64.

    Near a Bragg peak of a nearly perfect, thick stack the intensity I (and
    R_kin) has a peak only ~1e-6 wide in relative phase, about ten float32 units;
    R saturates there, but its band edges still lose accuracy (5.5e-5 in R
    with the phase in float32 against 2.8e-7, docs/physics-accuracy.md). The
    phase in units of 2π, ``t = 2 cos θ (n_a d_a + n_b d_b)/λ``, is therefore
    formed and reduced to ``t - round(t)`` in float64 (a no-op for numpy).
    """
    t = (2.0 * (n_a * d_a + n_b * d_b)) * ops.wide(ops.abs(cos_theta)) / ops.wide(wavelength_nm)
    frac = ops.narrow(t - ops.round(t))
    return ops.sin(math.pi * frac)


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
    pairs: Any = None,
) -> Any:
    """Intensity per lamella pair ``I = <|V|²>/(2 N r²)`` of a random two-phase stack.

    Parameters
    ----------
    wavelength_nm, cos_theta:
        Vacuum wavelength (nm) and cosine of the angle to the lamella normal
        inside the stone; broadcast against each other.
    n_a, n_b:
        Refractive indices of the two lamella phases.
    d_a, d_b, sigma_a, sigma_b:
        Mean thickness and thickness standard deviation (absolute, nm) of each phase.
    pairs:
        Number of lamella pairs N. ``None`` is the infinite stack of the formula;
        a finite N adds a coherence damping ``φ_x²/(π² N)`` to each ``α_x`` (the
        damping of a thickness jitter ``σ_N = d_x √(2/N)/π``), which keeps a
        perfect stack (``σ = 0``) finite: at the first-order Bragg peak of equal
        optical thicknesses (``φ = π``) it gives ``2 N r² I = 4 N² r²``, the
        coherent sum of the 2N interface amplitudes, and ``R = tanh²(2Nr)``,
        the dynamical result. Like the real damping it vanishes at grazing
        incidence. Negligible whenever ``σ`` is not tiny.

    Returns
    -------
    I >= 0, finite; 0 at grazing incidence. Unitless.
    """
    ops = ops_for(wavelength_nm, cos_theta, n_a, n_b, d_a, d_b, sigma_a, sigma_b, pairs)
    k = FOUR_PI * ops.abs(cos_theta) / wavelength_nm
    p_a = k * n_a
    p_b = k * n_b
    phi_a = p_a * d_a
    phi_b = p_b * d_b
    alpha_a = 0.5 * (p_a * sigma_a) ** 2
    alpha_b = 0.5 * (p_b * sigma_b) ** 2
    if pairs is not None:  # finite-stack coherence, see the docstring
        inv_pi2_n = 1.0 / (math.pi * math.pi * pairs)
        alpha_a = alpha_a + phi_a * phi_a * inv_pi2_n
        alpha_b = alpha_b + phi_b * phi_b * inv_pi2_n
    a = ops.exp(-alpha_a)
    b = ops.exp(-alpha_b)
    one_a = _one_minus_exp(ops, alpha_a)  # 1 - a
    one_b = _one_minus_exp(ops, alpha_b)  # 1 - b
    one_ab = _one_minus_exp(ops, alpha_a + alpha_b)  # 1 - ab
    one_a2 = _one_minus_exp(ops, 2.0 * alpha_a)  # 1 - a²
    one_b2 = _one_minus_exp(ops, 2.0 * alpha_b)  # 1 - b²
    s_a = ops.sin(0.5 * phi_a)
    s_b = ops.sin(0.5 * phi_b)
    s_m = _bragg_sine(ops, wavelength_nm, cos_theta, n_a, n_b, d_a, d_b)
    numerator = one_a * one_b * one_ab + 2.0 * a * one_b2 * s_a * s_a + 2.0 * b * one_a2 * s_b * s_b
    denominator = one_ab * one_ab + 4.0 * a * b * s_m * s_m
    return numerator / ops.maximum(denominator, ops.tiny)


def interface_reflectance(n_a: Any, n_b: Any) -> Any:
    """Power reflectance ``r²`` of one a|b interface (unpolarised).

    With one angle in both phases the s and p amplitudes are ``(n_a - n_b)/(n_a + n_b)``
    and its negative at every angle, so their mean square is angle-independent:
    ``r² = ((n_b - n_a)/(n_a + n_b))²`` (5.0e-6 for 1.555 | 1.562).
    """
    r_s = (n_a - n_b) / (n_a + n_b)
    r_p = (n_b - n_a) / (n_b + n_a)
    return 0.5 * (r_s * r_s + r_p * r_p)


def saturate(r_kin: Any) -> Any:
    """Map a kinematic reflectance ``R_kin >= 0`` into [0, 1]: ``tanh²(√R_kin)``.

    ``R ≈ R_kin`` for ``R_kin << 1`` (kinematic theory) and exactly ``tanh²(2Nr)``
    at the Bragg peak of a perfect stack (dynamical theory). For strongly
    disordered, highly reflecting stacks it reads high: an incoherent stack has
    ``R_kin/(1 + R_kin)`` (0.0571 vs 0.0582 at N = 6000; docs/physics.md).
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
) -> Any:
    """Reflectance in [0, 1] of a stack of ``pairs`` lamella pairs (unpolarised).

    ``R = tanh²(√R_kin)``, ``R_kin = 2 N r² I(λ, θ)``, with ``r²`` the interface
    reflectance of :func:`interface_reflectance` and ``I`` from
    :func:`lamella_intensity`. Arguments as there.
    """
    intensity = lamella_intensity(wavelength_nm, cos_theta, n_a, n_b, d_a, d_b, sigma_a, sigma_b, pairs=pairs)
    r2 = interface_reflectance(n_a, n_b)
    return saturate(2.0 * pairs * r2 * intensity)


def bragg_wavelength(cos_theta: Any, n_a: Any, n_b: Any, d_a: Any, d_b: Any, order: int = 1) -> Any:
    """Bragg peak ``λ_k = 2 cos θ (n_a d_a + n_b d_b) / k`` in nm (DESIGN.md §2)."""
    ops = ops_for(cos_theta, n_a, n_b, d_a, d_b)
    return 2.0 * ops.abs(cos_theta) * (n_a * d_a + n_b * d_b) / order
