"""Error bars of a recommendation: how far the normal and the score may lie from the converged answer.

A recommendation is computed from a finite problem: ``surface_points`` surface samples
(stratified by default, :func:`labcut.geometry.surface.draw_samples`) and a deterministic set of light and view directions per lamp, environment map and viewing
cone (:class:`~labcut.scene.quality.Quality`). Its answer differs from the converged one
(infinitely many samples and directions) in two ways, and :func:`estimate_uncertainty`
measures each on the problem at hand, in a fraction of the recommendation's time:

* **sampling** (random, the surface points): a Poisson bootstrap over the surface points. It
  treats them as independent draws; stratified ones scatter less than that (docs/accuracy.md,
  "Stratified surface samples"), so this part of the bar is on the safe side.
  The pair radiance ``L_s/L_ref`` of every (point, view) pair is computed once at a small
  stencil of normals around the answer (17 normals within ``r`` degrees, only the triples whose
  mirror orientation lies near it); each of :data:`BOOTSTRAP` replicates reweights the points
  with Poisson(1) counts, re-forms the view-weighted objective (projected-area weights
  renormalised per view, as the estimator does) and fits a quadratic to the stencil: the spread
  of the fitted peaks is the sampling error of the normal, the spread of the peak values that
  of the score.
* **discretisation** (systematic, the directions): a problem with twice as many directions per
  lamp, map, cone and ring at a quarter of the surface points (the same number of terms,
  :func:`finer_directions`) is fitted the same way, its peak followed where it lies beyond the
  stencil (:func:`follow_peak`); the angle between the two peaks and the relative change of the
  score measure the error of the answer's set. (Halving the directions instead said little: a
  coarse set aliases a flash differently from the answer's, and its peak moved 2-7x as far as the
  answer's own error, or, held to the stencil, at most the stencil's radius: docs/accuracy.md.)
  The poses of a rocking motion likewise: a flash lives within a few degrees of pose, so coarse
  pose sets alias it (the benchmark, ``docs/accuracy.md``, finds the oval's energy with 3 and with
  5 front-to-back poses within 3 % of each other, both a third below the converged energy). For a
  scenario that rocks, a problem with twice the poses at a quarter of the surface points
  (:func:`finer_poses`) is fitted too. Both differences also hold the sampling noise of the fewer
  points, which makes them conservative.

The bars are ``sqrt((K σ)² + D²)`` with ``K`` = :data:`COVER` (sampling spread, 2 standard
deviations of the 2-D peak scatter) and ``D`` the discretisation differences, each scaled to the
error it implies (:data:`DIRECTION_FACTOR`, :data:`POSE_FACTOR`, calibrated by the study); also added in
quadrature: the distance between the optimiser's normal and the fitted peak of the full problem
(optimiser and fit error). ``docs/accuracy.md`` shows that these bars cover the distance to the
converged reference on the benchmark cases and under every scenario, and
``tests/test_uncertainty.py`` and ``tests/test_scenario_coverage.py`` check it.

Angles in degrees, normals unit vectors in the mesh frame (axial), scores relative (a share of
the score).
"""

from __future__ import annotations

import functools
import math
import threading
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..backend import Launched
from ..errors import ParameterError
from ..scene.quality import Quality
from .problem import FlashProblem
from .volume import BAR_PATH_BUDGET, build_volume_problem

#: bootstrap replicates of the sampling spread
BOOTSTRAP = 32
#: coverage factor on the sampling spread (standard deviations)
COVER = 2.0
#: the error of a direction set, and of a pose set, over its difference to twice as many: if the
#: errors fall by r per doubling, the difference is (1 - 1/r) of the error, so the error is
#: r / (r - 1) times the difference. Directions: 2. No steady r can be measured: under the worn
#: scenarios the answers move between flashes of nearly equal energy, and the ratio of successive
#: differences ranges over 0.1-10 (benchmarks/direction_convergence.py), so the factor is
#: calibrated on the study of every scenario (docs/accuracy.md): at 2 the median distance to the
#: reference is 0.48 of the bar, as for a 2-D normal error whose bar covers 95 % (1.18 / 2.45
#: standard deviations). Poses: 2.5 at r = 1.7
#: (the accuracy study's 1.7-2.5x per doubling of the poses)
DIRECTION_FACTOR = 2.0
POSE_FACTOR = 2.5
#: how many times a discretisation problem's peak is followed to a new stencil (:func:`follow_peak`)
FOLLOW_STEPS = 8
#: stencil: rings at these fractions of the fit radius, directions per ring
RINGS = (0.5, 1.0)
RING_DIRECTIONS = 8


@dataclass(frozen=True)
class Uncertainty:
    """Error bars of an answer (about 95 % coverage of the distance to the converged answer).

    ``angle_deg``: angle (degrees) within which the converged normal lies; ``score_rel``: relative
    error of the score (0.05 = ±5 %). The parts: ``sampling_*`` (bootstrap over the surface
    points, :data:`COVER` standard deviations), ``discretisation_*`` (difference to twice as
    many light and view directions and rocking poses), ``fit_angle_deg`` (optimiser's normal to the fitted peak);
    ``radius_deg`` the stencil radius, ``method`` how it was estimated."""

    angle_deg: float
    score_rel: float
    sampling_angle_deg: float
    sampling_score_rel: float
    discretisation_angle_deg: float
    discretisation_score_rel: float
    fit_angle_deg: float
    radius_deg: float
    replicates: int
    method: str = "bootstrap over surface points + finer-direction and finer-pose differences"
    #: the raw differences behind ``discretisation_*`` (before :data:`DIRECTION_FACTOR` and
    #: :data:`POSE_FACTOR`): the finer-direction and the finer-pose problem's peak against the
    #: answer's, degrees and a share of the score (0 where not made)
    directions_angle_deg: float = 0.0
    directions_score_rel: float = 0.0
    poses_angle_deg: float = 0.0
    poses_score_rel: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: Any) -> Uncertainty | None:
        """The inverse of :meth:`to_dict`; None for an empty or missing block (older JSON)."""
        if not data:
            return None
        if not isinstance(data, dict):
            raise ParameterError("uncertainty must be a JSON object")
        try:
            optional = ("directions_angle_deg", "directions_score_rel", "poses_angle_deg", "poses_score_rel")
            values: dict[str, Any] = {k: float(data[k]) for k in cls.__dataclass_fields__
                                      if k not in ("replicates", "method") and (k in data or k not in optional)}
            values["replicates"] = int(data["replicates"])
            if "method" in data:
                values["method"] = str(data["method"])
            return cls(**values)
        except (KeyError, TypeError, ValueError) as exc:
            raise ParameterError(f"uncertainty: bad or missing field ({exc})") from None

    def scaled(self, factor: float) -> Uncertainty:
        """The same bars times ``factor`` (for tests and calibration studies)."""
        f = float(factor)
        return Uncertainty(self.angle_deg * f, self.score_rel * f, self.sampling_angle_deg * f, self.sampling_score_rel * f,
                           self.discretisation_angle_deg * f, self.discretisation_score_rel * f, self.fit_angle_deg * f,
                           self.radius_deg, self.replicates, self.method, self.directions_angle_deg * f,
                           self.directions_score_rel * f, self.poses_angle_deg * f, self.poses_score_rel * f)


def finer_directions(quality: Quality) -> Quality:
    """``quality`` with twice as many directions per lamp, environment map, viewing cone and ring
    and a quarter of the surface samples (the same number of terms): the error bars' check of the
    answer's direction sets."""
    return quality.replace(surface_points=max(500, quality.surface_points // 4),
                           lamp_samples=2 * quality.lamp_samples, env_samples=2 * quality.env_samples,
                           cone_views=2 * quality.cone_views, ring_views=2 * quality.ring_views)


def finer_poses(quality: Quality) -> Quality:
    """``quality`` with twice the moved poses of each rocking line and a quarter of the surface
    samples (the same number of terms): the rocking motion's quadrature, checked as the direction
    sets are (:func:`finer_directions`: a flash lives within a few degrees of pose, and at draft's
    15° pose spacing a coarser set aliases it too)."""
    def double(k: int) -> int:
        moved = k - k % 2
        return 2 * moved + 1

    return quality.replace(surface_points=max(500, quality.surface_points // 4),
                           rock_steps=tuple(double(s) for s in quality.rock_steps))


def tangent_basis(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors orthogonal to the unit vector ``m`` and to each other."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(m[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(m, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(m, e1)


def stencil(m: np.ndarray, radius_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Normals around ``m`` (the centre and :data:`RINGS` rings) and their tangent-plane
    coordinates (degrees, along :func:`tangent_basis`)."""
    e1, e2 = tangent_basis(m)
    xy = [(0.0, 0.0)]
    for k, frac in enumerate(RINGS):
        for j in range(RING_DIRECTIONS):
            phi = 2.0 * math.pi * (j + 0.5 * k) / RING_DIRECTIONS
            xy.append((frac * radius_deg * math.cos(phi), frac * radius_deg * math.sin(phi)))
    xy_a = np.array(xy)
    theta = np.radians(np.hypot(xy_a[:, 0], xy_a[:, 1]))
    phi = np.arctan2(xy_a[:, 1], xy_a[:, 0])
    normals = (np.cos(theta)[:, None] * m[None, :]
               + np.sin(theta)[:, None] * (np.cos(phi)[:, None] * e1[None, :] + np.sin(phi)[:, None] * e2[None, :]))
    return normals, xy_a


def fit_peaks(xy: np.ndarray, values: np.ndarray, radius_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Peaks of quadratics fitted to rows of ``values`` (R, K) over stencil coordinates ``xy``
    (K, 2): ``(peaks (R, 2) in degrees, peak values (R,))``. A fit that is not concave, or
    whose peak lies beyond the stencil, falls back on the best stencil point. All rows at once
    (the 2 x 2 Hessians' concavity and stationary points in closed form)."""
    peaks, heights, _ = _fit(xy, values, radius_deg)
    return peaks, heights


def _fit(xy: np.ndarray, values: np.ndarray, radius_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`fit_peaks` and, per row, whether its fitted peak lies inside the stencil (else the
    peak is the best stencil point)."""
    x, y = xy[:, 0], xy[:, 1]
    design = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=1)
    coef = np.linalg.lstsq(design, values.T, rcond=None)[0].T  # (R, 6)
    a, b, c = 2.0 * coef[:, 3], coef[:, 4], 2.0 * coef[:, 5]  # Hessian [[a, b], [b, c]]
    det = a * c - b * b
    concave = (a < 0.0) & (det > 0.0)  # both eigenvalues negative
    safe = np.where(concave, det, 1.0)
    # the stationary point -H^-1 g of g = (c1, c2)
    px = -(c * coef[:, 1] - b * coef[:, 2]) / safe
    py = -(a * coef[:, 2] - b * coef[:, 1]) / safe
    inside = concave & (np.hypot(px, py) <= radius_deg)
    best = np.argmax(values, axis=1)
    rows = np.arange(len(values))
    peaks = np.where(inside[:, None], np.stack([px, py], axis=1), xy[best])
    fitted = (coef[:, 0] + coef[:, 1] * px + coef[:, 2] * py + coef[:, 3] * px * px + coef[:, 4] * px * py
              + coef[:, 5] * py * py)
    heights = np.where(inside, fitted, values[rows, best])
    return peaks, heights, inside


def offset_normal(m: np.ndarray, xy: Any) -> np.ndarray:
    """The unit normal at tangent-plane coordinates ``xy`` (degrees, along :func:`tangent_basis`)
    from the unit normal ``m``: the inverse of the stencil's coordinates."""
    e1, e2 = tangent_basis(m)
    x, y = float(xy[0]), float(xy[1])
    theta = math.radians(math.hypot(x, y))
    phi = math.atan2(y, x)
    return math.cos(theta) * m + math.sin(theta) * (math.cos(phi) * e1 + math.sin(phi) * e2)


def follow_peak(problem: Any, m: np.ndarray, radius_deg: float, objective: str,
                radiance: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """The peak of ``problem``'s objective near the unit normal ``m``: ``(unit normal, value)``.
    A quadratic is fitted to the stencil around ``m`` (``radiance``: its pair sums, when made
    already); where the fitted peak lies beyond the stencil, or the fit is not concave, the
    stencil moves to its best point and fits again, up to :data:`FOLLOW_STEPS` times. A
    discretisation problem's peak can lie several stencil radii away (a flat landscape whose
    direction sets alias differently): a fit that stopped at the first stencil would read at most
    its radius as the difference."""
    centre = m
    for step in range(FOLLOW_STEPS + 1):
        normals, xy = stencil(centre, radius_deg)
        values = stencil_values(problem, normals, objective, radiance=radiance if step == 0 else None)
        peaks, heights, inside = _fit(xy, values, radius_deg)
        if inside[0]:
            return offset_normal(centre, peaks[0]), float(heights[0])
        best = int(np.argmax(values[0]))
        if best == 0:  # the centre is the best point (a flat or ridged top): stay
            return centre, float(values[0, 0])
        centre = normals[best] / np.linalg.norm(normals[best])
    return centre, float(heights[0])


def pair_radiance(problem: FlashProblem, normals: np.ndarray) -> np.ndarray:
    """``L_s/L_ref`` of every (point, view) pair at each normal (P, K), float64, summed over the
    triples whose mirror orientation lies within the lobe's reach of the normals (terms below
    ``exp(-12.5)`` of the lobe's peak are dropped)."""
    normals = np.asarray(normals, dtype=np.float64)
    reach = _reach(problem.kappa, normals)
    return problem.pair_radiance(normals, reach)


def _reach(kappa: float, normals: np.ndarray) -> float:
    """The angle (radians) from ``normals[0]`` within which :func:`pair_radiance` sums triples."""
    from .problem import lobe_reach

    centre = normals[0]
    spread = float(np.degrees(np.arccos(np.clip(np.abs(normals @ centre), 0.0, 1.0))).max())
    return lobe_reach(kappa, math.radians(spread))


#: bytes of the (points x views x columns) float32 layout :func:`objective_values` fills per product:
#: views go in groups of at most this much (a high-quality problem's every view at once would take
#: hundreds of MB)
VALUES_BLOCK_BYTES = 32 << 20


def objective_values(problem: FlashProblem, radiance: np.ndarray, point_weights: np.ndarray, objective: str) -> np.ndarray:
    """The objective at each stencil normal for each set of surface-point weights (R, n_points):
    (R, K). Weights 1 give the problem's own estimator (DESIGN.md §4's metrics). ``objective``
    ``"all"``: energy, area and intensity at once, (3, R, K).

    The views' sums a group at a time: a pair is one (point, view), so the pairs' values laid out by
    point and view, ``X[point, view, column]`` (zero where the point does not face the view), give
    each replicate's weighted sums per view as one product ``W @ X`` (float32 BLAS: the weights are
    small whole numbers, exact in float32, and the sums' rounding, ~1e-7 of them, lies far below
    the bootstrap's spread; the projected areas that divide them in float64). Columns: the pairs'
    ``pair weight x L_s/L_ref`` per normal (energy) and, for the thresholded objectives, their
    flashing area and in-flash radiance. A standard problem's views fit one group
    (:data:`VALUES_BLOCK_BYTES`)."""
    pw = problem.pair_weight.astype(np.float64)
    pv = np.asarray(problem.pair_view)
    pp = problem.info.get("pair_point")
    pp = np.arange(pw.size) if pp is None else np.asarray(pp)  # without points: a bootstrap over pairs
    n_w, n_views, K = point_weights.shape[1], problem.view_weight.size, radiance.shape[1]
    x = pw[:, None] * radiance
    blocks = [x]
    if objective != "energy":
        flash = radiance >= problem.threshold
        blocks += [np.where(flash, pw[:, None], 0.0), np.where(flash, x, 0.0)]
    values = np.concatenate(blocks, axis=1) if len(blocks) > 1 else x
    cols = values.shape[1]
    w32 = point_weights.astype(np.float32)
    group = max(1, min(n_views, VALUES_BLOCK_BYTES // max(1, 4 * n_w * (cols + 1))))
    per_view = np.empty((point_weights.shape[0], n_views, cols))
    order = bounds = None
    if group < n_views:  # the pairs of each group of views
        order = np.argsort(pv, kind="stable")
        bounds = np.searchsorted(pv[order], np.arange(0, n_views + group, group).clip(max=n_views))
    for g, v0 in enumerate(range(0, n_views, group)):
        v1 = min(n_views, v0 + group)
        seg = slice(None) if order is None else order[bounds[g]:bounds[g + 1]]
        X = _zeroed_buffer((n_w, v1 - v0, cols + 1))  # the last column: the pair's projected area
        X[pp[seg], pv[seg] - v0, :cols] = values[seg]
        X[pp[seg], pv[seg] - v0, cols] = pw[seg]
        sums = (w32 @ X.reshape(n_w, (v1 - v0) * (cols + 1))).reshape(-1, v1 - v0, cols + 1).astype(np.float64)
        # each view's mean over its visible area under each replicate's weights
        per_view[:, v0:v1] = sums[:, :, :cols] / np.maximum(sums[:, :, cols:], 1e-300)
    wv = problem.view_weight.astype(np.float64)
    energy = np.einsum("rvk,v->rk", per_view[:, :, :K], wv)
    if objective == "energy":
        return energy
    ar_v, in_v = per_view[:, :, K:2 * K], per_view[:, :, 2 * K:]
    area = np.einsum("rvk,v->rk", ar_v, wv)
    if objective == "area":
        return area
    intensity = np.einsum("rvk,v->rk", np.where(ar_v > 1e-12, in_v / np.maximum(ar_v, 1e-12), 0.0), wv)
    if objective == "intensity":
        return intensity
    if objective == "all":
        return np.stack([energy, area, intensity])
    return np.sqrt(np.maximum(area * intensity, 0.0))


_BUFFERS = threading.local()


def _zeroed_buffer(shape: tuple[int, int, int]) -> np.ndarray:
    """A zeroed float32 array of ``shape``, this thread's own, kept for the next call of the same
    shape (at most :data:`VALUES_BLOCK_BYTES`): zeroing a kept array costs a memset, a fresh one page
    faults at every recommendation."""
    held = getattr(_BUFFERS, "array", None)
    if held is None or held.shape != shape:
        held = np.zeros(shape, dtype=np.float32)
        _BUFFERS.array = held if held.nbytes <= VALUES_BLOCK_BYTES else None
    else:
        held.fill(0.0)
    return held


def stencil_values(problem: Any, normals: np.ndarray, objective: str, radiance: np.ndarray | None = None) -> np.ndarray:
    """The objective at each stencil normal with every surface point weighted 1 (the problem's own
    estimator): (1, K), from the stencil's pair sums (:func:`pair_radiance`, or ``radiance`` when
    they are made already). The energy is linear in the pair radiances: their ``pair_alpha``
    weighted sum; the thresholded objectives go through :func:`objective_values`."""
    if radiance is None:
        radiance = pair_radiance(problem, normals)
    if objective == "energy":
        return (problem.pair_alpha @ radiance)[None, :]
    return objective_values(problem, radiance, np.ones((1, _point_count(problem))), objective)


def _launch_stencil_sums(problem: Any, normals: np.ndarray) -> Launched[np.ndarray] | None:
    """:func:`pair_radiance` of ``problem`` (None: none) at the stencil ``normals``, launched
    (``launch_pair_radiance``): the result's ``value`` is the sums."""
    if problem is None:
        return None
    return problem.launch_pair_radiance(np.asarray(normals, dtype=np.float64), _reach(problem.kappa, normals))


def _point_count(problem: FlashProblem) -> int:
    pp = problem.info.get("pair_point")
    return int(problem.n_points if pp is not None else problem.pair_view.size)


def stencil_radius(tolerance_deg: float | None) -> float:
    """The stencil radius (degrees) for an answer of tolerance ``tolerance_deg``: half of it, within 0.3-3°."""
    return float(np.clip(0.5 * (tolerance_deg if tolerance_deg and math.isfinite(tolerance_deg) else 3.0), 0.3, 3.0))


def _stratified(problem: FlashProblem) -> bool:
    """Whether ``problem``'s surface samples are stratified, one to a stratum in point order
    (:func:`labcut.geometry.surface.draw_samples`): a problem that does not say is taken as random."""
    return problem.info.get("sampling") == "stratified"


@functools.lru_cache(maxsize=4)
def bootstrap_weights(seed: int, points: int, replicates: int, stratified: bool = False) -> np.ndarray:
    """(replicates + 1, points) float64 surface-point weights of the bootstrap: a row of ones (the
    problem's own estimator), then ``replicates`` rows from the stream of ``seed``. Read-only and
    kept for the last few arguments: the same for every recommendation of a question, so they are
    drawn once.

    Random samples (``stratified`` False) are independent draws: each row holds Poisson(1) counts.
    Stratified samples hold one point per stratum, in stratum order, and the spread between
    independent draws is not what they scatter by: neighbouring strata are paired (collapsed
    strata) and each pair's weights are (2, 0) or (0, 2), even odds, so a replicate's mean moves by
    ``±(x_2k - x_2k+1) / N`` per pair, whose variance ``Σ (x_2k - x_2k+1)² / N²`` is the
    stratified mean's when a pair's strata share their mean (more where they do not: on the safe
    side). An odd last point keeps weight 1."""
    rng = np.random.default_rng(int(seed) + 7919)
    if not stratified:
        rows = rng.poisson(1.0, (replicates, points)).astype(np.float64)
    else:
        rows = np.ones((replicates, points))
        pairs = points // 2
        first = 2.0 * rng.integers(0, 2, (replicates, pairs))
        rows[:, 0:2 * pairs:2] = first
        rows[:, 1:2 * pairs:2] = 2.0 - first
    weights = np.vstack([np.ones(points), rows]).astype(np.float64)
    weights.setflags(write=False)
    return weights


def estimate_uncertainty(problem: FlashProblem, normal: Any, objective: str = "energy", *,
                         dense: FlashProblem | None = None, fine: FlashProblem | None = None,
                         tolerance_deg: float | None = None,
                         replicates: int = BOOTSTRAP, seed: int = 0) -> Uncertainty:
    """Error bars of the answer ``normal`` (unit, mesh frame) of ``problem`` (module docstring).

    ``dense``: twice the directions at a quarter of the points (:func:`finer_directions`);
    ``fine``: twice the rocking poses at a quarter of the points (:func:`finer_poses`, for a
    scenario that rocks); each None: that discretisation part left out (they add in quadrature). ``tolerance_deg``: the answer's tolerance, which sets the
    stencil radius (half of it, within 0.3-3°)."""
    m = np.asarray(normal, dtype=np.float64)
    if m.shape != (3,) or not np.all(np.isfinite(m)) or not np.linalg.norm(m) > 0:
        raise ParameterError(f"normal must be three finite numbers, not all zero, got {normal!r}")
    m = m / np.linalg.norm(m)
    if not isinstance(replicates, int) or replicates < 4:
        raise ParameterError(f"replicates must be a whole number >= 4, got {replicates!r}")
    radius = stencil_radius(tolerance_deg)
    normals, xy = stencil(m, radius)
    # every problem's stencil sums launched at once: the discretisation problems' kernels run on
    # Dr.Jit's threads while the host makes the answer's bootstrap
    launched = [_launch_stencil_sums(p, normals) for p in (problem, dense, fine)]
    rad = launched[0].value
    weights = bootstrap_weights(seed, _point_count(problem), replicates, _stratified(problem))
    values = objective_values(problem, rad, weights, objective)
    peaks, heights = fit_peaks(xy, values, radius)
    base_peak, base_height = peaks[0], heights[0]
    boot = peaks[1:]
    spread = float(np.sqrt(np.mean(np.sum((boot - boot.mean(axis=0)) ** 2, axis=1))))
    scale = abs(base_height) if base_height != 0 else 1.0
    score_sd = float(np.std(heights[1:], ddof=1) / scale)
    fit = float(np.hypot(*base_peak))
    base_normal = offset_normal(m, base_peak)
    raw = {}
    for name, other, sums in (("directions", dense, launched[1]), ("poses", fine, launched[2])):
        if other is None:
            continue
        o_normal, o_height = follow_peak(other, m, radius, objective, radiance=sums.value)
        raw[f"{name}_angle_deg"] = math.degrees(math.acos(min(1.0, abs(float(np.dot(o_normal, base_normal))))))
        raw[f"{name}_score_rel"] = float(abs(o_height - base_height) / scale)
    d_angle, d_score = discretisation(**raw)
    s_angle, s_score = COVER * spread, COVER * score_sd
    return Uncertainty(
        angle_deg=float(math.sqrt(s_angle ** 2 + d_angle ** 2 + fit ** 2)),
        score_rel=float(math.sqrt(s_score ** 2 + d_score ** 2)),
        sampling_angle_deg=s_angle, sampling_score_rel=s_score,
        discretisation_angle_deg=d_angle, discretisation_score_rel=d_score,
        fit_angle_deg=fit, radius_deg=radius, replicates=int(replicates), **raw,
    )


def discretisation(directions_angle_deg: float = 0.0, directions_score_rel: float = 0.0, poses_angle_deg: float = 0.0,
                   poses_score_rel: float = 0.0) -> tuple[float, float]:
    """The discretisation bars ``(angle_deg, score_rel)`` from the raw differences of the
    finer-direction and finer-pose problems: each times its factor, in quadrature."""
    return (math.hypot(DIRECTION_FACTOR * directions_angle_deg, POSE_FACTOR * poses_angle_deg),
            math.hypot(DIRECTION_FACTOR * directions_score_rel, POSE_FACTOR * poses_score_rel))


def uncertainty_for(mesh: Any, setup: Any, problem: FlashProblem, normal: Any, *, occlusion: bool | None,
                    tolerance_deg: float | None, volume: bool = False, env_samples: int | None = None) -> Uncertainty:
    """:func:`estimate_uncertainty` of a recommendation asked as ``setup`` (a
    :class:`~labcut.orientation.question.FlashQuestion`) whose sample problem is ``problem``: the
    finer-direction problem of the same question (:meth:`FlashQuestion.at_quality
    <labcut.orientation.question.FlashQuestion.at_quality>` with :func:`finer_directions`) and, for a
    scenario that rocks, the finer-pose one (:func:`finer_poses`).

    Both are built as pairs only (:func:`labcut.orientation.pairs.build_pairs`): their stencil sums
    make each (pair, light) term in one kernel, within reach of the stencil around ``normal``, the
    terms and sums of whole problems' (:func:`build_problem`) without their triples. With
    ``volume`` (the volume estimator's answer) both are volumetric problems
    (:func:`~labcut.orientation.volume.build_volume_problem`), so that the bars measure the
    discretisation of the same model. With ``env_samples`` (the answer's map seen through that many
    directions, the planner's choice past a carving's parts) the finer-direction problem sees it
    through twice as many, the finer-pose one through as many."""
    from .pairs import build_pairs

    def build(q: Quality, env: int | None) -> Any:
        other = setup.at_quality(q)
        settings = other.scenario.with_env_samples(env).settings()
        if volume:
            return build_volume_problem(mesh, setup.material, other.quality, setup.tau, setup.seed,
                                        settings=settings, occlusion=occlusion, path_budget=BAR_PATH_BUDGET)
        return build_pairs(mesh, setup.material, other.quality, setup.tau, setup.seed, settings, occlusion=occlusion)

    dense = build(finer_directions(setup.quality), None if env_samples is None else 2 * env_samples)
    rocks = setup.scenario.rock_deg > 0.0 or setup.scenario.sway_deg > 0.0
    fine = build(finer_poses(setup.quality), env_samples) if rocks else None
    return estimate_uncertainty(problem, normal, setup.objective, dense=dense, fine=fine, tolerance_deg=tolerance_deg,
                                seed=setup.seed)


#: the metrics :func:`sampling_error` gives a bar for
SAMPLED_METRICS = ("flash_energy", "flash_area", "flash_intensity")


def sampling_error(problem: FlashProblem, normal: Any, *, replicates: int = BOOTSTRAP, seed: int = 0) -> dict[str, float]:
    """The surface-sampling error of the flash metrics at one lamella normal (unit, mesh frame):
    ``{metric: error}`` for :data:`SAMPLED_METRICS`, each :data:`COVER` standard deviations of the
    metric over a Poisson bootstrap of the surface points (the sampling part of
    :func:`estimate_uncertainty`'s score bar, at a given normal instead of at a fitted peak; in the
    metric's own units). What it leaves out: the error of the finite light and view directions,
    which only a recommendation's bars hold. A live view (``labcut explore``) shows it beside the
    metrics of the normal the user set."""
    m = np.asarray(normal, dtype=np.float64)
    if m.shape != (3,) or not np.all(np.isfinite(m)) or not np.linalg.norm(m) > 0:
        raise ParameterError(f"normal must be three finite numbers, not all zero, got {normal!r}")
    if not isinstance(replicates, int) or replicates < 4:
        raise ParameterError(f"replicates must be a whole number >= 4, got {replicates!r}")
    m = (m / np.linalg.norm(m))[None, :]
    radiance = problem.pair_radiance(m, _reach(problem.kappa, m))
    weights = bootstrap_weights(seed, _point_count(problem), replicates, _stratified(problem))[1:]
    values = objective_values(problem, radiance, weights, "all")[:, :, 0]  # energy, area, intensity
    return {name: float(COVER * np.std(v, ddof=1)) for name, v in zip(SAMPLED_METRICS, values)}
