"""One frozen, validated description of a flash question: :class:`FlashQuestion`.

Everything but the stone that decides an answer of :func:`labcut.recommend_orientation` or
:func:`labcut.evaluate_orientation`: the material, the scenario (lights, viewers, poses), the
:class:`~labcut.Quality`, the objective, the flash threshold ``tau`` (units of ``L_ref``), the
sampling seed, where the normal may go (:class:`~labcut.orientation.optimize.Constraint`: max
tilt in degrees from +Z, optional horizontal tilt axis, mesh frame), the estimator, the effect
overrides and colour zoning. :meth:`FlashQuestion.build` is the one place these are checked; the
CLI builds a setup once, before any work, and hands it to the library, which does not check
again; :meth:`FlashQuestion.to_dict` is what a recommendation's ``settings`` record.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from ..errors import ParameterError
from ..physics.material import Labradorite
from ..scene import Scenario, resolve_scene
from ..scene.effects import ESTIMATORS, check_effects
from ..scene.quality import Quality
from ..validation import check_number
from .kernels import DEFAULT_KERNELS, KernelOptions
from .optimize import Constraint
from .problem import build_problem
from .scoring import OBJECTIVES, Scorer
from .volume import build_volume_problem



@dataclass(frozen=True)
class FlashQuestion:
    """A validated flash question (module docstring); build it with :meth:`build`."""

    material: Labradorite
    scenario: Scenario
    quality: Quality
    objective: str = "energy"
    tau: float = 0.1
    seed: int = 0
    constraint: Constraint = field(default_factory=Constraint)
    estimator: str = "auto"
    #: the effect planner's overrides, ``((name, on), ...)`` (:data:`labcut.scene.effects.SWITCHABLE`)
    effects: tuple[tuple[str, bool], ...] = ()
    #: colour zones (a :class:`~labcut.rendering.zoning.Zoning`), or None for a uniform material
    zoning: Any = None
    #: the ``(scenario, lighting, viewing)`` as asked (names, files or objects), so that the same
    #: scene can be sampled at another quality (:meth:`at_quality`: the error bars' coarse problem)
    scene_spec: tuple[Any, Any, Any] = field(default=(None, None, None), compare=False, repr=False)
    #: which steps of the sample estimator run as Dr.Jit kernels (how an answer is computed, not what
    #: is asked: not part of :meth:`to_dict`; every choice gives the same answer to float32 rounding)
    kernels: KernelOptions = field(default=DEFAULT_KERNELS, compare=False, repr=False)

    @classmethod
    def build(
        cls,
        material: Labradorite | str | None = None,
        scenario: str | Scenario | None = None,
        lighting: Any = None,
        viewing: Any = None,
        *,
        objective: str = "energy",
        quality: Quality | str = "standard",
        tau: float = 0.1,
        seed: int = 0,
        max_tilt: float = 90.0,
        tilt_axis: Any = None,
        estimator: str = "auto",
        effects: Mapping[str, Any] | None = None,
        zoning: Any = None,
    ) -> FlashQuestion:
        """Check every argument once and return the setup; arguments as
        :func:`labcut.recommend_orientation`. Raises a one-line
        :class:`~labcut.errors.ParameterError` naming the first bad one.

        Examples
        --------
        >>> from labcut.orientation.question import FlashQuestion
        >>> s = FlashQuestion.build("blue", "pendant", quality="draft", max_tilt=30)
        >>> s.scenario.name, s.quality.name, s.constraint.max_tilt_deg, s.to_dict()["tau"]
        ('pendant', 'draft', 30.0, 0.1)
        >>> FlashQuestion.build(objective="sparkle")
        Traceback (most recent call last):
        ...
        labcut.errors.ParameterError: objective must be one of energy, area, intensity, balanced, got 'sparkle'
        """

        if objective not in OBJECTIVES:
            raise ParameterError(f"objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}", parameter="objective")
        if estimator not in ESTIMATORS:
            raise ParameterError(f"estimator must be one of {', '.join(ESTIMATORS)}, got {estimator!r}")
        quality = Quality.coerce(quality)
        tau_v = check_number(tau, "flash threshold tau", 0.0, 10.0, low_open=True)
        if not tau_v < 10.0:
            raise ParameterError(f"flash threshold tau must lie in (0, 10), got {tau!r}")
        seed_v = check_number(seed, "seed", 0, 2**63 - 1, integer=True)
        material = Labradorite.coerce(material)
        scene = resolve_scene(scenario, lighting, viewing, quality)
        constraint = Constraint(float(max_tilt) if isinstance(max_tilt, int | float) and not isinstance(max_tilt, bool)
                                else max_tilt, tilt_axis)
        switches = check_effects(effects)
        zone = None
        if zoning is not None:
            from ..rendering.zoning import resolve as resolve_zoning

            zone = resolve_zoning(zoning, material)
        return cls(material, scene, quality, objective, float(tau_v), int(seed_v), constraint, estimator,
                   tuple(sorted(switches.items())), zone, (scenario, lighting, viewing))

    def at_quality(self, quality: Quality | str) -> FlashQuestion:
        """The same question sampled at another :class:`~labcut.Quality` (the scene's lamp, map
        and viewing-cone directions and rocking poses re-drawn from :attr:`scene_spec`; a
        :class:`~labcut.Scenario` given as an object keeps its own directions)."""
        q = Quality.coerce(quality)
        return replace(self, quality=q, scenario=resolve_scene(*self.scene_spec, q), scene_spec=self.scene_spec)

    def with_scenario(self, scenario: Scenario) -> FlashQuestion:
        """The same question under another :class:`~labcut.Scenario` (a variant of this one,
        :mod:`labcut.scene.variants`), kept as the object it is at every quality."""
        return replace(self, scenario=scenario, scene_spec=(scenario, None, None))

    def scorer(self, mesh: Any, *, occlusion: bool, volume: bool = False, env_samples: int | None = None) -> Scorer:
        """The sample estimator's scorer of this question about ``mesh`` (a checked trimesh): its
        flash problem over every pose of the scenario, with occlusion rays or not (the effect
        planner's choice), the question's kernel options; with ``volume``, the light carried
        through the stone (:func:`~labcut.orientation.volume.build_volume_problem`, the volume
        estimator's problem) instead of mirrored where it entered; with ``env_samples``, the
        scenario's environment map seen through that many directions
        (:meth:`~labcut.Scenario.with_env_samples`, the planner's choice past a carving's parts)."""
        settings = self.scenario.with_env_samples(env_samples).settings()
        if volume:
            problem = build_volume_problem(mesh, self.material, quality=self.quality, tau=self.tau, seed=self.seed,
                                           settings=settings, occlusion=occlusion, kernels=self.kernels)
        else:
            problem = build_problem(mesh, self.material, quality=self.quality, tau=self.tau, seed=self.seed,
                                    settings=settings, occlusion=occlusion, kernels=self.kernels)
        return Scorer(problem, self.objective)

    @property
    def effect_overrides(self) -> dict[str, bool]:
        return dict(self.effects)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON: what a recommendation's ``settings`` record of its question."""
        return {
            "material": self.material.to_dict(), "scenario": self.scenario.to_dict(),
            "lighting": self.scenario.lights.name, "viewing": self.scenario.views.name,
            "quality": self.quality.name, "quality_settings": self.quality.to_dict(),
            "objective": self.objective, "max_tilt_deg": self.constraint.max_tilt_deg,
            "tilt_axis": self.constraint.tilt_axis, "tau": self.tau, "seed": self.seed,
            "estimator_asked": self.estimator, "effects": self.effect_overrides,
            "zoning": None if self.zoning is None else (self.zoning.name or "custom"),
        }

    def __repr__(self) -> str:
        tilt = "" if math.isclose(self.constraint.max_tilt_deg, 90.0) else f", max_tilt={self.constraint.max_tilt_deg:g}°"
        return (f"FlashQuestion({self.material.name!r}, scenario={self.scenario.name!r}, quality={self.quality.name!r}, "
                f"objective={self.objective!r}, tau={self.tau:g}, seed={self.seed}{tilt}, estimator={self.estimator!r})")
