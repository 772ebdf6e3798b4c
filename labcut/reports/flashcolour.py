"""Where a stone flashes and in what colour: dominant wavelength over its face.

From a render of the schiller lobe alone (linear sRGB, D65 white) seen from the scenario's main
viewer, each pixel of the stone gets

* its *level*: luminance ``Y`` over the flash threshold ``τ P L_ref`` of the render's lights
  (DESIGN.md §4 and :mod:`labcut.orientation.radiance`: ``L_ref`` is the schiller of a flat face,
  lamellae parallel, lit and seen along its normal by one light of the same total irradiance; ``P``
  the brightest share of it the scene's lights can give); a pixel flashes when ``level >= 1``,
  so the flashing share of the stone's pixels estimates the main view's flash area;
* its *dominant wavelength* (CIE 15, :func:`labcut.colour.dominant_wavelength`): the
  spectral-locus wavelength on the ray from the white point through the pixel's chromaticity;
  negative for purples (the complementary wavelength).

The dominant wavelength is found for all pixels at once with the construction of
:func:`labcut.colour.dominant_wavelength` (the ray from white crossing the spectral locus).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..colour import (
    dominant_wavelength,
    encode_srgb,
    reflectance_to_xyz,
    tables,
    xy_chromaticity,
)

#: chromaticity distance from white (xy) below which a pixel has no hue
NO_HUE = 1e-4
CHUNK = 4096


@functools.lru_cache(maxsize=1)
def _locus() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """White point (xy, D65), the spectral locus (xy, 380-700 nm) and its wavelengths, as
    :func:`labcut.colour.dominant_wavelength` uses them."""
    t = tables()
    white = xy_chromaticity(reflectance_to_xyz(np.ones_like(t.wavelengths), "D65"))
    keep = (t.wavelengths >= 380.0) & (t.wavelengths <= 700.0)
    return white, xy_chromaticity(t.xyz_bar[keep]), t.wavelengths[keep]


def linear_srgb_to_xyz(rgb: np.ndarray) -> np.ndarray:
    """XYZ (..., 3) of linear sRGB values (..., 3) (the inverse of :func:`labcut.colour.xyz_to_linear_srgb`)."""
    return np.asarray(rgb, dtype=np.float64) @ np.linalg.inv(tables().xyz_to_srgb).T


def dominant_wavelengths(rgb: np.ndarray) -> np.ndarray:
    """Dominant wavelength (nm; negative: a purple's complementary wavelength; NaN: no hue) of
    linear sRGB colours (..., 3): :func:`labcut.colour.dominant_wavelength`'s construction (the
    nearest crossing of the spectral locus by the ray from white through the colour, else by the
    opposite ray) for every colour at once."""
    white, locus, lam = _locus()
    xyz = linear_srgb_to_xyz(rgb)
    shape = xyz.shape[:-1]
    xyz = xyz.reshape(-1, 3)
    total = xyz.sum(axis=-1)
    ok = total > 1e-12
    d = xyz[:, :2] / np.where(ok, total, 1.0)[:, None] - white
    out = np.full(len(d), np.nan)
    a, e = locus[:-1], locus[1:] - locus[:-1]
    w = a - white
    w_x_e = w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]
    for s0 in range(0, len(d), CHUNK):
        dd = d[s0 : s0 + CHUNK]
        denom = dd[:, 0:1] * e[None, :, 1] - dd[:, 1:2] * e[None, :, 0]
        denom = np.where(np.abs(denom) > 1e-15, denom, np.nan)
        with np.errstate(invalid="ignore"):
            t = w_x_e[None, :] / denom
            u = (w[None, :, 0] * dd[:, 1:2] - w[None, :, 1] * dd[:, 0:1]) / denom
            on = (u >= 0) & (u <= 1)
            ahead = np.where(on & (t > 0), t, np.inf)
            behind = np.where(on & (t < 0), -t, np.inf)
        rows = np.arange(len(dd))
        ia, ib = np.argmin(ahead, axis=1), np.argmin(behind, axis=1)
        fwd = np.isfinite(ahead[rows, ia])
        i = np.where(fwd, ia, ib)
        hit = fwd | np.isfinite(behind[rows, ib])
        value = lam[i] + u[rows, i] * (lam[i + 1] - lam[i])
        out[s0 : s0 + CHUNK] = np.where(hit, np.where(fwd, value, -value), np.nan)
    out = np.where(ok & (np.hypot(d[:, 0], d[:, 1]) > NO_HUE), out, np.nan)
    return out.reshape(shape)


def _weighted_quantile(values: np.ndarray, weights: np.ndarray, q: float) -> float:
    order = np.argsort(values)
    v, w = values[order], weights[order]
    c = np.cumsum(w)
    return float(np.interp(q * c[-1], c - 0.5 * w, v))


@dataclass
class FlashColourMap:
    """Flash colour over the stone as the main viewer sees it (H x W arrays; see the module docstring).

    ``wavelength_nm``: dominant wavelength per pixel (NaN off the stone or without hue).
    ``level``: schiller luminance / (τ P L_ref), 0 off the stone. ``mask``: stone pixels.
    ``stats``: :func:`colour_stats`."""

    wavelength_nm: np.ndarray
    level: np.ndarray
    mask: np.ndarray
    stats: dict[str, Any]


def flash_colour_map(schiller_rgb: np.ndarray, mask: np.ndarray, threshold: float,
                     ratio: np.ndarray | None = None, ratio_threshold: float = 0.1) -> FlashColourMap:
    """:class:`FlashColourMap` of a schiller-only render (linear sRGB, H x W x 3) with the stone's
    ``mask`` and the flash ``threshold`` ``τ P L_ref`` in the render's units (luminance).

    ``ratio`` (H x W, ``L_s / L_ref``: a :class:`~labcut.orientation.flash_mask.FlashMask`'s, the
    lights summed exactly) decides which pixels flash and how much instead of the render's
    sampled luminance (``ratio_threshold`` the threshold ``τ P`` in units of ``L_ref``: the mask's
    ``threshold``): the colours stay the render's, the flash is the one the metrics count."""
    rgb = np.nan_to_num(np.asarray(schiller_rgb, dtype=np.float64))
    xyz = linear_srgb_to_xyz(rgb)
    if ratio is None:
        level = np.where(mask, np.clip(xyz[..., 1], 0.0, None) / float(threshold), 0.0)
    else:
        level = np.where(mask, np.clip(np.asarray(ratio, dtype=np.float64), 0.0, None) / float(ratio_threshold), 0.0)
    inside = np.asarray(mask, dtype=bool)
    wl = np.full(inside.shape, np.nan)
    wl[inside] = dominant_wavelengths(rgb[inside])  # the stone's pixels only: the background has no flash
    return FlashColourMap(wl, level, np.asarray(mask, dtype=bool), colour_stats(rgb, wl, level, mask))


def colour_stats(rgb: np.ndarray, wavelength: np.ndarray, level: np.ndarray, mask: np.ndarray) -> dict[str, Any]:
    """Summary of a flash-colour map (plain JSON).

    ``flash_fraction``: share of the stone's pixels at or above the threshold (the main view's
    flash area, as the render sees it). The colour is taken over the flashing pixels
    (``basis: "flash"``), or, where none flashes, over the whole stone (``basis: "faint"``: the
    colour of the schiller below the threshold), each pixel weighted by its luminance:
    ``dominant_wavelength_nm`` (weighted median), ``p10_nm``/``p90_nm`` (weighted 10th/90th
    percentiles), ``purple_fraction`` (weight of pixels whose hue is a purple), and the mean
    colour (``mean_hex``, a display swatch, and its own ``mean_dominant_wavelength_nm``,
    ``mean_purity``)."""
    stone = int(mask.sum())
    flash = mask & (level >= 1.0)
    basis = "flash" if flash.any() else "faint"
    sel = flash if flash.any() else mask & (level > 0)
    out: dict[str, Any] = {"stone_pixels": stone, "flash_pixels": int(flash.sum()),
                           "flash_fraction": float(flash.sum() / stone) if stone else 0.0, "basis": basis,
                           "peak_level": float(level[mask].max()) if stone else 0.0}
    w = level[sel]
    lam = wavelength[sel]
    hue = np.isfinite(lam)
    keys = ("dominant_wavelength_nm", "p10_nm", "p90_nm", "purple_fraction", "mean_hex", "mean_dominant_wavelength_nm",
            "mean_purity")
    if not hue.any() or float(w[hue].sum()) <= 0.0:
        return {**out, **{k: None for k in keys}}
    spectral = hue & (lam > 0)
    out["purple_fraction"] = float(w[hue & (lam < 0)].sum() / w[hue].sum())
    if spectral.any():
        out["dominant_wavelength_nm"] = _weighted_quantile(lam[spectral], w[spectral], 0.5)
        out["p10_nm"] = _weighted_quantile(lam[spectral], w[spectral], 0.1)
        out["p90_nm"] = _weighted_quantile(lam[spectral], w[spectral], 0.9)
    else:
        out["dominant_wavelength_nm"] = out["p10_nm"] = out["p90_nm"] = None
    mean = rgb[sel].sum(axis=0)
    shown = np.clip(mean, 0.0, None)
    swatch = encode_srgb(shown / shown.max()) if shown.max() > 0 else np.zeros(3)
    out["mean_hex"] = "#" + "".join(f"{round(255 * float(v)):02x}" for v in swatch)
    dom, purity = dominant_wavelength(linear_srgb_to_xyz(mean), "D65")
    out["mean_dominant_wavelength_nm"] = None if not np.isfinite(dom) else float(dom)
    out["mean_purity"] = None if not np.isfinite(purity) else float(purity)
    return out
