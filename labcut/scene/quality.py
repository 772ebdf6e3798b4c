"""One :class:`Quality`: every knob that trades accuracy for time, in one frozen object.

Three named presets, ``draft``, ``standard`` (the default) and ``high``, hold every count and
step that used to live in per-module tables: surface samples of the flash problem, directions
per lamp, per environment map and per viewing cone or ring, poses of a rocking motion, the
spacing of the hemisphere score map, the optimisers' budgets, and the comparison report's
curves and renders. :meth:`Quality.coerce` turns a name (or a Quality) into a validated
Quality once, at the API's edge; everything below reads its fields.

A custom setting is a preset with fields changed::

    >>> from labcut.scene.quality import Quality
    >>> q = Quality.coerce("standard").replace(surface_points=20000)
    >>> q.name, q.surface_points, q.map_spacing_deg
    ('custom', 20000, 3.0)

``docs/accuracy.md`` measures what each knob costs in time and gives in accuracy.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields
from typing import Any, ClassVar

from ..errors import ParameterError
from ..geometry.surface import SAMPLINGS

#: the preset names, cheapest first
QUALITIES = ("draft", "standard", "high")


@dataclass(frozen=True)
class Quality:
    """Every accuracy-for-time knob of labcut (counts are whole numbers, angles in degrees).

    Flash problem and scenarios (:mod:`labcut.orientation.problem`, :mod:`labcut.scene`):

    * ``surface_points``: area-uniform samples of the stone's surface; ``surface_sampling`` how they
      are placed: ``"stratified"`` (one in each of as many equal-area patches along a space-filling
      curve: a flash's share of them is nearly exact) or ``"random"`` (independent draws);
    * ``lamp_samples``: directions per lamp of finite size (a disc of light);
    * ``env_samples``: directions per environment map (importance-sampled);
    * ``cone_views``: viewing directions per viewing cone (``face-up``, ``eye-level``; twice
      as many for ``front``); ``ring_views``: directions of the ``above`` ring;
    * ``rock_steps``: poses of a rocking motion, (front-to-back, side-to-side), the rest pose
      not counted.

    Optimisation (:mod:`labcut.orientation`):

    * ``map_spacing_deg``: spacing of the hemisphere score map (global check, runners-up);
    * ``grid_coarse_deg``: coarse spacing of the exhaustive ``grid`` optimiser;
    * ``nlopt_evals``: DIRECT-L evaluations of the ``nlopt`` optimiser (few: its L-BFGS polish also
      starts from a coarse energy map's best cells, and the accuracy study finds 60 as good as 400);
    * ``gradient_starts``: starts of the ``gradient`` optimiser.

    Comparison reports (:mod:`labcut.reports`):

    * ``tilt_step_deg``, ``tilt_points``: the tilt-performance curve's step and surface samples;
    * ``miss_step_deg``: the misorientation curve's step;
    * ``render_resolution`` (pixels, square), ``render_spp`` (samples per pixel) and
      ``strip_angles_deg`` (the rocking strip's tilts) of a report's renders.

    The render estimator (:mod:`labcut.orientation.render_estimator`):

    * ``estimator_resolution`` (pixels, square, orthographic: the stone's bounding sphere fills
      it) and ``estimator_spp`` (samples per pixel) of its differentiable renders;
    * ``estimator_iterations``: its L-BFGS evaluations;
    * ``estimator_coarse_deg``: the spacing of the coarse map of renders that picks its start
      when none is given.

    Rough planning (:mod:`labcut.rough`):

    * ``rough_directions``: face-up axes tried for a cut inside a rough (spread over the sphere);
    * ``rough_spins``: turns of the cut about its face-up axis tried with each;
    * ``rough_refine``: steps of the local search that polishes the best poses.

    These seven and ``surface_sampling`` have the ``standard`` preset's values as defaults, so a Quality written out by
    hand before they existed still builds.
    """

    name: str
    surface_points: int
    lamp_samples: int
    env_samples: int
    cone_views: int
    ring_views: int
    rock_steps: tuple[int, int]
    map_spacing_deg: float
    grid_coarse_deg: float
    nlopt_evals: int
    gradient_starts: int
    tilt_step_deg: float
    tilt_points: int
    miss_step_deg: float
    render_resolution: int
    render_spp: int
    strip_angles_deg: tuple[float, ...]
    estimator_resolution: int = 96
    estimator_spp: int = 8
    estimator_iterations: int = 25
    estimator_coarse_deg: float = 15.0
    rough_directions: int = 240
    rough_spins: int = 12
    rough_refine: int = 40
    surface_sampling: str = "stratified"

    PRESETS: ClassVar[dict[str, Quality]]

    #: (field, low, high) of the whole-number fields
    _COUNTS: ClassVar[tuple[tuple[str, int, int], ...]] = (
        ("surface_points", 16, 10_000_000), ("lamp_samples", 1, 100_000), ("env_samples", 1, 100_000),
        ("cone_views", 1, 100_000), ("ring_views", 1, 100_000), ("nlopt_evals", 4, 1_000_000),
        ("gradient_starts", 1, 10_000), ("tilt_points", 16, 10_000_000), ("render_resolution", 8, 8192),
        ("render_spp", 1, 1 << 20), ("estimator_resolution", 8, 4096), ("estimator_spp", 1, 1 << 16),
        ("estimator_iterations", 1, 10_000), ("rough_directions", 8, 100_000), ("rough_spins", 1, 360),
        ("rough_refine", 0, 10_000),
    )
    #: (field, low (open), high) of the angle fields, degrees
    _ANGLES: ClassVar[tuple[tuple[str, float, float], ...]] = (
        ("map_spacing_deg", 0.05, 30.0), ("grid_coarse_deg", 0.05, 30.0), ("tilt_step_deg", 0.05, 30.0),
        ("miss_step_deg", 0.01, 15.0), ("estimator_coarse_deg", 1.0, 45.0),
    )

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ParameterError(f"quality name must be a non-empty string, got {self.name!r}", parameter="quality")
        for key, low, high in self._COUNTS:
            object.__setattr__(self, key, _whole(getattr(self, key), f"quality {key}", low, high))
        for key, low, high in self._ANGLES:
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or not low < value <= high:
                raise ParameterError(f"quality {key} must be a number of degrees in ({low:g}, {high:g}], got {value!r}", parameter="quality")
            object.__setattr__(self, key, float(value))
        try:
            steps = tuple(self.rock_steps)
        except TypeError:
            raise ParameterError(f"quality rock_steps must be two whole numbers, got {self.rock_steps!r}", parameter="quality") from None
        if len(steps) != 2:
            raise ParameterError(f"quality rock_steps must be two whole numbers, got {self.rock_steps!r}", parameter="quality")
        object.__setattr__(self, "rock_steps", tuple(_whole(s, "quality rock_steps", 1, 1000) for s in steps))
        try:
            strip = tuple(float(a) for a in self.strip_angles_deg)
        except (TypeError, ValueError):
            raise ParameterError(f"quality strip_angles_deg must be numbers of degrees, got {self.strip_angles_deg!r}", parameter="quality") from None
        if not strip or not all(math.isfinite(a) and abs(a) <= 60.0 for a in strip):
            raise ParameterError(f"quality strip_angles_deg must be 1 or more angles within ±60°, got {self.strip_angles_deg!r}", parameter="quality")
        object.__setattr__(self, "strip_angles_deg", strip)
        if self.surface_sampling not in SAMPLINGS:
            raise ParameterError(f"quality surface_sampling must be one of {', '.join(SAMPLINGS)}, got "
                                 f"{self.surface_sampling!r}", parameter="quality")

    # ------------------------------------------------------------------ construction
    @classmethod
    def coerce(cls, value: Quality | str | dict[str, Any]) -> Quality:
        """A :class:`Quality` from a preset name (``draft``, ``standard``, ``high``), a Quality
        (returned as it is) or a dict of :meth:`to_dict` (a preset's fields with some changed).

        Raises :class:`~labcut.errors.ParameterError` naming the choices otherwise."""
        if isinstance(value, Quality):
            return value
        if isinstance(value, str):
            key = value.strip().lower()
            if key in cls.PRESETS:
                return cls.PRESETS[key]
            raise ParameterError(f"quality must be one of {', '.join(QUALITIES)}, got {value!r}", parameter="quality")
        if isinstance(value, dict):
            base = cls.PRESETS.get(str(value.get("name", "")), cls.PRESETS["standard"])
            unknown = sorted(set(value) - {f.name for f in fields(cls)})
            if unknown:
                raise ParameterError(f"quality: unknown field(s) {', '.join(unknown)}", parameter="quality")
            return dataclasses.replace(base, **value)
        raise ParameterError(f"quality must be one of {', '.join(QUALITIES)} or a labcut Quality, got {value!r}", parameter="quality")

    def replace(self, **changes: Any) -> Quality:
        """This quality with some fields changed (validated); named ``custom`` unless ``name`` is given."""
        changes.setdefault("name", "custom")
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON of every field (tuples as lists)."""
        return {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v) for f in fields(self)}

    def __str__(self) -> str:
        return self.name


def _whole(value: Any, what: str, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value != int(value):
        raise ParameterError(f"{what} must be a whole number, got {value!r}")
    if not low <= int(value) <= high:
        raise ParameterError(f"{what} must lie in [{low}, {high}], got {int(value)}")
    return int(value)


Quality.PRESETS = {
    "draft": Quality(
        "draft", surface_points=3000, lamp_samples=7, env_samples=32, cone_views=7, ring_views=12, rock_steps=(5, 2),
        map_spacing_deg=4.0, grid_coarse_deg=2.0, nlopt_evals=40, gradient_starts=8,
        tilt_step_deg=10.0, tilt_points=1000, miss_step_deg=1.0,
        render_resolution=96, render_spp=8, strip_angles_deg=(-20.0, 0.0, 20.0),
        estimator_resolution=48, estimator_spp=4, estimator_iterations=15, estimator_coarse_deg=20.0,
        rough_directions=96, rough_spins=8, rough_refine=16),
    "standard": Quality(
        "standard", surface_points=8000, lamp_samples=13, env_samples=64, cone_views=13, ring_views=20, rock_steps=(9, 4),
        map_spacing_deg=3.0, grid_coarse_deg=1.5, nlopt_evals=60, gradient_starts=12,
        tilt_step_deg=7.5, tilt_points=2000, miss_step_deg=0.5,
        render_resolution=128, render_spp=32, strip_angles_deg=(-20.0, -10.0, 0.0, 10.0, 20.0),
        estimator_resolution=96, estimator_spp=8, estimator_iterations=25, estimator_coarse_deg=15.0,
        rough_directions=240, rough_spins=12, rough_refine=40),
    "high": Quality(
        "high", surface_points=24000, lamp_samples=25, env_samples=128, cone_views=25, ring_views=40, rock_steps=(17, 6),
        map_spacing_deg=1.5, grid_coarse_deg=1.0, nlopt_evals=120, gradient_starts=20,
        tilt_step_deg=5.0, tilt_points=5000, miss_step_deg=0.25,
        render_resolution=256, render_spp=128, strip_angles_deg=(-24.0, -16.0, -8.0, 0.0, 8.0, 16.0, 24.0),
        estimator_resolution=160, estimator_spp=16, estimator_iterations=40, estimator_coarse_deg=10.0,
        rough_directions=600, rough_spins=24, rough_refine=80),
}
