"""The flash estimators behind one interface: :class:`FlashEstimator`, chosen by name.

A flash question is answered by an estimator the effect planner names (``plan.estimator``):

- ``samples`` (:class:`SampleEstimator`): the surface-sample triples of the flash problem and
  their :class:`~labcut.orientation.scoring.Scorer` (fast; every effect but light between a
  carving's parts);
- ``volume`` (:class:`SampleEstimator` too): the same, over the volumetric flash problem
  (:mod:`labcut.orientation.volume`: the light mirrored below the surface and leaving elsewhere,
  where the stack's depth matters against the stone's thickness and curvature);
- ``render`` (:class:`RenderEstimator`): Mitsuba renders of the schiller
  (:class:`~labcut.orientation.render_objective.RenderObjective`), optimised through Dr.Jit's
  automatic differentiation from the sample estimator's answer (carries inter-reflection and
  colour zones).

Each gives the metrics of a lamella normal, the objective over many normals (the energy map for
``energy``), the objective's gradient at a normal, and the answer's refinement from the sample
estimator's optimum (:meth:`FlashEstimator.refine`; the sample estimator's own is itself). Their
predicted seconds are the planner's (:func:`labcut.planner.estimator_seconds`, by the same name),
which times them on this machine. :func:`estimator_for` makes the one a plan names, so the
recommendation and the evaluation have no branch per estimator. Normals: unit, mesh frame, axial.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from ..errors import ParameterError
from ..scene.directions import axial_upper
from .scoring import FlashMetrics, Scorer


@dataclass(frozen=True)
class Refined:
    """An estimator's answer from a starting optimum: the normal, its objective value, its metrics
    (None: the sample estimator's, computed with the error bars), and the estimator's statistics."""

    normal: np.ndarray
    score: float
    metrics: FlashMetrics | None = None
    stats: dict[str, Any] = field(default_factory=dict)


class FlashEstimator(Protocol):
    """What every flash estimator answers (module docstring)."""

    #: the name the effect planner chooses it by (``plan.estimator``)
    name: str
    #: the share of a recommendation's progress spent before :meth:`refine` (the sample estimator's
    #: map and optimiser)
    progress_before_refine: float
    #: whether its objective values are the sample estimator's (then the tolerances and runners-up,
    #: which are always the sample estimator's, start from its score as it is)
    scores_are_samples: bool

    def metrics(self, normal: np.ndarray) -> FlashMetrics: ...

    def objective(self, normals: np.ndarray) -> np.ndarray: ...

    def value_and_grad(self, normal: np.ndarray) -> tuple[float, np.ndarray]: ...

    def refine(self, normal: np.ndarray, score: float, progress: Callable[[str, float], None]) -> Refined: ...


@dataclass
class SampleEstimator:
    """The surface-sample estimator: its flash problem's :class:`~labcut.orientation.scoring.Scorer`."""

    scorer: Scorer
    name: str = "samples"
    progress_before_refine: float = 1.0
    scores_are_samples: bool = True

    def metrics(self, normal: np.ndarray) -> FlashMetrics:
        return self.scorer.metrics(normal)

    def objective(self, normals: np.ndarray) -> np.ndarray:
        return self.scorer.scores(np.atleast_2d(normals))

    def value_and_grad(self, normal: np.ndarray) -> tuple[float, np.ndarray]:
        return self.scorer.sparse_map.value_and_grad(np.asarray(normal, dtype=np.float64))

    def refine(self, normal: np.ndarray, score: float, progress: Callable[[str, float], None]) -> Refined:
        """The sample estimator's optimum is its answer."""
        return Refined(normal, float(score))


@dataclass
class RenderEstimator:
    """The render estimator for a question (``ask``, a :class:`~labcut.orientation.question.FlashQuestion`)
    about ``mesh``: paths as deep as the plan's inter-reflection asks (``max_depth``), the render
    settings of the question's quality (its ``estimator_*`` fields)."""

    mesh: Any
    ask: Any
    max_depth: int = 2
    name: str = "render"
    progress_before_refine: float = 0.3
    scores_are_samples: bool = False
    _objective: Any = field(default=None, repr=False)

    def render_objective(self) -> Any:
        """The renders' objective (:class:`~labcut.orientation.render_objective.RenderObjective`), made once."""
        if self._objective is None:
            from .render_estimator import RenderQuality
            from .render_objective import RenderObjective

            q = RenderQuality.of(self.ask.quality)
            a = self.ask
            self._objective = RenderObjective(self.mesh, a.material, a.scenario.settings(), objective=a.objective,
                                              tau=a.tau, resolution=q.resolution, spp=q.spp, seed=a.seed,
                                              max_depth=self.max_depth, zoning=a.zoning)
        return self._objective

    def metrics(self, normal: np.ndarray) -> FlashMetrics:
        return self.render_objective().metrics(normal)

    def objective(self, normals: np.ndarray) -> np.ndarray:
        obj = self.render_objective()
        return np.array([obj.value(n) for n in np.atleast_2d(normals)])

    def value_and_grad(self, normal: np.ndarray) -> tuple[float, np.ndarray]:
        return self.render_objective().value_and_grad(normal)

    def refine(self, normal: np.ndarray, score: float, progress: Callable[[str, float], None]) -> Refined:
        """The renders' optimum, from the sample estimator's (a zoned stone's from a coarse map of
        renders over the whole hemisphere: its optimum may lie far from the uniform material's)."""
        from .render_estimator import recommend_by_render

        a = self.ask
        found = recommend_by_render(
            self.mesh, a.material, a.scenario.settings(), start_normal=None if a.zoning is not None else normal,
            objective=a.objective, tau=a.tau, constraint=a.constraint, quality=a.quality, seed=a.seed,
            progress=progress, max_depth=self.max_depth, zoning=a.zoning)
        angle = math.degrees(math.acos(min(1.0, abs(float(found.normal @ normal)))))
        stats = dict(found.stats, samples_normal=[float(x) for x in normal], samples_score=float(score),
                     angle_to_samples_deg=angle)
        return Refined(axial_upper(found.normal), float(found.score), found.metrics, stats)


def estimator_for(name: str, mesh: Any, ask: Any, scorer: Scorer, plan: Any) -> FlashEstimator:
    """The estimator ``name`` (a plan's ``estimator``: ``samples``, ``volume`` or ``render``) for the question
    ``ask`` about ``mesh``, its sample ``scorer`` and effect ``plan``."""
    make = ESTIMATORS.get(name or "samples")
    if make is None:
        raise ParameterError(f"no flash estimator named {name!r}; estimators: {', '.join(ESTIMATORS)}")
    return make(mesh, ask, scorer, plan)


#: whether each estimator's sample problem carries the light through the stone's volume
#: (:func:`~labcut.orientation.volume.build_volume_problem`) rather than mirroring it where it enters:
#: the scorer a plan's estimator is handed (:func:`labcut.orientation.recommend.build_scorer`), its
#: error bars' and its variants' problems are built so
VOLUME_PROBLEM: dict[str, bool] = {"samples": False, "volume": True, "render": False}


def volume_problem(name: str | None) -> bool:
    """Whether the estimator ``name``'s sample problem is volumetric (:data:`VOLUME_PROBLEM`)."""
    return VOLUME_PROBLEM.get(name or "samples", False)


#: the estimators by name: how each is made from a question, its sample scorer and its plan
ESTIMATORS: dict[str, Callable[[Any, Any, Scorer, Any], FlashEstimator]] = {
    "samples": lambda mesh, ask, scorer, plan: SampleEstimator(scorer),
    # the scorer of a volume plan is the volumetric problem's (recommend.build_scorer): the same estimator over it
    "volume": lambda mesh, ask, scorer, plan: SampleEstimator(scorer, name="volume"),
    "render": lambda mesh, ask, scorer, plan: RenderEstimator(mesh, ask, 4 if plan.on("inter_reflection") else 2),
}
