"""Writing rendered images: tonemapped PNG for people, linear EXR for programs."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from ..fileio import atomic_output

IMAGE_SUFFIXES = (".png", ".exr")


def auto_exposure(image: np.ndarray, percentile: float = 99.5, target: float = 2.0) -> float:
    """Exposure that brings the ``percentile`` of lit pixels' brightest channel to ``target``."""
    peak = np.max(image, axis=-1)
    lit = peak[peak > 1e-6]
    if lit.size == 0:
        return 1.0
    return float(target / max(np.percentile(lit, percentile), 1e-6))


def tonemap(image: np.ndarray, exposure: float | None = None) -> np.ndarray:
    """Linear RGB -> display sRGB in [0, 1], hue-preserving.

    Each pixel is scaled by ``(1 - exp(-m))/m`` with ``m`` its brightest channel
    after exposure, so saturated flashes keep their colour instead of clipping to
    white; then the sRGB transfer curve is applied.
    """
    from ..colour import encode_srgb

    if exposure is not None and not (isinstance(exposure, int | float) and np.isfinite(exposure) and exposure > 0):
        raise ParameterError(f"exposure must be a finite number > 0, got {exposure!r}")
    x = np.clip(np.nan_to_num(np.asarray(image, dtype=np.float64)), 0.0, None)
    x = x * (auto_exposure(x) if exposure is None else float(exposure))
    m = np.max(x, axis=-1, keepdims=True)
    scale = np.where(m > 1e-9, -np.expm1(-m) / np.maximum(m, 1e-9), 1.0)
    return encode_srgb(x * scale)


def save_image(image: np.ndarray, path: str | os.PathLike[str], exposure: float | None = None) -> Path:
    """Write ``image`` (H, W, 3 linear) as tonemapped 8-bit PNG or float32 EXR, atomically."""
    import mitsuba as mi

    out = Path(path)
    suffix = out.suffix.lower()
    if suffix not in IMAGE_SUFFIXES:
        raise ParameterError(f"image file {out.name!r} must end in .png (tonemapped) or .exr (linear HDR)")
    with atomic_output(out, IMAGE_SUFFIXES) as tmp:
        if suffix == ".exr":
            mi.Bitmap(np.ascontiguousarray(image, dtype=np.float32), mi.Bitmap.PixelFormat.RGB).write(str(tmp))
        else:
            ldr = np.ascontiguousarray(np.round(tonemap(image, exposure) * 255.0).astype(np.uint8))
            mi.Bitmap(ldr, mi.Bitmap.PixelFormat.RGB).write(str(tmp))
    return out
