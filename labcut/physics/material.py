"""The :class:`Labradorite` material: lamella-stack parameters, presets, validation.

Lengths in nm, angles in degrees, refractive indices unitless. ``cos_theta`` is
always the cosine of the angle between a ray inside the stone (index
``n_surface``) and the lamella normal.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import ParameterError
from ..validation import check_number
from . import lamella
from .search import golden_section_max
from .ops import is_drjit

#: Bøggild range of bulk anorthite content (mol % An) over which labradorite
#: shows schiller, as quoted by Weidlich & Wilkie 2009 §3 (after Miura 1978).
AN_RANGE = (44.0, 61.0)
#: Lamella period d_a + d_b (nm) at the two ends of AN_RANGE: the span that puts
#: the first-order normal-incidence peak across the visible (Miura 1978, J. Gemmol.
#: Soc. Japan 5:3: visible schiller needs a period of ~128-252 nm).
PERIOD_RANGE_NM = (128.0, 252.0)

_DEFAULT_PERIOD_NM = 155.0  # blue-green flash near 483 nm at normal incidence


def _check_number(name: str, value: Any, low: float, high: float = math.inf, *, low_open: bool = False) -> float:
    return check_number(value, name, low, high, low_open=low_open)


@dataclass(frozen=True)
class Labradorite:
    """A labradorite (or other schiller feldspar) described by its lamella stack.

    ``cos_theta`` in every method is the cosine of the angle between a ray
    inside the stone and the lamella normal.

    Attributes
    ----------
    n_a, n_b:
        Refractive indices of the two lamella phases (~An44 and ~An58:
        1.555 and 1.562, plagioclase n_beta interpolated). Must exceed 1.
    d_a, d_b:
        Mean lamella thicknesses in nm (> 0).
    sigma_a, sigma_b:
        Standard deviation of the thicknesses in nm (>= 0, absolute).
    pairs:
        Number of lamella pairs N (>= 1). R_kin grows ~ N: thousands are needed
        for a strong flash because one interface reflects only r² ~ 5e-6.
    spread_deg:
        Angular spread (mosaic spread) of the lamella normals in degrees, the
        width of the schiller lobe. Not published; default 3°.
    body_albedo:
        Albedo of the grey diffuse body lobe, in [0, 1].
    n_surface:
        Bulk refractive index of the stone (surface Fresnel terms, refraction).
    name:
        Optional label (presets set it).
    """

    n_a: float = 1.555
    n_b: float = 1.562
    d_a: float = _DEFAULT_PERIOD_NM / 2
    d_b: float = _DEFAULT_PERIOD_NM / 2
    sigma_a: float = 16.0
    sigma_b: float = 16.0
    pairs: int = 6000
    spread_deg: float = 3.0
    body_albedo: float = 0.05
    n_surface: float = 1.56
    name: str | None = None

    PRESETS: ClassVar[dict[str, float]] = {
        "blue": 470.0,
        "green": 530.0,
        "gold": 580.0,
        "red": 630.0,
    }

    def __post_init__(self) -> None:
        for key in ("n_a", "n_b", "n_surface"):
            value = _check_number(key, getattr(self, key), 1.0, 4.0, low_open=True)
            object.__setattr__(self, key, value)
        for key in ("d_a", "d_b"):
            object.__setattr__(self, key, _check_number(f"{key} (thickness, nm)", getattr(self, key), 0.0, 1e5, low_open=True))
        for key in ("sigma_a", "sigma_b"):
            object.__setattr__(self, key, _check_number(f"{key} (nm)", getattr(self, key), 0.0, 1e5))
        pairs = _check_number("pairs", self.pairs, 1.0, 1e8)
        if pairs != int(pairs):
            raise ParameterError(f"pairs must be a whole number, got {self.pairs!r}")
        object.__setattr__(self, "pairs", int(pairs))
        object.__setattr__(self, "spread_deg", _check_number("spread_deg", self.spread_deg, 0.0, 45.0, low_open=True))
        object.__setattr__(self, "body_albedo", _check_number("body_albedo", self.body_albedo, 0.0, 1.0))
        if self.name is not None and not isinstance(self.name, str):
            raise ParameterError(f"material name must be text, got {self.name!r}")

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_peak_wavelength(cls, nm: float, **params: Any) -> Labradorite:
        """Material whose first-order flash peaks at ``nm`` at normal incidence.

        Equal phase thicknesses; the period is first set by Bragg's law
        ``λ = 2 (n_a d_a + n_b d_b)`` and then refined so that the peak of the full
        reflectance (which the λ-dependence of the damping moves 1-2.5 nm above
        the Bragg estimate at σ = 16 nm) is at ``nm`` to 0.01 nm. Other
        parameters as in the constructor.
        
        Examples
        --------
        >>> import labcut
        >>> round(labcut.Labradorite.from_peak_wavelength(470.0).peak_wavelength(), 1)
        470.0
        """
        target = _check_number("peak wavelength (nm)", nm, 250.0, 2500.0)
        base = cls(**params)
        period = target / (base.n_a + base.n_b)  # λ = 2 (n_a + n_b) d with d = period / 2
        lab = base
        for _ in range(6):
            lab = dataclasses.replace(base, d_a=period / 2.0, d_b=period / 2.0)
            peak = lab.peak_wavelength(1.0)
            if abs(peak - target) < 0.01:
                break
            period *= target / peak
        return lab

    @classmethod
    def from_anorthite(cls, an_percent: float, **params: Any) -> Labradorite:
        """Material for a bulk anorthite content ``an_percent`` (mol % An).

        Documented mapping (docs/physics.md): more An, thicker lamellae, redder
        flash (Bolton et al. 1966; Miura 1978; paper Fig. 3 and 7). The lamella
        period grows linearly from 128 nm at An44 to 252 nm at An61, the ends of
        the Bøggild range quoted by the paper and of the period range that gives
        visible schiller (Miura 1978); the two phases get equal thickness. Outside
        44-61 % An labradorite shows no schiller: a :class:`ParameterError`.
        
        Examples
        --------
        >>> import labcut
        >>> round(labcut.Labradorite.from_anorthite(52).peak_wavelength(), 1)
        582.1
        """
        an = _check_number("anorthite content (An %)", an_percent, -math.inf)
        lo, hi = AN_RANGE
        if not lo <= an <= hi:
            raise ParameterError(
                f"anorthite content must lie in the Bøggild range An{lo:g}-An{hi:g} "
                f"where labradorite shows schiller, got An{an:g}"
            )
        t = (an - lo) / (hi - lo)
        period = PERIOD_RANGE_NM[0] + t * (PERIOD_RANGE_NM[1] - PERIOD_RANGE_NM[0])
        params.setdefault("name", f"An{an:g}")
        return cls(d_a=period / 2.0, d_b=period / 2.0, **params)

    @classmethod
    def preset(cls, name: str, **params: Any) -> Labradorite:
        """A named preset: ``blue`` (470 nm), ``green`` (530), ``gold`` (580), ``red`` (630)."""
        key = str(name).strip().lower()
        if key not in cls.PRESETS:
            raise ParameterError(f"unknown material preset {name!r}; choose one of {', '.join(cls.PRESETS)}")
        params.setdefault("name", key)
        return cls.from_peak_wavelength(cls.PRESETS[key], **params)

    @classmethod
    def coerce(cls, material: Any) -> Labradorite:
        """A material argument as the API takes it: ``None`` (the default blue-green labradorite),
        a preset name, or a :class:`Labradorite` (returned as is)."""
        if material is None:
            return cls()
        if isinstance(material, str):
            return cls.preset(material)
        if not isinstance(material, cls):
            raise ParameterError(f"material must be a labcut.Labradorite or a preset name, got {type(material).__name__}")
        return material

    def replace(self, **changes: Any) -> Labradorite:
        """A copy with some parameters changed (validated again)."""
        return dataclasses.replace(self, **changes)

    # ------------------------------------------------------------------ physics
    @property
    def stack(self) -> lamella.Stack:
        """The stack's optical parameters as one value (:class:`labcut.physics.lamella.Stack`)."""
        return lamella.Stack(self.n_a, self.n_b, self.d_a, self.d_b, self.sigma_a, self.sigma_b, self.pairs, self.n_surface)

    @property
    def lobe_kappa(self) -> float:
        """Concentration κ = 1/spread² (radians) of the axial von Mises-Fisher lobe of lamella
        orientations; for large κ a 2D Gaussian of standard deviation ``spread_deg`` per axis."""
        s = math.radians(self.spread_deg)
        return 1.0 / (s * s)

    @property
    def lobe_norm(self) -> float:
        """Density of the lobe at its centre, q(1) = κ / (2π (1 - e^{-κ})) per steradian
        (normalised over the hemisphere of orientations)."""
        k = self.lobe_kappa
        return k / (2.0 * math.pi * -math.expm1(-k))

    @property
    def period_nm(self) -> float:
        """Lamella period d_a + d_b in nm."""
        return self.d_a + self.d_b

    def bragg_wavelength(self, cos_theta: float = 1.0, order: int = 1) -> float:
        """Bragg estimate ``2 cos θ (n_a d_a + n_b d_b) / order`` of a peak, nm."""
        return float(
            lamella.bragg_wavelength(cos_theta, self.n_a, self.n_b, self.d_a, self.d_b, order)
        )

    def intensity(self, wavelength_nm: Any, cos_theta: Any) -> Any:
        """Intensity per pair ``I`` of :func:`labcut.physics.lamella_intensity`, finite stack, Snell
        in each phase (``cos_theta`` measured in the bulk stone, index ``n_surface``)."""
        wl, c = self._coerce(wavelength_nm, cos_theta)
        return lamella.lamella_intensity(
            wl, c, self.n_a, self.n_b, self.d_a, self.d_b, self.sigma_a, self.sigma_b,
            pairs=self.pairs, n_surface=self.n_surface,
        )

    def reflectance(self, wavelength_nm: Any, cos_theta: Any, polarization: str | None = None) -> Any:
        """Stack reflectance R in [0, 1] at vacuum wavelength (nm) and ``cos_theta``.

        ``cos_theta`` is the cosine of the angle between the ray in the bulk stone (index
        ``n_surface``) and the lamella normal (axial: its sign does not matter).
        ``polarization``: ``None`` (unpolarised, the mean of s and p), ``'s'`` or ``'p'``
        (electric field perpendicular to / in the plane of incidence on the lamellae).
        numpy inputs broadcast and give float64 arrays (validated: wavelength > 0,
        |cos_theta| <= 1, no NaN); Dr.Jit inputs (inside Mitsuba kernels) give
        Dr.Jit arrays through the same expression, unvalidated.

        Examples
        --------
        >>> import numpy as np, labcut
        >>> lab = labcut.Labradorite.from_peak_wavelength(470.0)
        >>> np.round(lab.reflectance([450, 470, 500], 1.0), 3)
        array([0.293, 0.365, 0.235])
        >>> round(float(lab.reflectance(470, 0.85, "s")), 3), round(float(lab.reflectance(470, 0.85, "p")), 3)
        (0.128, 0.028)
        """
        if polarization not in (None, "s", "p"):
            raise ParameterError(f"polarization must be None (unpolarised), 's' or 'p', got {polarization!r}")
        wl, c = self._coerce(wavelength_nm, cos_theta)
        return lamella.stack_reflectance(wl, c, self.stack, polarization)

    def reflectance_sp(self, wavelength_nm: Any, cos_theta: Any) -> tuple[Any, Any, Any]:
        """``(R_s, R_p, sign of r_s r_p)`` in one evaluation (:func:`labcut.physics.lamella.stack_reflectance_sp`)."""
        wl, c = self._coerce(wavelength_nm, cos_theta)
        return lamella.stack_reflectance_sp(wl, c, self.stack)

    def peak_wavelength(self, cos_theta: float = 1.0) -> float:
        """Wavelength (nm) of the first-order reflectance peak at ``cos_theta``.

        Searched in [0.7, 1.45] x the Bragg estimate on a 0.5 nm grid, then refined
        by golden-section search to 1e-4 nm. Returns NaN when the spectrum has no
        first-order maximum in that window (a grey stone: very large sigma).
        """
        c = float(np.abs(self._coerce(1.0, cos_theta)[1]))
        if c < 1e-6:
            raise ParameterError("cos_theta must be > 0: at grazing incidence there is no peak")
        centre = self.bragg_wavelength(c)
        grid = np.arange(0.7 * centre, 1.45 * centre, 0.5)
        i = int(np.argmax(self.intensity(grid, c)))
        if i == 0 or i == grid.size - 1:
            return math.nan
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
        # R is monotone in I: same peak, and no saturation plateau to confuse the search
        return float(golden_section_max(lambda x: float(self.intensity(x, c)), lo, hi, 1e-4))

    def peak_reflectance(self, cos_theta: float = 1.0) -> float:
        """Reflectance at the first-order peak, at ``cos_theta`` (NaN when there is none)."""
        peak = self.peak_wavelength(cos_theta)
        return math.nan if math.isnan(peak) else float(self.reflectance(peak, cos_theta))

    # ------------------------------------------------------------------ colour
    def flash_colour(self, cos_theta: float = 1.0, illuminant: str = "D65") -> Any:
        """Colour of the flash at ``cos_theta``: a :class:`labcut.colour.FlashColour`."""
        from ..colour import flash_colour

        return flash_colour(self, cos_theta, illuminant=illuminant)

    def srgb(self, cos_theta: float = 1.0) -> tuple[float, float, float]:
        """Display sRGB (gamma-encoded, in [0, 1], brightest channel 1) of the flash hue."""
        return self.flash_colour(cos_theta).srgb

    def dominant_wavelength(self, cos_theta: float = 1.0) -> float:
        """CIE dominant wavelength (nm) of the flash; negative = complementary (purples)."""
        return self.flash_colour(cos_theta).dominant_wavelength_nm

    # ------------------------------------------------------------------ I/O
    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON description (every parameter; units nm / degrees)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Labradorite:
        """Inverse of :meth:`to_dict`; unknown keys are an error."""
        fields = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - fields)
        if unknown:
            raise ParameterError(f"unknown material parameter(s): {', '.join(unknown)}")
        return cls(**data)

    # ------------------------------------------------------------------ helpers
    @staticmethod
    def _coerce(wavelength_nm: Any, cos_theta: Any) -> tuple[Any, Any]:
        if is_drjit(wavelength_nm) or is_drjit(cos_theta):
            return wavelength_nm, cos_theta
        try:
            wl = np.asarray(wavelength_nm, dtype=np.float64)
            c = np.asarray(cos_theta, dtype=np.float64)
        except (TypeError, ValueError):
            raise ParameterError("wavelength and cos_theta must be numbers or numeric arrays") from None
        if not np.all(np.isfinite(wl)) or not np.all(np.isfinite(c)):
            raise ParameterError("wavelength and cos_theta must be finite (no NaN or inf)")
        if np.any(wl <= 0.0):
            raise ParameterError(f"wavelength must be > 0 nm, got {float(np.min(wl)):g}")
        if np.any(np.abs(c) > 1.0):
            raise ParameterError(f"cos_theta must lie in [-1, 1], got {float(np.max(np.abs(c))):g}")
        return wl, c
