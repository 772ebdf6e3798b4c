"""Colour of the flash: spectrum -> CIE 1931 XYZ -> sRGB, and dominant wavelength.

The CIE 1931 2° observer, the D65 illuminant and the XYZ -> linear sRGB matrix
come from Mitsuba (``mitsuba.scalar_rgb``: tabulated once, 1 nm steps over
360-830 nm, no variant is set). Conventions:

* XYZ of a reflectance spectrum R(λ) under an illuminant S(λ) is
  ``∫ R S xyz̄ dλ / ∫ S ȳ dλ``: a perfect white reflector has Y = 1, and under
  D65 its linear sRGB is (1, 1, 1). This is what a Mitsuba spectral render of a
  white-lit surface shows, and what the RGB variants of the BSDF tabulate.
* ``srgb`` is a display swatch: linear sRGB clipped to >= 0, scaled so its
  brightest channel is 1, then gamma-encoded (IEC 61966-2-1). ``linear_srgb`` is
  the unscaled, unclipped value.
* Dominant wavelength (CIE 15): the spectral-locus wavelength hit by the ray from
  the white point (the illuminant's chromaticity) through the colour; a colour on
  the purple side gets the negative complementary wavelength (:attr:`FlashColour.hue`
  says which kind a colour is; :func:`dominant_text` writes it for people). Excitation
  purity is the distance to white over the distance of the boundary point to white.
"""

from __future__ import annotations

import functools
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .errors import ParameterError

LAMBDA_MIN_NM = 360.0
LAMBDA_MAX_NM = 830.0
ILLUMINANTS = ("D65", "E")


@dataclass(frozen=True)
class _Tables:
    wavelengths: np.ndarray  # (K,) nm
    xyz_bar: np.ndarray  # (K, 3) CIE 1931 colour matching functions
    d65: np.ndarray  # (K,) relative spectral power
    xyz_to_srgb: np.ndarray  # (3, 3) linear sRGB = M @ XYZ


@functools.lru_cache(maxsize=1)
def tables() -> _Tables:
    """CIE tables on a 1 nm grid from Mitsuba (cached)."""
    import importlib

    from .backend import variant_name

    mis = importlib.import_module(f"mitsuba.{variant_name('rgb')}")  # vectorised; no variant is set
    wl = np.arange(LAMBDA_MIN_NM, LAMBDA_MAX_NM + 0.5, 1.0)
    w = mis.Float(wl)
    xyz = np.array(mis.cie1931_xyz(w), dtype=np.float64).T
    d65 = np.array(mis.cie_d65(w), dtype=np.float64).ravel()
    m = np.array(mis.xyz_to_srgb(mis.Color3f(np.eye(3))), dtype=np.float64)  # [out channel, in basis]
    return _Tables(wl, xyz, d65, m)


def illuminant_spd(name: str = "D65") -> np.ndarray:
    """Relative spectral power of ``D65`` or equal-energy ``E`` on the table grid."""
    t = tables()
    key = str(name).upper()
    if key == "D65":
        return t.d65
    if key == "E":
        return np.ones_like(t.d65)
    raise ParameterError(f"unknown illuminant {name!r}; choose one of {', '.join(ILLUMINANTS)}")


def reflectance_to_xyz(reflectance: np.ndarray, illuminant: str = "D65") -> np.ndarray:
    """XYZ (..., 3) of reflectance spectra (..., K) sampled on :func:`tables` wavelengths."""
    t = tables()
    r = np.asarray(reflectance, dtype=np.float64)
    if r.shape[-1] != t.wavelengths.size:
        raise ParameterError(f"reflectance spectra need {t.wavelengths.size} samples (360-830 nm, 1 nm steps)")
    s = illuminant_spd(illuminant)
    weights = t.xyz_bar * s[:, None]
    return (r @ weights) / float(s @ t.xyz_bar[:, 1])


def xyz_to_linear_srgb(xyz: np.ndarray) -> np.ndarray:
    """Linear sRGB (D65 white) of XYZ values (..., 3)."""
    return np.asarray(xyz, dtype=np.float64) @ tables().xyz_to_srgb.T


def encode_srgb(linear: np.ndarray) -> np.ndarray:
    """sRGB transfer function (IEC 61966-2-1) of linear values clipped to [0, 1]."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def spectral_srgb(wavelength_nm: Any) -> np.ndarray:
    """The display colour (sRGB-encoded, in [0, 1], shape (..., 3)) of monochromatic light at each
    wavelength (nm): its CIE 1931 XYZ in linear sRGB, brought into the gamut by adding white (the
    hue kept, the least desaturation) and scaled so its largest channel is 1. A flash at 477 nm is
    blue, at 560 nm yellow-green: what a figure that encodes flash colour should paint (a rainbow
    colour map paints 477 nm green). NaN and wavelengths outside the tables give grey (0.5)."""
    t = tables()
    nm = np.asarray(wavelength_nm, dtype=np.float64)
    ok = np.isfinite(nm) & (nm >= LAMBDA_MIN_NM) & (nm <= LAMBDA_MAX_NM)
    safe = np.where(ok, nm, 550.0)
    xyz = np.stack([np.interp(safe, t.wavelengths, t.xyz_bar[:, k]) for k in range(3)], axis=-1)
    rgb = xyz_to_linear_srgb(xyz)
    rgb = np.clip(rgb, 0.0, None)
    peak = rgb.max(axis=-1, keepdims=True)
    rgb = rgb / np.where(peak > 0, peak, 1.0)
    return np.where(ok[..., None], encode_srgb(rgb), 0.5)


def xy_chromaticity(xyz: np.ndarray) -> np.ndarray:
    xyz = np.asarray(xyz, dtype=np.float64)
    total = xyz.sum(axis=-1, keepdims=True)
    return xyz[..., :2] / np.where(total > 0, total, 1.0)


def _ray_hit(origin: np.ndarray, direction: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ray parameter t and segment parameter u of the ray's hits on segments a->b."""
    e = b - a
    denom = direction[0] * e[:, 1] - direction[1] * e[:, 0]
    safe = np.where(np.abs(denom) > 1e-15, denom, np.nan)
    w = a - origin
    t = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / safe
    u = (w[:, 0] * direction[1] - w[:, 1] * direction[0]) / safe
    return t, u


def dominant_wavelength(xyz: np.ndarray, illuminant: str = "D65") -> tuple[float, float]:
    """``(dominant wavelength nm, excitation purity)`` of one XYZ colour.

    Negative wavelength: complementary wavelength of a purple. NaN for a colour
    at the white point (no hue).
    """
    t = tables()
    white = xy_chromaticity(reflectance_to_xyz(np.ones_like(t.wavelengths), illuminant))
    sample = xy_chromaticity(np.asarray(xyz, dtype=np.float64))
    direction = sample - white
    dist = float(np.hypot(*direction))
    if dist < 1e-6:
        return float("nan"), 0.0
    keep = (t.wavelengths >= 380.0) & (t.wavelengths <= 700.0)
    lam = t.wavelengths[keep]
    locus = xy_chromaticity(t.xyz_bar[keep])
    a, b = locus[:-1], locus[1:]
    for sign in (1.0, -1.0):
        tt, uu = _ray_hit(white, sign * direction, a, b)
        hit = np.where((tt > 0) & (uu >= 0) & (uu <= 1))[0]
        if hit.size:
            i = hit[np.argmin(tt[hit])]
            wavelength = float(lam[i] + uu[i] * (lam[i + 1] - lam[i]))
            if sign > 0:
                return wavelength, min(dist / float(tt[i] * dist), 1.0) if tt[i] > 0 else 0.0
            # purple: purity against the line of purples
            tp, _ = _ray_hit(white, direction, locus[-1:], locus[:1])
            purity = 1.0 / float(tp[0]) if np.isfinite(tp[0]) and tp[0] > 0 else float("nan")
            return -wavelength, min(purity, 1.0)
    return float("nan"), float("nan")


@dataclass(frozen=True)
class FlashColour:
    """The colour of a flash (or any reflectance spectrum) under an illuminant."""

    xyz: tuple[float, float, float]
    linear_srgb: tuple[float, float, float]
    srgb: tuple[float, float, float]
    hex: str
    dominant_wavelength_nm: float
    purity: float
    luminance: float

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @property
    def hue(self) -> str | None:
        """What ``dominant_wavelength_nm`` is: :func:`hue_of`."""
        return hue_of(self.dominant_wavelength_nm)

    @property
    def complementary_wavelength_nm(self) -> float:
        """A purple's complementary wavelength in nm (``-dominant_wavelength_nm``); NaN for a
        spectral or grey colour, which have none worth reporting."""
        return -self.dominant_wavelength_nm if self.hue == "purple" else float("nan")


def hue_of(dominant_nm: float) -> str | None:
    """The kind of colour a CIE dominant wavelength (:func:`dominant_wavelength`) describes.

    ``"spectral"`` (positive: the colour is a whitened spectral colour of that wavelength),
    ``"purple"`` (negative: a mix of red and violet that no single wavelength matches; the
    value is minus its complementary wavelength, the spectral hue opposite it across the white
    point) or None (NaN: white or grey, no hue).
    """
    if dominant_nm is None or math.isnan(dominant_nm):
        return None
    return "purple" if dominant_nm < 0 else "spectral"


def dominant_text(dominant_nm: float, spec: str = ".1f") -> str:
    """A dominant wavelength for people: ``"636.8 nm"``, a purple as ``"c 498.7 nm"`` (its
    complementary wavelength, marked ``c`` rather than written negative), ``"—"`` without a hue."""
    hue = hue_of(dominant_nm)
    if hue is None:
        return "—"
    return f"c {-dominant_nm:{spec}} nm" if hue == "purple" else f"{dominant_nm:{spec}} nm"


#: a caption that explains :func:`dominant_text`'s ``c`` where a table shows one
PURPLE_CAPTION = ("c: a purple (red + violet) flash, which no single wavelength matches; the number is its "
                  "complementary wavelength, the hue opposite it across white (CIE)")


def colour_of_spectrum(reflectance: np.ndarray, illuminant: str = "D65") -> FlashColour:
    """:class:`FlashColour` of a reflectance spectrum sampled on :func:`tables` wavelengths."""
    xyz = reflectance_to_xyz(reflectance, illuminant)
    lin = xyz_to_linear_srgb(xyz)
    shown = np.clip(lin, 0.0, None)
    peak = float(shown.max())
    swatch = encode_srgb(shown / peak) if peak > 0 else np.zeros(3)
    hexcode = "#" + "".join(f"{int(round(255 * v)):02x}" for v in swatch)
    dom, purity = dominant_wavelength(xyz, illuminant)
    return FlashColour(
        xyz=tuple(float(v) for v in xyz),
        linear_srgb=tuple(float(v) for v in lin),
        srgb=tuple(float(v) for v in swatch),
        hex=hexcode,
        dominant_wavelength_nm=dom,
        purity=purity,
        luminance=float(xyz[1]),
    )


def flash_colour(material: Any, cos_theta: float = 1.0, illuminant: str = "D65") -> FlashColour:
    """Colour of ``material``'s lamella reflection at internal ``cos_theta``."""
    return colour_of_spectrum(material.reflectance(tables().wavelengths, cos_theta), illuminant)


def stack_spectra(stack: Any, cos_theta: Any, polarization: str | None = None, *, jit: bool = True) -> np.ndarray:
    """``R(λ, cos θ)`` (float64, shape ``cos_theta.shape + (wavelengths,)``) of a lamella stack at an
    array of internal cosines, on the CIE grid of :func:`tables` (the stack's
    :meth:`~labcut.physics.lamella.Stack.spectra`: by one Dr.Jit kernel in float64, or with
    ``jit=False`` numpy's reference passes)."""
    return stack.spectra(tables().wavelengths, cos_theta, (polarization,), jit=jit)[0]


def stack_spectra_sp(stack: Any, cos_theta: Any, *, jit: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """``(R_s, R_p)`` of :func:`stack_spectra` from one evaluation of the stack (each to the last bit
    what ``polarization="s"`` and ``"p"`` give on the same path)."""
    r_s, r_p = stack.spectra(tables().wavelengths, cos_theta, ("s", "p"), jit=jit)
    return r_s, r_p


def stack_table(stack: Any, cos_theta: Any, kind: str = "rgb", illuminant: str = "D65",
                polarization: str | None = None, *, jit: bool = True) -> np.ndarray:
    """The one reflectance-table builder: ``R(λ, cos θ)`` of a lamella
    :class:`~labcut.physics.lamella.Stack` (:func:`stack_spectra`; ``jit`` as there) integrated
    against the CIE curves under ``illuminant``, as linear sRGB (``kind="rgb"``, shape (..., 3)) or
    luminance (``kind="mono"``, shape (..., 1)) at an array of internal cosines. The RGB and mono
    BSDF tables, the flash estimators' luminance table and colour zoning's per-row tables
    are all built here, once per material, never per ray.
    """
    spectra = stack_spectra(stack, cos_theta, polarization, jit=jit)
    xyz = reflectance_to_xyz(spectra, illuminant)
    if kind == "mono":
        return xyz[..., 1:2]
    if kind == "rgb":
        return xyz_to_linear_srgb(xyz)
    raise ParameterError(f"table kind must be 'rgb' or 'mono', got {kind!r}")


def reflectance_rgb(material: Any, cos_theta: Any, illuminant: str = "D65", polarization: str | None = None) -> np.ndarray:
    """Linear sRGB reflectance (..., 3) of ``material`` at an array of internal cosines
    (unpolarised, or ``'s'`` / ``'p'``): :func:`stack_table` of its stack."""
    return stack_table(material.stack, cos_theta, "rgb", illuminant, polarization)


LUMINANCE_TABLE_SIZE = 1024


@functools.lru_cache(maxsize=1)
def table_code() -> str:
    """The versions and code the material tables are computed with (their disk cache's key):
    labcut's physics and this module, numpy, Mitsuba (the CIE curves), Dr.Jit and its backend
    (the spectra's kernel: :func:`stack_spectra`)."""
    import drjit
    import mitsuba

    from . import __version__
    from .backend import device
    from .fileio import code_hash

    here = Path(__file__).resolve().parent
    return (f"labcut {__version__} numpy {np.__version__} mitsuba {mitsuba.__version__} drjit {drjit.__version__} "
            f"{device()} code {code_hash(here / 'colour.py', here / 'physics')}")


def material_key(material: Any) -> str:
    """The part of a disk-cache key that a value computed from ``material``'s spectra depends on:
    :func:`table_code` and every material parameter (full precision). The material tables and the
    planner's polarisation biases are keyed by it."""
    return f"{table_code()} material {json.dumps(material.to_dict(), sort_keys=True)}"


def _table_key(material: Any, kind: str, polarization: str | None) -> str:
    """Everything a material table depends on: the table's kind, size and polarisation, :func:`material_key`."""
    return f"{kind} size {LUMINANCE_TABLE_SIZE} polarization {polarization} {material_key(material)}"


@functools.lru_cache(maxsize=16)
def rgb_table(material: Any, polarization: str | None = None) -> np.ndarray:
    """Linear sRGB reflectance (LUMINANCE_TABLE_SIZE, 3) of a material over cos θ in [0, 1], clipped at
    0, float32: the RGB BSDF's table, built once per material (a scene build reuses it) and kept
    on disk for later processes (:func:`labcut.fileio.cached_array`, keyed by the material's
    parameters and the code and versions that compute it)."""
    from .fileio import cached_array

    c = np.linspace(0.0, 1.0, LUMINANCE_TABLE_SIZE)
    return cached_array("rgb", _table_key(material, "rgb", polarization),
                        lambda: np.clip(reflectance_rgb(material, c, polarization=polarization), 0.0, None).astype(np.float32),
                        shape=(LUMINANCE_TABLE_SIZE, 3), dtype=np.float32)


@functools.lru_cache(maxsize=16)
def luminance_table(material: Any) -> tuple[np.ndarray, np.ndarray]:
    """(cos θ grid over [0, 1], luminance reflectance R_Y) of a material, computed once and
    shared by the mono BSDF, its sampling weight and the flash estimators; kept on disk for
    later processes like :func:`rgb_table` (a CLI call's first recommendation would otherwise
    compute the 1024 x 471 spectra)."""
    from .fileio import cached_array

    c = np.linspace(0.0, 1.0, LUMINANCE_TABLE_SIZE)
    return c, cached_array("luminance", _table_key(material, "luminance", None), lambda: reflectance_luminance(material, c),
                           shape=(LUMINANCE_TABLE_SIZE,), dtype=np.float64)


@functools.lru_cache(maxsize=16)
def luminance_sp_table(material: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(cos θ grid over [0, 1], ``Y_s``, ``Y_p``): :func:`reflectance_luminance_sp` of a material on
    the grid of :func:`luminance_table`, computed once per material and kept on disk like it. The
    planner's polarisation bias reads it by linear interpolation (within about 1e-5 of the exact
    bias, relative: a decision against a 2 % tolerance, not a number an answer carries), so that a
    new light's plan does not evaluate the stack's spectra at every light and view pair."""
    from .fileio import cached_array

    c = np.linspace(0.0, 1.0, LUMINANCE_TABLE_SIZE)
    both = cached_array("luminance-sp", _table_key(material, "luminance-sp", None),
                        lambda: np.stack(reflectance_luminance_sp(material, c)), shape=(2, LUMINANCE_TABLE_SIZE),
                        dtype=np.float64)
    return c, both[0], both[1]


def reflectance_luminance(material: Any, cos_theta: Any, illuminant: str = "D65", polarization: str | None = None) -> np.ndarray:
    """Luminance Y (...) of ``material``'s reflectance (unpolarised, or ``'s'`` / ``'p'``): the mono variants' table."""
    return stack_table(material.stack, cos_theta, "mono", illuminant, polarization)[..., 0]


def reflectance_luminance_sp(material: Any, cos_theta: Any, illuminant: str = "D65") -> tuple[np.ndarray, np.ndarray]:
    """``(Y_s, Y_p)``: :func:`reflectance_luminance` of the ``'s'`` and of the ``'p'`` polarisation
    from one evaluation of the stack's spectra (the planner's polarisation bias asks both)."""
    r_s, r_p = stack_spectra_sp(material.stack, cos_theta)
    return reflectance_to_xyz(r_s, illuminant)[..., 1], reflectance_to_xyz(r_p, illuminant)[..., 1]
