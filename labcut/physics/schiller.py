"""The schiller lobe, written once for numpy (float64) and Dr.Jit (float32 kernels).

Both the Mitsuba BSDF (:mod:`labcut.rendering.bsdf`, local shading frame, arrays of
Dr.Jit) and the flash estimators (:mod:`labcut.orientation.problem` and
:mod:`labcut.orientation.scoring`, mesh frame, numpy and Dr.Jit) evaluate the
schiller radiance through the functions here, so the lobe has one definition
(DESIGN.md §4, paper §3)::

    f_s(l, v) = T(n·l) T(n·v) / η² · R(λ, |a·h|) q(h·m) / (4 |a·h| max(a·n, b·n))

``a`` and ``b`` are the internal directions (pointing out of the surface) that
refract into the external directions ``l`` (towards the light) and ``v`` (towards
the viewer); ``h = normalize(a + b)`` is the lamella orientation that mirrors one
into the other; ``q`` is the axial von Mises-Fisher density of lamella
orientations around ``m`` (per steradian) and ``T = 1 - F`` the unpolarised
Fresnel transmission of the polished surface (index ``η`` inside, 1 outside).

Every function takes an ``ops`` namespace (:func:`labcut.physics.ops.ops_for`);
vectors are ``(..., 3)`` numpy arrays or Dr.Jit ``Array3f``.
"""

from __future__ import annotations

from typing import Any

from .ops import ops_for


def fresnel_reflectance(cos_i: Any, eta: Any, ops: Any = None) -> Any:
    """Unpolarised Fresnel reflectance for light arriving from outside (index 1) onto index
    ``eta``, at ``cos_i`` = cosine of the external angle (clamped to [0, 1])."""
    ops = ops or ops_for(cos_i, eta)
    c = ops.minimum(ops.maximum(cos_i, 0.0), 1.0)
    s2t = (1.0 - c * c) / (eta * eta)
    ct = ops.safe_sqrt(1.0 - s2t)
    rs = (c - eta * ct) / ops.maximum(c + eta * ct, ops.tiny)
    rp = (eta * c - ct) / ops.maximum(eta * c + ct, ops.tiny)
    return 0.5 * (rs * rs + rp * rp)


def transmission(cos_i: Any, eta: Any, ops: Any = None) -> Any:
    """Unpolarised Fresnel transmission ``1 - F`` (same arguments as :func:`fresnel_reflectance`)."""
    return 1.0 - fresnel_reflectance(cos_i, eta, ops)


def internal_direction(w: Any, n: Any, eta: Any, ops: Any) -> Any:
    """Internal unit direction (on the outer side of the surface's tangent plane, i.e. a·n > 0)
    that refracts into the external unit direction ``w`` through a surface of normal ``n``."""
    cos = ops.dot(w, n)
    tangent = ops.scale(w - ops.scale(n, cos), 1.0 / eta)
    return tangent + ops.scale(n, ops.safe_sqrt(1.0 - ops.dot(tangent, tangent)))


def lobe_density(cos_hm: Any, kappa: Any, norm: Any, ops: Any = None) -> Any:
    """Axial vMF density of lamella orientations at ``|h·m|`` = ``|cos_hm|`` (per steradian):
    ``norm · exp(κ (|h·m| - 1))``; ``norm`` = q(1) = κ / (2π (1 - e^{-κ}))."""
    ops = ops or ops_for(cos_hm)
    return norm * ops.exp(kappa * (ops.abs(cos_hm) - 1.0))


def schiller_geometry(l: Any, v: Any, n: Any, eta: Any, ops: Any) -> tuple[Any, Any, Any, Any, Any]:
    """(a, b, h, |a·h|, max(a·n, b·n)) of a light direction ``l`` and a view ``v`` at normal ``n``."""
    a = internal_direction(l, n, eta, ops)
    b = internal_direction(v, n, eta, ops)
    return (a, b, *mirror_terms(a, b, n, ops))


def mirror_terms(a: Any, b: Any, n: Any, ops: Any) -> tuple[Any, Any, Any]:
    """(h, |a·h|, max(a·n, b·n)) of internal directions ``a``, ``b`` at normal ``n``:
    ``h = normalize(a + b)`` is the lamella orientation that mirrors ``a`` into ``b``."""
    s = a + b
    h = ops.scale(s, 1.0 / ops.sqrt(ops.maximum(ops.dot(s, s), ops.tiny)))
    return h, ops.abs(ops.dot(a, h)), ops.maximum(ops.dot(a, n), ops.dot(b, n))


def schiller_factor(t_l: Any, t_v: Any, cos_l: Any, max_an_bn: Any, eta: Any, ops: Any) -> Any:
    """The m-independent factor of ``f_s`` without the stack reflectance R:
    ``T_l T_v / (η² · 4 |a·h| max(a·n, b·n))`` (the denominator floored at 1e-12)."""
    return t_l * t_v / (eta * eta * ops.maximum(4.0 * cos_l * max_an_bn, 1e-12))


def schiller_pdf(q: Any, cos_l: Any, b_n: Any, cos_v: Any, eta: Any, ops: Any) -> Any:
    """Solid-angle density of the external direction sampled by drawing ``h`` from ``q``,
    mirroring ``a`` and refracting out: ``q(h) cos θ_v / (4 |a·h| η² b·n)``."""
    return q * cos_v / ops.maximum(4.0 * cos_l * eta * eta * b_n, 1e-12)
