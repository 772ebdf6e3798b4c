"""Reflectance of the labradorite lamella stack (Bolton et al. 1966; DESIGN.md §2).

Written once against :mod:`labcut.physics.ops`, so every function here accepts numpy
arrays (float64, broadcasting; the API and the tests) or Dr.Jit arrays (float32,
inside Mitsuba kernels). The functions do no validation and no host-side
branching; :class:`labcut.Labradorite` validates parameters before calling them.

Frames and units
----------------
* ``wavelength_nm``: vacuum wavelength in nm.
* ``cos_theta``: cosine of the angle between the ray inside the stone (the bulk, index
  ``n_surface``) and the lamella NORMAL. The lamella orientation is axial, so
  ``|cos_theta|`` is used. Each phase refracts by Snell's law
  (:func:`phase_wavenumbers`); :func:`lamella_intensity` without ``n_surface`` keeps the
  printed one-angle form (docs/physics.md §3).
* thicknesses ``d_x`` and their standard deviations ``sigma_x`` in nm.

The stack reflectance (:func:`stack_reflectance_sp`): per polarisation, the kinematic
``x = 2 N r² I`` with the interface amplitude ``r_s`` or ``r_p`` at the phases' angles,
saturated by the random-medium law ``1 - <T>`` (:func:`saturate_random`), or by the
dynamical ``tanh²`` for the phase-coherent part of a nearly perfect stack.

The intensity per lamella pair, ``I = <|V|^2> / (2 N r^2)``, is (DESIGN.md §2)::

    I = [(1 - a²b²) - a(1 - b²) cos φa - b(1 - a²) cos φb]
        / [(1 - ab)² + 4ab sin²((φa + φb)/2)]

with ``a = exp(-α_a)``, ``α_x = (p_x σ_x)²/2``, ``φ_x = p_x d_x`` and
``p_x = 4π q_x/λ``, ``q_x = n_x cos θ_x``. Evaluated as printed it cancels catastrophically when
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
from typing import Any, NamedTuple

import numpy as np

from ..errors import ParameterError
from .ops import ops_for

FOUR_PI = 4.0 * math.pi


class Stack(NamedTuple):
    """The optical parameters of a lamella stack, travelling as one value.

    Fields are floats (numpy, the API) or Dr.Jit arrays (per-texel parameters of colour
    zoning, inside kernels): indices ``n_a``, ``n_b`` of the two phases and ``n_surface``
    of the bulk stone; mean thicknesses ``d_a``, ``d_b`` and their standard deviations
    ``sigma_a``, ``sigma_b`` (nm); ``pairs``, the number of lamella pairs N.
    :attr:`labcut.Labradorite.stack` gives a material's.
    """

    n_a: Any
    n_b: Any
    d_a: Any
    d_b: Any
    sigma_a: Any
    sigma_b: Any
    pairs: Any
    n_surface: Any

    def opaque(self, float_type: Any) -> Stack:
        """This stack with every field an opaque Dr.Jit value of ``float_type`` (the kernel's
        float type, e.g. ``mi.Float``): a kernel that reads it is compiled once for every
        material, where float fields would be baked into a new kernel as literals."""
        import drjit as dr

        return Stack(*(dr.opaque(float_type, float(f)) for f in self))

    def reflectance(self, wavelength_nm: Any, cos_theta: Any, polarization: str | None = None) -> Any:
        """:func:`stack_reflectance` of this stack (what the colour tables ask of the stack they
        are given, :func:`labcut.colour.stack_table`)."""
        return stack_reflectance(wavelength_nm, cos_theta, self, polarization)

    def reflectance_sp(self, wavelength_nm: Any, cos_theta: Any) -> tuple[Any, Any]:
        """``(R_s, R_p)`` of this stack from one evaluation (:func:`stack_reflectance_sp`): both
        polarisations for the price of one."""
        r_s, r_p, _ = stack_reflectance_sp(wavelength_nm, cos_theta, self)
        return r_s, r_p

    @property
    def plain(self) -> bool:
        """Whether every field is a plain number (a material's stack), not an array."""
        return all(isinstance(f, int | float | np.integer | np.floating) for f in self)

    def spectra(self, wavelength_nm: Any, cos_theta: Any, polarizations: tuple[str | None, ...] = (None,), *,
                jit: bool = True) -> list[np.ndarray]:
        """This stack's reflectance on a grid, float64, one array of shape ``cos_theta.shape +
        wavelength_nm.shape`` (a stack of arrays: broadcast with its fields) for each of ``polarizations`` (``None``: unpolarised, ``'s'``, ``'p'``;
        all from one evaluation): :func:`stack_reflectance`, evaluated in float64 throughout either
        by one Dr.Jit kernel (``jit``, for a :attr:`plain` stack: Dr.Jit's float64 namespace of
        :mod:`labcut.physics.ops`, the fields opaque so that one compiled kernel serves every
        material; docs/performance.md times it) or by numpy (``jit=False``, the
        reference path, and a stack of arrays). The two agree to about 1e-13 relative, the last bits
        of Dr.Jit's and the C library's exp, sin and tanh (``tests/test_colour.py``)."""
        for pol in polarizations:
            if pol not in (None, "s", "p"):
                raise ParameterError(f"polarization must be None, 's' or 'p', got {pol!r}")
        wl = np.asarray(wavelength_nm, dtype=np.float64)
        c = np.asarray(cos_theta, dtype=np.float64)
        if jit and self.plain:
            return _jit_grid(self, wl, c, polarizations)
        r_s, r_p, _ = stack_reflectance_sp(wl, c.reshape(c.shape + (1,) * wl.ndim), self)
        picked = {None: lambda: 0.5 * (r_s + r_p), "s": lambda: r_s, "p": lambda: r_p}
        return [np.asarray(picked[pol](), dtype=np.float64) for pol in polarizations]


#: (cosine, wavelength) entries per kernel of :meth:`Stack.spectra` (a colour table of 1024 cosines
#: x 471 wavelengths is one; a few hundred bytes each while the kernel runs)
SPECTRA_CHUNK = 1 << 20


def _jit_grid(stack: Stack, wl: np.ndarray, c: np.ndarray, polarizations: tuple[str | None, ...]) -> list[np.ndarray]:
    """:meth:`Stack.spectra` by Dr.Jit in float64: every (cosine, wavelength) of the grid,
    :data:`SPECTRA_CHUNK` entries per kernel. The kernel makes each entry's cosine and wavelength
    itself, gathered by its index from the two short arrays, and the stack's fields are opaque:
    its code is the same for every material, grid and chunk (a kernel that read the whole grid
    from numpy's memory would compile again whenever numpy's buffers fell on another alignment)."""
    from ..backend import ad_types

    dr, t = ad_types()
    opaque = stack.opaque(t.Float64)
    wl_d, c_d = t.Float64(np.array(wl.ravel())), t.Float64(np.array(c.ravel()))
    n_wl, total = wl.size, wl.size * c.size
    width = dr.opaque(t.UInt32, n_wl)
    outs = [np.empty(total) for _ in polarizations]
    for i in range(0, total, SPECTRA_CHUNK):
        j = min(total, i + SPECTRA_CHUNK)
        index = dr.arange(t.UInt32, i, j)
        row = index // width
        r_s, r_p, _ = stack_reflectance_sp(dr.gather(t.Float64, wl_d, index - row * width), dr.gather(t.Float64, c_d, row),
                                           opaque)
        parts = [0.5 * (r_s + r_p) if pol is None else (r_s if pol == "s" else r_p) for pol in polarizations]
        dr.eval(*parts)
        for out, part in zip(outs, parts):
            out[i:j] = np.asarray(part)
    return [out.reshape(c.shape + wl.shape) for out in outs]


def _one_minus_exp(ops: Any, x: Any) -> Any:
    """1 - exp(-x) without cancellation for small x >= 0."""
    return -ops.expm1(-x)


def _bragg_sine(ops: Any, wavelength_nm: Any, q_a_wide: Any, q_b_wide: Any, d_a: Any, d_b: Any) -> Any:
    """sin((φa + φb)/2), the Bragg term, with the phase reduced modulo 2π in float64.

    Near a Bragg peak of a nearly perfect, thick stack the intensity I (and
    R_kin) has a peak only ~1e-6 wide in relative phase, about ten float32 units;
    R saturates there, but its band edges still lose accuracy (5.5e-5 in R
    with the phase in float32 against 2.8e-7, docs/physics-accuracy.md). The
    phase in units of 2π, ``t = 2 (q_a d_a + q_b d_b)/λ``, is therefore formed
    and reduced to ``t - round(t)`` in float64 (a no-op for numpy); ``q_x`` come in
    float64 too.
    """
    t = (2.0 * (q_a_wide * d_a + q_b_wide * d_b)) / ops.wide(wavelength_nm)
    frac = ops.narrow(t - ops.round(t))
    return ops.sin(math.pi * frac)


def phase_wavenumbers(cos_theta: Any, n_a: Any, n_b: Any, n_surface: Any = None, ops: Any = None) -> tuple[Any, Any]:
    """``q_x = n_x cos θ_x`` of both phases for a ray at ``cos_theta`` to the lamella normal in
    the bulk stone (index ``n_surface``), in the ops' wide precision (float64).

    With ``n_surface`` (Snell in each phase): the tangential invariant
    ``κ² = n_surface² (1 - cos²θ)`` is conserved and ``q_x = √(n_x² - κ²)``; κ² is
    clamped just below ``min(n_a, n_b)²``, so beyond the critical angle of the
    lower-index phase (θ > 85.4° for 1.555 in 1.56) the wave keeps a tiny real q and
    the interfaces reflect totally (r → ±1, R → 1), as the evanescent wave does.
    Without it (``None``): one angle in both phases, ``q_x = n_x |cos θ|`` (DESIGN.md §2's
    printed form, used by :func:`lamella_intensity`'s Monte Carlo check).
    """
    ops = ops or ops_for(cos_theta, n_a, n_b, n_surface)
    c = ops.wide(ops.abs(cos_theta))
    if n_surface is None:
        return n_a * c, n_b * c
    kappa2 = n_surface * n_surface * ((1.0 - c) * (1.0 + c))
    kappa2 = ops.minimum(kappa2, ops.minimum(n_a * n_a, n_b * n_b) * (1.0 - 1e-6))
    return ops.sqrt(n_a * n_a - kappa2), ops.sqrt(n_b * n_b - kappa2)


def _intensity_q(ops: Any, wavelength_nm: Any, q_a_w: Any, q_b_w: Any, d_a: Any, d_b: Any, sigma_a: Any, sigma_b: Any,
                 pairs: Any) -> tuple[Any, Any]:
    """(I, α_a + α_b of the thickness jitter alone) from the phases' wavenumbers (wide)."""
    q_a, q_b = ops.narrow(q_a_w), ops.narrow(q_b_w)
    k = FOUR_PI / wavelength_nm
    p_a = k * q_a
    p_b = k * q_b
    phi_a = p_a * d_a
    phi_b = p_b * d_b
    alpha_a = 0.5 * (p_a * sigma_a) ** 2
    alpha_b = 0.5 * (p_b * sigma_b) ** 2
    jitter = alpha_a + alpha_b
    if pairs is not None:  # finite-stack coherence, see lamella_intensity
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
    s_m = _bragg_sine(ops, wavelength_nm, q_a_w, q_b_w, d_a, d_b)
    numerator = one_a * one_b * one_ab + 2.0 * a * one_b2 * s_a * s_a + 2.0 * b * one_a2 * s_b * s_b
    denominator = one_ab * one_ab + 4.0 * a * b * s_m * s_m
    return numerator / ops.maximum(denominator, ops.tiny), jitter


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
    n_surface: Any = None,
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
    n_surface:
        Index of the bulk stone in which ``cos_theta`` is measured: the phases then
        use Snell's law each (:func:`phase_wavenumbers`). ``None``: one angle in both.

    Returns
    -------
    I >= 0, finite; 0 at grazing incidence (one angle). Unitless.

    Examples
    --------
    >>> from labcut.physics import lamella_intensity
    >>> round(float(lamella_intensity(470.0, 1.0, 1.555, 1.562, 77.5, 77.5, 16.0, 16.0)), 4)
    7.8209
    """
    ops = ops_for(wavelength_nm, cos_theta, n_a, n_b, d_a, d_b, sigma_a, sigma_b, pairs)
    q_a, q_b = phase_wavenumbers(cos_theta, n_a, n_b, n_surface, ops)
    return _intensity_q(ops, wavelength_nm, q_a, q_b, d_a, d_b, sigma_a, sigma_b, pairs)[0]


def interface_reflectance(n_a: Any, n_b: Any) -> Any:
    """Power reflectance ``r²`` of one a|b interface at normal incidence (s = p):
    ``((n_b - n_a)/(n_a + n_b))²`` (5.0e-6 for 1.555 | 1.562). At other angles see
    :func:`interface_amplitudes`."""
    r = (n_a - n_b) / (n_a + n_b)
    return r * r


def interface_amplitudes(q_a: Any, q_b: Any, n_a: Any, n_b: Any) -> tuple[Any, Any]:
    """Fresnel amplitudes ``(r_s, r_p)`` of the a|b interface from the phases' ``q_x = n_x cos θ_x``:
    ``r_s = (q_a - q_b)/(q_a + q_b)``, ``r_p = (n_b² q_a - n_a² q_b)/(n_b² q_a + n_a² q_b)``
    (Mitsuba's sign convention: at normal incidence ``r_p = -r_s``; ``r_p`` vanishes at the
    phases' Brewster angle, ~45° here)."""
    r_s = (q_a - q_b) / (q_a + q_b)
    nb2_qa, na2_qb = n_b * n_b * q_a, n_a * n_a * q_b
    return r_s, (nb2_qa - na2_qb) / (nb2_qa + na2_qb)


def saturate(r_kin: Any) -> Any:
    """The dynamical (coherent) limit ``tanh²(√x)`` of a kinematic reflectance ``x >= 0``:
    exact at the Bragg peak of a perfect stack, ``tanh²(2Nr)``."""
    ops = ops_for(r_kin)
    t = ops.tanh(ops.safe_sqrt(r_kin))
    return t * t


SERIES_BELOW = 0.01  # saturate_random: the Taylor series below this x, the closed form above


def saturate_random(x: Any) -> Any:
    """Ensemble-mean reflectance ``R = 1 - <T>`` of a random 1D medium of kinematic
    reflectance ``x`` (= L/ℓ, length over the backscattering mean free path).

    The exact ``<T>`` of a weakly disordered 1D medium (Gertsenshtein & Vasil'ev 1959;
    Abrikosov 1981) goes from ``1 - x`` to ``∝ x^{-3/2} e^{-x/4}``; here it is the closed form
    ``<T> = e^{-x/4} / √(1 + 1.5 x + 0.2325 x² + 0.02848 x³)``, whose coefficients were
    fitted to that law and are checked against transfer-matrix ensemble means of
    labradorite stacks (docs/physics-accuracy.md §5).

    Evaluation without cancellation: below x = 0.01 its Taylor series
    ``x - 0.94625 x² + 1.015282 x³`` (truncation error ~x⁴: 1.2e-6 relative at the switch),
    above it ``1 - e^{-x/4} / √(1 + P)`` (the subtraction then costs at most ~6e-6 relative
    in float32). One exp and one reciprocal square root: cheaper in a kernel than
    expm1/log1p. R ≈ x for small x, 1 for x → ∞, finite for every x >= 0 (x = inf gives 1).
    """
    ops = ops_for(x)
    series = x * (1.0 + x * (-0.94625 + 1.015282 * x))
    poly = x * (1.5 + x * (0.2325 + 0.02848 * x))
    closed = 1.0 - ops.exp(-0.25 * x) / ops.sqrt(1.0 + poly)
    return ops.select(x < SERIES_BELOW, series, closed)


def stack_reflectance_sp(wavelength_nm: Any, cos_theta: Any, stack: Stack) -> tuple[Any, Any, Any]:
    """``(R_s, R_p, sign)`` of a :class:`Stack` of ``pairs`` lamella pairs, each in [0, 1].

    ``cos_theta`` is the cosine of the angle between the ray and the lamella normal in
    the bulk stone of index ``n_surface``. Each phase refracts by Snell's law
    (:func:`phase_wavenumbers`); the kinematic reflectance of each polarisation is
    ``x = 2 N r² I`` with its own interface amplitude (:func:`interface_amplitudes`) and
    the intensity per pair ``I`` of those phases; each is saturated separately:
    ``R = w tanh²(√x) + (1 - w) F(x)``, ``F`` the random-medium law
    (:func:`saturate_random`) and ``w = e^{-N(α_a + α_b)}`` the part of the stack that the
    thickness jitter leaves phase-coherent (1 for a perfect stack: the dynamical
    ``tanh²(2Nr)``; 0 for any real labradorite, σ of a few nm and N in the thousands).
    ``sign`` is the sign of ``r_s r_p`` (-1 below the phases' Brewster angle): the
    handedness term of the schiller's Mueller matrix.
    """
    n_a, n_b, d_a, d_b, sigma_a, sigma_b, pairs, n_surface = stack
    ops = ops_for(wavelength_nm, cos_theta, *stack)
    q_a, q_b = phase_wavenumbers(cos_theta, n_a, n_b, n_surface, ops)
    intensity, jitter = _intensity_q(ops, wavelength_nm, q_a, q_b, d_a, d_b, sigma_a, sigma_b, pairs)
    r_s, r_p = interface_amplitudes(ops.narrow(q_a), ops.narrow(q_b), n_a, n_b)
    w = ops.exp(-pairs * jitter)
    two_n_i = 2.0 * pairs * intensity
    out = []
    for r in (r_s, r_p):
        x = two_n_i * (r * r)
        out.append(w * saturate(x) + (1.0 - w) * saturate_random(x))
    sign = ops.select(r_s * r_p < 0.0, -1.0, 1.0)
    return out[0], out[1], sign


def stack_reflectance(wavelength_nm: Any, cos_theta: Any, stack: Stack, polarization: str | None = None) -> Any:
    """Reflectance in [0, 1] of a :class:`Stack`: unpolarised
    ``(R_s + R_p)/2`` (``polarization=None``), or ``R_s`` / ``R_p`` (``'s'`` / ``'p'``).
    Arguments and model as :func:`stack_reflectance_sp`."""
    r_s, r_p, _ = stack_reflectance_sp(wavelength_nm, cos_theta, stack)
    if polarization is None:
        return 0.5 * (r_s + r_p)
    if polarization == "s":
        return r_s
    if polarization == "p":
        return r_p
    raise ParameterError(f"polarization must be None, 's' or 'p', got {polarization!r}")


def bragg_wavelength(cos_theta: Any, n_a: Any, n_b: Any, d_a: Any, d_b: Any, order: int = 1) -> Any:
    """Bragg peak ``λ_k = 2 cos θ (n_a d_a + n_b d_b) / k`` in nm (DESIGN.md §2)."""
    ops = ops_for(cos_theta, n_a, n_b, d_a, d_b)
    return 2.0 * ops.abs(cos_theta) * (n_a * d_a + n_b * d_b) / order
