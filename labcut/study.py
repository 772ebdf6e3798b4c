"""One flash question of one stone, asked and re-asked: :class:`Study`.

A Study is a stone (:class:`~labcut.Stone`) with a material, a scenario (how it is lit, worn and
seen), a quality and the rest of a flash question (:class:`~labcut.orientation.question.FlashQuestion`),
and everything answering it makes: the effect plan, the sample estimator's flash problem and its
scorer (with the binned energy map), the recommendation. Each is made at the first question that
needs it and kept; :meth:`Study.with_lights`, :meth:`~Study.with_material`,
:meth:`~Study.with_scenario` and :meth:`~Study.with_quality` return a new Study that shares
what the change leaves valid: always the stone and its derived geometry (surface samples per count
and seed, the smooth-shaded split, ray scenes), and the plan and flash problem where the change
does not touch them. A designer in a notebook moves the lamp or swaps the material and asks again
without rebuilding the rest.

:func:`labcut.recommend_orientation`, :func:`labcut.evaluate_orientation` and :func:`labcut.render`
answer the same questions in one call (the Study answers bit for bit as they do; tests hold it).

Frames and units: the mesh frame (mm, +Z face-up, the front at -Y), lamella normals axial (z >= 0),
tilt from +Z and azimuth from +X toward +Y in degrees (DESIGN.md §3).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from .backend import serial_blas
from .errors import ParameterError
from .geometry.stone import Stone
from .commands.budget import kind_of, mark_warm
from .orientation.kernels import DEFAULT_KERNELS, KernelOptions
from .orientation.optimize import hemisphere_grid, score_map
from .orientation.recommend import Recommendation, answer_recommendation, build_scorer, evaluation_metrics
from .orientation.scoring import FlashMetrics, Scorer
from .orientation.question import FlashQuestion
from .orientation.estimators import volume_problem
from .planner import plan_question, plan_surface_samples
from .scene.directions import lamella_normal
from .scene.scenario import SCENARIOS
from .scene.quality import Quality
from .validation import check_number


class Study:
    """A stone and a flash question about it, with what answering it has made (module docstring).

    ``stone``: a :class:`~labcut.Stone` or a trimesh (wrapped). The question's arguments are
    :func:`labcut.recommend_orientation`'s (``material``, ``scenario``, ``lighting``,
    ``viewing``, ``quality``, ``objective``, ``tau``, ``seed``, ``max_tilt``, ``tilt_axis``,
    ``estimator``, ``effects``, ``zoning``), checked once here; or ``question``, the question
    already built. ``plan``: the effect plan already made for this question (as a comparison
    makes them all first), used as it is. ``kernels``: which steps of the sample estimator run as Dr.Jit kernels
    (:class:`~labcut.orientation.kernels.KernelOptions`; how, not what: the answers agree to
    float32 rounding). ``pilot_seconds_max``: the most seconds the plan's pilot renders (light between
    a carving's parts, measured once per stone and scene) may take when they are not cached; over it
    they are not rendered and the plan leaves inter-reflection off, saying so (a live view's Study:
    0).

    ``builds`` counts what this Study and the Studies it was derived from made (``plan``,
    ``problem``, ``recommendation``): a re-ask that reuses something does not count it again.
    """

    def __init__(self, stone: Any, material: Any = None, scenario: Any = None, quality: Quality | str = "standard", *,
                 lighting: Any = None, viewing: Any = None, objective: str = "energy", tau: float = 0.1, seed: int = 0,
                 max_tilt: float = 90.0, tilt_axis: Any = None, estimator: str = "auto",
                 effects: Mapping[str, Any] | None = None, zoning: Any = None, question: FlashQuestion | None = None,
                 kernels: KernelOptions = DEFAULT_KERNELS, plan: Any = None, pilot_seconds_max: float | None = None) -> None:
        self.stone = Stone.of(stone, "stone").validate("stone")
        if question is None:
            question = FlashQuestion.build(material, scenario, lighting, viewing, objective=objective, quality=quality, tau=tau,
                                        seed=seed, max_tilt=max_tilt, tilt_axis=tilt_axis, estimator=estimator,
                                        effects=effects, zoning=zoning)
        elif not isinstance(question, FlashQuestion):
            raise ParameterError(f"question must be a labcut FlashQuestion (FlashQuestion.build(...)), got {type(question).__name__}")
        if not isinstance(kernels, KernelOptions):
            raise ParameterError(f"kernels must be a KernelOptions, got {type(kernels).__name__}")
        self.question = replace(question, kernels=kernels)
        self.builds: dict[str, int] = {"plan": 0, "problem": 0, "recommendation": 0}
        self._plan: Any = plan  # an effect plan made elsewhere for this very question (a comparison's), or None
        #: the most seconds the plan's pilot renders may take when not cached (None: no limit; 0: a live
        #: view's plan, which leaves inter-reflection unmeasured rather than wait for them)
        self.pilot_seconds_max = None if pilot_seconds_max is None else float(
            check_number(pilot_seconds_max, "pilot_seconds_max", 0.0, 86_400.0, unit="s"))
        self._scorer: Scorer | None = None
        self._surface: Scorer | None = None
        #: how :attr:`surface_scorer`'s problem was built (:func:`_build_key`), where it was built on its own
        self._surface_key: tuple[Any, ...] | None = None
        self._recommendations: dict[str, Recommendation] = {}

    # ------------------------------------------------------------------ the question
    @property
    def material(self) -> Any:
        return self.question.material

    @property
    def scenario(self) -> Any:
        return self.question.scenario

    @property
    def quality(self) -> Quality:
        return self.question.quality

    @property
    def kernels(self) -> KernelOptions:
        return self.question.kernels

    def __repr__(self) -> str:
        return (f"Study({self.stone!r}, scenario={self.scenario.name!r}, "
                f"quality={self.quality.name!r})")

    # ------------------------------------------------------------------ what answering makes, once
    def planned(self) -> Any:
        """The effect plan if :meth:`plan` has made it, else None (nothing is planned by asking)."""
        return self._plan

    def plan(self) -> Any:
        """The effect plan (:class:`labcut.planner.EffectPlan`): which effects are simulated and
        which estimator answers; made once."""
        if self._plan is None:
            with serial_blas():  # as recommend_orientation plans: the same numbers to the last bit
                self._plan = plan_question(self.stone.mesh, self.question, "recommend", pilot_seconds_max=self.pilot_seconds_max)
            self.builds["plan"] += 1
        return self._plan

    @property
    def scorer(self) -> Scorer:
        """The sample estimator's scorer of this question's flash problem, built as planned; made once."""
        if self._scorer is None:
            plan = self.plan()
            if self._surface is not None and self._surface_key == _build_key(plan):
                self._scorer = self._surface  # the live view's problem is the one the plan asks for
            else:
                with serial_blas():
                    self._scorer = build_scorer(self.stone.mesh, self.question, plan)
                self.builds["problem"] += 1
        return self._scorer

    @property
    def surface_scorer(self) -> Scorer:
        """The surface samples' scorer of this question (occlusion and the environment map's
        directions as the planner rules, the light mirrored where it enters), whatever estimator the
        plan chooses: what a live view answers from (the explorer). Where the plan is made and its
        estimator is the surface samples' (or the render estimator, whose scorer is theirs), the same
        object as :attr:`scorer`; where the plan is not made, it is not made for this either
        (:func:`labcut.planner.plan_surface_samples`: none of the material's decisions, which a moved
        lamp or a new material need not wait for), and a later :attr:`scorer` of the same problem is
        this one. Made once."""
        if self._surface is None:
            plan = self._plan
            if plan is not None and plan.estimator in (None, "samples", "render"):
                self._surface = self.scorer
            else:
                live = replace(plan, estimator="samples") if plan is not None else plan_surface_samples(self.stone.mesh, self.question)
                with serial_blas():
                    self._surface = build_scorer(self.stone.mesh, self.question, live)
                self._surface_key = _build_key(live)
                self.builds["problem"] += 1
        return self._surface

    # ------------------------------------------------------------------ questions
    def recommend(self, optimizer: str = "nlopt", progress: Callable[[str, float], None] | None = None) -> Recommendation:
        """The recommended lamella orientation (:func:`labcut.recommend_orientation`'s answer), found
        once per optimizer and kept."""
        hit = self._recommendations.get(optimizer)
        if hit is None:
            scorer, plan = self.scorer, self.plan()
            with serial_blas():
                hit = answer_recommendation(self.stone.mesh, self.question, scorer, plan, optimizer=optimizer,
                                            progress=progress)
            mark_warm(kind_of(hit.estimator, plan.on("occlusion")))  # as recommend_orientation
            self._recommendations[optimizer] = hit
            self.builds["recommendation"] += 1
        return hit

    def recommended(self, optimizer: str = "nlopt") -> Recommendation | None:
        """The recommendation :meth:`recommend` has made with ``optimizer``, or None when it has
        not been asked yet (nothing is computed here: a live view shows it only once made)."""
        return self._recommendations.get(optimizer)

    def evaluate(self, normal: Any = None, *, tilt: float | None = None, azimuth: float | None = None) -> FlashMetrics:
        """Flash metrics (DESIGN.md §4) of one lamella orientation: a ``normal`` (mesh frame, axial),
        or ``tilt`` (degrees from +Z) and ``azimuth`` (degrees from +X toward +Y). The answer of
        :func:`labcut.evaluate_orientation` for the same question."""
        m = lamella_normal(normal, tilt, azimuth)
        scorer, plan = self.scorer, self.plan()
        with serial_blas():
            return evaluation_metrics(self.stone.mesh, self.question, scorer, plan, m)

    def score_map(self, spacing_deg: float | None = None, *, surface: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """``(normals, scores)``: the objective over the allowed hemisphere, normals ``spacing_deg``
        apart (default: the quality's map spacing), from the sample estimator's scorer (:attr:`scorer`;
        with ``surface``, :attr:`surface_scorer`)."""
        spacing = self.quality.map_spacing_deg if spacing_deg is None else float(spacing_deg)
        if not (spacing > 0 and np.isfinite(spacing)):
            raise ParameterError(f"spacing_deg must be a positive number of degrees, got {spacing_deg!r}")
        normals = hemisphere_grid(spacing, self.question.constraint)
        scorer = self.surface_scorer if surface else self.scorer
        with serial_blas():
            return normals, score_map(scorer, normals)

    def render(self, normal: Any = None, *, tilt: float | None = None, azimuth: float | None = None, **kwargs: Any) -> Any:
        """A render (:func:`labcut.render`) of the stone under this Study's material and scenario at
        a lamella orientation: a ``normal`` or ``tilt``/``azimuth``, else the recommended one.
        ``kwargs``: the rest of :func:`labcut.render`'s request (``resolution``, ``spp``, ``view``,
        ``look``, ``output`` ...)."""
        from .commands.render import render

        if normal is None and tilt is None and azimuth is None:
            m = self.recommend().normal
        else:
            m = lamella_normal(normal, tilt, azimuth)
        for taken in ("material", "scenario", "lighting", "viewing", "setup", "lamella_normal"):
            if taken in kwargs:
                raise ParameterError(f"Study.render takes its {taken} from the Study (with_... makes another)")
        return render(self.stone, self.material, m, scenario=self.scenario, zoning=self.question.zoning, **kwargs)

    # ------------------------------------------------------------------ re-asking
    def _derived(self, question: FlashQuestion, *, keep_plan: bool = False, keep_problem: bool = False) -> Study:
        other = Study.__new__(Study)
        other.stone = self.stone
        other.question = question
        other.builds = self.builds  # one count for a Study and all derived from it
        other.pilot_seconds_max = self.pilot_seconds_max
        other._plan = self._plan if keep_plan else None
        other._scorer = self._scorer if keep_problem else None
        other._surface = None
        other._surface_key = None
        other._recommendations = {}
        return other

    def with_material(self, material: Any) -> Study:
        """The same question of another material (a :class:`~labcut.Labradorite` or a preset name)."""
        from .physics.material import Labradorite

        return self._derived(replace(self.question, material=Labradorite.coerce(material)))

    def with_scenario(self, scenario: Any) -> Study:
        """The same question under another scenario (a name, a JSON file or a :class:`~labcut.Scenario`)."""
        return self._derived(self._rebuilt(scenario=scenario))

    def with_lights(self, lighting: Any) -> Study:
        """The same question with other lights (a lighting preset, a JSON or .exr/.hdr file or a
        :class:`~labcut.Lights`), the scenario's viewers and poses kept."""
        scenario, _, viewing = self.question.scene_spec
        if scenario is None and viewing is None:  # the default scenario (or one of lights alone): its poses and viewers
            scenario = self.scenario.name if self.scenario.name in SCENARIOS else self.scenario
        return self._derived(self._rebuilt(scenario=scenario, lighting=lighting, viewing=viewing))

    def with_quality(self, quality: Quality | str) -> Study:
        """The same question at another :class:`~labcut.Quality`."""
        return self._derived(self.question.at_quality(quality))

    def with_objective(self, objective: str) -> Study:
        """The same question ranked by another objective (``energy``, ``area``, ``intensity``,
        ``balanced``): the plan and the flash problem are shared."""
        other = self._derived(self._rebuilt(objective=objective), keep_plan=True)
        if self._scorer is not None:  # the same triples, ranked by the other objective
            other._scorer = Scorer(self._scorer.problem, other.question.objective)
        return other

    def with_kernels(self, kernels: KernelOptions) -> Study:
        """The same question computed with other :class:`~labcut.orientation.kernels.KernelOptions`
        (the plan is shared)."""
        if not isinstance(kernels, KernelOptions):
            raise ParameterError(f"kernels must be a KernelOptions, got {type(kernels).__name__}")
        return self._derived(replace(self.question, kernels=kernels), keep_plan=True)

    def _rebuilt(self, **changes: Any) -> FlashQuestion:
        """This Study's question built again with ``changes`` (checked as any question is)."""
        s = self.question
        spec = dict(zip(("scenario", "lighting", "viewing"), s.scene_spec))
        if "scenario" in changes and "lighting" not in changes:
            spec = {"scenario": changes.pop("scenario"), "lighting": None, "viewing": None}
        spec.update({k: changes.pop(k) for k in ("scenario", "lighting", "viewing") if k in changes})
        asked = dict(objective=s.objective, quality=s.quality, tau=s.tau, seed=s.seed, estimator=s.estimator,
                     effects=s.effect_overrides, zoning=s.zoning, max_tilt=s.constraint.max_tilt_deg,
                     tilt_axis=s.constraint.tilt_axis)
        asked.update(changes)
        return replace(FlashQuestion.build(s.material, spec["scenario"], spec["lighting"], spec["viewing"], **asked),
                       kernels=s.kernels)


def _build_key(plan: Any) -> tuple[Any, ...]:
    """What of an effect plan :func:`~labcut.orientation.recommend.build_scorer` builds a problem from:
    occlusion, through the volume or not, the environment map's directions."""
    return (plan.on("occlusion"), volume_problem(plan.estimator), plan.env_samples)
