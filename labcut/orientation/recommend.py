"""``labcut.recommend_orientation`` and ``labcut.evaluate_orientation`` (DESIGN.md §4-5)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..validation import given_besides
from ..scene import Scenario, resolve_scene
from ..scene.directions import tilt_azimuth
from ..scene.quality import Quality
from .optimize import OPTIMIZERS, Constraint, search_best, tolerance_deg
from ..geometry.stone import Stone
from .scoring import FlashMetrics, Scorer
from .estimators import estimator_for, volume_problem
from .question import FlashQuestion
from .misorientation import MisorientationCurve, misorientation_curve
from .robustness import Robustness, scenario_robustness
from .uncertainty import Uncertainty, uncertainty_for
from ..scene.variants import Variation

#: the presets' map spacing (degrees), read from :class:`~labcut.scene.quality.Quality`
MAP_SPACING_DEG = {name: q.map_spacing_deg for name, q in Quality.PRESETS.items()}
RUNNER_UP_SEPARATION_DEG = 12.0
#: share of the best score the tolerances keep ("as good")
KEEP = 0.9

#: how to read a recommendation's numbers (written into its JSON as ``frame``)
FRAME = {
    "normal": "unit lamella normal in the mesh frame (axial: n and -n are the same; reported with z >= 0)",
    "axes": "+Z face-up; -Y the front of the stone, +Y its back (for a stone worn upright, pendant or brooch: "
            "+Y the top, the bail end); +X its right as seen from the front",
    "tilt_deg": "angle of the lamella normal from +Z (0: lamellae parallel to the base)",
    "azimuth_deg": "direction the lamella normal leans, from +X (right) towards +Y (back), in [0, 360): "
                   "0 right, 90 back (top), 180 left, 270 front (bottom)",
}

#: the flash metrics, as the table and the JSON state them (DESIGN.md §4, docs/orientation.md)
METRIC_DEFINITIONS = {
    "flash_area": "share of the visible stone (projected area) whose schiller reaches the flash threshold "
                  "tau x P x L_ref; mean over views",
    "flash_intensity": "mean L_s / L_ref over the flashing part of a view (0 where none flashes); mean over views",
    "flash_energy": "mean L_s / L_ref over the whole visible stone; mean over views. "
                    "= energy_in_flash + energy_below_threshold",
    "energy_in_flash": "sum over views of weight x flash_area x flash_intensity: the energy of the flashing parts",
    "energy_below_threshold": "the energy of the faint schiller below the flash threshold tau x P x L_ref",
    "L_ref": "the unit of flash values: the schiller radiance of a flat polished face with the lamellae parallel to it, "
             "lit and seen along its normal by one light carrying the scene's whole irradiance",
    "scene_peak": "P: the brightest schiller the scenario's own lights can give that flat face, turned whichever way "
                  "makes it brightest and seen along its normal, in units of L_ref (1 for one small lamp; a few "
                  "hundredths under an even ceiling or sky): settings.scene_peak",
    "flash_threshold": "tau x P in units of L_ref (settings.flash_threshold): a point flashes where its schiller "
                       "reaches that share of the brightest the scene's light can give, so flash means the same under "
                       "a lamp and under diffuse light",
    "coverage": "weight of the views whose flash_area exceeds 0.05",
    "balanced": "sqrt(flash_area x flash_intensity) of the aggregates",
    "misorientation": "flash energy kept (÷ the optimum's) when the lamella normal misses the recommended one by "
                      "miss_deg: mean_relative and worst_relative over 16 directions around it; by_side: leaning "
                      "further towards the stone's front (-Y), back (+Y; its top worn upright), left (-X), right (+X)",
    "visible_area_mm2": "the stone's projected area (mm²) as the views see it (outline area from each view, sampled); "
                        "mean over views. The flash metrics are scale-free (geometric optics: the same cut twice the "
                        "size flashes over the same share); this is the size",
    "flash_area_mm2": "the flashing part's projected area, mm²: sum over views of weight x flash_area x visible area "
                      "of that view. A bigger stone of the same cut has a bigger flash_area_mm2 and the same flash_area",
}


def energy_parts(metrics: FlashMetrics) -> tuple[float, float]:
    """``(energy_in_flash, energy_below_threshold)`` of some metrics; they add up to ``flash_energy``.

    Per view, the energy (mean ``L_s/L_ref`` over the visible stone) is the flashing part's
    ``area x intensity`` plus the faint schiller below the threshold; the aggregates are
    view-weighted means, so ``flash_area x flash_intensity`` of the aggregates is neither."""
    pv = metrics.per_view
    w = np.asarray(pv["weight"], dtype=np.float64)
    in_flash = float(w @ (np.asarray(pv["flash_area"]) * np.asarray(pv["flash_intensity"])))
    in_flash = min(in_flash, metrics.flash_energy)
    return in_flash, metrics.flash_energy - in_flash


def metrics_dict(metrics: FlashMetrics) -> dict[str, Any]:
    """Plain JSON of flash metrics with the energy split into its flashing and faint parts."""
    in_flash, below = energy_parts(metrics)
    return {**metrics.to_dict(), "energy_in_flash": in_flash, "energy_below_threshold": below}


FACE_UP_SIDES = ["right (+X)", "back-right", "back (+Y)", "back-left", "left (-X)", "front-left", "front (-Y)", "front-right"]
UPRIGHT_SIDES = ["right (+X)", "top-right", "top (+Y, the bail end)", "top-left", "left (-X)", "bottom-left", "bottom (-Y)", "bottom-right"]


def side_name(azimuth_deg: float, scenario: Scenario | None = None) -> str:
    """The side of the stone at an azimuth (degrees from +X towards +Y), named as the stone is worn."""
    sides = UPRIGHT_SIDES if scenario is not None and scenario.worn_upright else FACE_UP_SIDES
    return sides[int(((azimuth_deg + 22.5) % 360.0) // 45.0)]


def describe(normal: np.ndarray, scenario: Scenario | None = None, parallel_within_deg: float | None = None) -> str:
    """The orientation in a cutter's words: tilt of the lamella plane towards a side of the stone.

    Sides are named as the stone is worn: front/back for a stone lying face-up, top/bottom
    for one worn upright (pendant, brooch: the mesh's +Y end is up). ``parallel_within_deg``:
    the lamellae parallel to the base score as well as the optimum (within :data:`KEEP`) and
    any tilt up to this many degrees does too: the answer is then "parallel to the base"."""
    tilt, az = tilt_azimuth(normal)
    if parallel_within_deg is not None:
        return f"keep the lamella plane parallel to the base (any tilt within ±{parallel_within_deg:.1f}° is as good)"
    if tilt < 0.5:
        return "keep the lamella plane parallel to the base (face-up)"
    side = side_name(az, scenario)
    return f"tilt the lamella plane {tilt:.0f}° towards the {side} of the stone (azimuth {az:.0f}°)"


def workshop(normal: np.ndarray, mesh: Any, scenario: Scenario | None = None, parallel: bool = False) -> dict[str, Any]:
    """The orientation as a cutter sets it up when sawing or dopping, relative to the flash plane.

    Under the lamp the cutter finds the flash plane (the lamella plane: the rough flashes
    straight back at the eye when it lies level) and then cuts the stone's base, or sets it on
    the dop, at an angle to that plane. With the lamella normal tilted ``θ`` towards the side
    at azimuth ``φ`` (mesh frame), the base must rise towards that side: raise the stone's
    ``φ`` edge by ``θ`` above the flash plane, i.e. by ``span x sin θ`` mm, ``span`` being the
    stone's extent (mm) along ``φ`` measured on its base (the base is the hypotenuse). Returns a
    plain-JSON dict (degrees, mm)."""
    tilt, az = tilt_azimuth(normal)
    if parallel or tilt < 0.5:
        return {
            "raise_edge": None, "raise_deg": 0.0, "raise_mm": 0.0, "span_mm": None, "edge_azimuth_deg": None,
            "text": "saw and dop with the base parallel to the flash plane found under the lamp",
        }
    u = np.array([math.cos(math.radians(az)), math.sin(math.radians(az)), 0.0])
    v = np.asarray(mesh.vertices, dtype=np.float64)
    span = float(np.ptp(v @ u))
    rise = span * math.sin(math.radians(tilt))
    side = side_name(az, scenario)
    short, detail = side.split(" (")[0], side[len(side.split(" (")[0]):]
    opposite = side_name(az + 180.0, scenario).split(" (")[0]
    return {
        "raise_edge": side, "raise_deg": tilt, "raise_mm": rise, "span_mm": span, "edge_azimuth_deg": az,
        "text": (f"level the flash plane found under the lamp, then saw or dop with the {short} edge{detail} of the stone "
                 f"raised {tilt:.1f}° above it: {rise:.2f} mm over the {span:.1f} mm from its {opposite} edge to its {short} edge"),
    }


@dataclass
class Recommendation:
    """The answer of :func:`recommend_orientation`."""

    normal: np.ndarray
    tilt_deg: float
    azimuth_deg: float
    score: float
    objective: str
    metrics: FlashMetrics
    tolerance_deg: float
    tolerance_by_axis: dict[str, float]
    runners_up: list[dict[str, Any]]
    map_normals: np.ndarray
    map_scores: np.ndarray
    optimizer: str
    evaluations: int
    seconds: float
    settings: dict[str, Any] = field(default_factory=dict)
    scenario: Scenario | None = None  # the scenario it was found under (renders use it)
    #: degrees of tilt from the base that keep 90 % of the best score, when the base itself
    #: does (the answer is then "parallel to the base"); None otherwise
    parallel_within_deg: float | None = None
    #: the cutter's set-up: which edge to raise above the flash plane, degrees and mm (:func:`workshop`)
    workshop: dict[str, Any] = field(default_factory=dict)
    #: the stone's provenance (:meth:`labcut.Stone.provenance_dict`): path, units, up axis, repairs, bodies
    mesh: dict[str, Any] = field(default_factory=dict)
    #: the effect plan it ran under (:meth:`labcut.planner.EffectPlan.to_dict`): effects on and
    #: off and why, the estimator and the predicted seconds
    plan: dict[str, Any] = field(default_factory=dict)
    #: which estimator found the normal and scored it: ``samples`` or ``render``
    estimator: str = "samples"
    #: the render estimator's statistics (:class:`~labcut.orientation.render_estimator.RenderRecommendation`),
    #: when it answered: its settings, costs, and the sample estimator's normal it started from
    render: dict[str, Any] = field(default_factory=dict)
    #: error bars (:mod:`labcut.orientation.uncertainty`): the normal's angular error (degrees) and
    #: the score's relative error against the converged answer; None when not estimated
    uncertainty: Uncertainty | None = None
    #: flash energy kept when the cut misses this normal, against degrees off, on average, at
    #: worst and towards each side (:mod:`labcut.orientation.misorientation`); None: not computed
    misorientation: MisorientationCurve | None = None
    #: how far the best normal moves across plausible variants of the scenario
    #: (:mod:`labcut.orientation.robustness`); None unless asked for (``variants=``)
    robustness: Robustness | None = None

    @property
    def angle_error_deg(self) -> float | None:
        """Angle (degrees) within which the converged normal lies (about 95 %), or None."""
        return None if self.uncertainty is None else self.uncertainty.angle_deg

    @property
    def score_rel_error(self) -> float | None:
        """Relative error of the score (0.05 = ±5 %), or None."""
        return None if self.uncertainty is None else self.uncertainty.score_rel

    @property
    def description(self) -> str:
        return describe(self.normal, self.scenario, self.parallel_within_deg)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON: everything but the full score map (``map`` holds it as tilt/azimuth/score lists)."""
        tilt, az = np.array([tilt_azimuth(n) for n in self.map_normals]).T if len(self.map_normals) else ([], [])
        return {
            "normal": [float(x) for x in self.normal],
            "tilt_deg": self.tilt_deg,
            "azimuth_deg": self.azimuth_deg,
            "description": self.description,
            "parallel_to_base": self.parallel_within_deg is not None,
            "parallel_within_deg": self.parallel_within_deg,
            "workshop": self.workshop,
            "frame": FRAME,
            "objective": self.objective,
            "score": self.score,
            "metrics": metrics_dict(self.metrics),
            "metric_definitions": METRIC_DEFINITIONS,
            "mesh": self.mesh,
            "tolerance_deg": self.tolerance_deg,
            "tolerance_by_axis": self.tolerance_by_axis,
            "misorientation": None if self.misorientation is None else self.misorientation.to_dict(),
            "runners_up": self.runners_up,
            "optimizer": self.optimizer,
            "evaluations": self.evaluations,
            "seconds": self.seconds,
            "settings": self.settings,
            "estimator": self.estimator,
            "plan": self.plan,
            "render_estimator": self.render,
            "uncertainty": None if self.uncertainty is None else self.uncertainty.to_dict(),
            "robustness": None if self.robustness is None else self.robustness.to_dict(),
            "map": {"tilt_deg": list(map(float, tilt)), "azimuth_deg": list(map(float, az)), "score": self.map_scores.tolist()},
        }

    def __repr__(self) -> str:
        where = f", scenario={self.scenario.name!r}" if self.scenario is not None else ""
        bar = f" ± {self.uncertainty.angle_deg:.1f}°" if self.uncertainty is not None else ""
        sbar = f" ± {self.uncertainty.score_rel:.0%}" if self.uncertainty is not None else ""
        return (f"Recommendation(tilt={self.tilt_deg:.1f}°{bar}, azimuth={self.azimuth_deg:.1f}°, "
                f"{self.objective}={self.score:.4g}{sbar}, tolerance=±{self.tolerance_deg:.1f}°{where})")

    def _repr_html_(self) -> str:
        """A small table for notebooks: the instruction, the orientation, the score and its metrics."""
        from html import escape

        m = self.metrics
        rows = [("instruction", self.description),
                ("tilt / azimuth", f"{self.tilt_deg:.1f}° / {self.azimuth_deg:.1f}°"),
                ("error bar (normal, score)", "not estimated" if self.uncertainty is None else
                 f"± {self.uncertainty.angle_deg:.1f}°, ± {self.uncertainty.score_rel:.0%}"),
                ("normal (mesh frame)", "(" + ", ".join(f"{x:+.4f}" for x in self.normal) + ")"),
                ("tolerance (90 % kept)", f"±{self.tolerance_deg:.1f}°"),
                (f"score ({self.objective})", f"{self.score:.4g}"),
                ("flash area", f"{m.flash_area:.1%}"), ("flash intensity", f"{m.flash_intensity:.3f}"),
                ("flash energy", f"{m.flash_energy:.4f}"), ("coverage", f"{m.coverage:.0%}")]
        if self.scenario is not None:
            rows.insert(1, ("scenario", self.scenario.name))
        if self.robustness is not None:
            rows.insert(4, ("across scenario variants", f"moves ≤ {self.robustness.spread_deg:.1f}° ({self.robustness.verdict})"))
        body = "".join(f"<tr><td>{escape(k)}</td><td style='text-align:right'>{escape(v)}</td></tr>" for k, v in rows)
        return f"<table><thead><tr><th colspan='2'>labcut recommendation</th></tr></thead><tbody>{body}</tbody></table>"

    @classmethod
    def from_dict(cls, data: Any, source: str = "recommendation") -> Recommendation:
        """The inverse of :meth:`to_dict` (numbers, metrics, map and settings; the scenario is
        rebuilt when its name is a preset and its lights and views are the preset's, else None).

        Raises :class:`~labcut.errors.ParameterError` naming ``source`` when a key is missing or
        holds the wrong kind of value."""
        if not isinstance(data, dict):
            raise ParameterError(f"{source}: not a labcut recommendation (expected a JSON object)")
        try:
            metrics_in = data["metrics"]
            metrics = FlashMetrics(**{k: metrics_in[k] for k in
                                      ("flash_area", "flash_intensity", "flash_energy", "coverage", "balanced", "per_view")},
                                   **{k: metrics_in.get(k) for k in ("visible_area_mm2", "flash_area_mm2")})
            grid = data["map"]
            tilt = np.radians(np.asarray(grid["tilt_deg"], dtype=np.float64))
            az = np.radians(np.asarray(grid["azimuth_deg"], dtype=np.float64))
            map_normals = np.stack([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)], axis=-1).reshape(-1, 3)
            normal = np.asarray(data["normal"], dtype=np.float64)
            if normal.shape != (3,) or not np.all(np.isfinite(normal)):
                raise ValueError("normal must be three finite numbers")
            fields = dict(
                normal=normal, tilt_deg=float(data["tilt_deg"]), azimuth_deg=float(data["azimuth_deg"]),
                score=float(data["score"]), objective=str(data["objective"]), metrics=metrics,
                tolerance_deg=float(data["tolerance_deg"]),
                tolerance_by_axis={str(k): float(v) for k, v in data["tolerance_by_axis"].items()},
                runners_up=list(data["runners_up"]), map_normals=map_normals,
                map_scores=np.asarray(grid["score"], dtype=np.float64), optimizer=str(data["optimizer"]),
                evaluations=int(data["evaluations"]), seconds=float(data["seconds"]),
                settings=dict(data.get("settings", {})),
                parallel_within_deg=None if data.get("parallel_within_deg") is None else float(data["parallel_within_deg"]),
                workshop=dict(data.get("workshop", {})), mesh=dict(data.get("mesh", {})),
                plan=dict(data.get("plan", {})), estimator=str(data.get("estimator", "samples")),
                render=dict(data.get("render_estimator", {})),
                uncertainty=Uncertainty.from_dict(data.get("uncertainty")),
                misorientation=MisorientationCurve.from_dict(data.get("misorientation")),
                robustness=Robustness.from_dict(data.get("robustness")),
            )
        except KeyError as exc:
            raise ParameterError(f"{source}: not a labcut recommendation (missing {exc.args[0]!r})") from None
        except (TypeError, ValueError, AttributeError) as exc:
            raise ParameterError(f"{source}: not a labcut recommendation ({exc})") from None
        return cls(**fields, scenario=_saved_scenario(fields["settings"]))

    def save(self, path: Any) -> Path:
        """Write :meth:`to_dict` as JSON, atomically (no half-written file); returns the path."""
        import json

        from ..fileio import atomic_output

        with atomic_output(path, (".json",)) as tmp:
            tmp.write_text(json.dumps(self.to_dict(), indent=2) + "\n")
        return Path(path)

    @classmethod
    def load(cls, path: Any) -> Recommendation:
        """Read a recommendation back from the JSON that ``to_dict`` / ``--json`` wrote."""
        from ..fileio import read_json

        return cls.from_dict(read_json(path, "recommendation file"), source=str(path))


def _saved_scenario(settings: dict[str, Any]) -> Scenario | None:
    """The scenario a saved recommendation names, when it is a bundled preset left as it is."""
    from ..scene import SCENARIOS

    saved = settings.get("scenario")
    if not isinstance(saved, dict) or saved.get("name") not in SCENARIOS:
        return None
    try:
        scene = resolve_scene(saved["name"], quality=Quality.coerce(settings.get("quality_settings") or settings.get("quality", "standard")))
    except Exception:  # noqa: BLE001  (a preset that no longer resolves: keep the numbers, drop the scene)
        return None
    same = (scene.lights.name == saved.get("lighting") and scene.views.name == saved.get("viewing")
            and np.allclose(scene.pose, np.asarray(saved.get("pose", np.eye(3)), dtype=np.float64)))
    return scene if same else None


#: the question's arguments of recommend_orientation / evaluate_orientation and their defaults:
#: with ``setup=`` they stay at these (the setup holds them)
_QUESTION_DEFAULTS: dict[str, Any] = {
    "material": None, "lighting": None, "viewing": None, "scenario": None, "objective": "energy",
    "quality": "standard", "max_tilt": 90.0, "tilt_axis": None, "tau": 0.1, "seed": 0, "estimator": "auto",
    "effects": None, "zoning": None,
}


def question(setup: FlashQuestion | None = None, **asked: Any) -> FlashQuestion:
    """The :class:`~labcut.orientation.question.FlashQuestion` of a call: ``setup`` itself, or one built
    (and so validated) from the loose arguments ``asked`` (names of :data:`_QUESTION_DEFAULTS`).
    Both at once is an error: the setup holds the question."""
    if setup is None:
        return FlashQuestion.build(asked.get("material"), asked.get("scenario"), asked.get("lighting"), asked.get("viewing"),
                                **{k: v for k, v in asked.items() if k not in ("material", "scenario", "lighting", "viewing")})
    if not isinstance(setup, FlashQuestion):
        raise ParameterError(f"setup must be a labcut FlashQuestion (FlashQuestion.build(...)), got {type(setup).__name__}")
    given_besides(asked, _QUESTION_DEFAULTS, "setup= already holds the question")
    return setup


def build_scorer(mesh: Any, setup: FlashQuestion, plan: Any) -> Scorer:
    """The sample estimator's scorer of the question ``setup`` about ``mesh`` (a checked trimesh),
    its flash problem built as ``plan`` (an :class:`~labcut.planner.EffectPlan`) says: occlusion
    rays or not, through the stone's volume where the plan's estimator is ``volume``, the map seen
    through the plan's ``env_samples`` directions where it sets them, the setup's kernel options."""
    return setup.scorer(mesh, occlusion=plan.on("occlusion"), volume=volume_problem(plan.estimator),
                        env_samples=plan.env_samples)


def answer_recommendation(mesh: Any, ask: FlashQuestion, scorer: Scorer, plan: Any, *, optimizer: str = "nlopt",
                          progress: Callable[[str, float], None] | None = None, budget: Any = None,
                          start: float | None = None, variation: Variation | None = None) -> Recommendation:
    """The recommendation of question ``ask`` about ``mesh`` (a checked trimesh) from its sample
    estimator's ``scorer`` and effect ``plan`` (:func:`build_scorer`; a
    :class:`~labcut.study.Study` keeps both between questions): the map, the optimiser, the
    render estimator where planned, tolerances, runners-up, error bars. ``budget``: the time-budget
    choice the question was made at, for the answer's record; ``start``: when the call began
    (``time.perf_counter()``), for the answer's seconds; ``variation``: answer the question under
    these variants of its scenario too (:mod:`labcut.orientation.robustness`)."""
    if optimizer not in OPTIMIZERS:
        raise ParameterError(f"optimizer must be one of {', '.join(OPTIMIZERS)}, got {optimizer!r}")
    start = time.perf_counter() if start is None else start
    report = progress or (lambda stage, fraction: None)
    evaluations = scorer.evaluations
    scene, constraint, quality, objective, tau = ask.scenario, ask.constraint, ask.quality, ask.objective, ask.tau
    estimator = estimator_for(plan.estimator, mesh, ask, scorer, plan)
    share = estimator.progress_before_refine
    stage = lambda fraction: share * fraction  # noqa: E731 - the sample estimator's share of the progress
    report("mapping the hemisphere", stage(0.3))
    found = search_best(scorer, constraint, quality, optimizer, step=lambda name: report(name, stage(0.6)))
    normal, score, map_normals, map_scores = found.normal, found.score, found.map_normals, found.map_scores
    sample_normal = normal  # where the variants' moves are measured from (the render estimator starts here)
    if not score > 0.0:
        _no_flash(objective, scene, tau)
    refined = estimator.refine(normal, score, lambda st, f: report(f"renders: {st}", share + (0.9 - share) * f))
    render_stats = refined.stats
    normal, score, metrics = refined.normal, refined.score, refined.metrics
    if not score > 0.0:
        _no_flash(objective, scene, tau)
    own = estimator.scores_are_samples
    report("tolerance and runners-up", 0.8 if own else 0.9)
    sample_score = score if own else scorer.score(normal)  # the tolerances are the sample estimator's
    tol = tolerance_deg(scorer.scores, normal, sample_score, constraint, keep=KEEP)
    runners = _runners_up(scorer, constraint, map_normals, map_scores, normal, sample_score, scenario=scene)
    by_axis = axis_tolerances(scorer, normal, sample_score, constraint)
    report("error bars", 0.95)
    volume = volume_problem(plan.estimator)
    bars = uncertainty_for(mesh, ask, scorer.problem, normal, occlusion=plan.on("occlusion"), tolerance_deg=float(tol),
                           volume=volume, env_samples=plan.env_samples)
    robust = None
    if variation is not None:
        report("scenario variants", 0.96)
        robust = scenario_robustness(mesh, ask, sample_normal, occlusion=plan.on("occlusion"), volume=volume,
                                     env_samples=plan.env_samples, variation=variation,
                                     bar_deg=bars.angle_deg if bars is not None else 0.0, tolerance_deg=float(tol),
                                     optimizer=optimizer,
                                     progress=lambda f: report("scenario variants", 0.96 + 0.03 * f))
    if metrics is None:  # after the bars: their stencil's sums came with every triple's sum at the answer
        metrics = scorer.metrics(normal)
    tilt, az = tilt_azimuth(normal)
    # lamellae parallel to the base score as well as the optimum: that is the instruction
    pole = np.array([0.0, 0.0, 1.0])
    parallel = None
    if tilt >= 0.5 and scorer.score(pole) >= KEEP * sample_score:
        parallel = float(tolerance_deg(scorer.scores, pole, sample_score, constraint, keep=KEEP))
        if parallel < 0.5:  # the base only just keeps 90 %: "any tilt within ±0.0°" is no instruction
            parallel = None
    elif tilt < 0.5:
        parallel = float(tol)
    report("done", 1.0)
    return Recommendation(
        normal=normal, tilt_deg=tilt, azimuth_deg=az, score=float(score), objective=objective, metrics=metrics,
        tolerance_deg=float(tol), tolerance_by_axis=by_axis, runners_up=runners, map_normals=map_normals, map_scores=map_scores,
        optimizer=optimizer, evaluations=scorer.evaluations - evaluations, seconds=time.perf_counter() - start,
        parallel_within_deg=parallel, workshop=workshop(normal, mesh, scene, parallel=parallel is not None),
        mesh=Stone.of(mesh).provenance_dict(), plan=plan.to_dict(), estimator=plan.estimator or "samples", render=render_stats,
        uncertainty=bars, misorientation=misorientation_curve(scorer.energy_map, normal, float(tol), quality),
        robustness=robust,
        settings={
            **ask.to_dict(),
            "scene_peak": scorer.problem.threshold / scorer.problem.tau, "flash_threshold": scorer.problem.threshold,
            "convex": scorer.problem.convex, "surface_samples": scorer.problem.n_points,
            "triples": scorer.problem.n_triples, "lights": len(scene.lights), "views": len(scene.views),
            "estimator": plan.estimator, "occlusion": plan.on("occlusion"), "inter_reflection": plan.on("inter_reflection"),
            "depth": plan.on("depth"), "volume": scorer.problem.info.get("volume"),
            "zoning": render_stats.get("zoning"),
            "time_budget": None if budget is None else budget.to_dict(),
        },
        scenario=scene,
    )


def _no_flash(objective: str, scene: Scenario, tau: float) -> None:
    """No orientation scores above zero: under ``area``/``intensity``/``balanced`` that means no
    point of the stone reaches the flash threshold anywhere (diffuse light spreads the schiller
    thin), and a "best" orientation would be meaningless."""
    if objective == "energy":  # pragma: no cover - build_problem refuses a scene where no light reaches a viewer
        raise ParameterError(f"no light of scenario {scene.name!r} reaches a part of the stone its viewers see")
    raise ParameterError(
        f"under scenario {scene.name!r} ({scene.lights.name} light, {scene.views.name} viewers) no point of the stone reaches "
        f"the flash threshold (tau = {tau:g} x the brightest schiller its light can give) at any lamella orientation, so the {objective!r} objective "
        "is 0 everywhere and cannot rank them; use --objective energy (objective='energy'), which ranks the faint "
        "schiller, or a more directed light"
    )


def axis_tolerances(scorer: Scorer, best: np.ndarray, best_score: float, constraint: Constraint) -> dict[str, float]:
    """How far (degrees) the normal may miss tilting towards the front/back (±Y) and the sides (±X).

    The same ring search as :func:`~labcut.orientation.optimize.tolerance_deg`, restricted
    to the two directions of each axis; the overall tolerance is never larger than either.
    """
    out = {}
    for name, axis in (("front_back_deg", np.array([0.0, 1.0, 0.0])), ("left_right_deg", np.array([1.0, 0.0, 0.0]))):
        out[name] = tolerance_deg(scorer.scores, best, best_score, constraint, keep=KEEP, directions=[axis, -axis])
    return out


def _runners_up(scorer: Scorer, constraint: Constraint, normals: np.ndarray, scores: np.ndarray, best: np.ndarray, best_score: float, count: int = 3, scenario: Scenario | None = None) -> list[dict[str, Any]]:
    """Distinct local maxima of the map: >= 12° from better ones, >= 30 % of the best score
    (:func:`~labcut.orientation.optimize.distinct_optima`, vectorised)."""
    from .optimize import distinct_optima

    out: list[dict[str, Any]] = []
    for polished, value in distinct_optima(scorer, constraint, normals, scores, best, best_score, count=count,
                                           separation_deg=RUNNER_UP_SEPARATION_DEG,
                                           neighbour_deg=1.5 * MAP_SPACING_DEG.get("standard", 2.0)):
        tilt, az = tilt_azimuth(polished)
        out.append({"normal": [float(x) for x in polished], "tilt_deg": tilt, "azimuth_deg": az, "score": float(value),
                    "relative_score": float(value / best_score) if best_score > 0 else 0.0, "description": describe(polished, scenario)})
    return out


def evaluation_metrics(mesh: Any, ask: FlashQuestion, scorer: Scorer, plan: Any, m: np.ndarray) -> FlashMetrics:
    """Flash metrics of the unit lamella normal ``m`` for question ``ask`` about ``mesh``, by the
    estimator ``plan`` names (:func:`~labcut.orientation.estimators.estimator_for`: the sample
    estimator's ``scorer``, or renders)."""
    return estimator_for(plan.estimator, mesh, ask, scorer, plan).metrics(m)
