"""Denoising renders with Intel Open Image Denoise (``pyoidn``), guided by albedo and normal AOVs.

A denoised studio render traces its colour with the real integrator through a box pixel filter
(OIDN wants each pixel's noise independent of its neighbours'), then the auxiliary images in a
separate pass: Mitsuba's ``aov`` integrator alone over the same camera and shapes
(:func:`aux_scene`), at :data:`AUX_SPP` samples per pixel whatever the colour's count. The first
hit's albedo (``eval_diffuse_reflectance`` of the surface: the labradorite BSDF reports its body
colour plus its face-on flash colour; the table its reflectance; 0 where the ray misses) and its
shading normal (the mesh frame, which is the world frame of the scene: unit length, [-1, 1]) are
cheap to trace (a first hit, no lights), so they come out noise-free and pixel-averaged across
the stone's silhouette, which is what OIDN's ``RT`` filter expects with ``cleanAux`` on; it then
keeps edges, texture and the flash's boundary sharp while it removes the Monte Carlo noise. The
colour is denoised in HDR (linear, before exposure and the tone curve), OIDN choosing its input
scale from the image (an ``inputScale`` of the render's exposure measured the same; denoising
the tone-mapped LDR image instead measured worse).
``benchmarks/render_denoise.py`` measures what it buys (docs/render-performance.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import BackendError

AOVS = "albedo:albedo,nn:sh_normal"
#: samples per pixel of the auxiliary pass (first hits only: about 0.08 s at 160 x 160 on 2 cores)
AUX_SPP = 128


def available() -> bool:
    try:
        import pyoidn  # noqa: F401
    except ImportError:
        return False
    return True


def aux_scene(scene: Any) -> Any:
    """A scene tracing only the albedo and normal AOVs (:data:`AOVS`) of ``scene``'s shapes through
    its first sensor: no emitters, no light transport."""
    import mitsuba as mi

    d: dict[str, Any] = {"type": "scene", "sensor": scene.sensors()[0], "integrator": {"type": "aov", "aovs": AOVS}}
    for i, shape in enumerate(scene.shapes()):
        d[f"shape_{i}"] = shape
    return mi.load_dict(d)


def trace_aux(scene: Any, spp: int = AUX_SPP, seed: int = 0) -> np.ndarray:
    """(H, W, 6) float32: albedo RGB and normal XYZ of ``scene``'s camera at ``spp`` samples per
    pixel (:func:`aux_scene`), averaged over each pixel like the colour."""
    from .api import render_pass

    aux = aux_scene(scene)
    passes = -(-int(spp) // 64)  # passes of at most 64 samples, together at least ``spp``
    per = -(-int(spp) // passes)
    acc = None
    for k in range(passes):
        img = np.array(render_pass(aux, per, seed * 7919 + 1_000_003 + k), dtype=np.float64)
        acc = img if acc is None else acc + img
    return (acc / passes).astype(np.float32)


def denoise(colour: np.ndarray, albedo: np.ndarray | None = None, normal: np.ndarray | None = None,
            *, clean_aux: bool = True) -> np.ndarray:
    """Denoise a linear HDR image (H, W, 3) with optional albedo in [0, 1] and normals in [-1, 1].

    ``clean_aux``: the albedo and normal are noise-free (:func:`trace_aux`), so OIDN uses them as
    they are; False makes it prefilter them first (auxiliaries traced with the colour's few samples).
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
        out = pyoidn.denoise(c, a, n, hdr=True, clean_aux=bool(clean_aux) and a is not None, quality="high")
    except (RuntimeError, ValueError, TypeError) as exc:
        raise BackendError(f"denoising failed: {str(exc).splitlines()[0][:160]}") from None
    return np.clip(np.asarray(out, dtype=np.float32), 0.0, None)
