"""Tabulated summary of a material's flash at several internal angles."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ParameterError
from .material import Labradorite


def check_angles(angles_deg: Any) -> np.ndarray:
    """Validate internal angles to the lamella normal in degrees: finite, in [0, 90)."""
    try:
        a = np.atleast_1d(np.asarray(angles_deg, dtype=np.float64))
    except (TypeError, ValueError):
        raise ParameterError("angles must be numbers in degrees") from None
    if a.size == 0:
        raise ParameterError("give at least one angle")
    if not np.all(np.isfinite(a)) or np.any(a < 0.0) or np.any(a >= 90.0):
        raise ParameterError(f"angles must lie in [0, 90) degrees, got {a.tolist()}")
    return a


def spectrum_summary(material: Labradorite, angles_deg: Any = (0.0, 15.0, 30.0, 45.0)) -> list[dict[str, Any]]:
    """One row per internal angle (degrees from the lamella normal, inside the stone).

    Keys: ``angle_deg``, ``cos_theta``, ``peak_nm`` (NaN: no first-order peak),
    ``bragg_nm``, ``peak_reflectance``, ``dominant_nm`` (CIE dominant wavelength; negative:
    a purple, minus its complementary wavelength), ``hue`` (``"spectral"``, ``"purple"`` or
    None for a grey: :func:`labcut.colour.hue_of`), ``complementary_nm`` (a purple's
    complementary wavelength, else NaN), ``purity``, ``luminance`` (Y under D65, white = 1),
    ``srgb`` (display swatch), ``hex``.
    """
    rows = []
    for angle in check_angles(angles_deg):
        c = math.cos(math.radians(float(angle)))
        colour = material.flash_colour(c)
        peak = material.peak_wavelength(c)
        rows.append(
            {
                "angle_deg": float(angle),
                "cos_theta": c,
                "peak_nm": peak,
                "bragg_nm": material.bragg_wavelength(c),
                "peak_reflectance": material.peak_reflectance(c),
                "dominant_nm": colour.dominant_wavelength_nm,
                "hue": colour.hue,
                "complementary_nm": colour.complementary_wavelength_nm,
                "purity": colour.purity,
                "luminance": colour.luminance,
                "srgb": list(colour.srgb),
                "hex": colour.hex,
            }
        )
    return rows
