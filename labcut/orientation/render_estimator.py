"""The render estimator of the flash metrics and the lamella normal: Mitsuba renders (DESIGN.md §4).

:func:`render_metrics`: for each view an orthographic image of the schiller lobe alone is
rendered in the mono variant (luminance, as the surface-sample estimator uses) under the
model's distant lights (no ambient), with direct lighting and shadow rays. Pixels are
weighted by their coverage (alpha, box filter), so a pixel's weight is the projected area it
sees; ``L/L_ref`` per pixel gives the same metrics as
:meth:`labcut.orientation.scoring.Scorer.metrics` from independent machinery: Mitsuba's ray
tracing, the BSDF plugin and its tables.

:class:`RenderObjective`: the same images as a differentiable function of the lamella normal
(the scenes built once, one for all poses when only their lamps move; the normal written
through ``mi.traverse``; a fixed seed, so
the objective is deterministic), its gradient by Dr.Jit automatic differentiation through the
integrator (``direct`` for direct lighting, ``prb`` when paths bounce between the parts of a
carving). :func:`optimize_render` climbs it with L-BFGS from a start (the sample estimator's
answer, or a coarse map of renders); :func:`recommend_by_render` is the whole estimator, at a
quality of :class:`RenderQuality` (of the quality's ``estimator_*`` fields); :func:`predict_render_seconds` its cost on this machine,
calibrated by a measurement (:func:`render_timing`).

Frames and units: normals and directions in the mesh frame (mm, +Z face-up); radiance as
``L/L_ref`` (:func:`labcut.orientation.problem.reference_radiance`, lights at unit total
irradiance); times in seconds.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..geometry.stone import Stone

from ..errors import ParameterError
from ..physics.material import Labradorite
from ..scene.directions import normalize_normal
from ..scene import Lights, Setting, Views
from ..scene.quality import Quality
from .radiance import flash_threshold, reference_radiance
from ..validation import check_number
from .render_objective import CARVING_DEPTH, DIRECT_DEPTH, SMOOTH_WIDTH, RenderObjective, flash_integrator
from .scoring import FlashMetrics

__all__ = [
    "RenderObjective", "RenderOptimum", "RenderQuality", "RenderRecommendation", "RenderTiming",
    "SMOOTH_WIDTH", "STALLS", "optimize_render", "predict_render_seconds", "recommend_by_render", "render_metrics",
    "render_timing",
]


def render_metrics(
    mesh: Any,
    material: Labradorite,
    normal: Any,
    lights: Lights | None = None,
    views: Views | None = None,
    tau: float = 0.1,
    resolution: int = 160,
    spp: int = 16,
    seed: int = 0,
    *,
    settings: list[Setting] | None = None,
) -> FlashMetrics:
    """Flash metrics of ``normal`` from rendered images, one per view and pose.

    ``lights``/``views`` (mesh frame, one still pose) or ``settings`` (a scenario's poses,
    as :func:`~labcut.orientation.problem.build_problem` takes them)."""
    import mitsuba as mi

    from ..backend import set_variant
    from ..rendering import bsdf as _bsdf  # noqa: F401
    from ..rendering.api import bsdf_dict
    from ..rendering.scene import CameraView, camera, emitters, stone_entries, to_mitsuba_mesh

    if settings is None:
        if lights is None or views is None:
            raise ParameterError("render_metrics needs lights and views, or settings")
        settings = [Setting(lights, views, 1.0, np.eye(3))]
    m = normalize_normal(normal)
    set_variant("mono")
    l_ref = reference_radiance(material, 1.0)
    threshold = flash_threshold(material, settings[0].lights, tau)  # τ P, in units of L_ref
    stone = to_mitsuba_mesh(mesh, mi.load_dict(bsdf_dict(material, m, ("schiller",))))
    area_v, energy_v, intensity_v, weight_v = [], [], [], []
    pose_total = sum(float(st.weight) for st in settings)
    for st in settings:
        # lights at unit total irradiance, no ambient: L / L_ref as in the sample estimator
        lamps = emitters(st.lights, total_irradiance=1.0, ambient=0.0)
        for d, wv in zip(st.views.directions, st.views.weights):
            weight_v.append(float(st.weight) / pose_total * float(wv))
            sensor = camera(CameraView("v", tuple(d), tuple(st.up())), resolution)
            sensor["film"]["pixel_format"] = "luminance_alpha"
            sensor["film"]["rfilter"] = {"type": "box"}
            scene = mi.load_dict({"type": "scene", "integrator": flash_integrator(), "sensor": sensor, **stone_entries(stone), **lamps})
            img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
            value, alpha = img[..., 0], img[..., 1]
            cover = alpha > 1e-3
            w = alpha[cover]
            ratio = value[cover] / w / l_ref
            flash = ratio >= threshold
            total = float(w.sum())
            a = float((w * flash).sum()) / total if total > 0 else 0.0
            e = float((w * ratio).sum()) / total if total > 0 else 0.0
            i = float((w * ratio * flash).sum()) / float((w * flash).sum()) if a > 0 else 0.0
            area_v.append(a)
            energy_v.append(e)
            intensity_v.append(i)
    wv = np.array(weight_v)
    return FlashMetrics.from_views(area_v, intensity_v, energy_v, wv / wv.sum())


# ---------------------------------------------------------------------------------------------
# The render estimator: the lamella normal optimised through renders
# ---------------------------------------------------------------------------------------------

#: L-BFGS stops after this many evaluations in a row that do not improve on the best
STALLS = 4

@dataclass(frozen=True)
class RenderQuality:
    """The render estimator's settings at one :class:`~labcut.scene.quality.Quality`: image side
    (pixels, orthographic, the stone's bounding sphere fills it), samples per pixel, L-BFGS
    evaluations, and the spacing (degrees) of the coarse map of renders that picks a start when
    none is given. A view of the quality's ``estimator_*`` fields (the one quality table)."""

    resolution: int
    spp: int
    iterations: int
    coarse_deg: float

    @classmethod
    def of(cls, quality: Quality | str | Mapping[str, Any]) -> RenderQuality:
        """The render settings of ``quality`` (a preset name, a Quality or its dict)."""
        q = Quality.coerce(dict(quality) if isinstance(quality, Mapping) else quality)
        return cls(resolution=q.estimator_resolution, spp=q.estimator_spp, iterations=q.estimator_iterations,
                   coarse_deg=q.estimator_coarse_deg)


@dataclass
class RenderOptimum:
    """What :func:`optimize_render` found: the unit normal (mesh frame, z >= 0), its objective
    (hard threshold), the start (inside the constraint) and the objective there as optimised
    (smoothed for the thresholded objectives), and what it cost: objective evaluations, images
    rendered (primal and adjoint), wall seconds."""

    normal: np.ndarray
    score: float
    start_normal: np.ndarray
    start_score: float
    evaluations: int
    renders: int
    seconds: float
    method: str = "lbfgs"


class _Stop(Exception):
    """Raised inside the objective to end an L-BFGS run (nlopt passes it through)."""


def _stereo_clamp(x: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The point of the disc of ``radius`` that ``x`` (u, v) maps to (radially onto the edge from
    outside) and the (2, 2) Jacobian of that map, for the chain rule."""
    r = float(np.hypot(x[0], x[1]))
    if r <= radius:
        return x.copy(), np.eye(2)
    d = x / r
    return d * radius, (radius / r) * (np.eye(2) - np.outer(d, d))


def optimize_render(objective: RenderObjective, start_normal: Any, constraint: Any = None, iterations: int = 20,
                    progress: Callable[[int, int], None] | None = None) -> RenderOptimum:
    """Maximise ``objective`` over the lamella normal from ``start_normal`` with its AD gradients.

    L-BFGS (NLopt ``LD_LBFGS``) in stereographic coordinates ``(u, v)``
    (:func:`~labcut.orientation.scoring.stereo_to_normal`: the upper hemisphere is the unit disc,
    smooth at the pole), within ``constraint`` (:class:`~labcut.orientation.optimize.Constraint`):
    the disc of radius tan(max_tilt / 2), points outside pulled radially onto its edge (with that
    map's Jacobian in the gradient); with a tilt axis, over the one rotation angle about it
    (degrees, bounded by max_tilt). At most ``iterations`` evaluations of value and gradient; the
    best point seen wins (never worse than the start). ``progress(done, total)`` after each."""
    import nlopt

    from .optimize import Constraint
    from .scoring import normal_to_stereo, stereo_jacobian, stereo_to_normal

    constraint = Constraint() if constraint is None else constraint
    if not isinstance(constraint, Constraint):
        raise ParameterError(f"constraint must be a labcut Constraint, got {type(constraint).__name__}")
    iterations = check_number(iterations, "iterations", 1, 10_000, integer=True)
    m0 = normalize_normal(start_normal)
    start = time.perf_counter()
    evals0, renders0 = objective.evaluations, objective.renders
    seen: dict[str, Any] = {"normal": None, "value": -math.inf, "count": 0, "stalls": 0}

    def evaluate(m: np.ndarray) -> tuple[float, np.ndarray]:
        if seen["count"] >= iterations:  # nlopt's maxeval is not checked inside L-BFGS's line search
            raise _Stop
        value, g = objective.value_and_grad(m)
        seen["count"] += 1
        if seen["count"] == 1:
            seen["start_value"] = value
        if value > seen["value"] * (1.0 + 1e-9) or seen["normal"] is None:
            seen["normal"], seen["value"], seen["stalls"] = normalize_normal(m), value, 0
        else:  # no better: L-BFGS's line search is stuck at float32 noise, or the budget is spent
            seen["stalls"] += 1
        if progress is not None:
            progress(min(seen["count"], iterations), iterations)
        if seen["stalls"] >= STALLS:
            raise _Stop
        return value, g

    if constraint.tilt_axis is not None:
        k = np.asarray(constraint.tilt_axis)
        z = np.array([0.0, 0.0, 1.0])
        lim = constraint.max_tilt_deg
        a0 = float(np.clip(math.degrees(math.atan2(float(np.cross(z, m0) @ k), float(m0 @ z))), -lim, lim))

        def f(x: np.ndarray, grad: np.ndarray) -> float:
            t = math.radians(float(x[0]))
            value, g = evaluate(constraint.axis_normal(float(x[0])))
            if grad.size:  # d normal / d angle (degrees) of Rodrigues' rotation of +Z about k
                dn = (-z * math.sin(t) + np.cross(k, z) * math.cos(t) + k * (k @ z) * math.sin(t)) * (math.pi / 180.0)
                grad[0] = float(g @ dn)
            return value

        opt = nlopt.opt(nlopt.LD_LBFGS, 1)
        opt.set_lower_bounds([-lim])
        opt.set_upper_bounds([lim])
        opt.set_xtol_abs(1e-3)  # degrees
        x0 = [a0]
        seen["start"] = constraint.axis_normal(a0)
    else:
        radius = constraint.radius
        u0, v0 = normal_to_stereo(m0)
        x_start, _ = _stereo_clamp(np.array([u0, v0]), radius)

        def f(x: np.ndarray, grad: np.ndarray) -> float:
            p, jac = _stereo_clamp(np.asarray(x, dtype=np.float64), radius)
            value, g = evaluate(stereo_to_normal(float(p[0]), float(p[1])))
            if grad.size:
                grad[:] = jac.T @ (stereo_jacobian(float(p[0]), float(p[1])).T @ g)
            return value

        opt = nlopt.opt(nlopt.LD_LBFGS, 2)
        opt.set_lower_bounds([-radius, -radius])
        opt.set_upper_bounds([radius, radius])
        opt.set_xtol_abs(2e-5)  # ~0.002° in u, v near the pole
        x0 = [float(x_start[0]), float(x_start[1])]
        seen["start"] = stereo_to_normal(*x0)
    opt.set_max_objective(f)
    opt.set_ftol_rel(1e-7)
    opt.set_maxeval(iterations)
    try:
        opt.optimize(x0)
    except _Stop:  # the budget is spent, or L-BFGS stalls at float32 noise
        pass
    except Exception as exc:  # noqa: BLE001
        # nlopt's own stops (ForcedStop, RoundoffLimited, a failed line search: nlopt.runtime_error)
        # keep the best point seen; anything raised by the objective itself goes on up
        if not type(exc).__module__.startswith("nlopt"):
            raise
    if seen["normal"] is None:  # pragma: no cover - nlopt always evaluates the start
        raise ParameterError("the render optimiser made no evaluation")
    best = seen["normal"]
    if objective.objective == "energy":  # the optimised value is the score: no extra render
        score = float(seen["value"])
    else:
        score = objective.value(best)
    return RenderOptimum(best, score, normalize_normal(seen["start"]), float(seen["start_value"]), objective.evaluations - evals0,
                         objective.renders - renders0, time.perf_counter() - start)


@dataclass
class RenderRecommendation:
    """The render estimator's answer (:func:`recommend_by_render`): the lamella normal (unit, mesh
    frame, z >= 0), its score under the objective (hard threshold), every flash metric from the
    same renders, and ``stats`` (settings and costs: plain JSON)."""

    normal: np.ndarray
    score: float
    metrics: FlashMetrics
    stats: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"normal": [float(x) for x in self.normal], "score": float(self.score),
                "metrics": self.metrics.to_dict(), "stats": self.stats}


def recommend_by_render(mesh: Any, material: Any, settings: Sequence[Setting], start_normal: Any = None,
                        objective: str = "energy", tau: float = 0.1, constraint: Any = None, quality: Quality | str = "standard",
                        seed: int = 0, progress: Callable[[str, float], None] | None = None, *,
                        max_depth: int | None = None, zoning: Any = None) -> RenderRecommendation:
    """The render estimator end to end: the lamella normal that maximises ``objective`` through
    renders (:class:`RenderObjective`, :func:`optimize_render`), at a quality of
    :class:`RenderQuality` (of the quality's ``estimator_*`` fields) (image size, samples per pixel, L-BFGS evaluations).

    ``settings``: a scenario's poses (:meth:`labcut.Scenario.settings`, mesh frame).
    ``start_normal``: where the optimiser starts (e.g. the sample estimator's answer); None: the
    best normal of a coarse map of rendered objective values over the allowed hemisphere (spacing
    :attr:`RenderQuality.coarse_deg`). ``constraint``: a
    :class:`~labcut.orientation.optimize.Constraint` (max tilt, optional tilt axis).
    ``max_depth``: path depth (default 2 for a convex stone, 4 for a carving; see
    :class:`RenderObjective`). ``zoning``: colour zones (``"smooth"``, ``"sharp"``, a
    :class:`~labcut.rendering.zoning.Zoning`): each point of the stone flashes with its own
    lamella stack, so the objective weighs the zones as a viewer sees them. ``progress(stage, fraction)`` as :func:`labcut.recommend_orientation`.
    The thresholded objectives are optimised through a logistic relaxation of the threshold
    (:data:`SMOOTH_WIDTH` x tau wide) and scored with the hard threshold."""
    from .optimize import Constraint, hemisphere_grid

    q = RenderQuality.of(quality)
    constraint = Constraint() if constraint is None else constraint
    if not isinstance(constraint, Constraint):
        raise ParameterError(f"constraint must be a labcut Constraint, got {type(constraint).__name__}")
    start_given = start_normal is not None
    if start_given:
        start_normal = normalize_normal(start_normal)  # bad input fails before any scene is built
    report = progress or (lambda stage, fraction: None)
    t0 = time.perf_counter()
    report("building the render scenes", 0.0)
    obj = RenderObjective(mesh, material, settings, tau=tau, resolution=q.resolution, spp=q.spp, seed=seed,
                          objective=objective, max_depth=max_depth, zoning=zoning)
    map_normals = 0
    if not start_given:
        normals = hemisphere_grid(q.coarse_deg, constraint)
        map_normals = len(normals)
        values = []
        for k, n in enumerate(normals):
            values.append(obj.value(n))
            report("coarse map of renders", 0.05 + 0.25 * (k + 1) / len(normals))
        start_normal = normals[int(np.argmax(values))]
    report("optimising through renders", 0.3)
    best = optimize_render(obj, start_normal, constraint, q.iterations,
                           progress=lambda done, total: report("optimising through renders", 0.3 + 0.6 * done / total))
    report("metrics at the optimum", 0.9)
    metrics = obj.metrics(best.normal)
    report("done", 1.0)
    stats = {
        "estimator": "render", "quality": Quality.coerce(quality).name, "resolution": q.resolution, "spp": q.spp, "iterations": q.iterations,
        "seed": int(seed), "integrator": obj.integrator, "max_depth": obj.max_depth, "convex": obj.convex,
        "views": obj.n_views, "objective": objective, "tau": float(tau),
        "zoning": None if obj.zoning is None else (obj.zoning.name or "custom"),
        "smooth_width": None if objective == "energy" else obj.smooth_width,
        "start": "given" if start_given else f"coarse map of {map_normals} normals ({q.coarse_deg:g}° apart)",
        "start_normal": [float(x) for x in best.start_normal], "start_score": best.start_score,
        "evaluations": obj.evaluations, "renders": obj.renders, "render_seconds": obj.render_seconds,
        "seconds": time.perf_counter() - t0,
    }
    return RenderRecommendation(best.normal, float(metrics.score(objective)), metrics, stats)


# ---------------------------------------------------------------------------------------------
# Cost model, calibrated on this machine
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class RenderTiming:
    """Measured cost of the render estimator's renders on this machine (seconds). Per integrator
    (``direct``, ``prb`` at depth 4): a view's primal render and its adjoint pass each cost
    ``a + b x pixels x spp``; ``compile`` is the first evaluation's extra time (kernel tracing
    and compilation, once a process; Dr.Jit's on-disk cache shortens it on later runs) and
    ``setup`` the scene building per view."""

    primal: dict[str, tuple[float, float]]
    adjoint: dict[str, tuple[float, float]]
    compile: dict[str, float]
    setup: float
    key: str

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


#: the user-cache file of the calibration (:func:`render_timing`)
_TIMING_FILE = "render-estimator-timing.json"
#: calibration renders: (resolution, spp) pairs, small and large, to split per-call from per-sample cost
_CAL_POINTS = ((24, 2), (64, 8))


def _timing_key() -> str:
    import os

    import mitsuba as mi

    from ..backend import variant_name

    return f"{variant_name('mono')} mitsuba {mi.__version__} cpus {os.cpu_count()} v1"


def measure_render_timing() -> RenderTiming:
    """Time the render estimator here: a sphere, one overhead lamp set and one view, each
    integrator at two image sizes (a few seconds). :func:`render_timing` caches the result."""
    import trimesh

    from ..scene import resolve_scene

    sphere = Stone(trimesh.creation.icosphere(subdivisions=3, radius=5.0), convex=True).mesh
    st = resolve_scene(lighting="overhead", viewing="face-up", quality="draft").settings()[0]
    one = Setting(st.lights, type(st.views)(st.views.directions[:1]), 1.0, st.pose)
    material = Labradorite()
    normal = np.array([0.05, 0.02, 1.0])
    primal: dict[str, tuple[float, float]] = {}
    adjoint: dict[str, tuple[float, float]] = {}
    compile_s: dict[str, float] = {}
    setup = 0.0
    for integ, depth in (("direct", DIRECT_DEPTH), ("prb", CARVING_DEPTH)):
        rows = []
        for k, (res, spp) in enumerate(_CAL_POINTS):
            t = time.perf_counter()
            obj = RenderObjective(sphere, material, [one], resolution=res, spp=spp, max_depth=depth)
            setup = max(setup, time.perf_counter() - t) if integ == "direct" and k == 0 else setup
            if k == 0:  # the first evaluation traces and compiles the kernels
                t = time.perf_counter()
                obj.value_and_grad(normal)
                first = time.perf_counter() - t
            best_p = best_a = math.inf
            for _ in range(2):
                obj.render_seconds = 0.0
                t = time.perf_counter()
                obj.images(normal)
                p = time.perf_counter() - t
                t = time.perf_counter()
                obj.value_and_grad(normal)
                a = max(time.perf_counter() - t - p, 1e-6)
                best_p, best_a = min(best_p, p), min(best_a, a)
            rows.append((res * res * spp, best_p, best_a))
            if k == 0:
                compile_s[integ] = max(first - best_p - best_a, 0.0)
        (n0, p0, a0), (n1, p1, a1) = rows
        for out, y0, y1 in ((primal, p0, p1), (adjoint, a0, a1)):
            b = max((y1 - y0) / (n1 - n0), 0.0)
            out[integ] = (max(y0 - b * n0, 0.0), b)
    return RenderTiming(primal, adjoint, compile_s, setup, _timing_key())


def render_timing(refresh: bool = False) -> RenderTiming:
    """The calibration of :func:`predict_render_seconds`: measured once on this machine
    (:func:`measure_render_timing`) and kept in the user cache (:func:`labcut.fileio.calibration`,
    ``render-estimator-timing.json`` beside Dr.Jit's kernel cache), again whenever the Mitsuba
    variant, version or CPU count differ."""
    from ..fileio import calibration

    key = _timing_key()

    def read(data: dict[str, Any]) -> RenderTiming:
        return RenderTiming({k: (float(v[0]), float(v[1])) for k, v in data["primal"].items()},
                            {k: (float(v[0]), float(v[1])) for k, v in data["adjoint"].items()},
                            {k: float(v) for k, v in data["compile"].items()}, float(data["setup"]), key)

    return read(calibration(_TIMING_FILE, key, lambda: measure_render_timing().to_dict(), check=read, refresh=refresh,
                            timed=True))


def predict_render_seconds(n_views_total: int, resolution: int, spp: int, convex: bool, iterations: int | None = None,
                           coarse_normals: int = 0, max_depth: int | None = None) -> float:
    """Predicted wall seconds of :func:`recommend_by_render` on this machine (calibrated by
    :func:`render_timing`): scene set-up and kernel compilation, ``iterations`` L-BFGS evaluations
    (a primal render and an adjoint pass per view each; default: the ``standard`` quality's), the
    metrics at the optimum (a primal per view) and a coarse start map of ``coarse_normals`` normals
    (a primal per view each; 0 when the start is given). ``convex`` picks the integrator as
    :class:`RenderObjective` does (``max_depth`` overrides it)."""
    n_views = check_number(n_views_total, "n_views_total", 1, 1_000_000, integer=True)
    res = check_number(resolution, "resolution", 8, 4096, integer=True)
    spp = check_number(spp, "spp (samples per pixel)", 1, 1 << 16, integer=True)
    iters = Quality.PRESETS["standard"].estimator_iterations if iterations is None else check_number(iterations, "iterations", 1, 10_000, integer=True)
    coarse = check_number(coarse_normals, "coarse_normals", 0, 1_000_000, integer=True)
    depth = (DIRECT_DEPTH if convex else CARVING_DEPTH) if max_depth is None else check_number(max_depth, "max_depth", 2, 16, integer=True)
    integ = "direct" if depth == DIRECT_DEPTH else "prb"
    t = render_timing()
    samples = res * res * spp
    a_p, b_p = t.primal[integ]
    a_a, b_a = t.adjoint[integ]
    primal = a_p + b_p * samples
    adjoint = a_a + b_a * samples
    if integ == "prb":  # deeper paths cost in proportion to their extra bounces (calibrated at depth 4)
        scale = (depth - 1) / (CARVING_DEPTH - 1)
        primal, adjoint = primal * scale, adjoint * scale
    return float(t.setup * n_views + t.compile[integ] + n_views * (iters * (primal + adjoint) + (coarse + 1) * primal))
