"""The numbers a comparison adds to each recommendation: how the flash changes when the stone is
tilted, when the cutter misses the optimum, and one orientation that serves several scenarios.

Frames (DESIGN.md §3): lamella normals in the mesh frame (+Z face-up, -Y the front; axial,
reported with z >= 0); tilt axes of the stone in the scenario's world frame (+Z up). Angles
in degrees. Flash values in units of ``L_ref`` (DESIGN.md §4).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..orientation.misorientation import ring
from ..orientation.optimize import Constraint, hemisphere_grid, tolerance_deg
from ..orientation.problem import build_problem
from ..orientation.recommend import KEEP
from ..orientation.scoring import Scorer
from ..scene import Scenario, Setting, Views
from ..scene.quality import Quality
from ..scene.directions import axial_upper, rotation

#: the tilt-performance curve spans ±30° in steps of the quality's ``tilt_step_deg``, on a problem of
#: ``tilt_points`` surface samples (one view per pose, many poses: a curve, not a score)
TILT_RANGE_DEG = 30.0
#: the presets' ``tilt_points`` (read from :class:`~labcut.scene.quality.Quality`)
TILT_POINTS = {name: q.tilt_points for name, q in Quality.PRESETS.items()}
#: a compromise reads "parallel to the base" only when tilts up to at least this many degrees
#: from the base keep 90 % of its score (a base barely at 90 % is no instruction)
PARALLEL_MIN_DEG = 1.0


def _unit(v: Any) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


# ---------------------------------------------------------------------- tilt performance
def tilt_axes(scenario: Scenario) -> dict[str, np.ndarray]:
    """The two axes (world frame, unit) the stone is tilted about, as its main viewer sees it.

    ``front_back``: the horizontal axis across the line of sight (world +X for a viewer in
    front): a positive tilt brings the stone's far (face-up) or top (upright) edge towards the
    viewer. ``side_to_side``: the axis in the picture that points up: a positive tilt turns
    the stone's right edge (+X) away from the viewer."""
    v = _unit(scenario.views.main)
    a1 = np.cross([0.0, 0.0, 1.0], v)
    a1 = np.array([1.0, 0.0, 0.0]) if np.linalg.norm(a1) < 1e-6 else _unit(a1)
    return {"front_back": a1, "side_to_side": _unit(np.cross(v, a1))}


@dataclass
class TiltCurve:
    """Flash seen by the scenario's main viewer when the stone, cut at one lamella orientation, is
    tilted from its rest pose about each of :func:`tilt_axes` (lights and viewer fixed in the
    world). ``flash_energy`` / ``flash_area``: per axis, one value per angle of ``angles_deg``
    (NaN where the viewer sees the face edge-on or from behind)."""

    angles_deg: np.ndarray
    flash_energy: dict[str, np.ndarray]
    flash_area: dict[str, np.ndarray]
    axes: dict[str, np.ndarray]
    surface_points: int
    rock_deg: float = 0.0
    sway_deg: float = 0.0
    notes: list[str] = field(default_factory=list)

    def at_rest(self, key: str = "flash_energy") -> float:
        """The value at the rest pose (angle 0)."""
        i = int(np.argmin(np.abs(self.angles_deg)))
        return float(getattr(self, key)["front_back"][i])

    def to_dict(self) -> dict[str, Any]:
        def clean(a: np.ndarray) -> list[float | None]:
            return [None if not np.isfinite(x) else float(x) for x in a]

        return {
            "angles_deg": self.angles_deg.tolist(),
            "flash_energy": {k: clean(v) for k, v in self.flash_energy.items()},
            "flash_area": {k: clean(v) for k, v in self.flash_area.items()},
            "axes_world": {k: v.tolist() for k, v in self.axes.items()},
            "surface_points": self.surface_points,
            "scenario_rock_deg": self.rock_deg,
            "scenario_sway_deg": self.sway_deg,
            "notes": list(self.notes),
        }


def per_view_flash(problem: Any, normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(flash_energy, flash_area)`` per view of a :class:`~labcut.orientation.problem.FlashProblem`
    at lamella ``normal`` (mesh frame), in float64 numpy: the per-view values of
    :meth:`labcut.orientation.scoring.Scorer.metrics` without building a Dr.Jit scorer (whose
    binned hemisphere map a single normal does not need)."""
    from ..physics.ops import NUMPY
    from ..physics.schiller import lobe_density

    m = _unit(normal)
    q = lobe_density(problem.h.astype(np.float64) @ m, problem.kappa, problem.q_norm, NUMPY)
    radiance = np.bincount(problem.pair, weights=problem.c.astype(np.float64) * q, minlength=problem.pair_view.size)
    views = problem.view_weight.size
    w = problem.pair_weight
    energy = np.bincount(problem.pair_view, weights=w * radiance, minlength=views)
    area = np.bincount(problem.pair_view, weights=w * (radiance >= problem.threshold), minlength=views)
    return energy, area


def tilted_pose(scenario: Scenario, axis: str, angle_deg: float) -> np.ndarray:
    """The scenario's rest pose (mesh to world) tilted by ``angle_deg`` about the world ``axis``
    (``front_back`` or ``side_to_side``, :func:`tilt_axes`)."""
    return rotation(tilt_axes(scenario)[axis], angle_deg) @ scenario.pose


def tilt_settings(scenario: Scenario, quality: Quality | str = "standard") -> tuple[np.ndarray, list[Setting], list[bool]]:
    """The tilt curve's angles (degrees: whole multiples of the quality's ``tilt_step_deg`` within
    ±:data:`TILT_RANGE_DEG`, 0 among them)
    and its settings (mesh frame), front-back tilts then side-to-side, each the scenario's lights
    with its main viewer alone; and whether that viewer sees the face at each (False: edge-on or from
    behind, a placeholder view straight at the face stands in)."""
    step = Quality.coerce(quality).tilt_step_deg
    # whole steps either side of the rest pose (0 among the angles, none beyond the range, also for a
    # step that does not divide it: 7 gives -28 ... 28)
    count = int(math.floor(TILT_RANGE_DEG / step + 1e-9))
    angles = step * np.arange(-count, count + 1, dtype=np.float64)
    axes = tilt_axes(scenario)
    main = _unit(scenario.views.main)
    settings: list[Setting] = []
    seen: list[bool] = []
    for key in ("front_back", "side_to_side"):
        for a in angles:
            pose = rotation(axes[key], float(a)) @ scenario.pose
            v = pose.T @ main
            seen.append(bool(v[2] > 1e-3))
            if not seen[-1]:  # edge-on or from behind: a placeholder view straight at the face, masked below
                v = np.array([0.0, 0.0, 1.0])
            settings.append(Setting(scenario.lights.rotated(pose.T), Views([v], name="main"), 1.0, pose))
    return angles, settings, seen


def tilt_curve(mesh: Any, material: Any, normal: np.ndarray, scenario: Scenario, quality: Quality | str = "standard",
               tau: float = 0.1, seed: int = 0) -> TiltCurve:
    """The tilt-performance curve of a cut at lamella ``normal`` (mesh frame) under ``scenario``.

    One flash problem holds every tilted pose with the main viewer alone, so one evaluation
    gives the flash per pose (the quality's ``tilt_points`` surface samples: a curve, not a score)."""
    quality = Quality.coerce(quality)
    angles, settings, seen = tilt_settings(scenario, quality)
    axes = tilt_axes(scenario)
    n = len(angles)
    energy = np.zeros(2 * n)
    area = np.zeros(2 * n)
    notes: list[str] = []
    try:
        problem = build_problem(mesh, material, quality=quality, tau=tau, seed=seed, n_points=quality.tilt_points,
                                settings=settings)
        energy, area = per_view_flash(problem, normal)
    except ParameterError:  # no light reaches what the main viewer sees, in any pose
        notes.append("no light of the scenario reaches what its main viewer sees at any of these tilts")
    mask = ~np.asarray(seen)
    energy[mask] = np.nan
    area[mask] = np.nan
    if mask.any():
        notes.append(f"at {int(mask.sum())} tilt(s) the main viewer sees the face edge-on or from behind (no value)")
    return TiltCurve(angles, {"front_back": energy[:n], "side_to_side": energy[n:]},
                     {"front_back": area[:n], "side_to_side": area[n:]}, axes, quality.tilt_points,
                     scenario.rock_deg, scenario.sway_deg, notes)


# ---------------------------------------------------------------------- one orientation for several scenarios
@dataclass
class Compromise:
    """One lamella orientation for all chosen scenarios: the normal (mesh frame, z >= 0) that
    maximises the mean over scenarios of each scenario's flash energy divided by that scenario's
    best (``score``, 1 when one orientation is best everywhere). ``relative``: per scenario,
    energy at the compromise / energy at that scenario's own optimum. ``tolerance_deg``: how far
    the normal may miss it in any direction and keep 90 % of ``score``; ``tolerance_by_axis``:
    the same towards the front/back (±Y) and the sides (±X). ``parallel_within_deg``: when lamellae
    parallel to the base keep 90 % of ``score`` too, how far from the base any tilt does (the
    answer is then "parallel to the base", as :func:`labcut.recommend_orientation` says it), when
    that is at least :data:`PARALLEL_MIN_DEG`; else None."""

    normal: np.ndarray
    score: float
    relative: dict[str, float]
    tolerance_deg: float
    tolerance_by_axis: dict[str, float]
    parallel_within_deg: float | None = None


def compromise(scorers: Sequence[Scorer], names: Sequence[str], bests: Sequence[np.ndarray],
               quality: Quality | str = "standard", maps: Sequence[tuple[np.ndarray, np.ndarray]] | None = None) -> Compromise:
    """:class:`Compromise` of one cut: the score of each scenario's energy map (``scorers``, one per
    scenario) normalised by its value at that scenario's optimum (``bests``), averaged. Candidates: every
    scenario's own optimum and the cells of a hemisphere grid (spacing
    the quality's ``map_spacing_deg``), whose energies ``maps`` may give, one
    ``(normals, energies)`` per scenario on the same normals (a recommendation's ``map_normals``,
    ``map_scores``); the best is polished on grids of 0.5° then 0.1°. With one scenario it is that
    scenario's optimum."""
    if not scorers or not (len(scorers) == len(names) == len(bests)):
        raise ParameterError("compromise needs one scorer, name and optimum per scenario")
    best_scores = [float(sc.energy_map(axial_upper(b)[None, :])[0]) for sc, b in zip(scorers, bests)]
    if not all(s > 0 for s in best_scores):
        raise ParameterError("compromise needs a positive energy at every scenario's optimum")
    constraint = Constraint()

    def combined(normals: np.ndarray) -> np.ndarray:
        normals = np.atleast_2d(normals)
        return np.mean([sc.energy_map(normals) / b for sc, b in zip(scorers, best_scores)], axis=0)

    if len(scorers) == 1:
        normal = axial_upper(bests[0])
    else:
        spacing = Quality.coerce(quality).map_spacing_deg
        if maps is not None and len(maps) == len(scorers) and all(np.array_equal(maps[0][0], m[0]) for m in maps):
            grid = np.asarray(maps[0][0], dtype=np.float64)
            values = np.mean([np.asarray(m[1], dtype=np.float64) / b for m, b in zip(maps, best_scores)], axis=0)
        else:
            grid = hemisphere_grid(spacing, constraint)
            values = combined(grid)
        own = np.array([axial_upper(b) for b in bests])
        candidates = np.concatenate([grid, own])
        values = np.concatenate([values, combined(own)])
        normal = candidates[int(np.argmax(values))]
        for radius, step in ((spacing, 0.5), (1.0, 0.1)):
            cand = _cap_grid(normal, radius, step)
            values = combined(cand)
            normal = axial_upper(cand[int(np.argmax(values))])
    score = float(combined(normal[None, :])[0])
    rel = {n: float(sc.energy_map(normal[None, :])[0] / b) for n, sc, b in zip(names, scorers, best_scores)}
    tol = float(tolerance_deg(combined, normal, score, constraint, keep=KEEP))
    by_axis = {}
    for key, axis in (("front_back_deg", np.array([0.0, 1.0, 0.0])), ("left_right_deg", np.array([1.0, 0.0, 0.0]))):
        by_axis[key] = float(tolerance_deg(combined, normal, score, constraint, keep=KEEP, directions=[axis, -axis]))
    pole = np.array([0.0, 0.0, 1.0])
    parallel = None
    if math.degrees(math.acos(min(1.0, float(normal[2])))) < 0.5:
        parallel = tol
    elif float(combined(pole[None, :])[0]) >= KEEP * score:
        within = float(tolerance_deg(combined, pole, score, constraint, keep=KEEP))
        parallel = within if within >= PARALLEL_MIN_DEG else None
    return Compromise(normal, score, rel, tol, by_axis, parallel)


def _cap_grid(centre: np.ndarray, radius_deg: float, step_deg: float) -> np.ndarray:
    """Normals on concentric rings (every ``step_deg``) out to ``radius_deg`` around ``centre``, the centre first."""
    out = [axial_upper(centre)[None, :]]
    for a in np.arange(step_deg, radius_deg + 0.5 * step_deg, step_deg):
        count = max(6, math.ceil(2.0 * math.pi * a / step_deg))
        out.append(ring(centre, float(a), count))
    return np.concatenate(out)


def scorer_for(mesh: Any, material: Any, scenario: Scenario, quality: Quality | str, tau: float = 0.1, seed: int = 0,
               occlusion: bool | None = None) -> Scorer:
    """The energy :class:`Scorer` of a cut under a scenario, built exactly as
    :func:`labcut.recommend_orientation` builds its own (same samples for the same seed, the
    effect plan's ``occlusion``), so its scores equal the recommendation's."""
    problem = build_problem(mesh, material, quality=quality, tau=tau, seed=seed, settings=scenario.settings(),
                            occlusion=occlusion)
    return Scorer(problem, "energy")
