"""The search for poses: where each candidate cut sits in a convex region of the rough, how big
and how turned, and how the rough is sawn into pieces for several stones.

One region's search (:func:`search_region`) screens every rotation of a grid (face-up axes spread
over the sphere x spins about them; the quality's ``rough_directions`` and ``rough_spins``) with
a cheap lower bound of the scale (the cut centred at the region's deepest point, on a thinned
hull), solves the exact linear programme (:func:`labcut.rough.pose.largest_fit`) for the poses
that rank best, and polishes the best few by a local search of ``rough_refine`` steps. Several
stones (:func:`partition`): the region is sawn by planes (the rough's axes, its principal axes,
the flash plane), each piece keeping half the margin from the cut, greedily where a cut gains
most, then each piece searched for its stone.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..scene.directions import rotation as axis_rotation
from .candidates import CutModel
from .pose import (axial_upper, centred_scales, chebyshev_centre, largest_fit, rotation_of, rotations, sphere_directions,
                   supports)

#: ranking of plans: name -> exponents (a, b) of carats^a x flash_ratio^b
RANKS: dict[str, tuple[float, float]] = {"value": (1.5, 1.0), "weight": (1.0, 0.0), "flash": (0.1, 1.0)}
#: the flash ratio a pose counts with at least: where no pose flashes (a flash plane the rough
#: cannot turn up), plans still rank by weight
FLASH_FLOOR = 0.01
#: hull planes the screening reads at most (the exact programme reads them all; the points:
#: :data:`labcut.rough.pose.SCREEN_POINTS`)
SCREEN_PLANES = 256
#: poses per cut that the exact programme solves, by rank, and more by flash alone (the front)
EXACT_BY_RANK = 12
EXACT_BY_FLASH = 6
#: poses per cut solved exactly for their weight alone (the heavy end of the weight-flash front)
EXACT_BY_WEIGHT = 4
#: poses per cut a coarse search (choosing saw cuts) solves exactly
EXACT_COARSE = 2
#: poses per region polished by the local search
POLISHED = 2


@dataclass(frozen=True)
class Ranking:
    """How plans are ordered: ``name`` of :data:`RANKS` (carats^a x flash_ratio^b) and the least
    flash ratio a stone may keep (``min_flash``; below it a pose is worth nothing)."""

    name: str = "value"
    min_flash: float = 0.0

    def __post_init__(self) -> None:
        if self.name not in RANKS:
            raise ParameterError(f"rank must be one of {', '.join(RANKS)}, got {self.name!r}", parameter="rank")
        if not (isinstance(self.min_flash, int | float) and 0.0 <= self.min_flash <= 1.0):
            raise ParameterError(f"min flash must lie in [0, 1], got {self.min_flash!r}", parameter="min flash")

    def __call__(self, carats: Any, flash: Any) -> Any:
        a, b = RANKS[self.name]
        flash = np.clip(np.asarray(flash, dtype=np.float64), 0.0, None)
        value = np.power(np.asarray(carats, dtype=np.float64), a) * np.power(np.maximum(flash, FLASH_FLOOR), b)
        return value * (flash >= self.min_flash - 1e-12)


@dataclass
class Placement:
    """One pose of one cut in a region: ``rotation`` (cut frame -> rough frame), ``scale`` (times
    the cut's reference size), ``centre`` (mm, where the cut's reference point lands) and the
    share of the cut's best flash the pose keeps, read from the cut's map (``flash``)."""

    model: CutModel
    rotation: np.ndarray
    scale: float
    centre: np.ndarray
    flash: float

    @property
    def carats(self) -> float:
        return float(self.model.carats(self.scale))

    def value(self, rank: Ranking) -> float:
        return float(rank(self.carats, self.flash))


@dataclass
class Region:
    """A convex region of the rough that a cut's reference point and body must stay in:
    half-spaces ``a . x <= b`` (mm, already moved in by the margin)."""

    planes: np.ndarray
    centre: np.ndarray = field(init=False)
    radius: float = field(init=False)
    middle: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        found = chebyshev_centre(self.planes)
        self.centre, self.radius = (np.zeros(3), 0.0) if found is None else found
        # the mean of the region's corners: a slab's middle (its deepest points are a whole sheet)
        self.middle = self.centre if self.radius <= 1e-6 else _corners(self).mean(axis=0)

    @property
    def empty(self) -> bool:
        return self.radius <= 1e-6

    def screening_planes(self) -> np.ndarray:
        """At most :data:`SCREEN_PLANES` of the planes: for each of as many directions the plane
        that faces it most (a region a little larger than this one: the screening's bound)."""
        if len(self.planes) <= SCREEN_PLANES:
            return self.planes
        pick = np.unique(np.argmax(sphere_directions(SCREEN_PLANES) @ self.planes[:, :3].T, axis=1))
        return self.planes[pick]

    def cut(self, normal: np.ndarray, offset: float, half_gap: float) -> tuple[Region, Region]:
        """The two pieces of a saw cut ``normal . x = offset``, each ``half_gap`` mm from it."""
        n = np.asarray(normal, dtype=np.float64)
        a = Region(np.vstack([self.planes, np.append(n, offset - half_gap)]))
        b = Region(np.vstack([self.planes, np.append(-n, -offset - half_gap)]))
        return a, b


def _aligned(model: CutModel, normal: np.ndarray, n_spins: int) -> np.ndarray:
    """Rotations that put the rough's lamella normal exactly on the cut's best map normal: the
    least turn taking one onto the other, then every spin about the lamella normal."""
    best = model.normals[int(np.argmax(model.scores))]
    axis = np.cross(best, normal)
    s, c = float(np.linalg.norm(axis)), float(best @ normal)
    base = np.eye(3) if s < 1e-12 else axis_rotation(axis / s, math.degrees(math.atan2(s, c)))
    if s < 1e-12 and c < 0:
        base = axis_rotation(np.array([1.0, 0.0, 0.0]), 180.0)
    turns = np.arange(max(n_spins, 1) * 2) * (360.0 / (max(n_spins, 1) * 2))
    return np.stack([axis_rotation(normal, t) @ base for t in turns])


def exact_placement(model: CutModel, rot: np.ndarray, region: Region, flash: float) -> Placement | None:
    """``model`` turned by ``rot`` at the largest scale that fits ``region`` (a fixed size: at
    scale 1 when it fits), or None when it does not fit at its smallest size; ``flash`` travels."""
    h = supports(rot[None], region.planes[:, :3], model.points)[0]
    fit = largest_fit(h, region.planes)
    if fit is None:
        return None
    if model.fixed:
        if fit.scale < 1.0:
            return None
        lam = 1.0 / fit.scale  # (1, t) = lam (s*, t*) + (1 - lam) (0, c): inside, the region being convex
        return Placement(model, rot, 1.0, lam * fit.centre + (1.0 - lam) * region.centre, flash)
    if fit.scale < model.smallest_scale():
        return None
    return Placement(model, rot, fit.scale, fit.centre, flash)


def search_region(models: list[CutModel], region: Region, normal: np.ndarray, quality: Any, rank: Ranking, *,
                  coarse: bool = False, deadline: float = math.inf) -> list[Placement]:
    """Every pose solved exactly for ``models`` in ``region`` (rough frame; the lamella ``normal``
    in it), best first by ``rank``. ``coarse``: a third of the face-up axes, half the spins, no
    polish (what choosing a saw cut needs)."""
    if region.empty:
        return []
    n_dirs = max(8, quality.rough_directions // (3 if coarse else 1))
    n_spins = max(1, quality.rough_spins // (2 if coarse else 1))
    ups = np.vstack([sphere_directions(n_dirs), np.eye(3), -np.eye(3), normal, -normal])  # the rough's axes: a stone lying flat
    screen_planes = region.screening_planes()
    found: list[Placement] = []
    for model in models:
        period = math.pi if model.symmetric else 2.0 * math.pi
        spins = np.arange(n_spins) * (period / n_spins)
        rots = np.concatenate([rotations(ups, spins), _aligned(model, normal, n_spins)])
        h = supports(rots, screen_planes[:, :3], model.screen_points)
        scale = centred_scales(h, screen_planes, region.middle)
        flash = model.flash_ratio(axial_upper(np.einsum("rji,j->ri", rots, normal)))
        if model.fixed:
            bound = rank(model.carats(1.0), flash) * (scale >= 0.8)
        else:
            bound = rank(model.carats(scale), flash) * (scale >= model.smallest_scale())
        chosen = set(np.argsort(-bound)[: EXACT_COARSE if coarse else EXACT_BY_RANK].tolist())
        if not coarse:
            roomy = np.flatnonzero(scale >= 0.5 * scale.max()) if scale.max() > 0 else np.arange(0)
            chosen |= set(roomy[np.argsort(-flash[roomy])[:EXACT_BY_FLASH]].tolist())
            chosen |= set(np.argsort(-scale)[:EXACT_BY_WEIGHT].tolist())  # the front's heavy end
        for i in sorted(chosen):
            if scale[i] < (0.8 if model.fixed else model.smallest_scale()) * 0.5:
                continue
            p = exact_placement(model, rots[i], region, float(flash[i]))
            if p is not None:
                found.append(p)
    found.sort(key=lambda p: -p.value(rank))
    if not coarse and quality.rough_refine > 0:
        polished = [polish(p, region, normal, quality.rough_refine, rank, len(ups), deadline) for p in found[:POLISHED]]
        found = polished + found
        found.sort(key=lambda p: -p.value(rank))
    return found


def polish(start: Placement, region: Region, normal: np.ndarray, steps: int, rank: Ranking, n_dirs: int,
           deadline: float = math.inf) -> Placement:
    """A local search from ``start``: the face-up axis tipped and the cut spun by steps that halve
    after a round without gain (``steps`` exact programmes at most; stops at ``deadline``)."""
    best = start
    model = start.model
    tip = math.sqrt(4.0 * math.pi / n_dirs)  # about the grid's spacing, radians
    turn = tip
    up = best.rotation[:, 2].copy()
    psi = math.atan2(*(np.linalg.solve(rotation_of(up, 0.0), best.rotation[:, 0])[[1, 0]]))
    done = 0
    while done < steps and tip > 1e-3 and time.monotonic() < deadline:
        improved = False
        side = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
        side /= np.linalg.norm(side)
        other = np.cross(up, side)
        trials = [(axis_rotation(side, s * math.degrees(tip)) @ up, psi) for s in (1, -1)]
        trials += [(axis_rotation(other, s * math.degrees(tip)) @ up, psi) for s in (1, -1)]
        trials += [(up, psi + s * turn) for s in (1, -1)]
        for u, p in trials:
            if done >= steps:
                break
            done += 1
            rot = rotation_of(u / np.linalg.norm(u), p)
            flash = float(model.flash_ratio(axial_upper(rot.T @ normal))[0])
            cand = exact_placement(model, rot, region, flash)
            if cand is not None and cand.value(rank) > best.value(rank) * (1.0 + 1e-9):
                best, up, psi, improved = cand, rot[:, 2].copy(), p, True
        if not improved:
            tip /= 2.0
            turn /= 2.0
    return best


def saw_directions(rough_points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Directions of the saw cuts tried: the rough's axes, its principal axes and the lamella
    normal (sawing along the flash plane), without near-repeats."""
    centred = rough_points - rough_points.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    cands = [np.eye(3)[k] for k in range(3)] + [vt[k] for k in range(3)] + [np.asarray(normal, dtype=np.float64)]
    out: list[np.ndarray] = []
    for c in cands:
        c = c / np.linalg.norm(c)
        if all(abs(float(c @ o)) < 0.985 for o in out):
            out.append(c)
    return np.array(out)


#: where along a piece's extent the saw cuts are tried (shares of it)
SAW_FRACTIONS = (0.3, 0.4, 0.5, 0.6, 0.7)


@dataclass
class Piece:
    """A piece of the rough after the saw cuts so far (its region and the saw planes that bound it)."""

    region: Region
    saws: list[tuple[np.ndarray, float]] = field(default_factory=list)


def partition(rough_points: np.ndarray, region: Region, count: int, models: list[CutModel], normal: np.ndarray,
              quality: Any, rank: Ranking, margin: float, deadline: float = math.inf) -> list[Piece]:
    """``count`` pieces of ``region`` (fewer when no cut leaves room for another stone): at each
    step the saw cut (of :func:`saw_directions` x :data:`SAW_FRACTIONS` of a piece's extent) whose
    two pieces' best stones are worth most more than the piece's own."""
    dirs = saw_directions(rough_points, normal)
    pieces = [Piece(region)]

    def worth(r: Region) -> float:
        found = search_region(models, r, normal, quality, rank, coarse=True, deadline=deadline)
        return found[0].value(rank) if found else 0.0

    values = [worth(region)]
    while len(pieces) < count and time.monotonic() < deadline:
        best: tuple[float, int, Region, Region, np.ndarray, float, float, float] | None = None
        for k, piece in enumerate(pieces):
            verts = _region_points(piece.region, rough_points)
            for d in dirs:
                proj = verts @ d
                lo, hi = float(proj.min()), float(proj.max())
                for frac in SAW_FRACTIONS:
                    offset = lo + frac * (hi - lo)
                    a, b = piece.region.cut(d, offset, margin / 2.0)
                    if a.empty or b.empty:
                        continue
                    va, vb = worth(a), worth(b)
                    if va <= 0 or vb <= 0:
                        continue
                    gain = va + vb - values[k]
                    if best is None or gain > best[0]:
                        best = (gain, k, a, b, d, offset, va, vb)
        if best is None:
            break
        _, k, a, b, d, offset, va, vb = best
        saws = pieces[k].saws
        pieces[k:k + 1] = [Piece(a, saws + [(d, offset)]), Piece(b, saws + [(-d, -offset)])]
        values[k:k + 1] = [va, vb]
    return pieces


def _corners(region: Region) -> np.ndarray:
    """The corners of ``region`` (the intersection of its half-spaces, around its deepest point);
    its deepest point alone when qhull cannot make them (a region thinner than qhull resolves)."""
    from scipy.spatial import HalfspaceIntersection

    try:
        hs = np.concatenate([region.planes[:, :3], -region.planes[:, 3:]], axis=1)  # a . x - b <= 0
        return np.asarray(HalfspaceIntersection(hs, region.centre).intersections)
    except Exception:  # qhull: a degenerate region
        return region.centre[None]


def _region_points(region: Region, rough_points: np.ndarray) -> np.ndarray:
    """The corners of ``region``, or the rough's points when there are fewer than two."""
    corners = _corners(region)
    return corners if len(corners) >= 2 else rough_points
