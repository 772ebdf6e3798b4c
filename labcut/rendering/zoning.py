"""Colour zoning (paper §3.2.2, Fig. 5, 6, 9-12): lamella parameters that vary through the stone.

A real labradorite is rarely one colour: its composition, and with it the lamella
thicknesses, drift through the crystal, so its flash shows zones of colour. The
paper drives this with a Perlin noise value ``x`` in [0, 1] and a lookup table
(LUT) that maps ``x`` to a lamella parameter set, unblended in some ranges of
``x`` and linearly blended in the ranges between them (Fig. 6). labcut does the
same:

* :class:`Zoning` holds 1+ parameter sets (:class:`~labcut.Labradorite`
  materials that differ only in the *zoned* parameters ``d_a``, ``d_b``,
  ``sigma_a``, ``sigma_b``, ``pairs``), the LUT as a list of unblended
  ``ranges`` ``(x_lo, x_hi, set)``, and the noise (``scale_mm``, ``octaves``,
  ``seed``, ``resolution``). ``mode="smooth"`` blends linearly across the gap
  between two ranges; ``mode="sharp"`` replaces each gap by a step at its
  middle (Spectrolite-like zone edges, paper Fig. 10).
* The noise is 3D fBm of Perlin gradient noise in object (= mesh) space, in mm
  (a render looks it up in the stone's render frame, over the grid's box mapped
  there: :meth:`BakedZoning.in_frame`), baked once per render on a grid over the
  mesh's bounding box and then
  *equalised*: each grid value is replaced by its rank, scaled to [0, 1]. ``x``
  is therefore uniformly distributed over the box, and a LUT range of width w
  holds a fraction w of the stone's volume (about; the stone is not its box).
* Parameters, not colours, are blended: the LUT path ``P(x)`` interpolates
  ``d_a, d_b, sigma_a, sigma_b, pairs`` between two sets, as the paper does.
  :meth:`Zoning.bake` tabulates ``P`` on 128 values of ``x``.

In the kernel (:mod:`labcut.rendering.bsdf`) the grid is a trilinear
``mi.Texture3f`` read at ``si.p``; spectral variants read the five parameters
from a 1D texture over ``x`` and evaluate :func:`labcut.physics.stack_reflectance`
with them at ``si.wavelengths``; RGB and mono variants read a 2D table of linear
sRGB (or luminance) reflectance over (``x``, cos θ), integrated against the CIE
curves once per render from the same parameter path (:mod:`labcut.rendering.zoning_kernel`;
the noise is :mod:`labcut.rendering.noise`). docs/zoning.md has the details.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..validation import check_number
from ..physics.material import Labradorite
from .noise import equalise, fbm

#: Parameters a zoning blends between its sets.
ZONED_KEYS = ("d_a", "d_b", "sigma_a", "sigma_b", "pairs")
#: Parameters every set of one zoning must share (one BSDF has one surface, one lobe width).
SHARED_KEYS = ("n_a", "n_b", "spread_deg", "body_albedo", "n_surface")
MODES = ("smooth", "sharp")
PRESETS = ("smooth", "sharp", "natural")
#: Values of x at which the parameter path is tabulated for the kernel.
PATH_SIZE = 128
#: Entries over cos θ of the RGB / mono reflectance table.
COS_SIZE = 256

# ---------------------------------------------------------------------- helpers
def _number(name: str, value: Any, low: float, high: float, *, integer: bool = False) -> Any:
    return check_number(value, f"zoning {name}", low, high, integer=integer)


def _shared(material: Labradorite) -> dict[str, Any]:
    return {k: getattr(material, k) for k in SHARED_KEYS}


def _inherited(base: Labradorite) -> dict[str, Any]:
    """Everything of ``base`` but its thicknesses and name: what a preset set inherits."""
    return {k: v for k, v in base.to_dict().items() if k not in ("d_a", "d_b", "name")}


def default_ranges(count: int) -> tuple[tuple[float, float, int], ...]:
    """``count`` sets in order, each unblended over the middle half of an equal share of [0, 1]."""
    share = 1.0 / count
    out = []
    for k in range(count):
        lo = 0.0 if k == 0 else (k + 0.25) * share
        hi = 1.0 if k == count - 1 else (k + 0.75) * share
        out.append((lo, hi, k))
    return tuple(out)


@dataclass(frozen=True)
class BakedZoning:
    """A zoning baked for one mesh: the noise grid over a box and the tabulated parameter path.

    ``grid``: (nz, ny, nx) float32 values of x in [0, 1] at cell centres
    ``lo + (i + 0.5) (hi - lo) / n`` (Mitsuba's texture convention, so a point p
    is looked up at ``(p - lo) / (hi - lo)``). ``path``: (PATH_SIZE, 5) float32,
    row i the parameters ``d_a, d_b, sigma_a, sigma_b, pairs`` at ``x = i / (PATH_SIZE - 1)``.
    """

    grid: np.ndarray
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    path: np.ndarray

    def props(self) -> dict[str, Any]:
        """The ``labradorite`` plugin properties that carry this zoning (needs a JIT variant set)."""
        import mitsuba as mi

        return {
            "zoning_grid": mi.TensorXf(np.ascontiguousarray(self.grid[..., None], dtype=np.float32)),
            "zoning_path": mi.TensorXf(np.ascontiguousarray(self.path, dtype=np.float32)),
            "zoning_lo": [float(v) for v in self.lo],
            "zoning_hi": [float(v) for v in self.hi],
        }

    def in_frame(self, frame: Any) -> BakedZoning:
        """This zoning with its box in ``frame`` (a :class:`~labcut.rendering.scene.RenderFrame`:
        where a render places the stone; the grid, baked in mm, is the same)."""
        lo, hi = frame.box(self.lo, self.hi)
        return dataclasses.replace(self, lo=tuple(lo), hi=tuple(hi))

    def values_at(self, points: np.ndarray) -> np.ndarray:
        """x at ``points`` (N, 3) by trilinear interpolation of the grid (numpy twin of the kernel lookup)."""
        from scipy.ndimage import map_coordinates

        p = np.asarray(points, dtype=np.float64)
        lo, hi = np.asarray(self.lo), np.asarray(self.hi)
        n = np.array(self.grid.shape[::-1], dtype=np.float64)  # nx, ny, nz
        idx = (p - lo) / (hi - lo) * n - 0.5
        return map_coordinates(self.grid.astype(np.float64), idx[:, ::-1].T, order=1, mode="nearest")


@dataclass(frozen=True)
class Zoning:
    """Colour zoning: a noise field in object space that blends lamella parameter sets through a LUT.

    Attributes
    ----------
    materials:
        One or more parameter sets (:class:`~labcut.Labradorite`). They may differ only in
        ``d_a``, ``d_b``, ``sigma_a``, ``sigma_b`` and ``pairs``; the other parameters
        (indices, spread, body albedo) are one per stone. One set is a valid, degenerate zoning.
    ranges:
        The LUT: unblended ranges ``(x_lo, x_hi, set index)`` over the noise value x in
        [0, 1], sorted and not overlapping; between two ranges the parameters blend linearly
        from one range's set to the next one's (``mode="smooth"``) or jump at the middle of
        the gap (``"sharp"``). x below the first range takes its set, above the last likewise.
        Default: the sets in order, each unblended over the middle half of an equal share.
        The paper's Fig. 6 is ``((0, 0.5, 0), (0.9, 1, 1))``.
    scale_mm:
        Lattice spacing of the noise's first octave, mm: roughly the size of a zone.
    octaves:
        Number of fBm octaves (1-8); more give rougher, more ragged zone edges.
    seed:
        Seed of the noise (gradients and octave offsets); the same seed, mesh and
        parameters always give the same zones.
    mode:
        ``"smooth"`` (blended gaps, Labradorite, Fig. 9) or ``"sharp"`` (steps, Spectrolite, Fig. 10).
    resolution:
        Grid samples along the longest side of the mesh's bounding box (8-256); the other
        sides get proportionally many (at least 8).
    """

    materials: tuple[Labradorite, ...]
    ranges: tuple[tuple[float, float, int], ...] | None = None
    scale_mm: float = 5.0
    octaves: int = 4
    seed: int = 0
    mode: str = "smooth"
    resolution: int = 64
    name: str | None = None

    def __post_init__(self) -> None:
        mats = self.materials
        if isinstance(mats, Labradorite) or not isinstance(mats, list | tuple):
            raise ParameterError("zoning materials must be a list of labcut.Labradorite parameter sets")
        if not 1 <= len(mats) <= 64:
            raise ParameterError(f"zoning needs 1 to 64 parameter sets, got {len(mats)}")
        for i, m in enumerate(mats):
            if not isinstance(m, Labradorite):
                raise ParameterError(f"zoning set {i} must be a labcut.Labradorite, got {type(m).__name__}")
        first = _shared(mats[0])
        for i, m in enumerate(mats[1:], start=1):
            for key, value in _shared(m).items():
                if value != first[key]:
                    raise ParameterError(
                        f"zoning sets may differ only in {', '.join(ZONED_KEYS)}; set {i} has {key}={value:g}, set 0 {first[key]:g}"
                    )
        object.__setattr__(self, "materials", tuple(mats))
        object.__setattr__(self, "ranges", self._check_ranges(self.ranges, len(mats)))
        object.__setattr__(self, "scale_mm", _number("scale_mm", self.scale_mm, 0.01, 1e4))
        object.__setattr__(self, "octaves", _number("octaves", self.octaves, 1, 8, integer=True))
        object.__setattr__(self, "seed", _number("seed", self.seed, 0, 2**32 - 1, integer=True))
        object.__setattr__(self, "resolution", _number("resolution", self.resolution, 8, 256, integer=True))
        mode = str(self.mode).strip().lower() if isinstance(self.mode, str) else self.mode
        if mode not in MODES:
            raise ParameterError(f"zoning mode must be one of {', '.join(MODES)}, got {self.mode!r}")
        object.__setattr__(self, "mode", mode)

    @staticmethod
    def _check_ranges(ranges: Any, count: int) -> tuple[tuple[float, float, int], ...]:
        if ranges is None:
            return default_ranges(count)
        if isinstance(ranges, str) or not isinstance(ranges, list | tuple) or not ranges:
            raise ParameterError("zoning ranges must be a non-empty list of [x_lo, x_hi, set] triples")
        out: list[tuple[float, float, int]] = []
        for r in ranges:
            if isinstance(r, str) or not isinstance(r, list | tuple) or len(r) != 3:
                raise ParameterError(f"each zoning range must be [x_lo, x_hi, set], got {r!r}")
            lo = _number("range start", r[0], 0.0, 1.0)
            hi = _number("range end", r[1], 0.0, 1.0)
            k = _number("range set index", r[2], 0, count - 1, integer=True)
            if hi < lo:
                raise ParameterError(f"zoning range [{lo:g}, {hi:g}] ends before it starts")
            if out and lo < out[-1][1]:
                raise ParameterError(f"zoning ranges must be sorted and not overlap: [{lo:g}, {hi:g}] starts before {out[-1][1]:g}")
            out.append((lo, hi, k))
        unused = sorted(set(range(count)) - {k for _, _, k in out})
        if unused:
            raise ParameterError(f"zoning set(s) {', '.join(map(str, unused))} are not used by any range")
        return tuple(out)

    # ------------------------------------------------------------------ presets and I/O
    @classmethod
    def preset(cls, name: str, base: Labradorite | None = None, **changes: Any) -> Zoning:
        """``smooth`` (paper Fig. 9: blue, green and gold zones, soft blends, few octaves),
        ``sharp`` (Fig. 10: the same colours with hard edges and ragged, many-octave noise) or
        ``natural`` (:func:`_natural`: the material's own colour in domains of neighbouring colours
        and of fainter flash, the presentation renders' default).

        The sets of ``smooth`` and ``sharp`` are ``base`` (default :class:`~labcut.Labradorite`)
        with the lamella period set for first-order peaks at 470, 530 and 580 nm; every other
        parameter is ``base``'s.
        ``changes`` override fields (e.g. ``seed=3``).
        """
        key = str(name).strip().lower()
        if key not in PRESETS:
            raise ParameterError(f"unknown zoning preset {name!r}; choose one of {', '.join(PRESETS)}")
        if base is None:
            base = Labradorite()
        if not isinstance(base, Labradorite):
            raise ParameterError(f"zoning base material must be a labcut.Labradorite, got {type(base).__name__}")
        if key == "natural":
            return cls(**{**_natural(base), "seed": 0, "name": key, **changes})
        sets = tuple(
            Labradorite.from_peak_wavelength(nm, **{**_inherited(base), "name": label})
            for label, nm in (("blue", 470.0), ("green", 530.0), ("gold", 580.0))
        )
        if key == "smooth":
            fields = dict(ranges=((0.0, 0.3, 0), (0.5, 0.55, 1), (0.8, 1.0, 2)), scale_mm=7.0, octaves=2, mode="smooth")
        else:
            fields = dict(ranges=((0.0, 0.4, 0), (0.4, 0.72, 1), (0.72, 1.0, 2)), scale_mm=6.0, octaves=5, mode="sharp")
        return cls(**{"materials": sets, **fields, "seed": 0, "name": key, **changes})

    def replace(self, **changes: Any) -> Zoning:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON description (materials as full parameter dicts); inverse of :meth:`from_dict`."""
        return {
            "materials": [m.to_dict() for m in self.materials],
            "ranges": [list(r) for r in self.ranges],
            "scale_mm": self.scale_mm,
            "octaves": self.octaves,
            "seed": self.seed,
            "mode": self.mode,
            "resolution": self.resolution,
            "name": self.name,
        }

    @classmethod
    def from_dict(cls, data: Any, base: Labradorite | None = None) -> Zoning:
        """A zoning from JSON-like data.

        Keys: the :class:`Zoning` fields, and optionally ``preset`` (``smooth`` / ``sharp``) to
        start from. Each entry of ``materials`` is a preset name (``"blue"``), a peak
        wavelength in nm (``530``), or an object of :class:`~labcut.Labradorite` parameters
        (plus optionally ``peak_nm`` or ``an``); what an entry leaves out comes from ``base``
        (default :class:`~labcut.Labradorite`), thicknesses included.
        """
        if not isinstance(data, dict):
            raise ParameterError("zoning description must be a JSON object")
        base = base if base is not None else Labradorite()
        known = {f.name for f in dataclasses.fields(cls)} | {"preset"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ParameterError(f"unknown zoning field(s): {', '.join(unknown)}; known: {', '.join(sorted(known))}")
        fields = {k: v for k, v in data.items() if k not in ("preset", "materials")}
        if "ranges" in fields and isinstance(fields["ranges"], list):
            fields["ranges"] = tuple(tuple(r) if isinstance(r, list) else r for r in fields["ranges"])
        if "materials" in data:
            entries = data["materials"]
            if isinstance(entries, str) or not isinstance(entries, list | tuple):
                raise ParameterError("zoning materials must be a list of presets, peak wavelengths or parameter objects")
            fields["materials"] = tuple(_material_entry(e, base, i) for i, e in enumerate(entries))
        if "preset" in data:
            return cls.preset(data["preset"], base, **fields)
        if "materials" not in fields:
            raise ParameterError("zoning description needs 'materials' (or a 'preset')")
        return cls(**fields)

    @classmethod
    def load(cls, path: str | Path, base: Labradorite | None = None) -> Zoning:
        """:meth:`from_dict` of a JSON file (bad files are a :class:`ParameterError`)."""
        from ..fileio import read_json

        return cls.from_dict(read_json(path, "zoning file"), base)

    # ------------------------------------------------------------------ the LUT
    @property
    def shared(self) -> dict[str, Any]:
        """The parameters every set shares (indices, spread, body albedo)."""
        return _shared(self.materials[0])

    def set_table(self) -> np.ndarray:
        """(K, 5) float64: each set's ``d_a, d_b, sigma_a, sigma_b, pairs``."""
        return np.array([[float(getattr(m, k)) for k in ZONED_KEYS] for m in self.materials])

    def blend(self, x: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For noise values ``x``: ``(set i, set j, t)`` with ``P(x) = (1 - t) P_i + t P_j``."""
        x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
        ranges = self.ranges
        i = np.full(x.shape, ranges[0][2], dtype=np.int64)
        j = i.copy()
        t = np.zeros(x.shape)
        for (lo0, hi0, k0), (lo1, hi1, k1) in zip(ranges[:-1], ranges[1:]):
            gap = (x > hi0) & (x < lo1)
            if self.mode == "smooth":
                frac = (x - hi0) / max(lo1 - hi0, 1e-300)
            else:
                frac = (x >= 0.5 * (hi0 + lo1)).astype(np.float64)
            i = np.where(gap, k0, i)
            j = np.where(gap, k1, j)
            t = np.where(gap, frac, t)
            past = x >= lo1  # in the next range, or beyond it (a later pair refines that)
            i = np.where(past, k1, i)
            j = np.where(past, k1, j)
            t = np.where(past, 0.0, t)
        return i, j, t

    def parameters(self, x: Any) -> np.ndarray:
        """The parameter path ``P(x)``: (..., 5) float64 ``d_a, d_b, sigma_a, sigma_b, pairs``."""
        i, j, t = self.blend(x)
        table = self.set_table()
        return (1.0 - t)[..., None] * table[i] + t[..., None] * table[j]

    def path_table(self, size: int = PATH_SIZE) -> np.ndarray:
        """``P`` at ``x = k / (size - 1)``, k = 0..size-1: (size, 5)."""
        return self.parameters(np.linspace(0.0, 1.0, size))

    # ------------------------------------------------------------------ the noise
    def grid_shape(self, lo: np.ndarray, hi: np.ndarray) -> tuple[int, int, int]:
        """(nz, ny, nx) of the baked grid for a box ``lo``-``hi``."""
        ext = np.asarray(hi, dtype=np.float64) - np.asarray(lo, dtype=np.float64)
        n = np.maximum(8, np.ceil(self.resolution * ext / ext.max())).astype(int)
        return int(n[2]), int(n[1]), int(n[0])

    def bake(self, bounds: Any) -> BakedZoning:
        """Noise grid over ``bounds`` ((2, 3) mm; padded by 2 %) and the parameter path table."""
        return _bake(self, tuple(map(tuple, np.asarray(bounds, dtype=np.float64).reshape(2, 3).tolist())))


#: the natural preset's domains: (label, shift of the first-order peak in nm, share of the
#: lamella pairs), in the order of the noise's ranges
NATURAL_DOMAINS = (("faint", 0.0, 0.2), ("shorter", -30.0, 0.8), ("main", 0.0, 1.0), ("longer", 35.0, 0.6))
#: the natural preset's LUT: a few faint patches, a band of the shorter colour, mostly the
#: material's own, some of the longer; blended over short gaps (domain walls)
NATURAL_RANGES = ((0.0, 0.14, 0), (0.2, 0.3, 1), (0.36, 0.76, 2), (0.86, 1.0, 3))


def _natural(base: Labradorite) -> dict[str, Any]:
    """The ``natural`` preset's fields on ``base``: domains of the material's own flash colour,
    of colours 30 nm shorter and 35 nm longer (the neighbouring composition of a real stone's
    zoning, paper §3.2.2) and faint patches with a fifth of the lamella pairs (a stone's dull
    spots), in 4 mm zones with ragged (4-octave) edges and short blends."""
    peak = base.peak_wavelength()
    sets = []
    for label, shift, share in NATURAL_DOMAINS:
        nm = min(max(peak + shift, 380.0), 780.0)
        made = Labradorite.from_peak_wavelength(nm, **{**_inherited(base), "name": label})
        sets.append(dataclasses.replace(made, pairs=max(1, round(base.pairs * share))))
    return dict(materials=tuple(sets), ranges=NATURAL_RANGES, scale_mm=4.0, octaves=4, mode="smooth")


def _material_entry(entry: Any, base: Labradorite, index: int) -> Labradorite:
    inherited = _inherited(base)
    if isinstance(entry, str):
        return Labradorite.preset(entry, **inherited)
    if isinstance(entry, int | float) and not isinstance(entry, bool):
        return Labradorite.from_peak_wavelength(entry, **{**inherited, "name": f"{entry:g} nm"})
    if isinstance(entry, dict):
        e = dict(entry)
        if "peak_nm" in e and "an" in e:
            raise ParameterError(f"zoning set {index}: give peak_nm or an, not both")
        if "peak_nm" in e:
            peak = e.pop("peak_nm")
            return Labradorite.from_peak_wavelength(peak, **_checked({**inherited, **e}))
        if "an" in e:
            an = e.pop("an")
            return Labradorite.from_anorthite(an, **_checked({**inherited, **e}))
        return Labradorite.from_dict({**base.to_dict(), "name": None, **e})
    raise ParameterError(f"zoning set {index} must be a preset name, a peak wavelength or an object, got {entry!r}")


def _checked(params: dict[str, Any]) -> dict[str, Any]:
    fields = {f.name for f in dataclasses.fields(Labradorite)}
    unknown = sorted(set(params) - fields)
    if unknown:
        raise ParameterError(f"unknown material parameter(s): {', '.join(unknown)}")
    return params


@functools.lru_cache(maxsize=8)
def _bake(zoning: Zoning, bounds: tuple[tuple[float, ...], ...]) -> BakedZoning:
    lo, hi = np.array(bounds[0]), np.array(bounds[1])
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi >= lo)):
        raise ParameterError("zoning needs a finite bounding box")
    ext = np.maximum(hi - lo, 1e-3 * max(float(np.max(hi - lo)), 1e-3))
    centre = 0.5 * (lo + hi)
    lo, hi = centre - 0.51 * ext, centre + 0.51 * ext
    nz, ny, nx = zoning.grid_shape(lo, hi)
    axes = [lo[a] + (np.arange(n) + 0.5) * (hi[a] - lo[a]) / n for a, n in enumerate((nx, ny, nz))]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    grid = equalise(fbm(pts, zoning.scale_mm, zoning.octaves, zoning.seed)).reshape(nz, ny, nx)
    return BakedZoning(grid.astype(np.float32), tuple(lo.tolist()), tuple(hi.tolist()), zoning.path_table().astype(np.float32))


def resolve(spec: Any, material: Labradorite) -> Zoning | None:
    """The :class:`Zoning` a ``zoning=`` argument names, for stones of ``material``.

    ``None`` or ``"none"`` (no zoning), ``"smooth"`` / ``"sharp"`` / ``"natural"`` (presets built on
    ``material``), a dict
    (:meth:`Zoning.from_dict`) or a :class:`Zoning` whose sets share ``material``'s indices,
    spread and body albedo.
    """
    if spec is None or (isinstance(spec, str) and spec.strip().lower() == "none"):
        return None
    if isinstance(spec, str):
        return Zoning.preset(spec, material)
    if isinstance(spec, dict):
        return Zoning.from_dict(spec, material)
    if not isinstance(spec, Zoning):
        raise ParameterError(f"zoning must be None, 'smooth', 'sharp' or a labcut Zoning, got {type(spec).__name__}")
    mine = _shared(material)
    for key, value in spec.shared.items():
        if value != mine[key]:
            raise ParameterError(
                f"the zoning's sets have {key}={value:g} but the material has {mine[key]:g}; they must agree"
            )
    return spec
