"""The cuts a rough can yield, each with its own flash over lamella orientations.

By default the candidates are cabochon families: every outline with a low, medium and high dome
at the outline's usual proportions, at any size that fits (the planner scales them); with
``calibrated`` only the standard calibrated sizes of each family, none scaled. Any cut a
comparison takes (``cab:`` spec, mesh file, GemCad design; :func:`labcut.reports.cuts.resolve_cuts`)
may be given instead; it keeps its proportions and is scaled to fit.

The flash of a cut at any lamella orientation comes from its score map (one per cut and
scenario, :meth:`labcut.Study.score_map`): a pose that puts the rough's lamella normal ``n`` at
``R^T n`` in the cut's frame keeps ``map(R^T n) / max(map)`` of the cut's best flash. Flash is
the same at every size of one shape (the metrics are shares of the stone's area), so one map
at the reference size serves every scale.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..geometry.inspect import carats
from ..study import Study
from .pose import thinned
from .shape import DENSITY

#: outline -> (length, width) of the reference cut, mm: the outline's usual proportions
FAMILIES: dict[str, tuple[float, float]] = {
    "oval": (16.0, 12.0), "round": (10.0, 10.0), "cushion": (12.0, 12.0), "pear": (15.0, 10.0),
    "marquise": (20.0, 10.0), "rectangle": (16.0, 12.0),
}
DOMES = ("low", "medium", "high")

#: standard calibrated cabochon sizes (length x width, mm) of each outline
CALIBRATED: dict[str, tuple[tuple[float, float], ...]] = {
    "oval": ((6, 4), (7, 5), (8, 6), (9, 7), (10, 8), (12, 10), (14, 10), (16, 12), (18, 13), (20, 15), (22, 16),
             (25, 18), (30, 22), (40, 30)),
    "round": tuple((d, d) for d in (4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 18, 20, 22, 25, 30)),
    "cushion": tuple((d, d) for d in (6, 8, 10, 12, 14, 16, 18, 20)),
    "pear": ((8, 5), (10, 7), (12, 8), (14, 10), (15, 10), (18, 13), (20, 15), (25, 18), (30, 20)),
    "marquise": ((8, 4), (10, 5), (12, 6), (14, 7), (16, 8), (20, 10), (24, 12), (30, 15)),
    "rectangle": ((8, 6), (10, 8), (12, 10), (14, 10), (16, 12), (18, 13), (20, 15), (25, 18), (30, 20), (40, 30)),
}

#: outlines that look the same turned half a turn about their face-up axis (a pear does not)
HALF_TURN = {"oval", "round", "cushion", "marquise", "rectangle"}

#: the smallest stone a plan returns, mm along its longest side
MIN_STONE_MM = 4.0

#: spacing (degrees) of each cut's score map: finer than a recommendation's (a cut's flash peak is
#: a few degrees wide; the map is cheap once the cut's flash problem is built)
MAP_SPACING_DEG = 1.5

#: the cabochon builder's outline points for the planning meshes (smooth enough for the flash map)
PLAN_RESOLUTION = 96


@dataclass
class CutModel:
    """One candidate cut at its reference size (mm, its own face-up frame) and its flash map.

    ``ref``: the reference point (centre of the bounding box) that poses place; ``points``: the
    hull's vertices relative to it (what containment reads); ``normals``/``scores``: the score
    map (unit lamella normals, z >= 0, and flash energy); ``fixed``: a calibrated size, never
    scaled; ``symmetric``: the same after a half turn."""

    name: str
    mesh: Any
    spec: str | None
    design: dict[str, Any]
    fixed: bool
    symmetric: bool
    ref: np.ndarray = field(repr=False)
    points: np.ndarray = field(repr=False)
    normals: np.ndarray = field(repr=False)
    scores: np.ndarray = field(repr=False)

    @property
    def length_mm(self) -> float:
        return float(np.max(self.mesh.extents[:2]))

    @cached_property
    def screen_points(self) -> np.ndarray:
        """At most :data:`~labcut.rough.pose.SCREEN_POINTS` of ``points`` (:func:`~labcut.rough.pose.thinned`):
        what the screening of many rotations reads, the same for every region of every plan."""
        return thinned(self.points)

    @property
    def best_score(self) -> float:
        return float(np.max(self.scores))

    def flash_ratio(self, m: np.ndarray) -> np.ndarray:
        """Share of the cut's best flash at lamella normals ``m`` (rows, cut frame, axial): the
        score of the nearest map normal over the map's best."""
        m = np.asarray(m, dtype=np.float64).reshape(-1, 3)
        m = np.where(m[:, 2:3] < 0.0, -m, m)
        best = self.best_score
        if best <= 0:
            return np.zeros(len(m))
        out = np.empty(len(m))
        for k in range(0, len(m), 4096):
            out[k : k + 4096] = self.scores[np.argmax(m[k : k + 4096] @ self.normals.T, axis=1)] / best
        return out

    def carats(self, scale: Any) -> Any:
        """Weight (carats at :data:`~labcut.rough.shape.DENSITY`) of the cut ``scale`` times its reference size."""
        return carats(1.0, DENSITY) * float(self.mesh.volume) * np.asarray(scale, dtype=np.float64) ** 3

    def smallest_scale(self) -> float:
        """The scale below which the stone is smaller than :data:`MIN_STONE_MM` (1 for a fixed size)."""
        return 1.0 if self.fixed else MIN_STONE_MM / self.length_mm


def _model(name: str, mesh: Any, spec: str | None, design: dict[str, Any], fixed: bool, symmetric: bool,
           score_map: tuple[np.ndarray, np.ndarray]) -> CutModel:
    from scipy.spatial import ConvexHull

    lo, hi = np.asarray(mesh.bounds, dtype=np.float64)
    ref = (lo + hi) / 2.0
    v = np.asarray(mesh.vertices, dtype=np.float64)
    hull = v[ConvexHull(v).vertices]
    normals, scores = score_map
    return CutModel(name, mesh, spec, design, fixed, symmetric, ref, hull - ref, np.asarray(normals, dtype=np.float64),
                    np.asarray(scores, dtype=np.float64))


def family_specs(calibrated: bool = False, largest_mm: float | None = None) -> list[tuple[str, str, bool, bool]]:
    """(name, cab spec, fixed, symmetric) of the default candidates: every outline with every dome
    at its reference proportions, or with ``calibrated`` every calibrated size no longer than
    ``largest_mm`` (the rough's longest side)."""
    out = []
    for outline, (length, width) in FAMILIES.items():
        sym = outline in HALF_TURN
        for dome in DOMES:
            if not calibrated:
                size = f"{length:g}" if outline == "round" else f"{length:g}x{width:g}"
                out.append((f"{outline} {dome}", f"cab:{outline},{size},{dome},res={PLAN_RESOLUTION}", False, sym))
                continue
            for cl, cw in CALIBRATED[outline]:
                if largest_mm is not None and cl > largest_mm:
                    continue
                size = f"{cl:g}" if outline == "round" else f"{cl:g}x{cw:g}"
                out.append((f"{outline} {size} {dome}", f"cab:{outline},{size},{dome},res={PLAN_RESOLUTION}", True, sym))
    return out


def build_models(cuts: Any, material: Any, scenario: Any, quality: Any, *, calibrated: bool = False,
                 fixed_size: bool = False, largest_mm: float | None = None, progress: Any = None) -> list[CutModel]:
    """The candidate cuts with their flash maps: the default families (``cuts`` None) or the cuts
    given (as :func:`labcut.reports.cuts.resolve_cuts` takes them, units and up axis read from each
    file; scaled to fit, or kept at their size with ``fixed_size``). Calibrated families share one map per outline and dome (flash does
    not depend on size)."""
    from ..reports.cuts import resolve_cuts

    report = progress or (lambda done, total: None)
    if cuts is None:
        specs = family_specs(calibrated, largest_mm)
        if not specs:
            raise ParameterError(f"no calibrated size fits a rough {largest_mm:g} mm long")
        resolved = resolve_cuts([s for _, s, _, _ in specs])
        items = [(name, cut.mesh, spec, cut.design, fixed, sym) for (name, spec, fixed, sym), cut in zip(specs, resolved)]
    else:
        resolved = resolve_cuts(cuts)  # a cut file's units and up axis as the file says (--units is the rough's)
        items = [(c.name, c.mesh, c.source, c.design, bool(fixed_size), False) for c in resolved]
    models: list[CutModel] = []
    maps: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
    for k, (name, mesh, spec, design, fixed, sym) in enumerate(items):
        key = (str(design.get("outline", name)), name.split()[-1])
        if not (fixed and cuts is None and key in maps):
            maps[key] = Study(mesh, material, scenario, quality).score_map(MAP_SPACING_DEG)
        model = _model(name, mesh, spec, design, fixed, sym, maps[key])
        models.append(model)
        report(k + 1, len(items))
    return models
