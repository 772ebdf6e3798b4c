"""``labcut.plan_rough``: which stones to cut from a rough, where, how big and how tilted,
trading weight against flash (docs/rough.md).

The rough's flash plane is fixed (its lamella normal ``n``, rough frame); what the cutter chooses
is the cut, its size and its pose. A pose's flash is the share of the cut's best flash that its
lamella orientation ``R^T n`` keeps (the cut's own score map, :mod:`labcut.rough.candidates`);
its weight comes from the largest scale that fits (:mod:`labcut.rough.pose`). Plans are ranked
by carats^1.5 x flash ratio (``rank``, :data:`labcut.rough.search.RANKS`); the front of weight
against flash and the slab question (the best flash against the stone's size) come with it.
Every returned stone's flash ratio is measured again on the stone itself (its own recommendation
and evaluation, :class:`labcut.Study`), and every stone is checked against the rough with
manifold3d (:mod:`labcut.rough.check`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import MeshError, ParameterError
from ..geometry.meshio import units_scale
from ..geometry.orient import check_up_axis
from ..physics.material import Labradorite
from ..scene.directions import rotation as axis_rotation
from ..scene.directions import tilt_azimuth
from ..scene.quality import Quality
from ..study import Study
from ..validation import check_budget, check_number, unit_vector
from .candidates import CutModel, build_models
from .check import OUTSIDE_LIMIT, Checker, gap_mm, inside, overlap_mm3
from .pose import axial_upper, centred_scales, largest_fit, rotations, sphere_directions, supports, transform
from .search import Piece, Placement, Ranking, Region, exact_placement, partition, search_region
from .shape import SLAB_PREFIX, Rough, load_rough
from .workshop import stone_steps

#: most stones one plan cuts from a rough
MAX_COUNT = 12
#: the largest margin (mm) a plan keeps
MAX_MARGIN_MM = 20.0


@dataclass
class PlannedStone:
    """One stone of a plan (DESIGN.md §5): ``cut`` in its own face-up frame at its planned size,
    ``mesh`` the same in the rough's frame, ``transform`` (4 x 4, cut frame -> rough frame),
    ``carats`` (at 2.69 g/cm³), ``flash_ratio`` (its flash energy with the lamella normal the rough
    imposes over the same cut's best, both measured on the stone), ``lamella_normal_cut`` (``R^T
    n``, unit, cut frame), ``tolerance_deg`` (how far the lamella may stray from the cut's best
    and keep most of its flash), ``workshop`` (the steps, in workshop words)."""

    name: str
    cut: Any
    mesh: Any
    transform: np.ndarray
    carats: float
    flash_ratio: float
    lamella_normal_cut: np.ndarray
    tolerance_deg: float
    workshop: list[str]
    best_normal_cut: np.ndarray
    off_best_deg: float
    design: dict[str, Any]
    spec: str | None
    map_flash_ratio: float
    saws: list[tuple[np.ndarray, float]] = field(default_factory=list)

    @property
    def size_mm(self) -> tuple[float, float, float]:
        e = np.asarray(self.cut.extents, dtype=np.float64)
        return float(e[0]), float(e[1]), float(e[2])

    @property
    def within_tolerance(self) -> bool:
        return self.off_best_deg <= self.tolerance_deg

    def to_dict(self) -> dict[str, Any]:
        tilt, az = tilt_azimuth(self.lamella_normal_cut)
        return {
            "name": self.name, "spec": self.spec, "size_mm": list(self.size_mm), "carats": self.carats,
            "flash_ratio": self.flash_ratio, "flash_ratio_from_map": self.map_flash_ratio,
            "lamella_normal_cut": self.lamella_normal_cut.tolist(), "lamella_tilt_deg": tilt, "lamella_azimuth_deg": az,
            "best_normal_cut": self.best_normal_cut.tolist(), "off_best_deg": self.off_best_deg,
            "tolerance_deg": self.tolerance_deg, "within_tolerance": self.within_tolerance,
            "transform": self.transform.tolist(), "workshop": list(self.workshop), "design": dict(self.design),
        }


@dataclass
class RoughPlan:
    """What :func:`plan_rough` found (DESIGN.md §5): ``rough``, ``stones`` best first,
    ``yield_fraction`` (the stones' volume over the rough's), ``pareto`` (the front of weight
    against flash ratio over every cut and pose tried for one stone), ``tradeoff`` (the best flash
    ratio against the stone's length, the slab question), ``checks`` (manifold3d's verdicts)."""

    rough: Rough
    lamella_normal: np.ndarray
    stones: list[PlannedStone]
    yield_fraction: float
    pareto: list[dict[str, Any]]
    tradeoff: dict[str, Any]
    checks: dict[str, Any]
    settings: dict[str, Any]
    notes: list[str]
    seconds: float
    scenario: Any = None  # the scenario as given (a preset name, a JSON file or a Scenario): the renders' too

    def to_dict(self) -> dict[str, Any]:
        tilt, az = tilt_azimuth(self.lamella_normal)
        return {
            "rough": self.rough.to_dict(), "lamella_normal": self.lamella_normal.tolist(),
            "flash_plane": {"tilt_deg": tilt, "azimuth_deg": az, "from": "the rough's top face (+Z), azimuth from +X towards +Y"},
            "stones": [s.to_dict() for s in self.stones], "count": len(self.stones),
            "carats": float(sum(s.carats for s in self.stones)), "yield_fraction": self.yield_fraction,
            "pareto": self.pareto, "tradeoff": self.tradeoff, "checks": self.checks, "settings": self.settings,
            "notes": list(self.notes), "seconds": self.seconds,
            "frame": "rough frame: the file's (mm); a slab spans [0, L] x [0, W] x [0, T], its top face at z = T",
        }

    def save_json(self, path: str | Path) -> Path:
        from ..fileio import atomic_output
        import json

        with atomic_output(path, (".json",)) as tmp:
            Path(tmp).write_text(json.dumps(self.to_dict(), indent=2, allow_nan=False))
        return Path(path)

    def save_html(self, path: str | Path, *, renders: bool = True) -> Path:
        """A self-contained HTML report (figures inline): :func:`labcut.rough.report.write_html`."""
        from .report import write_html

        return write_html(self, path, renders=renders)

    def save_png(self, path: str | Path) -> Path:
        """The plan's figure (three views of the rough with its stones and flash plane, the front) as PNG."""
        from .report import write_png

        return write_png(self, path)


def check_request(rough: Any, lamella_normal: Any, count: Any = 1, margin_mm: Any = 0.5, quality: Any = "standard",
                  time_budget: Any = None, rank: str = "value", min_flash: Any = 0.0, units: Any = "auto",
                  up_axis: Any = "+Z", calibrated: bool = False, fixed_size: bool = False,
                  cuts: Any = None) -> tuple[np.ndarray, int, float, Ranking, Quality, float | None]:
    """Every option of :func:`plan_rough` checked before any work (the CLI asks it before its
    progress bar): ``(normal, count, margin, ranking, quality, time budget)``. A slab is in mm:
    a unit other than ``auto``/``mm`` for it is an error (``units`` is a mesh file's)."""
    n = unit_vector(lamella_normal, "lamella normal")
    count = int(check_number(count, "count", 1, MAX_COUNT, integer=True))
    margin = float(check_number(margin_mm, "margin", 0.0, MAX_MARGIN_MM, unit="mm"))
    ranking = Ranking(rank, float(check_number(min_flash, "min flash", 0.0, 1.0)))
    q = Quality.coerce(quality)
    budget = None if time_budget is None else check_budget(time_budget)
    check_up_axis(up_axis)
    if not (isinstance(units, str) and units.strip().lower() == "auto"):
        name, factor = units_scale(units)
        if isinstance(rough, str) and rough.strip().lower().startswith(SLAB_PREFIX) and factor != 1.0:
            raise ParameterError(f"a slab (slab:LxWxT) is given in mm; units {name} apply to a rough's mesh file",
                                 parameter="units")
    if fixed_size and cuts is None:
        raise ParameterError("fixed size keeps the size of the cuts given (--cut); the default cabochons take --calibrated")
    if calibrated and cuts is not None:
        raise ParameterError("--calibrated chooses among the default cabochon families; with --cut the cuts given are scaled to fit")
    return n, count, margin, ranking, q, budget


def plan_rough(rough: Any, lamella_normal: Any, cuts: Any = None, material: Any = None, scenario: Any = "bench",
               count: int = 1, margin_mm: float = 0.5, quality: Quality | str = "standard",
               time_budget: float | None = None, *, rank: str = "value", min_flash: float = 0.0, calibrated: bool = False,
               fixed_size: bool = False,
               units: str | float = "auto", up_axis: str = "+Z",
               progress: Callable[[str, float], None] | None = None) -> RoughPlan:
    """Plan the stones to cut from ``rough`` whose lamella normal is ``lamella_normal`` (rough frame).

    ``rough``: ``"slab:LxWxT"`` (mm), a mesh file (read in its own frame: ``units``, ``up_axis``
    default ``"+Z"``), a trimesh or a :class:`~labcut.Stone`. ``cuts``: None (the cabochon
    families; ``calibrated``: their standard sizes only) or cuts as :func:`labcut.compare_cuts`
    takes them, each scaled to fit (``fixed_size``: kept at its own size). ``material``, ``scenario``, ``quality`` as everywhere.
    ``count``: how many stones, non-overlapping, ``margin_mm`` apart and from the rough's surface.
    ``time_budget`` (s): the search stops polishing and sawing when it runs out (the answer then
    says so in ``notes``). ``rank``: ``"value"`` (carats^1.5 x flash ratio), ``"weight"``,
    ``"flash"``; ``min_flash``: the least flash ratio a stone may keep (a pose below it is not
    taken). ``progress(stage, fraction)``: called as the work goes.

    Raises :class:`~labcut.errors.ParameterError` (bad normal, count, margin, rank, spec) or
    :class:`~labcut.errors.MeshError` (a rough that cannot be read or repaired; a rough too small
    for any candidate)."""
    started = time.monotonic()
    report = progress or (lambda stage, fraction: None)
    n, count, margin, ranking, q, budget = check_request(rough, lamella_normal, count, margin_mm, quality, time_budget,
                                                         rank, min_flash, units, up_axis, calibrated, fixed_size, cuts)
    deadline = math.inf if budget is None else started + budget
    mat = Labradorite.coerce(material)
    report("reading the rough", 0.0)
    r = load_rough(rough, units=units, up_axis=up_axis)
    region = Region(np.concatenate([r.planes[:, :3], r.planes[:, 3:] - margin], axis=1))
    if region.empty:
        raise MeshError(f"the rough {r.name!r} is too small to keep a {margin:g} mm margin all round")
    report("flash maps of the candidate cuts", 0.05)
    lo, hi = r.bounds
    models = build_models(cuts, mat, scenario, q, calibrated=calibrated, fixed_size=fixed_size, largest_mm=float(np.max(hi - lo)),
                          progress=lambda d, t: report("flash maps of the candidate cuts", 0.05 + 0.35 * d / t))
    report("placing the cuts", 0.4)
    whole = search_region(models, region, n, q, ranking, deadline=deadline)
    if whole and ranking.min_flash > 0:
        whole = [p for p in whole if p.flash >= ranking.min_flash - 1e-12]
        if not whole:
            raise ParameterError(f"no pose of any candidate cut keeps a flash ratio of {ranking.min_flash:g} in this rough: "
                                 f"lower the least flash", parameter="min flash")
    if not whole:
        raise MeshError(f"the rough {r.name!r} is too small for any candidate cut (the smallest stone is "
                        f"{4.0:g} mm long, with a {margin:g} mm margin)")
    notes: list[str] = []
    if count > 1:
        report("choosing the saw cuts", 0.55)
        ranked = sorted({id(p.model): p.model for p in whole}.values(), key=lambda m: -max(p.value(ranking) for p in whole if p.model is m))
        pieces = partition(r.mesh.vertices, region, count, ranked[:3], n, q, ranking, margin, deadline)
        if len(pieces) < count:
            notes.append(f"{len(pieces)} stone(s), not {count}: no saw cut leaves room for another stone")
    else:
        pieces = [Piece(region)]
    report("measuring the stones", 0.75)
    stones: list[PlannedStone] = []
    for k, piece in enumerate(pieces):
        found = whole if count == 1 else search_region(models, piece.region, n, q, ranking, deadline=deadline)
        found = [p for p in found if p.flash >= ranking.min_flash - 1e-12]
        made = _first_that_holds(found, r, n, mat, scenario, q, margin, piece, ranking)
        if made is not None:
            stones.append(made)
        report("measuring the stones", 0.75 + 0.2 * (k + 1) / len(pieces))
    if not stones:
        raise MeshError(f"no candidate cut fits inside the rough {r.name!r} with a {margin:g} mm margin")
    order = np.argsort([-float(ranking(s.carats, s.flash_ratio)) for s in stones], kind="stable")
    stones = [stones[i] for i in order]
    for i, s in enumerate(stones):
        s.name = f"stone {i + 1}: {s.name}"
        s.workshop = stone_steps(s, r, n, i + 1)
    if time.monotonic() > deadline:
        notes.append("the time budget ran out: the search stopped early (a longer budget may find better poses)")
    checks = _checks(r, stones, margin)
    plan = RoughPlan(
        rough=r, lamella_normal=n, stones=stones,
        yield_fraction=float(sum(float(s.mesh.volume) for s in stones) / r.volume_mm3),
        pareto=_pareto(whole), tradeoff=_tradeoff(whole, region, n, q, ranking), checks=checks,
        settings={"count": count, "margin_mm": margin, "quality": q.name, "rank": rank, "min_flash": ranking.min_flash, "calibrated": calibrated, "fixed_size": fixed_size,
                  "scenario": str(getattr(scenario, "name", scenario)), "material": mat.to_dict(),
                  "candidates": [m.name for m in models], "time_budget_s": time_budget},
        notes=notes + list(r.notes), seconds=time.monotonic() - started, scenario=scenario)
    report("done", 1.0)
    return plan


def _stone_meshes(p: Placement) -> tuple[Any, Any, np.ndarray]:
    cut = p.model.mesh.copy()
    cut.apply_scale(p.scale)
    t = transform(p.rotation, p.scale, p.model.ref, p.centre)
    mesh = cut.copy()
    mesh.apply_transform(t)
    return cut, mesh, t


def _holds(rough: Rough, mesh: Any, margin: float) -> bool:
    if rough.convex:
        return True  # exact by construction (the rough's own half-spaces, moved in by the margin)
    checker = _checker(rough)
    if checker.outside_share(mesh) > OUTSIDE_LIMIT:
        return False
    return margin <= 0 or checker.clearance_mm(mesh) >= margin * 0.999


def _checker(rough: Rough) -> Checker:
    """The rough's :class:`~labcut.rough.check.Checker`, made once per rough."""
    return rough.cached("checker", lambda: Checker(rough.mesh))


def _deep_point(rough: Rough, region: Region) -> np.ndarray:
    """A point of the piece far from the rough's surface: the deepest of the region's centre and
    400 points spread over the rough's box that lie inside both the region (the piece, the margin
    kept) and the rough itself (:func:`labcut.rough.check.inside`). A stone shrunk towards it
    stays in its piece (the piece is convex)."""
    lo, hi = rough.bounds
    grid = lo + (hi - lo) * np.random.default_rng(0).random((400, 3))
    pts = np.vstack([region.centre, grid])
    pts = pts[np.all(pts @ region.planes[:, :3].T <= region.planes[:, 3] + 1e-9, axis=1)]
    pts = pts[inside(rough.mesh, pts)] if len(pts) else pts
    if len(pts) == 0:
        return region.centre
    return pts[int(np.argmax(_checker(rough).distance(pts)))]


def _shrunk(p: Placement, rough: Rough, region: Region, margin: float) -> Placement | None:
    """``p`` shrunk towards a deep point of a non-convex rough until it holds (bisection), or None."""
    if p.model.fixed:
        return None
    c = _deep_point(rough, region)
    lo, hi = 0.0, 1.0
    best = None
    for _ in range(12):
        lam = (lo + hi) / 2.0
        trial = Placement(p.model, p.rotation, p.scale * lam, lam * p.centre + (1.0 - lam) * c, p.flash)
        if trial.scale < p.model.smallest_scale():
            lo = lam
            continue
        if _holds(rough, _stone_meshes(trial)[1], margin):
            best, lo = trial, lam
        else:
            hi = lam
    return best


def _first_that_holds(found: list[Placement], rough: Rough, n: np.ndarray, material: Any, scenario: Any,
                      quality: Quality, margin: float, piece: Piece, ranking: Ranking) -> PlannedStone | None:
    """The best-ranked of the first placements once each holds in the rough itself: a convex
    rough's hold as they are (the first is taken); a non-convex rough's are shrunk where they poke
    out, so the first :data:`HOLD_TRIES` are compared after shrinking."""
    held: list[Placement] = []
    for p in found[: HOLD_TRIES * 2]:
        if not rough.convex and not _holds(rough, _stone_meshes(p)[1], margin):
            p = _shrunk(p, rough, piece.region, margin)
            if p is None:
                continue
        held.append(p)
        if rough.convex or len(held) >= HOLD_TRIES:
            break
    if not held:
        return None
    best = max(held, key=lambda p: p.value(ranking))
    return _measured(best, n, material, scenario, quality, piece, rough, margin, ranking)


#: placements of a non-convex rough compared once shrunk to hold
HOLD_TRIES = 4


#: shares of the turn that would bring the lamella onto the cut's best orientation, tried last
SNAP_FRACTIONS = (1.0, 0.75, 0.5, 0.25)


def _measured(p: Placement, n: np.ndarray, material: Any, scenario: Any, quality: Quality, piece: Piece,
              rough: Rough, margin: float, ranking: Ranking) -> PlannedStone:
    """The stone of placement ``p``, its flash measured on the stone itself; first turned the
    whole way, or part of it, towards the cut's own best orientation when that fits and is worth
    more (the map's spacing blurs the last degrees; here the flash is exact)."""
    meshes = _stone_meshes(p)
    study = Study(meshes[0], material, scenario, quality)
    rec = study.recommend()
    best_n = axial_upper(np.asarray(rec.normal, dtype=np.float64))

    def exact_flash(rot: np.ndarray) -> tuple[float, np.ndarray]:
        m = axial_upper(rot.T @ n)
        m = m / np.linalg.norm(m)
        return (float(study.evaluate(m).flash_energy / rec.score) if rec.score > 0 else 0.0), m

    chosen, (ratio, m_cut) = p, exact_flash(p.rotation)
    worth = float(ranking(chosen.carats, ratio))
    angle = math.degrees(math.acos(min(1.0, float(m_cut @ best_n))))
    if angle > 1e-6:
        axis = np.cross(m_cut, best_n)
        axis /= np.linalg.norm(axis)
        for frac in SNAP_FRACTIONS:
            rot = p.rotation @ axis_rotation(axis, frac * angle).T  # R'^T n = Q R^T n: the lamella turned by Q
            cand = exact_placement(p.model, rot, piece.region, p.flash)
            if cand is None:
                continue
            r2, m2 = exact_flash(rot)
            w2 = float(ranking(cand.carats, r2))
            if w2 > worth * (1.0 + 1e-9) and (rough.convex or _holds(rough, _stone_meshes(cand)[1], margin)):
                chosen, ratio, m_cut, worth = cand, r2, m2, w2
    cut, mesh, t = meshes if chosen is p else _stone_meshes(chosen)
    if chosen.scale != p.scale:  # measured again on the stone as it will be cut
        study = Study(cut, material, scenario, quality)
        rec = study.recommend()
        best_n = axial_upper(np.asarray(rec.normal, dtype=np.float64))
        ratio = float(study.evaluate(m_cut).flash_energy / rec.score) if rec.score > 0 else 0.0
    off = math.degrees(math.acos(min(1.0, abs(float(best_n @ m_cut)))))
    return PlannedStone(name=chosen.model.name, cut=cut, mesh=mesh, transform=t, carats=chosen.carats, flash_ratio=ratio,
                        lamella_normal_cut=m_cut, tolerance_deg=float(rec.tolerance_deg), workshop=[],
                        best_normal_cut=best_n, off_best_deg=off, design=dict(chosen.model.design), spec=chosen.model.spec,
                        map_flash_ratio=chosen.flash, saws=list(piece.saws))


def _checks(rough: Rough, stones: list[PlannedStone], margin: float) -> dict[str, Any]:
    """manifold3d's verdicts on the plan: each stone's share outside the rough and its clearance,
    the volume and the gap between each pair of stones."""
    out: dict[str, Any] = {"stones": [], "pairs": []}
    for s in stones:
        out["stones"].append({"outside_share": _checker(rough).outside_share(s.mesh),
                              "clearance_mm": _checker(rough).clearance_mm(s.mesh)})
    for i in range(len(stones)):
        for j in range(i + 1, len(stones)):
            out["pairs"].append({"stones": [i + 1, j + 1], "overlap_mm3": overlap_mm3(stones[i].mesh, stones[j].mesh),
                                 "gap_mm": gap_mm(stones[i].mesh, stones[j].mesh, 500)})
    out["inside"] = all(c["outside_share"] <= OUTSIDE_LIMIT for c in out["stones"])
    out["apart"] = all(c["overlap_mm3"] <= 1e-6 and c["gap_mm"] >= margin * 0.99 for c in out["pairs"])
    out["margin_mm"] = margin
    return out


def _pareto(found: list[Placement]) -> list[dict[str, Any]]:
    """The placements no other beats on both weight and flash (heaviest first)."""
    pts = sorted(found, key=lambda p: (-p.carats, -p.flash))
    front, best_flash = [], -1.0
    for p in pts:
        if p.flash > best_flash + 1e-9:
            front.append({"cut": p.model.name, "carats": p.carats, "flash_ratio": p.flash,
                          "length_mm": p.scale * p.model.length_mm})
            best_flash = p.flash
    return front


#: the flash ratios at which the slab question's curve is read
TRADEOFF_LEVELS = (0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95, 0.98, 1.0)


def _tradeoff(found: list[Placement], region: Region, n: np.ndarray, quality: Quality, rank: Ranking) -> dict[str, Any]:
    """The slab question, for the best-ranked cut: the longest stone (mm) that keeps at least each
    flash ratio of :data:`TRADEOFF_LEVELS` (from the cut's map): the longest of the poses the search
    solved and of the exact fits of the grid's three roomiest rotations at that level."""
    model = max(found, key=lambda p: p.value(rank)).model
    period = math.pi if model.symmetric else 2.0 * math.pi
    rots = rotations(sphere_directions(quality.rough_directions), np.arange(quality.rough_spins) * (period / quality.rough_spins))
    planes = region.screening_planes()
    scale = centred_scales(supports(rots, planes[:, :3], model.screen_points), planes, region.middle)
    flash = model.flash_ratio(axial_upper(np.einsum("rji,j->ri", rots, n)))
    curve = []
    for level in TRADEOFF_LEVELS:
        idx = np.flatnonzero(flash >= level - 1e-9)
        # the poses the search solved (and polished) count too: the curve never falls below the front
        best = max([p.scale for p in found if p.model is model and p.flash >= level - 1e-9], default=0.0)
        for i in idx[np.argsort(-scale[idx])[:3]]:
            fit = largest_fit(supports(rots[i][None], region.planes[:, :3], model.points)[0], region.planes)
            if fit is not None:
                best = max(best, min(fit.scale, 1.0) if model.fixed else fit.scale)
        curve.append({"flash_ratio": level, "length_mm": best * model.length_mm})
    return {"cut": model.name, "curve": curve,
            "reads": "the longest stone of this cut that keeps at least each share of its best flash"}
