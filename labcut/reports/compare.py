"""``labcut.compare_cuts``: compare cuts (and ways of wearing them) for their schiller.

Every cut gets, under every chosen scenario, its own best lamella orientation
(:func:`labcut.recommend_orientation`), and one compromise orientation over all the scenarios
(:func:`labcut.reports.analysis.compromise`). For each (cut, scenario) the comparison holds the
answer in a cutter's words, its tolerance (overall and per axis), the flash metrics and the same
normalised to a reference cut, the carat weight and a rank; a tilt-performance curve, a
misorientation curve, renders (one reference exposure for every cut and scenario), a rocking strip,
the score map and a flash-colour map. :meth:`Comparison.save_html` writes the report page,
:meth:`Comparison.to_dict` / :meth:`Comparison.save_json` / :meth:`Comparison.save_csv` every
number in it (docs/compare.md).

Units and frames: mm, degrees, nm; lamella normals in the mesh frame (+Z face-up, -Y the front,
axial, z >= 0); flash values in units of ``L_ref`` (DESIGN.md §4).
"""

from __future__ import annotations

import csv
import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..scene.scenario import scenarios_from
from .html import COMPARE_DEFINITIONS
from ..geometry.stone import Stone
from ..validation import check_number
from .cuts import Cut, resolve_cuts

#: metrics compared with the reference cut (best orientation of each cut, per scenario)
NORMALISED = ("flash_energy", "flash_area", "flash_intensity", "coverage", "tolerance_deg")
#: columns of :meth:`Comparison.save_csv` (one number per row)
CSV_COLUMNS = ("cut", "scenario", "orientation", "quantity", "value", "unit", "x", "x_unit", "y", "y_unit")



@dataclass
class ScenarioResult:
    """One cut under one scenario: its recommendation and everything derived from it.

    ``compromise_metrics``: flash metrics (:class:`~labcut.orientation.scoring.FlashMetrics`) at
    the cut's compromise orientation; ``compromise_relative``: its energy there / at the optimum.
    ``normalised``: :data:`NORMALISED` divided by the reference cut's (None where that is 0)."""

    cut: str
    scenario: Any
    recommendation: Any
    tilt: Any
    misorientation: Any
    renders: Any
    colour: Any
    compromise_metrics: Any = None
    compromise_relative: float = 1.0
    rank: int = 0
    #: whether another cut shares :attr:`rank` under this scenario (energies within their error bars)
    tied: bool = False
    normalised: dict[str, float | None] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def energy(self) -> float:
        """Flash energy at the best orientation (L_ref units): the ranking metric."""
        return float(self.recommendation.metrics.flash_energy)

    @property
    def energy_error(self) -> float:
        """The error bar of :attr:`energy` (L_ref units): the energy times the recommendation's
        relative score error bar (``uncertainty.score_rel``, about 95 %; 0 where it has none)."""
        u = self.recommendation.uncertainty
        return float(self.energy * u.score_rel) if u is not None else 0.0

    @property
    def flashes(self) -> bool:
        """Whether any part of the stone reaches the flash threshold at its best orientation."""
        return float(self.recommendation.metrics.flash_area) > 0.0

    def value(self, key: str) -> float:
        """A normalised quantity (:data:`NORMALISED`) at the best orientation."""
        if key == "tolerance_deg":
            return float(self.recommendation.tolerance_deg)
        return float(getattr(self.recommendation.metrics, key))


@dataclass
class CutResult:
    """One cut: its mesh summary, a :class:`ScenarioResult` per scenario, its compromise
    (:class:`~labcut.reports.analysis.Compromise`) in words and workshop terms, overall score and rank."""

    cut: Cut
    summary: Any
    scenarios: dict[str, ScenarioResult]
    compromise: Any
    compromise_description: str
    compromise_workshop: dict[str, Any]
    overall_score: float = 0.0
    rank: int = 0
    #: the error bar of :attr:`overall_score` (:func:`overall_error`)
    overall_error: float = 0.0
    #: whether another cut shares :attr:`rank` (their overall scores lie within their error bars)
    tied: bool = False

    @property
    def name(self) -> str:
        return self.cut.name


def competition_ranks(values: Sequence[float], errors: Sequence[float] | None = None) -> list[int]:
    """Ranks, largest value first; values that do not differ share a rank ("1, 2, 2, 4").

    With ``errors`` (each value's error bar, same units; about 95 %), two values differ only when
    they lie further apart than their error bars combined in quadrature (:func:`differ`): a cut's
    rank is one plus the number of cuts that are better beyond their error bars, so cuts within
    each other's bars share a rank, a tie."""
    errs = [0.0] * len(values) if errors is None else list(errors)
    return [1 + sum(1 for j, w in enumerate(values) if differ(w, errs[j], v, errs[i])) for i, v in enumerate(values)]


def differ(a: float, a_err: float, b: float, b_err: float) -> bool:
    """Whether ``a`` is larger than ``b`` beyond their error bars: ``a - b`` exceeds
    sqrt(a_err² + b_err²), the bar of a difference of two independent estimates (same coverage)."""
    return a - b > math.hypot(a_err, b_err)


def shared(ranks: Sequence[int]) -> list[bool]:
    """For each rank, whether another entry holds it too (a tie)."""
    return [list(ranks).count(r) > 1 for r in ranks]


def _and(names: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    names = list(names)
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


def _ratio(a: float, b: float) -> float | None:
    return float(a / b) if b > 0 else None


def naming_scenario(scenarios: Sequence[Any]) -> Any:
    """The scenario whose side names (front/back or top/bottom) a compromise uses: the first, when
    every scenario wears the stone the same way up; else None (face-up names)."""
    kinds = {s.worn_upright for s in scenarios}
    return scenarios[0] if len(kinds) == 1 else None


def _json(value: Any) -> Any:
    """Plain JSON: numpy scalars and arrays to Python, NaN and infinities to None."""
    if isinstance(value, dict):
        return {str(k): _json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json(v) for v in value]
    if isinstance(value, np.ndarray):
        return _json(value.tolist())
    if isinstance(value, np.bool_ | bool):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(float(value)) else None
    return value


@dataclass
class Comparison:
    """The result of :func:`compare_cuts`: per cut a :class:`CutResult`, in the order given.

    ``scenarios``: the :class:`~labcut.Scenario` objects; ``reference``: index of the reference
    cut; ``exposures``: per scenario the one exposure of its renders and rocking strips;
    ``render``: resolution (pixels), samples per pixel and strip angles (degrees)."""

    cuts: list[CutResult]
    scenarios: list[Any]
    material: Any
    reference: int
    quality: Any  # a labcut.Quality (str() is its name) or a preset name
    exposures: dict[str, float]
    render: dict[str, Any]
    seconds: float
    tau: float = 0.1
    seed: int = 0
    #: ``time_budget=``'s choice (:class:`labcut.commands.budget.BudgetChoice` as a dict), or empty
    budget: dict[str, Any] = field(default_factory=dict)

    # ------------------------------------------------------------------ access
    @property
    def sides_note(self) -> str:
        """How the compromise orientation names the stone's sides (front/back lying face-up, top/bottom
        worn upright; both when the scenarios mix the two)."""
        upright = [s.worn_upright for s in self.scenarios]
        if all(upright):
            return "sides are named as the stone is worn upright: +Y is its top (the bail end), -Y its bottom"
        if not any(upright):
            return "sides are named as the stone lies face-up: -Y is its front, +Y its back"
        return ("sides are named as the stone lies face-up: +Y is its back lying face-up and its top (the bail end) "
                "worn upright, -Y its front and its bottom")

    @property
    def scenario_names(self) -> list[str]:
        return [s.name for s in self.scenarios]

    @property
    def reference_cut(self) -> CutResult:
        return self.cuts[self.reference]

    def result(self, cut: int | str, scenario: str) -> ScenarioResult:
        """The :class:`ScenarioResult` of a cut (index or name) under a scenario (name)."""
        c = self.cuts[cut] if isinstance(cut, int) else next((x for x in self.cuts if x.name == cut), None)
        if c is None:
            raise ParameterError(f"no cut named {cut!r} in this comparison: {', '.join(x.name for x in self.cuts)}")
        if scenario not in c.scenarios:
            raise ParameterError(f"no scenario {scenario!r} in this comparison: {', '.join(self.scenario_names)}")
        return c.scenarios[scenario]

    def ranked(self) -> list[CutResult]:
        """The cuts by overall rank (ties in the order given)."""
        return sorted(self.cuts, key=lambda c: (c.rank, self.cuts.index(c)))

    # ------------------------------------------------------------------ verdicts
    def flashes(self, scenario: str) -> bool:
        """Whether any cut, at its best orientation, reaches the flash threshold under ``scenario``."""
        return any(c.scenarios[scenario].flashes for c in self.cuts)

    def scenario_verdict(self, scenario: str) -> str:
        """One sentence on ``scenario``: which cut flashes most (or which tie: energies within their
        error bars), or, where no cut reaches the flash threshold, that none shows flash, the best
        achievable, and what to try."""
        rs = sorted((c.scenarios[scenario] for c in self.cuts), key=lambda r: -r.energy)
        if not self.flashes(scenario):
            return (f"under {scenario} no cut shows flash: none reaches the flash threshold at its best orientation; the best "
                    f"achievable is the faint schiller of {rs[0].cut} (flash energy {rs[0].energy:.4f}); try a directed "
                    "light (--scenario bench, or --lighting spot) to see which cut flashes")
        leaders = [r.cut for r in rs if r.rank == 1]
        if len(leaders) > 1:
            return (f"under {scenario} {_and(leaders)} tie for the most flash: their flash energies lie within their "
                    "error bars")
        return f"under {scenario} {leaders[0]} flashes most"

    @property
    def verdict(self) -> str:
        """The comparison in one or two sentences: the leader over all scenarios, or the cuts tied for
        the lead (overall scores within their error bars), or that no cut shows flash at all; and
        each scenario under which no cut flashes."""
        names = self.scenario_names
        dark = [n for n in names if not self.flashes(n)]
        if len(dark) == len(names):
            best = self.ranked()[0]
            return (f"No cut shows flash under {_and(names)}: none reaches the flash threshold at its best orientation; "
                    f"the best achievable is the faint schiller of {best.name} (overall score {best.overall_score:.2f}); "
                    "try a directed light (--scenario bench, or --lighting spot) to see which cut flashes.")
        leaders = [c.name for c in self.ranked() if c.rank == 1]
        over = f"over {_and(names)}" + (" (each cut at one orientation for all)" if len(names) > 1 else "")
        if len(leaders) > 1:
            text = (f"{_and(leaders)} tie for the most flash {over}: their overall scores lie within their error bars, "
                    "so this comparison cannot tell them apart.")
        else:
            text = f"{leaders[0]} flashes most {over}."
        if dark:
            text += f" Under {_and(dark)} no cut reaches the flash threshold: faint schiller only."
        return text

    # ------------------------------------------------------------------ notebooks
    def __repr__(self) -> str:
        best = self.ranked()[0].name if self.cuts else "-"
        return (f"Comparison({len(self.cuts)} cuts x {len(self.scenarios)} scenarios ({', '.join(self.scenario_names)}), "
                f"best {best!r}, reference {self.reference_cut.name!r}, {self.seconds:.1f} s)")

    def _repr_html_(self) -> str:
        """The ranked summary as a small table: rank, cut, weight, overall score and per scenario
        the flash energy relative to the reference cut."""
        from html import escape

        head = "".join(f"<th>{escape(n)}</th>" for n in ["rank", "cut", "ct", "overall", *self.scenario_names])
        body = []
        for row in self.summary_rows():
            cells = [str(row["rank"]), escape(row["cut"]), f"{row['weight_ct']:.2f}", f"{row['overall_score']:.3g}"]
            for name in self.scenario_names:
                rel = row["scenarios"][name]["flash_energy_normalised"]
                cells.append("-" if rel is None else f"{rel:.0%}")
            body.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
        caption = f"flash energy relative to {escape(self.reference_cut.name)}"
        return f"<table><caption>{caption}</caption><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict[str, Any]:
        """Plain JSON of every number in the report (docs/compare.md lists the keys)."""
        from .. import __version__
        from ..orientation.recommend import FRAME, METRIC_DEFINITIONS

        cuts = []
        for c in self.cuts:
            scen = {}
            for name, r in c.scenarios.items():
                rec = r.recommendation.to_dict()
                rec.pop("metric_definitions", None)
                rec.pop("frame", None)
                rec.pop("mesh", None)
                rec.pop("misorientation", None)  # the scenario's own "misorientation", below
                scen[name] = {
                    "rank": r.rank,
                    "tied": r.tied,
                    "flash_energy_error": r.energy_error,
                    "best": rec,
                    "normalised": r.normalised,
                    "tilt_curve": r.tilt.to_dict(),
                    "misorientation": r.misorientation.to_dict(),
                    "flash_colour": r.colour.stats if r.colour is not None else None,
                    "render": None if r.renders is None else {
                        "view": r.renders.view, "resolution": r.renders.resolution, "spp": r.renders.spp,
                        "exposure": self.exposures.get(name), "strip_angles_deg": list(r.renders.strip_angles_deg),
                        "strip_axis": "front_back", "plan": r.renders.plan,
                    },
                    "compromise": {"relative_to_best": r.compromise_relative,
                                   "metrics": _metrics(r.compromise_metrics)},
                    "seconds": r.seconds,
                }
            cp = c.compromise
            cuts.append({
                "name": c.name,
                "source": c.cut.to_dict(),
                "mesh": _mesh_block(c.cut),
                "weight_ct": c.summary.weight_ct,
                "weight_ct_range": c.summary.weight_ct_range,
                "volume_mm3": c.summary.volume_mm3,
                "dimensions_mm": [c.summary.length_mm, c.summary.width_mm, c.summary.height_mm],
                "rank": c.rank,
                "tied": c.tied,
                "overall_score": c.overall_score,
                "overall_score_error": c.overall_error,
                "compromise": {
                    "normal": cp.normal.tolist(), "tilt_deg": _tilt(cp.normal)[0], "azimuth_deg": _tilt(cp.normal)[1],
                    "description": c.compromise_description, "workshop": c.compromise_workshop,
                    "parallel_to_base": cp.parallel_within_deg is not None, "parallel_within_deg": cp.parallel_within_deg,
                    "score": cp.score, "relative_to_best": cp.relative, "tolerance_deg": cp.tolerance_deg,
                    "tolerance_by_axis": cp.tolerance_by_axis,
                },
                "scenarios": scen,
            })
        return _json({
            "kind": "labcut.compare",
            "labcut_version": __version__,
            "quality": str(self.quality),
            "tau": self.tau,
            "seed": self.seed,
            "material": self.material.to_dict(),
            "reference": {"index": self.reference, "name": self.reference_cut.name},
            "scenarios": [s.to_dict() for s in self.scenarios],
            "render": self.render,
            "exposures": self.exposures,
            "verdict": self.verdict,
            "scenario_verdicts": {n: {"any_flash": self.flashes(n), "verdict": self.scenario_verdict(n)}
                                  for n in self.scenario_names},
            "summary": self.summary_rows(),
            "compromise_sides": self.sides_note,
            "cuts": cuts,
            "frame": FRAME,
            "metric_definitions": {**METRIC_DEFINITIONS, **COMPARE_DEFINITIONS},
            "seconds": self.seconds,
            "time_budget": self.budget or None,
        })

    def summary_rows(self) -> list[dict[str, Any]]:
        """The ranked summary table (one row per cut, by overall rank): rank, name, weight, overall
        score, and per scenario the rank, flash energy, energy / reference, tolerance."""
        rows = []
        for c in self.ranked():
            row: dict[str, Any] = {"rank": c.rank, "tied": c.tied, "cut": c.name, "weight_ct": c.summary.weight_ct,
                                   "overall_score": c.overall_score, "overall_score_error": c.overall_error,
                                   "compromise": c.compromise_description,
                                   "compromise_tolerance_deg": c.compromise.tolerance_deg, "scenarios": {}}
            for name, r in c.scenarios.items():
                row["scenarios"][name] = {"rank": r.rank, "tied": r.tied, "flash_energy": r.energy,
                                          "flash_energy_error": r.energy_error,
                                          "flash_energy_normalised": r.normalised.get("flash_energy"),
                                          "tolerance_deg": r.recommendation.tolerance_deg,
                                          "description": r.recommendation.description}
            rows.append(row)
        return rows

    def save_json(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`to_dict` as indented JSON, atomically."""
        import json

        from ..fileio import atomic_output

        with atomic_output(path, (".json",)) as tmp:
            tmp.write_text(json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n")
        return Path(path)

    # ------------------------------------------------------------------ CSV
    def rows(self) -> list[dict[str, Any]]:
        """Every number of the report as tidy rows (:data:`CSV_COLUMNS`): per cut (scenario empty),
        per cut and scenario at the ``best`` and the ``compromise`` orientation, and the curves and
        the score map point by point (``x``/``y`` their abscissae)."""
        return csv_rows(self.to_dict())

    def save_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`rows` as CSV, atomically."""
        from ..fileio import atomic_output

        with atomic_output(path, (".csv",)) as tmp, open(tmp, "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=CSV_COLUMNS)
            writer.writeheader()
            for row in self.rows():
                writer.writerow({k: ("" if v is None else (repr(v) if isinstance(v, float) else v)) for k, v in row.items()})
        return Path(path)

    # ------------------------------------------------------------------ HTML
    def save_html(self, path: str | os.PathLike[str]) -> Path:
        """Write the report: one self-contained HTML page (images embedded, no scripts, no
        network), readable on a phone and printable; atomically."""
        from .html import write_report

        return write_report(self, path)


def _tilt(normal: np.ndarray) -> tuple[float, float]:
    from ..scene.directions import tilt_azimuth

    return tilt_azimuth(np.asarray(normal, dtype=np.float64))


def _metrics(metrics: Any) -> dict[str, Any] | None:
    if metrics is None:
        return None
    from ..orientation.recommend import metrics_dict

    return metrics_dict(metrics)


def _mesh_block(cut: Cut) -> dict[str, Any]:
    out = Stone.of(cut.mesh).provenance_dict()
    if cut.kind == "file":
        out["path"] = cut.source
    return out


# ---------------------------------------------------------------------- CSV rows from the JSON
def csv_rows(data: dict[str, Any]) -> list[dict[str, Any]]:
    """The tidy rows of a comparison's JSON (:meth:`Comparison.to_dict`); see :meth:`Comparison.rows`."""
    rows: list[dict[str, Any]] = []

    def add(cut: str, scen: str, orient: str, qty: str, value: Any, unit: str = "", x: Any = None, x_unit: str = "",
            y: Any = None, y_unit: str = "") -> None:
        if value is None or isinstance(value, bool) or not isinstance(value, int | float):
            return
        rows.append({"cut": cut, "scenario": scen, "orientation": orient, "quantity": qty, "value": value, "unit": unit,
                     "x": x, "x_unit": x_unit if x is not None else "", "y": y, "y_unit": y_unit if y is not None else ""})

    metric_units = {"flash_area": "fraction", "flash_intensity": "L_ref", "flash_energy": "L_ref", "coverage": "fraction",
                    "balanced": "", "energy_in_flash": "L_ref", "energy_below_threshold": "L_ref",
                    "visible_area_mm2": "mm2", "flash_area_mm2": "mm2"}
    for s in data["scenarios"]:
        add("", s["name"], "", "exposure", data["exposures"].get(s["name"]), "multiplier")
    for c in data["cuts"]:
        n = c["name"]
        add(n, "", "", "rank", c["rank"])
        add(n, "", "", "tied", int(c["tied"]), "0/1")
        add(n, "", "", "overall_score", c["overall_score"], "ratio")
        add(n, "", "", "overall_score_error", c["overall_score_error"], "ratio")
        add(n, "", "", "weight_ct", c["weight_ct"], "ct")
        for lo_hi, v in zip(("weight_ct_min", "weight_ct_max"), c["weight_ct_range"]):
            add(n, "", "", lo_hi, v, "ct")
        add(n, "", "", "volume_mm3", c["volume_mm3"], "mm3")
        for axis, v in zip(("length_mm", "width_mm", "height_mm"), c["dimensions_mm"]):
            add(n, "", "", axis, v, "mm")
        cp = c["compromise"]
        _orientation_rows(add, n, "", "compromise", cp)
        add(n, "", "compromise", "score", cp["score"], "ratio")
        for scen, rel in cp["relative_to_best"].items():
            add(n, scen, "compromise", "relative_to_best", rel, "ratio")
        for scen, r in c["scenarios"].items():
            best = r["best"]
            add(n, scen, "best", "rank", r["rank"])
            add(n, scen, "best", "tied", int(r["tied"]), "0/1")
            add(n, scen, "best", "flash_energy_error", r["flash_energy_error"], "L_ref")
            _orientation_rows(add, n, scen, "best", best)
            add(n, scen, "best", "score", best["score"], "L_ref")
            for k, v in best["metrics"].items():
                if k != "per_view":
                    add(n, scen, "best", k, v, metric_units.get(k, ""))
            for k, v in r["normalised"].items():
                add(n, scen, "best", f"{k}_normalised", v, "ratio")
            for k, v in r["compromise"]["metrics"].items():
                if k != "per_view":
                    add(n, scen, "compromise", k, v, metric_units.get(k, ""))
            fc = r["flash_colour"] or {}
            colour_units = {"flash_fraction": "fraction", "dominant_wavelength_nm": "nm", "p10_nm": "nm", "p90_nm": "nm",
                            "purple_fraction": "fraction", "mean_dominant_wavelength_nm": "nm", "mean_purity": "fraction",
                            "peak_level": "tau L_ref", "estimator_flash_area": "fraction"}
            for k, unit in colour_units.items():
                add(n, scen, "best", f"colour_{k}", fc.get(k), unit)
            tc = r["tilt_curve"]
            for qty in ("flash_energy", "flash_area"):
                for axis, values in tc[qty].items():
                    for a, v in zip(tc["angles_deg"], values):
                        add(n, scen, "best", f"tilt_{qty}_{axis}", v, metric_units[qty], a, "deg")
            mc = r["misorientation"]
            for key in ("mean_relative", "worst_relative"):
                for a, v in zip(mc["miss_deg"], mc[key]):
                    add(n, scen, "best", f"misorientation_{key}", v, "ratio", a, "deg")
            for side, values in mc.get("by_side", {}).items():
                for a, v in zip(mc["miss_deg"], values):
                    add(n, scen, "best", f"misorientation_towards_{side}", v, "ratio", a, "deg")
            mp = best["map"]
            for t, az, v in zip(mp["tilt_deg"], mp["azimuth_deg"], mp["score"]):
                add(n, scen, "", "score_map_flash_energy", v, "L_ref", t, "deg tilt", az, "deg azimuth")
    return rows


def _orientation_rows(add: Callable[..., None], cut: str, scen: str, orient: str, block: dict[str, Any]) -> None:
    for axis, v in zip("xyz", block["normal"]):
        add(cut, scen, orient, f"normal_{axis}", v, "unit")
    add(cut, scen, orient, "tilt_deg", block["tilt_deg"], "deg")
    add(cut, scen, orient, "azimuth_deg", block["azimuth_deg"], "deg")
    add(cut, scen, orient, "tolerance_deg", block["tolerance_deg"], "deg")
    for k, v in block["tolerance_by_axis"].items():
        add(cut, scen, orient, f"tolerance_{k}", v, "deg")
    add(cut, scen, orient, "parallel_within_deg", block.get("parallel_within_deg"), "deg")
    shop = block.get("workshop") or {}
    add(cut, scen, orient, "raise_deg", shop.get("raise_deg"), "deg")
    add(cut, scen, orient, "raise_mm", shop.get("raise_mm"), "mm")
    add(cut, scen, orient, "span_mm", shop.get("span_mm"), "mm")


# ---------------------------------------------------------------------- the comparison
def _reference(reference: Any, cuts: list[Cut]) -> int:
    if isinstance(reference, str):
        names = [c.name for c in cuts]
        if reference not in names:
            raise ParameterError(f"reference {reference!r} is none of the cuts: {', '.join(names)}")
        return names.index(reference)
    index = check_number(reference, "reference (a cut's index or name)", integer=True)
    if not -len(cuts) <= index < len(cuts):
        raise ParameterError(f"reference {index} is out of range: {len(cuts)} cut(s), indices 0 to {len(cuts) - 1}")
    return index % len(cuts)


@dataclass
class ComparisonPlan:
    """A checked comparison, ready to run (:func:`plan_comparison`): resolved cuts, the material,
    the scenarios, the reference cut's index, quality, seed, render size (pixels) and samples per
    pixel (main render, rocking strip), strip angles (degrees)."""

    cuts: list[Cut]
    material: Any
    scenarios: list[Any]
    reference: int
    quality: Any  # a labcut.Quality
    seed: int
    resolution: int
    spp: int
    strip_spp: int
    strip_angles: tuple[float, ...]
    tau: float = 0.1
    #: the user's overrides of the effect planner (``{"occlusion": bool}``)
    effects: dict[str, bool] = field(default_factory=dict)
    #: the effect plan of each (cut name, scenario name) (:class:`labcut.planner.EffectPlan`)
    effect_plans: dict[tuple[str, str], Any] = field(default_factory=dict)
    #: ``time_budget=``'s choice of quality (:class:`labcut.commands.budget.BudgetChoice`), or None
    budget: Any = None

    @property
    def steps(self) -> int:
        """Units of work (and of a progress bar): cuts x scenarios."""
        return len(self.cuts) * len(self.scenarios)


def plan_comparison(
    cuts: Any,
    material: Any = None,
    scenarios: Sequence[Any] | Any = None,
    reference: int | str = 0,
    quality: Any = "standard",
    *,
    units: str | float = "auto",
    up_axis: str = "auto",
    seed: int = 0,
    resolution: int | None = None,
    spp: int | None = None,
    effects: Mapping[str, Any] | None = None,
    size: float | None = None,
    time_budget: float | None = None,
) -> ComparisonPlan:
    """Check every input of :func:`compare_cuts` (each cut parsed, read and validated) without
    starting the long work; a bad one is a one-line :class:`~labcut.errors.ParameterError` or
    :class:`~labcut.errors.MeshError` naming it. Arguments as :func:`compare_cuts`."""
    from ..scene.quality import Quality
    from ..commands.budget import quality_or_budget
    from ..validation import is_default

    quality_or_budget(not is_default(quality, "standard"), time_budget is not None)
    quality = Quality.coerce(quality)
    seed = check_number(seed, "seed", 0, 2**63 - 1, integer=True)
    res = quality.render_resolution if resolution is None else check_number(resolution, "render resolution (pixels)", 16, 2048, integer=True)
    n_spp = quality.render_spp if spp is None else check_number(spp, "render samples per pixel", 1, 4096, integer=True)
    from ..physics.material import Labradorite

    lab = Labradorite.coerce(material)
    scens = scenarios_from(scenarios, quality)
    from ..planner import plan_effects
    from ..scene.effects import check_effects

    switches = check_effects(effects)
    if time_budget is not None:
        from ..validation import check_budget

        check_budget(time_budget)  # a bad budget fails before the cuts are read
    resolved = resolve_cuts(cuts, units=units, up_axis=up_axis, size=size)
    ref = _reference(reference, resolved)
    choice = None
    if time_budget is not None:
        import warnings

        from ..errors import LabcutWarning
        from .budget import choose_quality

        choice = choose_quality(time_budget, resolved, scenarios if scenarios is not None else ["bench"], switches,
                                resolution, spp)
        if choice.note:
            warnings.warn(choice.note, LabcutWarning, stacklevel=3)
        quality = choice.quality
        res = quality.render_resolution if resolution is None else res
        n_spp = quality.render_spp if spp is None else n_spp
        scens = scenarios_from(scenarios, quality)
    plans = {(cut.name, sc.name): plan_effects(cut.mesh, lab, command="compare", scenario=sc, quality=quality,
                                               effects=switches, predict=True)
             for cut in resolved for sc in scens}
    return ComparisonPlan(resolved, lab, scens, ref, quality, seed, res, n_spp, max(1, n_spp // 2), quality.strip_angles_deg,
                          effects=switches, effect_plans=plans, budget=choice)


def compare_cuts(
    cuts: Any,
    material: Any = None,
    scenarios: Sequence[Any] | Any = None,
    reference: int | str = 0,
    quality: Any = "standard",
    *,
    units: str | float = "auto",
    up_axis: str = "auto",
    seed: int = 0,
    resolution: int | None = None,
    spp: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    effects: Mapping[str, Any] | None = None,
    size: float | None = None,
    time_budget: float | None = None,
) -> Comparison:
    """Compare cuts for their schiller under one or more scenarios.

    Parameters
    ----------
    cuts: mesh paths, ``trimesh.Trimesh`` meshes (mm, +Z face-up), cabochon specs such as
        ``"cab:oval,16x12,low"`` (:mod:`labcut.reports.cuts`), ``(name, cut)`` pairs, or a
        mapping ``{name: cut}``. Equal names are told apart (``oval.ply (2)``).
    material: :class:`~labcut.Labradorite` or a preset name (default blue-green labradorite).
    scenarios: scenario names, JSON files or :class:`~labcut.Scenario` objects (default ``["bench"]``).
    reference: the cut (index, or name) every other is normalised to.
    quality: ``draft`` | ``standard`` | ``high``: of the recommendations (as
        :func:`labcut.recommend_orientation`), the curves and the renders.
    units, up_axis: how mesh files are read (:func:`labcut.load_mesh`); ``size``: the girdle
        width (mm) of the GemCad designs among the cuts (``.asc``, ``.gem``).
    seed: surface sampling and render seed.
    resolution, spp: size (pixels) and samples per pixel of the renders (default by quality:
        96/8, 128/32, 256/128); the rocking strip uses half the samples.
    progress: ``callback(done, total)`` over all cuts x scenarios.
    effects: overrides of the effect planner, ``{"occlusion": bool}`` (docs/planner.md); each
        cut's plan under each scenario is in its recommendation's ``plan``. Compare ranks with the
        sample estimator.
    time_budget: seconds the whole comparison may take: the most accurate quality predicted to fit
        on this machine replaces ``quality`` (:mod:`labcut.reports.budget`; ``resolution`` and
        ``spp``, when given, are kept and counted); the choice is in ``Comparison.budget``. Below
        the cheapest setting's prediction the cheapest runs, with a one-line
        :class:`~labcut.errors.LabcutWarning`.

    Every input is checked (:func:`plan_comparison`) before the long work starts; a bad one
    raises a one-line :class:`~labcut.errors.ParameterError` or :class:`~labcut.errors.MeshError`
    naming it. Returns a :class:`Comparison`.

    Examples
    --------
    >>> import labcut
    >>> cmp = labcut.compare_cuts(["cab:oval,16x12,low,res=48", "cab:oval,16x12,high,res=48"], "blue", ["bench"],
    ...                           quality="draft", resolution=32, spp=2)
    >>> len(cmp.cuts), cmp.scenario_names, cmp.result(0, "bench").normalised["flash_energy"]
    (2, ['bench'], 1.0)
    >>> labcut.compare_cuts(["cab:oval,16x12,low"], "blue", ["beach"])
    Traceback (most recent call last):
    ...
    labcut.errors.ParameterError: unknown scenario 'beach'; choose one of bench, ring, pendant, brooch, display, outdoor, ring-diffuse,
    pendant-diffuse, brooch-diffuse, outdoor-still, or a scenario JSON file
    """
    plan = plan_comparison(cuts, material, scenarios, reference, quality, units=units, up_axis=up_axis, seed=seed,
                           resolution=resolution, spp=spp, effects=effects, size=size, time_budget=time_budget)
    return run_comparison(plan, progress)


def rank_and_normalise(cuts: Sequence[CutResult], scenarios: Sequence[Any], reference: int) -> dict[str, float]:
    """Finish a comparison of ``cuts`` (each with its per-scenario results): per scenario the ranks
    by flash energy and every value of :data:`NORMALISED` over the ``reference`` cut's, each cut's
    overall score (the mean over scenarios of its energy at the compromise orientation over the
    reference's) and its overall rank. Returns the exposure of each scenario's renders and rocking
    strips: the diagram look's reference (:func:`labcut.rendering.exposure.reference_exposure`),
    one for every cut and scenario, so a scenario whose light reaches the viewer less looks
    dimmer, as it is."""
    from ..rendering.exposure import reference_exposure

    exposures = {sc.name: reference_exposure(None) for sc in scenarios}
    refc = cuts[reference]
    for sc in scenarios:
        rs = [c.scenarios[sc.name] for c in cuts]
        base = refc.scenarios[sc.name]
        ranks = competition_ranks([r.energy for r in rs], [r.energy_error for r in rs])
        for r, rank, tie in zip(rs, ranks, shared(ranks)):
            r.rank, r.tied = rank, tie
            r.normalised = {k: _ratio(r.value(k), base.value(k)) for k in NORMALISED}
    for c in cuts:
        ratios = [_ratio(c.scenarios[s.name].compromise_metrics.flash_energy,
                         refc.scenarios[s.name].compromise_metrics.flash_energy) for s in scenarios]
        c.overall_score, c.overall_error = overall_score(ratios, [c.scenarios[s.name].recommendation.uncertainty
                                                                  for s in scenarios])
    ranks = competition_ranks([c.overall_score for c in cuts], [c.overall_error for c in cuts])
    for c, rank, tie in zip(cuts, ranks, shared(ranks)):
        c.rank, c.tied = rank, tie
    return exposures


def overall_score(ratios: Sequence[float | None], bars: Sequence[Any]) -> tuple[float, float]:
    """A cut's overall score and its error bar: the mean of its per-scenario ratios (energy at its
    compromise orientation / the reference cut's; None where the reference has none, left out),
    and the bar of that mean, each ratio's error (the ratio times its recommendation's
    ``score_rel``; none where it has no error bars) added in quadrature over the count. The
    reference's own error divides every cut alike, so it cannot change their order and is left out."""
    pairs = [(r, b) for r, b in zip(ratios, bars) if r is not None]
    if not pairs:
        return 0.0, 0.0
    errors = [r * (b.score_rel if b is not None else 0.0) for r, b in pairs]
    return float(np.mean([r for r, _ in pairs])), float(math.sqrt(sum(e * e for e in errors)) / len(pairs))


def run_comparison(plan: ComparisonPlan, progress: Callable[[int, int], None] | None = None) -> Comparison:
    """The long work of :func:`compare_cuts` for a checked :class:`ComparisonPlan`."""
    from ..geometry.inspect import summarize
    from ..orientation.radiance import reference_radiance
    from ..study import Study
    from ..orientation.recommend import describe, workshop
    from ..rendering.scene import RENDER_IRRADIANCE
    from .analysis import (
        compromise,
        tilt_axes,
        tilt_curve,
    )
    from .budget import mark_warm
    from .flashcolour import flash_colour_map
    from .renders import render_cut

    start = time.perf_counter()
    resolved, lab, scens, ref, quality, seed = plan.cuts, plan.material, plan.scenarios, plan.reference, plan.quality, plan.seed
    res, n_spp, strip_spp, strip_angles, tau = plan.resolution, plan.spp, plan.strip_spp, plan.strip_angles, plan.tau
    report = progress or (lambda done, total: None)
    l_ref = reference_radiance(lab, RENDER_IRRADIANCE)
    naming = naming_scenario(scens)

    total = len(resolved) * len(scens)
    done = 0
    report(done, total)
    results: list[CutResult] = []
    for cut in resolved:
        per: dict[str, ScenarioResult] = {}
        scorers = []
        for sc in scens:
            t0 = time.perf_counter()
            eplan = plan.effect_plans.get((cut.name, sc.name))
            # one Study per cut and scenario: the recommendation's flash problem and scorer serve the
            # curves and the compromise too (planned once, in plan_comparison)
            study = Study(cut.mesh, lab, sc, quality, seed=seed, tau=tau, estimator="samples", effects=plan.effects,
                          plan=eplan)
            rec = study.recommend()
            scorer = study.scorer
            scorers.append(scorer)
            mis = rec.misorientation  # the recommendation's own curve, from the same scorer
            tilt = tilt_curve(cut.mesh, lab, rec.normal, sc, quality, tau, seed)
            renders = render_cut(cut.mesh, lab, rec.normal, sc, tilt_axes(sc)["front_back"], res, n_spp, strip_angles,
                                 seed, strip_spp=strip_spp, tau=tau)
            mark_warm(renders.plan["integrator"])
            h, w = renders.schiller.shape[:2]
            level = renders.flash.threshold  # τ P: the scenario's own flash threshold, in units of L_ref
            colour = flash_colour_map(renders.schiller, renders.mask, level * l_ref, renders.flash.ratio_at(h, w), level)
            rest = tilt.at_rest("flash_area")  # the estimator's, the same view at rest (NaN: edge-on)
            colour.stats["estimator_flash_area"] = rest if math.isfinite(rest) else None
            per[sc.name] = ScenarioResult(cut.name, sc, rec, tilt, mis, renders, colour, seconds=time.perf_counter() - t0)
            done += 1
            report(done, total)
        recs = [per[s.name].recommendation for s in scens]
        cp = compromise(scorers, [s.name for s in scens], [r.normal for r in recs], quality,
                        maps=[(r.map_normals, r.map_scores) for r in recs])
        for sc, scorer in zip(scens, scorers):
            per[sc.name].compromise_metrics = scorer.metrics(cp.normal)
            per[sc.name].compromise_relative = cp.relative[sc.name]
        del scorers
        parallel = cp.parallel_within_deg is not None
        results.append(CutResult(cut, summarize(cut.mesh, cut.name), per, cp, describe(cp.normal, naming, cp.parallel_within_deg),
                                 workshop(cp.normal, cut.mesh, naming, parallel=parallel)))

    exposures = rank_and_normalise(results, scens, ref)
    render_info = {"resolution": res, "spp": n_spp, "strip_spp": strip_spp, "strip_angles_deg": list(strip_angles),
                   "l_ref": l_ref, "irradiance": RENDER_IRRADIANCE}
    seconds = time.perf_counter() - start
    budget: dict[str, Any] = {}
    if plan.budget is not None:  # the calibration learns from this run (reports/budget.py)
        from ..commands.budget import record
        from .budget import KIND

        record(KIND, plan.budget.predicted_seconds / plan.budget.correction, seconds)
        budget = plan.budget.to_dict()
    return Comparison(results, scens, lab, ref, quality, exposures, render_info, seconds, tau, seed, budget)
