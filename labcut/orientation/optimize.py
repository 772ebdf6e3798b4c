"""Optimisers over the lamella normal: exhaustive grid (reference), NLopt, Dr.Jit gradient ascent.

All work in stereographic coordinates ``(u, v)`` (see :mod:`labcut.orientation.scoring`),
inside the disc of radius ``tan(max_tilt/2)``; points outside are pulled radially onto
its edge, so the objective is defined on the whole box NLopt searches. A fixed tilt
axis (a horizontal unit vector) reduces the search to one angle: the normal is +Z
rotated about that axis.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..backend import Launched
from ..errors import ParameterError
from ..scene.directions import axial_upper
from ..scene.quality import Quality
from .scoring import Scorer, normal_to_stereo, stereo_to_normal

OPTIMIZERS = ("nlopt", "gradient", "grid")


@dataclass(frozen=True)
class Constraint:
    """Where the lamella normal may go: within ``max_tilt_deg`` of +Z, optionally about a fixed axis."""

    max_tilt_deg: float = 90.0
    tilt_axis: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.max_tilt_deg, int | float) and math.isfinite(self.max_tilt_deg) and 0.0 < self.max_tilt_deg <= 90.0):
            raise ParameterError(f"max_tilt must lie in (0, 90] degrees, got {self.max_tilt_deg!r}", parameter="max_tilt")
        if self.tilt_axis is not None:
            a = np.asarray(self.tilt_axis, dtype=np.float64)
            if a.shape != (3,) or not np.all(np.isfinite(a)):
                raise ParameterError("tilt axis must be three finite numbers", parameter="tilt axis")
            if not np.any(a):
                raise ParameterError("tilt axis must not be the zero vector", parameter="tilt axis")
            a = a - a[2] * np.array([0.0, 0.0, 1.0])
            if np.linalg.norm(a) < 1e-9:
                raise ParameterError("tilt axis must be horizontal (it may not be the face-up axis)", parameter="tilt axis")
            object.__setattr__(self, "tilt_axis", tuple(float(x) for x in a / np.linalg.norm(a)))

    @property
    def radius(self) -> float:
        return math.tan(math.radians(self.max_tilt_deg) / 2.0)

    def clamp(self, u: float, v: float) -> tuple[float, float]:
        r = math.hypot(u, v)
        return (u, v) if r <= self.radius else (u * self.radius / r, v * self.radius / r)

    def axis_normal(self, angle_deg: float) -> np.ndarray:
        """+Z rotated by ``angle_deg`` about the tilt axis (Rodrigues)."""
        k = np.asarray(self.tilt_axis)
        t = math.radians(angle_deg)
        z = np.array([0.0, 0.0, 1.0])
        return z * math.cos(t) + np.cross(k, z) * math.sin(t) + k * (k @ z) * (1 - math.cos(t))

    def allowed(self, normals: np.ndarray) -> np.ndarray:
        return normals[:, 2] >= math.cos(math.radians(self.max_tilt_deg)) - 1e-12


def hemisphere_grid(spacing_deg: float, constraint: Constraint) -> np.ndarray:
    """Unit normals on a Fibonacci spiral with about ``spacing_deg`` between neighbours, within the constraint."""
    if constraint.tilt_axis is not None:
        angles = np.arange(-constraint.max_tilt_deg, constraint.max_tilt_deg + 1e-9, spacing_deg)
        return np.array([constraint.axis_normal(a) for a in angles])
    cap = 1.0 - math.cos(math.radians(constraint.max_tilt_deg))
    n = max(8, int(math.ceil(2.0 * math.pi * cap / math.radians(spacing_deg) ** 2)))
    i = np.arange(n) + 0.5
    z = 1.0 - cap * i / n
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    phi = i * math.pi * (3.0 - math.sqrt(5.0))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def score_map(scorer: Scorer, normals: np.ndarray) -> np.ndarray:
    """Objective at many normals: the exact binned sum for energy, per-normal scoring otherwise
    (skipping normals whose energy is below 2 % of the best: no flash can be there)."""
    energy = scorer.energy_map(normals)
    if scorer.objective == "energy":
        return energy
    out = np.zeros(len(normals))
    keep = np.nonzero(energy >= 0.02 * energy.max())[0] if energy.max() > 0 else np.arange(len(normals))
    for i in keep:
        out[i] = scorer.score(normals[i])
    return out


@dataclass
class OptimumResult:
    normal: np.ndarray
    score: float
    evaluations: int
    method: str


def polish_grid(scorer: Scorer, centre: np.ndarray, constraint: Constraint, radius_deg: float, step_deg: float) -> tuple[np.ndarray, float]:
    """The best normal (and its score) of an exhaustive grid of ``step_deg`` spacing within
    ``radius_deg`` of ``centre`` (mesh frame, unit), or of a 1D segment of angles for a fixed
    tilt axis; candidates outside the constraint are pulled onto its edge."""
    if constraint.tilt_axis is not None:
        k = np.asarray(constraint.tilt_axis)
        z = np.array([0.0, 0.0, 1.0])
        a0 = math.degrees(math.atan2(np.cross(z, centre) @ k, centre @ z))
        angles = np.clip(np.arange(a0 - radius_deg, a0 + radius_deg + 1e-9, step_deg), -constraint.max_tilt_deg, constraint.max_tilt_deg)
        cand = np.array([constraint.axis_normal(a) for a in angles])
    else:
        u0, v0 = normal_to_stereo(centre)
        scale = (1.0 + u0 * u0 + v0 * v0) / 2.0  # stereographic radius per radian at (u0, v0)
        d = math.radians(radius_deg) * scale
        s = math.radians(step_deg) * scale
        g = np.arange(-d, d + 1e-12, s)
        uu, vv = np.meshgrid(u0 + g, v0 + g)
        pts = [constraint.clamp(a, b) for a, b in zip(uu.ravel(), vv.ravel())]
        cand = np.array([stereo_to_normal(a, b) for a, b in pts])
    values = score_map(scorer, cand)
    i = int(np.argmax(values))
    return cand[i], float(values[i])


def optimize_grid(scorer: Scorer, constraint: Constraint, coarse_deg: float = 1.5, fine_deg: float = 0.1) -> OptimumResult:
    """Reference: a grid over the whole allowed region, then a 0.1° grid around the 3 best cells."""
    start = scorer.evaluations
    normals = hemisphere_grid(coarse_deg, constraint)
    values = score_map(scorer, normals)
    order = np.argsort(values)[::-1][:3]
    best_n, best_v = normals[order[0]], float(values[order[0]])
    for i in order:
        n, v = polish_grid(scorer, normals[i], constraint, 1.5 * coarse_deg, fine_deg)
        if v > best_v:
            best_n, best_v = n, v
    return OptimumResult(best_n, best_v, scorer.evaluations - start, "grid")


def _local_lbfgs(scorer: Scorer, u0: float, v0: float, constraint: Constraint) -> tuple[float, float, float]:
    import nlopt

    r = constraint.radius
    seen: list = [(u0, v0), -np.inf]

    def f(x: np.ndarray, grad: np.ndarray) -> float:
        u, v = constraint.clamp(float(x[0]), float(x[1]))
        value, g = scorer.value_and_grad_uv(u, v)
        if grad.size:
            grad[:] = g
        if value > seen[1]:
            seen[:] = [(u, v), value]
        return value

    opt = nlopt.opt(nlopt.LD_LBFGS, 2)
    opt.set_max_objective(f)
    opt.set_lower_bounds([-r, -r])
    opt.set_upper_bounds([r, r])
    opt.set_xtol_abs(1e-5)
    opt.set_maxeval(60)
    try:
        opt.optimize([u0, v0])
    except Exception:  # nlopt stops on roundoff / line-search failure: keep the best point seen
        pass
    u, v = seen[0]
    return u, v, scorer.score_uv(u, v)


def optimize_nlopt(scorer: Scorer, constraint: Constraint, global_evals: int | None = None,
                   seed_map: tuple[np.ndarray, Any] | None = None) -> OptimumResult:
    """NLopt: DIRECT-L (global, derivative-free) over the disc's bounding box, then an L-BFGS
    polish (``LD_LBFGS``) with Dr.Jit gradients. A fixed axis uses the same pair in 1D.
    ``global_evals``: DIRECT-L's evaluations (default: the standard quality's ``nlopt_evals``).
    ``seed_map``: ``(normals, energies)`` of an energy map already made over the allowed region
    (the recommendation's hemisphere map, :data:`SEED_SPACING_DEG` or finer), whose best distinct
    cells seed the polishes instead of a map of their own; ``energies`` may be a
    :class:`~labcut.backend.Launched` map (still being summed on Dr.Jit's threads while DIRECT-L steps in numpy: read
    for after DIRECT-L)."""
    import nlopt

    if global_evals is None:
        global_evals = Quality.coerce("standard").nlopt_evals

    start = scorer.evaluations
    if constraint.tilt_axis is not None:
        lim = constraint.max_tilt_deg
        f = lambda x, grad: scorer.score(constraint.axis_normal(float(x[0])))  # noqa: E731
        opt = nlopt.opt(nlopt.GN_DIRECT_L, 1)
        opt.set_max_objective(f)
        opt.set_lower_bounds([-lim])
        opt.set_upper_bounds([lim])
        opt.set_maxeval(max(40, global_evals // 4))
        x = opt.optimize([0.0])
        loc = nlopt.opt(nlopt.LN_BOBYQA, 1)
        loc.set_max_objective(f)
        loc.set_lower_bounds([-lim])
        loc.set_upper_bounds([lim])
        loc.set_xtol_abs(1e-3)
        loc.set_initial_step(0.5)
        loc.set_maxeval(40)
        x = loc.optimize(x)
        n = constraint.axis_normal(float(x[0]))
        return OptimumResult(n, scorer.score(n), scorer.evaluations - start, "nlopt")
    r = constraint.radius
    best: list = [None, -np.inf]

    def f_global(x: np.ndarray, grad: np.ndarray) -> float:
        u, v = constraint.clamp(float(x[0]), float(x[1]))
        value = scorer.score_uv(u, v)
        if value > best[1]:
            best[:] = [(u, v), value]
        return value

    opt = nlopt.opt(nlopt.GN_DIRECT_L, 2)
    opt.set_max_objective(f_global)
    opt.set_lower_bounds([-r, -r])
    opt.set_upper_bounds([r, r])
    opt.set_maxeval(global_evals)
    try:
        opt.optimize([0.0, 0.0])
    except Exception:  # nlopt's own stop conditions: keep the best point seen
        pass
    # DIRECT's few hundred samples can miss a peak narrower than its cells (a lobe of a few
    # degrees): L-BFGS also starts from the best distinct cells of a coarse energy map (one
    # batched kernel), and the best polished point wins
    seeds = (_map_seeds(scorer, constraint, SEED_SPACING_DEG, 3) if seed_map is None else
             _best_cells(seed_map[0], seed_map[1].value if isinstance(seed_map[1], Launched) else seed_map[1], 3))
    starts = [best[0]] + [normal_to_stereo(n) for n in seeds]
    result = (best[0], best[1])
    for u0, v0 in starts:
        u, v, value = _local_lbfgs(scorer, u0, v0, constraint)
        if value > result[1]:
            result = ((u, v), value)
    (u, v), value = result
    return OptimumResult(stereo_to_normal(u, v), value, scorer.evaluations - start, "nlopt")


#: spacing (degrees) of the energy map whose best cells seed the optimisers' local searches
SEED_SPACING_DEG = 6.0


def _map_seeds(scorer: Scorer, constraint: Constraint, spacing_deg: float, count: int, separation_deg: float = 8.0) -> list[np.ndarray]:
    """The best ``count`` cells of an energy map at ``spacing_deg``, at least ``separation_deg`` apart."""
    coarse = hemisphere_grid(spacing_deg, constraint)
    return _best_cells(coarse, scorer.energy_map(coarse), count, separation_deg)


def _best_cells(normals: np.ndarray, values: np.ndarray, count: int, separation_deg: float = 8.0) -> list[np.ndarray]:
    """The best ``count`` of the map's cells (``normals`` with their ``values``) scoring above 0, at
    least ``separation_deg`` apart (axial)."""
    seeds: list[np.ndarray] = []
    for i in np.argsort(values)[::-1]:
        if len(seeds) >= count or values[i] <= 0:
            break
        if all(abs(float(normals[i] @ s)) < math.cos(math.radians(separation_deg)) for s in seeds):
            seeds.append(normals[i])
    return seeds


def optimize_gradient(scorer: Scorer, constraint: Constraint, starts: int = 12, iterations: int = 60, seed: int = 0) -> OptimumResult:
    """Dr.Jit gradient ascent (Adam on (u, v)) from ``starts`` spread-out starting normals plus
    the best distinct cells of a coarse 6° energy map, all starts stepped together in one kernel."""
    start = scorer.evaluations
    if constraint.tilt_axis is not None:
        return _axis_gradient(scorer, constraint, starts, iterations)
    inits = hemisphere_grid(max(2.0, math.degrees(math.sqrt(2 * math.pi * (1 - math.cos(math.radians(constraint.max_tilt_deg))) / starts))), constraint)
    inits = inits[np.linspace(0, len(inits) - 1, min(starts, len(inits))).astype(int)]
    # plus the best distinct cells of a coarse (6°) energy map: one batched evaluation
    seeds = _map_seeds(scorer, constraint, SEED_SPACING_DEG, max(4, starts // 2))
    if seeds:
        inits = np.vstack([np.array(seeds), inits])
    best_uv, best_value = (0.0, 0.0), -np.inf
    r = constraint.radius
    if scorer.objective == "energy":  # all starts in one kernel per step
        x = np.array([normal_to_stereo(n) for n in inits])
        m1 = np.zeros_like(x)
        m2 = np.zeros_like(x)
        lr = 0.02 * max(r, 0.05)
        for it in range(1, iterations + 1):
            _, g = scorer.energy_batch_value_and_grad(x[:, 0], x[:, 1])
            m1 = 0.9 * m1 + 0.1 * g
            m2 = 0.999 * m2 + 0.001 * g * g
            step = lr * (m1 / (1 - 0.9**it)) / (np.sqrt(m2 / (1 - 0.999**it)) + 1e-12)
            x = np.array([constraint.clamp(a, b) for a, b in x + step])
        values, _ = scorer.energy_batch_value_and_grad(x[:, 0], x[:, 1])
        i = int(np.argmax(values))
        best_uv, best_value = (float(x[i, 0]), float(x[i, 1])), float(values[i])
        inits = []
    for n0 in inits:
        x = np.array(normal_to_stereo(n0))
        m1 = np.zeros(2)
        m2 = np.zeros(2)
        lr = 0.02 * max(r, 0.05)
        for it in range(1, iterations + 1):
            value, g = scorer.value_and_grad_uv(*constraint.clamp(*x))
            m1 = 0.9 * m1 + 0.1 * g
            m2 = 0.999 * m2 + 0.001 * g * g
            step = lr * (m1 / (1 - 0.9**it)) / (np.sqrt(m2 / (1 - 0.999**it)) + 1e-12)
            x = np.array(constraint.clamp(*(x + step)))
            if np.linalg.norm(step) < 1e-6:
                break
        value = scorer.score_uv(*x)
        if value > best_value:
            best_uv, best_value = (float(x[0]), float(x[1])), value
    u, v, value = _local_lbfgs(scorer, *best_uv, constraint)
    if value < best_value:
        (u, v), value = best_uv, best_value
    return OptimumResult(stereo_to_normal(u, v), value, scorer.evaluations - start, "gradient")


def _axis_gradient(scorer: Scorer, constraint: Constraint, starts: int, iterations: int) -> OptimumResult:
    start = scorer.evaluations
    lim = constraint.max_tilt_deg
    best = (0.0, -np.inf)
    h = 0.05
    for a in np.linspace(-lim, lim, max(3, starts)):
        for _ in range(iterations):
            f = lambda t: scorer.score(constraint.axis_normal(float(np.clip(t, -lim, lim))))  # noqa: E731
            g = (f(a + h) - f(a - h)) / (2 * h)
            a_new = float(np.clip(a + 2.0 * np.sign(g) * min(abs(g) * 50, 1.0), -lim, lim))
            if abs(a_new - a) < 1e-3:
                break
            a = a_new
        value = scorer.score(constraint.axis_normal(a))
        if value > best[1]:
            best = (a, value)
    n = constraint.axis_normal(best[0])
    return OptimumResult(n, best[1], scorer.evaluations - start, "gradient")


def run_optimizer(name: str, scorer: Scorer, constraint: Constraint, quality: Quality | str = "standard",
                  seed_map: tuple[np.ndarray, Any] | None = None) -> OptimumResult:
    """Run optimiser ``name`` with its budget from ``quality`` (:class:`~labcut.scene.quality.Quality`:
    ``grid_coarse_deg``, ``nlopt_evals``, ``gradient_starts``). ``seed_map``: an energy map
    already made (``(normals, energies)``, :func:`optimize_nlopt`); NLopt's polishes start from
    its best cells (the other optimisers ignore it)."""
    q = Quality.coerce(quality)
    if name == "grid":
        return optimize_grid(scorer, constraint, coarse_deg=q.grid_coarse_deg)
    if name == "nlopt":
        return optimize_nlopt(scorer, constraint, global_evals=q.nlopt_evals, seed_map=seed_map)
    if name == "gradient":
        return optimize_gradient(scorer, constraint, starts=q.gradient_starts)
    raise ParameterError(f"optimizer must be one of {', '.join(OPTIMIZERS)}, got {name!r}")


@dataclass(frozen=True, eq=False)
class Search:
    """The best normal of a question's scorer (:func:`search_best`): the normal (unit, mesh frame,
    z >= 0) and its score, and the hemisphere map made on the way (its normals and scores)."""

    normal: np.ndarray
    score: float
    map_normals: np.ndarray
    map_scores: np.ndarray


def search_best(scorer: Scorer, constraint: Constraint, quality: Quality | str, optimizer: str = "nlopt",
                step: Callable[[str], None] | None = None) -> Search:
    """The best lamella normal of ``scorer`` where ``constraint`` allows: a map over the allowed
    hemisphere at ``quality.map_spacing_deg`` and optimiser ``optimizer`` (:func:`run_optimizer`),
    the better of the two, polished. ``step``: called with ``"optimising"`` once the map is launched.

    The energy map is launched (Dr.Jit's threads sum it while the optimiser's DIRECT-L steps in
    numpy) and read when its cells seed the polishes, or after the optimiser; its best cells seed
    the polishes where the map is at least twice as fine as the seed map NLopt would make
    (standard's 3° and high's 1.5°, not draft's 4°: a peak narrower than its cells can hide between
    them, and the seeds are the energy's)."""
    q = Quality.coerce(quality)
    map_normals = hemisphere_grid(q.map_spacing_deg, constraint)
    map_launched = scorer.launch_energy_map(map_normals) if scorer.objective == "energy" else None
    if step is not None:
        step("optimising")
    seeds = ((map_normals, map_launched) if map_launched is not None and q.map_spacing_deg <= 0.5 * SEED_SPACING_DEG
             and constraint.tilt_axis is None else None)
    best = run_optimizer(optimizer, scorer, constraint, q, seed_map=seeds)
    map_scores = map_launched.value if map_launched is not None else score_map(scorer, map_normals)
    normal = axial_upper(best.normal)
    score = scorer.score(normal)
    if map_scores.max() > score * (1.0 + 1e-4):  # the map found better: trust the better point, polished
        normal, score = polish_grid(scorer, map_normals[int(np.argmax(map_scores))], constraint, q.map_spacing_deg, 0.1)
        normal = axial_upper(normal)
    return Search(normal, float(score), map_normals, map_scores)


#: the tolerance's precision (degrees): the answer lies within this of the first failing ring
TOLERANCE_STEP_DEG = 0.05


def tolerance_deg(scores: Callable[[np.ndarray], np.ndarray], best: np.ndarray, best_score: float, constraint: Constraint, keep: float = 0.9, limit_deg: float = 30.0, directions: list[np.ndarray] | None = None) -> float:
    """How far (degrees) the normal may miss in any direction and keep ``keep`` x the score.

    Rings of 16 directions (scored together) around ``best``; the smallest angle whose ring has a
    point below ``keep * best_score`` bounds the tolerance, found to :data:`TOLERANCE_STEP_DEG`.
    The score falls off a peak about quadratically in the angle, so the search predicts where a
    ring first fails from the rings it has scored (the root of ``α + β a²`` through the last two
    rings that keep, from the centre and a ring at 0.25°; then regula falsi in the squared angle
    between a ring that keeps and one that fails, scoring the two rings a step apart around the
    prediction at once, halving when that is slow): four to six calls where a bisection from 0.25°
    in steps of 1.6x took nine to fourteen (the rings that keep grow at most 4x from one to the
    next). Returns the largest angle known to keep, 0 when the centre itself does not, or
    ``limit_deg`` when no ring up to it fails.
    """
    target = keep * best_score
    best = best / np.linalg.norm(best)
    helper = np.array([1.0, 0.0, 0.0]) if abs(best[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(best, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(best, e1)
    if directions is not None:  # tangent directions to test, e.g. front and back only
        dirs = []
        for d in directions:
            t = d - (d @ best) * best
            if np.linalg.norm(t) < 1e-6:  # the axis is the normal itself: tilt across it instead
                t = np.cross(best, d if abs(d[2]) < 0.9 else np.array([1.0, 0.0, 0.0]))
                if np.linalg.norm(t) < 1e-6:
                    t = np.cross(best, [0.0, 0.0, 1.0])
            dirs.append(t / np.linalg.norm(t))
    elif constraint.tilt_axis is not None:
        k = np.asarray(constraint.tilt_axis)
        dirs = [np.cross(k, best), -np.cross(k, best)]
    else:
        dirs = [math.cos(p) * e1 + math.sin(p) * e2 for p in np.linspace(0, 2 * math.pi, 16, endpoint=False)]
    tangent = np.array(dirs)
    step = TOLERANCE_STEP_DEG

    def worst(angles_deg: list[float], centre: bool = False) -> list[float]:
        """The lowest score on each ring (one call for all of them), after the centre's score
        when ``centre``."""
        t = np.radians(np.asarray(angles_deg, dtype=np.float64))
        rings = (np.cos(t)[:, None, None] * best[None, None, :] + np.sin(t)[:, None, None] * tangent[None, :, :]).reshape(-1, 3)
        if centre:
            rings = np.vstack([best[None, :], rings])
        rings = np.where(rings[:, 2:3] < 0, -rings, rings)
        values = np.asarray(scores(rings), dtype=np.float64)
        head = [float(values[0])] if centre else []
        return head + [float(x) for x in values[int(centre):].reshape(len(t), len(tangent)).min(axis=1)]

    def narrow(kept: list[tuple[float, float]], hi: float | None, v_hi: float) -> tuple[float, float | None]:
        """From rings that keep (``kept``: (angle, lowest score), by angle) and the nearest that
        fails (``hi`` with its lowest score ``v_hi``; None: none found yet), the angles of the ring
        that keeps and the one that fails within ``step`` of each other (None: none up to the limit)."""
        while hi is None:  # bracket: the root of v = α + β a² through the last two rings that keep
            (a1, v1), (a2, v2) = kept[-2], kept[-1]
            if a2 >= limit_deg:
                return a2, None
            guess = 4.0 * a2
            if v2 < v1:
                guess = 1.05 * math.sqrt(max(a2 * a2 + (a2 * a2 - a1 * a1) * (v2 - target) / (v1 - v2), 0.0))
            guess = min(max(guess, 1.6 * a2), 4.0 * a2, limit_deg)
            value = worst([guess])[0]
            if value < target:
                hi, v_hi = guess, value
            else:
                kept.append((guess, value))
        lo, v_lo = kept[-1]
        halve = False
        while hi - lo > step + 1e-9:  # regula falsi in a², the two rings a step apart around it; halving when slow
            width = hi - lo
            if halve:
                pair = [0.5 * (lo + hi)]
            else:
                frac = min(max((v_lo - target) / (v_lo - v_hi), 0.0), 1.0) if v_lo > v_hi else 0.5
                guess = math.sqrt(lo * lo + (hi * hi - lo * lo) * frac)
                gap = min(0.25 * step, 0.25 * width)
                a, b = max(guess - 0.5 * step, lo + gap), min(guess + 0.5 * step, hi - gap)
                pair = [a, b] if a < b else [0.5 * (lo + hi)]
            for angle, value in zip(pair, worst(pair)):
                if value < target:
                    hi, v_hi = angle, value
                    break
                lo, v_lo = angle, value
            halve = not halve and hi - lo > 0.5 * width
        return lo, hi

    centre, v0 = worst([0.25], centre=True)
    if centre < target:
        return 0.0
    if v0 < target:
        lo, hi = narrow([(0.0, centre)], 0.25, v0)
    else:
        lo, hi = narrow([(0.0, centre), (0.25, v0)], None, v0)
    return lo if hi is not None else limit_deg


def _dots(normals: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Dot product of each row of ``normals`` (N, 3) with ``t`` (3,), as three multiply-adds
    (no BLAS call: OpenBLAS threads next to Dr.Jit's pool wait milliseconds on few cores)."""
    return normals[:, 0] * t[0] + normals[:, 1] * t[1] + normals[:, 2] * t[2]


def _axial_deg(normals: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Axial angle (degrees) between each row of ``normals`` and the unit vector ``t``."""
    return np.degrees(np.arccos(np.minimum(1.0, np.abs(_dots(normals, np.asarray(t, dtype=np.float64))))))


def distinct_optima(scorer: Scorer, constraint: Constraint, normals: np.ndarray, scores: np.ndarray, best: np.ndarray,
                    best_score: float, count: int = 3, separation_deg: float = 12.0, neighbour_deg: float = 4.5,
                    floor: float = 0.3) -> list[tuple[np.ndarray, float]]:
    """Distinct local maxima of a score map (unit ``normals``, mesh frame, with ``scores``), best first:
    each a map point at least ``separation_deg`` (axial) from ``best`` and from the optima already
    found, no lower than any map point within ``neighbour_deg``, scoring at least ``floor`` x
    ``best_score``; polished on a 0.25° grid within 2° (:func:`polish_grid`) and kept when the
    polished normal (folded to z >= 0) is still that far from the others. At most ``count``.

    Vectorised: the distance of every candidate to a newly found optimum is one array operation
    (the per-candidate Python loop made millions of ``acos`` calls at high quality)."""
    normals = np.asarray(normals, dtype=np.float64)
    scores = np.asarray(scores, dtype=np.float64)
    order = np.argsort(scores)[::-1]
    order = order[scores[order] >= floor * best_score]  # the loop stops at the first one below
    cand = normals[order]
    free = _axial_deg(cand, best) >= separation_deg  # not within the separation of a taken optimum
    taken = [np.asarray(best, dtype=np.float64)]
    out: list[tuple[np.ndarray, float]] = []
    for k in np.flatnonzero(free):
        if len(out) >= count:
            break
        if not free[k]:  # an optimum found since the mask was made lies near
            continue
        n = cand[k]
        near = np.degrees(np.arccos(np.clip(np.abs(_dots(normals, n)), 0.0, 1.0))) < neighbour_deg
        if np.any(scores[near] > scores[order[k]]):  # not a local maximum
            continue
        polished, value = polish_grid(scorer, n, constraint, 2.0, 0.25)
        polished = np.asarray(polished, dtype=np.float64)
        polished = polished / np.linalg.norm(polished)
        if polished[2] < 0:
            polished = -polished
        if any(float(_axial_deg(polished[None, :], t)[0]) < separation_deg for t in taken):
            continue
        taken.append(polished)
        free &= _axial_deg(cand, polished) >= separation_deg
        out.append((polished, value))
    return out
