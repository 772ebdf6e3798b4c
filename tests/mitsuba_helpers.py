"""Helpers for tests that call the BSDF plugin directly."""

from __future__ import annotations

import drjit as dr
import mitsuba as mi


def surface_interaction(n: int, wi, p=None) -> mi.SurfaceInteraction3f:
    """``n`` surface interactions with incident direction ``wi`` (local frame), the shading
    frame the lamella normal is expressed in, optionally a hit point ``p`` (zoning looks it up),
    and four fixed wavelengths in spectral variants. Opaque: a test that asks many directions
    compiles its kernels once (a literal direction would be baked into a new kernel each time)."""
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = wi
    if p is not None:
        si.p = p
    si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
    si.n = mi.Vector3f(0.0, 0.0, 1.0)
    if mi.is_spectral:
        si.wavelengths = mi.UnpolarizedSpectrum(450.0, 500.0, 550.0, 600.0)
    dr.make_opaque(si)  # values, not literals: another ``wi`` runs the kernels already compiled
    return si


def launched(call):
    """``(call(), kernels)``: what ``call`` returns and the JIT kernels it launched, compiled or
    found in memory or the cache folder (Dr.Jit's kernel history, cleared first)."""
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        dr.kernel_history()  # cleared
        value = call()
        return value, [k for k in dr.kernel_history() if k.get("type") == dr.KernelType.JIT]
