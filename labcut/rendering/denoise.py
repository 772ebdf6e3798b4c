"""Denoising renders with Intel Open Image Denoise (``pyoidn``), guided by albedo and normal AOVs.

A studio render is traced with Mitsuba's ``aov`` integrator wrapped around the real one, so each
pixel carries, besides its colour, the first hit's albedo (``eval_diffuse_reflectance`` of the
surface: the labradorite BSDF reports its body colour plus its face-on flash colour) and its
shading normal (mesh frame). OIDN's ``RT`` filter uses them to keep edges, texture and the flash's
boundary sharp while it removes the Monte Carlo noise; the colour is denoised in HDR (linear,
before exposure). ``benchmarks/render_denoise.py`` measures what it buys (docs/render-performance.md).
"""

from __future__ import annotations

import numpy as np

from ..errors import BackendError

AOVS = "albedo:albedo,nn:sh_normal"
AOV_CHANNELS = 6  # albedo RGB, normal XYZ after the colour


def available() -> bool:
    try:
        import pyoidn  # noqa: F401
    except ImportError:
        return False
    return True


def denoise(colour: np.ndarray, albedo: np.ndarray | None = None, normal: np.ndarray | None = None) -> np.ndarray:
    """Denoise a linear HDR image (H, W, 3) with optional albedo in [0, 1] and normals in [-1, 1].

    Returns float32 (H, W, 3), >= 0. Raises :class:`~labcut.errors.BackendError` when pyoidn
    is missing or OIDN fails."""
    try:
        import pyoidn
    except ImportError:
        raise BackendError("denoising needs the pyoidn package (pip install pyoidn), or render with denoise off") from None
    c = np.ascontiguousarray(np.clip(np.nan_to_num(colour), 0.0, None), dtype=np.float32)
    a = None if albedo is None else np.ascontiguousarray(np.clip(np.nan_to_num(albedo), 0.0, 1.0), dtype=np.float32)
    n = None
    if normal is not None:
        n = np.nan_to_num(np.asarray(normal, dtype=np.float64))
        length = np.linalg.norm(n, axis=-1, keepdims=True)
        n = np.ascontiguousarray(np.where(length > 1e-6, n / np.maximum(length, 1e-6), 0.0), dtype=np.float32)
    if n is not None and a is None:
        n = None  # OIDN takes a normal only together with an albedo
    try:
        out = pyoidn.denoise(c, a, n, hdr=True, clean_aux=False, quality="high")
    except (RuntimeError, ValueError, TypeError) as exc:
        raise BackendError(f"denoising failed: {str(exc).splitlines()[0][:160]}") from None
    return np.clip(np.asarray(out, dtype=np.float32), 0.0, None)
