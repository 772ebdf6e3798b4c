"""``labcut.recommend_orientation`` and ``labcut.evaluate_orientation``: the flash questions as
commands: check the question, plan its effects (:mod:`labcut.planner`), fit it into a time budget
(:mod:`labcut.commands.budget`), then answer with the flash problem's scorer
(:func:`labcut.orientation.recommend.answer_recommendation`,
:func:`~labcut.orientation.recommend.evaluation_metrics`), and let the budget's calibration learn
from the run. A :class:`labcut.Study` answers the same questions from the same pieces.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Mapping
from typing import Any

from ..backend import with_serial_blas
from ..errors import LabcutWarning, ParameterError
from ..geometry.meshio import validate_mesh
from ..geometry.stone import Stone, mesh_of
from .budget import choose, kind_of, mark_warm, quality_or_budget, record
from ..orientation.optimize import OPTIMIZERS
from ..orientation.recommend import Recommendation, answer_recommendation, build_scorer, evaluation_metrics, question
from ..orientation.scoring import FlashMetrics, Scorer
from ..orientation.question import FlashQuestion
from ..physics.material import Labradorite
from ..planner import PILOT_BUDGET_SHARE, EffectPlan, occlusion_on, plan_question
from ..scene import Lights, Scenario, Views
from ..scene.directions import lamella_normal
from ..scene.quality import Quality
from ..scene.variants import Variation
from ..validation import check_budget, is_default


def planned_scorer(mesh: Any, setup: FlashQuestion, command: str = "recommend", plan: Any = None, *,
                   pilot_seconds_max: float | None = None) -> tuple[Scorer, Any]:
    """Plan the effects of ``setup`` on ``mesh`` (:func:`labcut.planner.plan_effects`; ``plan``: one
    already made for them, used as it is; ``pilot_seconds_max``: as there) and build the sample
    estimator's problem as planned (:func:`build_scorer`): ``(scorer, plan)``."""
    validate_mesh(mesh)
    if plan is not None:
        if not isinstance(plan, EffectPlan) or plan.command not in ((command, "compare") if command == "recommend" else (command,)):
            raise ParameterError(f"plan must be the labcut.planner.plan_effects(..., command={command!r}) of this mesh "
                                 f"and question, got {plan!r:.80}")
    else:
        plan = plan_question(mesh, setup, command, predict=command == "recommend",  # a recommendation's JSON holds its predicted seconds
                             pilot_seconds_max=pilot_seconds_max)
    return build_scorer(mesh, setup, plan), plan


@with_serial_blas
def recommend_orientation(
    mesh: Any,
    material: Labradorite | str | None = None,
    lighting: str | Lights | None = None,
    viewing: str | Views | None = None,
    objective: str = "energy",
    quality: Quality | str = "standard",
    optimizer: str = "nlopt",
    max_tilt: float = 90.0,
    tilt_axis: Any = None,
    tau: float = 0.1,
    seed: int = 0,
    progress: Callable[[str, float], None] | None = None,
    *,
    scenario: str | Scenario | None = None,
    estimator: str = "auto",
    effects: Mapping[str, Any] | None = None,
    zoning: Any = None,
    setup: FlashQuestion | None = None,
    time_budget: float | None = None,
    plan: Any = None,
    variants: int | Variation | None = None,
) -> Recommendation:
    """Find the lamella normal (mesh frame) that maximises the flash objective.

    Parameters
    ----------
    mesh: a ``trimesh.Trimesh`` in mm, +Z face-up (``labcut.load_mesh`` / ``labcut.cabochon``).
    material: :class:`~labcut.Labradorite` or a preset name (default blue-green labradorite).
    scenario: how the stone is lit, worn and seen: ``bench`` (default) | ``ring`` | ``pendant`` |
        ``brooch`` | ``display`` | ``outdoor`` | a scenario JSON file | :class:`~labcut.Scenario`
        (docs/scenarios.md).
    lighting: replaces the scenario's lights (world frame): a preset of
        :data:`labcut.scene.LIGHTING`, a JSON file, an .exr/.hdr map or :class:`~labcut.Lights`.
    viewing: replaces the scenario's viewers: a preset of :data:`labcut.scene.VIEWING`, a JSON
        file or :class:`~labcut.Views`. With ``lighting``/``viewing`` but no ``scenario`` the
        stone lies still and face-up (``overhead``/``face-up`` fill in the one not given).
    objective: ``energy`` | ``area`` | ``intensity`` | ``balanced`` (DESIGN.md §4).
    quality: ``draft`` | ``standard`` | ``high`` or a :class:`~labcut.Quality`: surface samples,
        light/view directions, map spacing, optimiser budget (docs/accuracy.md).
    optimizer: ``nlopt`` (DIRECT-L + L-BFGS with Dr.Jit gradients) | ``gradient`` (Dr.Jit
        multi-start gradient ascent) | ``grid`` (exhaustive reference).
    max_tilt: largest allowed tilt of the lamella normal from +Z, degrees (the rough is
        sawn near the plane). ``tilt_axis``: a horizontal axis the normal may only rotate about.
    tau: flash threshold in units of L_ref.
    progress: optional ``callback(stage, fraction)``.
    estimator: ``auto`` (the effect planner chooses, docs/planner.md) | ``samples`` (surface
        sample triples: fast, every effect but light between the parts of a carving) |
        ``render`` (Mitsuba renders of the schiller, optimised through Dr.Jit's automatic
        differentiation from the sample estimator's answer; carries inter-reflection).
    effects: overrides of the planner's switchable effects, ``{"occlusion": bool,
        "inter_reflection": bool}`` (:data:`labcut.scene.effects.SWITCHABLE`).
    zoning: colour zones (``"smooth"``, ``"sharp"``, a :class:`~labcut.rendering.zoning.Zoning`,
        docs/zoning.md): the render estimator answers, weighing each zone's flash as the viewers
        see it (starting from a coarse map of rendered zoned flash).
    time_budget: seconds the call may take: the most accurate quality predicted to fit on this
        machine replaces ``quality`` (:mod:`labcut.commands.budget`; the choice is in
        ``settings["time_budget"]``). Below the cheapest setting's prediction the cheapest runs,
        with a one-line :class:`~labcut.errors.LabcutWarning`.
    setup: the whole question at once, validated (:meth:`FlashQuestion.build
        <labcut.orientation.question.FlashQuestion.build>`, what the CLI passes); then the arguments it
        holds (material to zoning above, but not ``optimizer`` and ``progress``) stay unset.
    plan: the effect plan of this mesh and question already made
        (:func:`labcut.planner.plan_effects` with ``command="recommend"``, e.g. to show it first, as
        the CLI does), used as it is instead of planning again; not with ``time_budget`` (which
        plans at the quality it chooses).
    variants: also answer under this many plausible variants of the scenario (2-64; a
        :class:`~labcut.scene.variants.Variation` sets the ranges too): room layout, motion range,
        viewers (:mod:`labcut.scene.variants`); ``rec.robustness`` says how far the best normal
        moves across them, against the error bar and the tolerance
        (:mod:`labcut.orientation.robustness`). Each variant costs about one search of the
        question; a time budget covers the recommendation, not its variants.

    Returns a :class:`Recommendation`: normal (unit, z >= 0), tilt and azimuth, score and all
    metrics, the tolerance (degrees the cutter may miss and keep 90 % of the score), distinct
    runner-up optima, the score map over the allowed hemisphere, and the effect plan. With the
    render estimator the normal, score and metrics are the renders'; the map, tolerance and
    runners-up come from the sample estimator around that normal.
    """
    mesh = mesh_of(mesh)  # a Stone or a trimesh
    variation = Variation.coerce(variants)
    if optimizer not in OPTIMIZERS:
        raise ParameterError(f"optimizer must be one of {', '.join(OPTIMIZERS)}, got {optimizer!r}")
    start = time.perf_counter()
    report = progress or (lambda stage, fraction: None)
    report("sampling the surface", 0.0)
    ask = question(setup, material=material, scenario=scenario, lighting=lighting, viewing=viewing, objective=objective,
                   quality=quality, max_tilt=max_tilt, tilt_axis=tilt_axis, tau=tau, seed=seed, estimator=estimator,
                   effects=effects, zoning=zoning)
    budget = pilots_max = None
    if time_budget is not None:
        if plan is not None:
            raise ParameterError("give plan or time_budget, not both (the budget plans at the quality it chooses)")
        ask, budget = within_budget(mesh, ask, time_budget, quality_given=not is_default(quality, "standard"))
        pilots_max = PILOT_BUDGET_SHARE * budget.budget_seconds
    scorer, plan = planned_scorer(mesh, ask, "recommend", plan, pilot_seconds_max=pilots_max)
    rec = answer_recommendation(mesh, ask, scorer, plan, optimizer=optimizer, progress=report, budget=budget, start=start,
                                variation=variation)
    if budget is not None:  # the calibration learns from this run (commands/budget.py)
        # what the calibration predicts: the recommendation, not the plans' pilot renders; the
        # first of its kind in this process feeds the first-call seconds instead of the factor
        record(budget.kind, budget.uncorrected(budget.predicted_seconds),
               rec.seconds - budget.pilot_seconds - plan.pilot_seconds - (rec.robustness.seconds if rec.robustness else 0.0),
               first_call=budget.cold)
    mark_warm(kind_of(rec.estimator, plan.on("occlusion")))  # the next one of its kind here is predicted warm
    return rec


def within_budget(mesh: Any, ask: FlashQuestion, time_budget: Any, *, quality_given: bool) -> tuple[FlashQuestion, Any]:
    """``ask`` at the most accurate quality predicted to fit ``time_budget`` seconds
    (:func:`labcut.commands.budget.choose`), and the choice."""
    quality_or_budget(quality_given, True)
    # which estimator answers (the planner's choice does not depend on the quality): the budget predicts that one
    # a stone's first plan makes its pilot renders (at the pilot quality, whatever the rung: the rung's
    # plan finds them cached): their seconds are the budget's (the calibration's recommendations,
    # which the rungs are predicted from, include a plan but not its pilots)
    plan = plan_question(mesh, ask, "recommend", predict=False, pilot_seconds_max=PILOT_BUDGET_SHARE * check_budget(time_budget))
    choice = choose(time_budget, ask.scene_spec, occlusion_on(Stone.of(mesh).convex, ask.effect_overrides), plan=plan)
    if choice.note:
        warnings.warn(choice.note, LabcutWarning, stacklevel=3)
    return ask.at_quality(choice.quality), choice


@with_serial_blas
def evaluate_orientation(
    mesh: Any,
    normal: Any = None,
    material: Labradorite | str | None = None,
    lighting: str | Lights | None = None,
    viewing: str | Views | None = None,
    quality: Quality | str = "standard",
    tau: float = 0.1,
    seed: int = 0,
    *,
    scenario: str | Scenario | None = None,
    estimator: str = "auto",
    effects: Mapping[str, Any] | None = None,
    zoning: Any = None,
    setup: FlashQuestion | None = None,
    plan: Any = None,
    tilt: float | None = None,
    azimuth: float | None = None,
) -> FlashMetrics:
    """Flash metrics (DESIGN.md §4) of a given lamella orientation under a scenario: a ``normal``
    (mesh frame, axial) or ``tilt`` (degrees from +Z) and ``azimuth`` (degrees from +X toward +Y),
    one of the two (:func:`labcut.scene.lamella_normal`); under a
    scenario (default ``bench``; ``lighting``/``viewing`` as in :func:`recommend_orientation`).

    ``estimator``/``effects`` as in :func:`recommend_orientation`: with the render estimator the
    metrics come from renders (:class:`~labcut.orientation.render_objective.RenderObjective` at the
    quality's render settings, paths as deep as the plan's inter-reflection asks; with ``zoning``
    always, each point flashing with its own lamella stack). ``setup``: the question at once, as in
    :func:`recommend_orientation` (its objective and constraint do not matter here). ``plan``: the
    effect plan already made (``plan_effects(..., command="evaluate")``), as in
    :func:`recommend_orientation`."""
    mesh = mesh_of(mesh)  # a Stone or a trimesh

    m = lamella_normal(normal, tilt, azimuth)
    ask = question(setup, material=material, scenario=scenario, lighting=lighting, viewing=viewing, quality=quality, tau=tau,
                   seed=seed, estimator=estimator, effects=effects, zoning=zoning)
    scorer, plan = planned_scorer(mesh, ask, "evaluate", plan)
    return evaluation_metrics(mesh, ask, scorer, plan, m)
