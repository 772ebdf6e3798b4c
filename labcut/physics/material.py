"""The :class:`Labradorite` material: lamella-stack parameters, presets, validation.

Lengths in nm, angles in degrees, refractive indices unitless. ``cos_theta`` is
always the cosine of the angle between a ray inside the stone (index
``n_surface``) and the lamella normal.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import warnings
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import LabcutWarning, ParameterError
from ..validation import check_number
from . import depth, lamella
from .search import golden_section_max
from .ops import is_drjit

#: Bøggild range of bulk anorthite content (mol % An) over which labradorite
#: shows schiller, as quoted by Weidlich & Wilkie 2009 §3 (after Miura 1978).
AN_RANGE = (44.0, 61.0)
#: Lamella period d_a + d_b (nm) at the two ends of AN_RANGE: the span that puts
#: the first-order normal-incidence peak across the visible (Miura 1978, J. Gemmol.
#: Soc. Japan 5:3: visible schiller needs a period of ~128-252 nm).
PERIOD_RANGE_NM = (128.0, 252.0)

#: Wavelengths (nm) a person sees: the range of the CIE 1931 observer's tables (CIE 15). A material
#: whose first-order flash peaks outside it face-on gets a :class:`~labcut.errors.LabcutWarning`
#: (:meth:`Labradorite.visibility_note`); it is still a valid material.
VISIBLE_RANGE_NM = (380.0, 780.0)

_DEFAULT_PERIOD_NM = 155.0  # blue-green flash near 483 nm at normal incidence
#: the lamella stacks whose :meth:`Labradorite.visibility_note` this process has issued as a
#: warning. Each is issued once, as Python's "once" action would (front ends that record
#: warnings turn every one on): labcut re-creates materials from their parameters (the
#: renderer's plugin does), and that must not repeat the warning
_NOTED_STACKS: set[lamella.Stack] = set()
#: face-on Bragg estimates (nm) between which the true peak (1-2.5 nm above the estimate at
#: sigma 16 nm, more at larger sigma) is surely visible, so that no peak search is needed
_SURELY_VISIBLE_BRAGG_NM = (420.0, 740.0)
#: face-on Bragg estimates (nm) outside which the estimate itself is quoted (the peak search's
#: 0.5 nm grid would be long, or shorter than one step)
_PEAK_SEARCH_BRAGG_NM = (100.0, 5000.0)


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
        self._validate()
        note = self.visibility_note()
        if note is not None and self.stack not in _NOTED_STACKS:
            _NOTED_STACKS.add(self.stack)
            warnings.warn(note, LabcutWarning, stacklevel=_maker_stacklevel(sys._getframe()))

    def _validate(self) -> None:
        """Check and normalise every parameter; a bad one is a :class:`ParameterError`."""
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
        period = _fit_period(base.stack, target)
        return dataclasses.replace(base, d_a=period / 2.0, d_b=period / 2.0)

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
    def stack_depth_mm(self) -> float:
        """Depth of the whole stack, ``pairs x (d_a + d_b)``, mm (the presets: 0.93 mm)."""
        return depth.stack_depth_mm(self)

    @property
    def flash_depth_mm(self) -> float:
        """The flash depth: the mean depth (mm, along the lamella normal, from where the light
        entered the stack) at which the flash is mirrored, at normal incidence, luminance-weighted
        (:func:`labcut.physics.depth.depth_law`: the stack's own reflectance cut at each depth). A
        part of the stone thinner than this holds less than the stack that makes its flash; the
        effect planner weighs it against the stone's thickness and curvature."""
        return depth.depth_law(self).mean_mm(1.0)

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
        return _first_order_peak(self.stack, c)

    def visibility_note(self) -> str | None:
        """Why this material shows no first-order flash in the visible face-on, or None.

        The face-on (normal incidence) first-order peak is checked against
        :data:`VISIBLE_RANGE_NM`. Outside it the material is valid (a dark labradorite can
        schiller in the infrared) but a viewer does not see what the number suggests, so
        the answer is one sentence saying what they see instead: for an infrared peak,
        face-on at most a dim colour from the band's edge and weaker higher orders, and the
        first-order peak only at internal angles steep enough for Bragg's law
        (λ ∝ cos θ) to bring it below 780 nm; for an ultraviolet peak, no first-order
        peak in the visible at any angle, since tilting moves it shorter still. The peak
        is the true one (:meth:`peak_wavelength`), not the Bragg estimate, where that can
        matter (near the edges). Making such a material issues this note as a
        :class:`~labcut.errors.LabcutWarning`, once per process for each lamella stack (labcut
        re-creates materials from their parameters); front ends that must show or record it
        every time ask this method (the CLI's material options, the JSON of ``labcut spectrum``).

        Examples
        --------
        >>> import labcut
        >>> labcut.Labradorite.preset("blue").visibility_note() is None
        True
        """
        lo, hi = VISIBLE_RANGE_NM
        peak = self.bragg_wavelength(1.0)
        if _SURELY_VISIBLE_BRAGG_NM[0] <= peak <= _SURELY_VISIBLE_BRAGG_NM[1]:
            return None
        if _PEAK_SEARCH_BRAGG_NM[0] <= peak <= _PEAK_SEARCH_BRAGG_NM[1]:
            found = _first_order_peak(self.stack, 1.0)
            peak = peak if math.isnan(found) else found  # no first-order maximum: the Bragg estimate
        if lo <= peak <= hi:
            return None
        head = f"{self.name}: " if self.name else ""
        shown = f"{peak:.0f}" if round(peak) not in (lo, hi) else f"{peak:.1f}"  # never "780 nm lies outside 380-780"
        where = f"the face-on flash peak, {shown} nm, lies outside the visible range ({lo:g}-{hi:g} nm)"
        if peak < lo:
            return (f"{head}{where}, in the ultraviolet: this stone shows no first-order flash peak in the "
                    f"visible at any angle, since tilting moves the peak to still shorter wavelengths; at most the "
                    f"band's long-wavelength edge gives it a faint bluish tint")
        steep = math.degrees(math.acos(hi / peak))
        critical = math.degrees(math.asin(1.0 / self.n_surface))
        reach = (f" (more than the {critical:.0f}° that light reaches through a face parallel to the lamellae)"
                 if steep > critical else "")
        return (f"{head}{where}, in the infrared: face-on this stone shows at most a dim colour from the band's "
                f"short-wavelength edge and weaker higher orders; the first-order peak enters the visible only at "
                f"internal angles over {steep:.0f}° from the lamella normal{reach}, where Bragg's law moves it "
                f"below {hi:g} nm")

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
        """CIE dominant wavelength (nm) of the flash; negative for a purple: minus its complementary
        wavelength (:attr:`labcut.colour.FlashColour.hue`)."""
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


#: rounds of :func:`_fit_period`: rescaling by target / peak for the first, secant steps after
_RESCALE_ROUNDS, _FIT_ROUNDS = 6, 40
#: how close (nm) the fitted period's first-order peak lies to the peak asked for
PEAK_FIT_NM = 0.01


def _fit_period(stack: lamella.Stack, target: float) -> float:
    """The period (nm, equal phases) of ``stack`` whose face-on first-order peak lies within
    :data:`PEAK_FIT_NM` of ``target``, or a :class:`ParameterError` when there is none.

    Starts at the Bragg estimate and rescales the period by ``target / peak``: the peak lies a
    little above the estimate, by about the same fraction at nearby periods, so a few rounds
    suffice at the presets' sigma of 16 nm. A larger thickness spread moves the peak further
    above the estimate, and by a fraction that grows as the period shrinks: the rescaling then
    converges slowly (by a factor of about 0.37 a round at sigma 40 nm), so after
    ``_RESCALE_ROUNDS`` rounds the fit takes secant steps. A trial period that has no
    first-order maximum (the spread washes it out at short periods) is stepped back halfway to
    the last period that had one. The trials are bare stacks: a trial is no material and warns
    of nothing."""
    period = target / (stack.n_a + stack.n_b)  # λ = 2 (n_a + n_b) d with d = period / 2
    trials: list[tuple[float, float]] = []  # (period, peak - target) of each trial with a peak
    for k in range(_FIT_ROUNDS):
        peak = _first_order_peak(stack._replace(d_a=period / 2.0, d_b=period / 2.0), 1.0)
        if math.isnan(peak):
            if not trials:
                break
            period = 0.5 * (period + trials[-1][0])
            continue
        trials.append((period, peak - target))
        if abs(peak - target) < PEAK_FIT_NM:
            return period
        if k < _RESCALE_ROUNDS or len(trials) < 2 or trials[-1][1] == trials[-2][1]:
            period *= target / peak
        else:
            (p0, e0), (p1, e1) = trials[-2], trials[-1]
            period = p1 - e1 * (p1 - p0) / (e1 - e0)
            if not period > 0.0:
                period = p1 * target / peak
    raise ParameterError(
        f"no lamella period puts the first-order flash peak at {target:g} nm with thickness spreads of "
        f"sigma_a {stack.sigma_a:g} nm and sigma_b {stack.sigma_b:g} nm: the spread washes the peak out at the "
        f"periods that would place it there; ask for a longer peak wavelength or smaller spreads")


def _maker_stacklevel(frame: Any) -> int:
    """``stacklevel`` for a warning that ``frame`` (:meth:`Labradorite.__post_init__`'s) issues,
    naming the code which made the material: the first caller outside this module, ``dataclasses``
    (``replace``) and generated code (the dataclass ``__init__``). The frame is passed, not found
    by depth, so that a wrapper around either function (a profiler's, a mutation tool's) does not
    shift the count."""
    internal = (__file__, dataclasses.__file__)
    level = 1  # level 1: the frame that calls warnings.warn
    while frame.f_back is not None and (frame.f_code.co_filename in internal or frame.f_code.co_filename.startswith("<")):
        frame, level = frame.f_back, level + 1
    return level


def _first_order_peak(stack: lamella.Stack, c: float) -> float:
    """Wavelength (nm) of the first-order maximum of ``stack``'s intensity at ``cos θ = c`` (> 0).

    Searched in [0.7, 1.45] x the Bragg estimate on a 0.5 nm grid, then refined by
    golden-section search to 1e-4 nm; NaN when the window has no maximum. The search of
    :meth:`Labradorite.peak_wavelength`, on a bare stack so that
    :meth:`Labradorite.from_peak_wavelength` tries periods without making materials.
    """
    n_a, n_b, d_a, d_b, sigma_a, sigma_b, pairs, n_surface = stack

    def intensity(wavelength_nm: Any) -> Any:
        return lamella.lamella_intensity(np.asarray(wavelength_nm, dtype=np.float64), np.asarray(c, dtype=np.float64),
                                         n_a, n_b, d_a, d_b, sigma_a, sigma_b, pairs=pairs, n_surface=n_surface)

    centre = float(lamella.bragg_wavelength(c, n_a, n_b, d_a, d_b))
    grid = np.arange(0.7 * centre, 1.45 * centre, 0.5)
    if grid.size < 3:
        return math.nan
    i = int(np.argmax(intensity(grid)))
    if i == 0 or i == grid.size - 1:
        return math.nan
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    # R is monotone in I: same peak, and no saturation plateau to confuse the search
    return float(golden_section_max(lambda x: float(intensity(x)), lo, hi, 1e-4))
