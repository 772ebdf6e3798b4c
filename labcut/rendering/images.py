"""Writing rendered images: tonemapped PNG for people, linear EXR for programs.

A PNG records the exposure it was tonemapped with (a ``labcut:exposure`` text chunk, with
``labcut:exposure_mode`` = ``auto`` or ``given`` and any other ``labcut:*`` fields the caller
passes), so two PNGs can be compared honestly; :func:`shared_exposure` gives a series of
images (orbit tiles, a comparison) one exposure.
"""

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


def shared_exposure(images: list[np.ndarray] | tuple[np.ndarray, ...], percentile: float = 99.5, target: float = 2.0) -> float:
    """One automatic exposure for a series of linear images, from all their lit pixels together:
    tonemap each with it so that brightness differences between them are real."""
    if not len(images):
        raise ParameterError("shared_exposure needs at least one image")
    flat = np.concatenate([np.asarray(im, dtype=np.float64).reshape(-1, np.asarray(im).shape[-1]) for im in images], axis=0)
    return auto_exposure(np.clip(np.nan_to_num(flat), 0.0, None), percentile, target)


def read_png_metadata(path: str | os.PathLike[str]) -> dict[str, str]:
    """The ``labcut:*`` text fields of a PNG written by :func:`save_image` (key without the prefix)."""
    from PIL import Image

    with Image.open(path) as im:
        text = dict(getattr(im, "text", {}) or {})
    return {k.split(":", 1)[1]: v for k, v in text.items() if k.startswith("labcut:")}


def tonemap(image: np.ndarray, exposure: float | None = None, curve: str = "hue") -> np.ndarray:
    """Linear RGB -> display sRGB in [0, 1].

    ``curve="hue"`` (the diagram look): each pixel is scaled by ``(1 - exp(-m))/m`` with ``m``
    its brightest channel after exposure, so saturated flashes keep their colour instead of
    clipping to white; then the sRGB transfer curve is applied. ``curve="agx"`` (the studio
    look): the filmic curve of :func:`labcut.rendering.tonemap.agx`.
    """
    from ..colour import encode_srgb

    if exposure is not None and (isinstance(exposure, bool) or not (isinstance(exposure, int | float) and np.isfinite(exposure) and exposure > 0)):
        raise ParameterError(f"exposure must be a finite number > 0, got {exposure!r}", parameter="exposure")
    if curve not in ("hue", "agx"):
        raise ParameterError(f"tone curve must be 'hue' or 'agx', got {curve!r}")
    x = np.clip(np.nan_to_num(np.asarray(image, dtype=np.float64)), 0.0, None)
    x = x * (auto_exposure(x) if exposure is None else float(exposure))
    if curve == "agx":
        from .tonemap import agx

        return agx(x)
    m = np.max(x, axis=-1, keepdims=True)
    scale = np.where(m > 1e-9, -np.expm1(-m) / np.maximum(m, 1e-9), 1.0)
    return encode_srgb(x * scale)


def to_uint8(image: np.ndarray, exposure: float, curve: str = "hue") -> np.ndarray:
    """Tonemapped 8-bit sRGB (H, W, 3) of a linear image."""
    x = np.clip(np.nan_to_num(np.asarray(image, dtype=np.float64)), 0.0, None)
    return np.ascontiguousarray(np.round(tonemap(x, exposure, curve) * 255.0).astype(np.uint8))


def save_image(image: np.ndarray, path: str | os.PathLike[str], exposure: float | None = None,
               metadata: dict[str, object] | None = None, exposure_mode: str | None = None, curve: str = "hue") -> Path:
    """Write ``image`` (H, W, 3 linear) as tonemapped 8-bit PNG or float32 EXR, atomically.

    ``exposure``: the PNG's exposure multiplier (None: automatic, :func:`auto_exposure`). The PNG
    records it as ``labcut:exposure`` (and ``labcut:exposure_mode``), plus ``metadata`` as
    ``labcut:<key>`` text (non-strings as JSON). ``exposure_mode`` overrides the recorded mode
    (a caller that computed the automatic exposure itself passes ``"auto"``). An EXR is linear:
    no exposure is applied. ``curve``: the tone curve (:func:`tonemap`), recorded as
    ``labcut:tonemap`` with ``labcut:exposure_ev`` (log2 of the exposure)."""
    import mitsuba as mi

    out = Path(path)
    suffix = out.suffix.lower()
    if suffix not in IMAGE_SUFFIXES:
        raise ParameterError(f"image file {out.name!r} must end in .png (tonemapped) or .exr (linear HDR)")
    with atomic_output(out, IMAGE_SUFFIXES) as tmp:
        if suffix == ".exr":
            mi.Bitmap(np.ascontiguousarray(image, dtype=np.float32), mi.Bitmap.PixelFormat.RGB).write(str(tmp))
        else:
            from PIL import Image

            x = np.clip(np.nan_to_num(np.asarray(image, dtype=np.float64)), 0.0, None)
            mode = exposure_mode or ("auto" if exposure is None else "given")
            used = auto_exposure(x) if exposure is None else exposure
            fields = {"exposure": repr(float(used)), "exposure_ev": repr(float(np.log2(used))), "exposure_mode": mode,
                      "tonemap": curve, **(metadata or {})}
            Image.fromarray(to_uint8(x, used, curve), "RGB").save(tmp, format="PNG", pnginfo=_png_text(fields))
    return out


def _png_text(metadata: dict[str, object]) -> object:
    """PNG text chunks: ``Software`` = labcut and each ``labcut:<key>`` (non-strings as JSON)."""
    import json

    from PIL import PngImagePlugin

    info = PngImagePlugin.PngInfo()
    info.add_text("Software", "labcut")
    for key, value in metadata.items():
        info.add_text(f"labcut:{key}", value if isinstance(value, str) else json.dumps(value, allow_nan=False))
    return info


def save_picture(picture: np.ndarray, path: str | os.PathLike[str], metadata: dict[str, object] | None = None) -> Path:
    """Write a display picture (H x W x 3 uint8, sRGB) as a PNG, atomically, with ``metadata`` as
    ``labcut:<key>`` text (non-strings as JSON)."""
    from PIL import Image

    out = Path(path)
    if out.suffix.lower() != ".png":
        raise ParameterError(f"picture file {out.name!r} must end in .png")
    with atomic_output(out, (".png",)) as tmp:
        Image.fromarray(np.ascontiguousarray(picture, dtype=np.uint8), "RGB").save(tmp, format="PNG",
                                                                                  pnginfo=_png_text(metadata or {}))
    return out
