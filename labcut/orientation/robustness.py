"""How far the best lamella orientation moves across plausible variants of the scenario (issue 39).

A recommendation is the best orientation for one room, one motion and one set of onlookers; the
world the stone is worn in differs from the preset in ways nobody can fix in advance
(:mod:`labcut.scene.variants`). :func:`scenario_robustness` answers the same question under
``count`` variants and reports:

* ``moved_deg`` per variant: the angle from the answer (the sample estimator's normal; where the
  render estimator answered, the normal it started from) to the variant's best normal, both found
  by the sample estimator with the same surface samples (common random numbers: the spread is the
  scenario's, not the sampling's);
* ``keeps`` per variant: the variant's score of the answer over the variant's best score (what the
  cutter loses by cutting for the preset when the stone is worn in the variant);
* the largest and the median move (``spread_deg``, ``median_deg``) and the verdict, the median
  against the answer's error bar and its tolerance: ``inside`` (within the error bar: the answer
  does not depend on the free parameters more than on the sampling), ``beside`` (beyond the bar,
  within the tolerance), ``swings`` (beyond the tolerance: the output says the answer depends on
  how the stone is lit and worn); and always how much of each variant's best the cut keeps.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..scene.directions import tilt_azimuth
from ..scene.variants import Variation, scenario_variants
from .optimize import search_best
from .question import FlashQuestion

VERDICTS = ("inside", "beside", "swings")


@dataclass(frozen=True)
class Robustness:
    """The answer across variants of its scenario (module docstring); angles in degrees, normals
    in the mesh frame."""

    #: the draw's ranges (:meth:`labcut.scene.variants.Variation.to_dict`)
    variation: dict[str, Any]
    #: per variant: ``name``, ``changes`` (the values drawn), ``normal``, ``tilt_deg``,
    #: ``azimuth_deg``, ``moved_deg``, ``keeps``; or ``name``, ``changes`` and ``error`` where the
    #: variant has no answer (no light reaches a viewer, nothing flashes)
    variants: tuple[dict[str, Any], ...]
    #: the largest and the median move of the best normal (variants with an answer)
    spread_deg: float
    median_deg: float
    #: the smallest share of a variant's best score the answer keeps
    keeps_min: float
    #: the answer's error bar and tolerance the spread is judged against
    bar_deg: float
    tolerance_deg: float
    seconds: float = 0.0

    @property
    def verdict(self) -> str:
        """How far the best normal typically moves (the median over the variants): ``inside`` the
        error bar, ``beside`` it (within the tolerance), or ``swings`` beyond the tolerance (also
        where a variant has no answer at all: the stone may stay grey there). The median, not the
        largest move: the largest grows with the number of variants drawn, and is reported beside."""
        if self.answered < len(self.variants):
            return "swings"
        if self.median_deg <= self.bar_deg:
            return "inside"
        return "beside" if self.median_deg <= self.tolerance_deg else "swings"

    @property
    def answered(self) -> int:
        return sum("error" not in v for v in self.variants)

    def sentence(self) -> str:
        """One line for people: how far the answer moves, what that means, what the cut keeps."""
        n = len(self.variants)
        head = f"across {n} variants of the scenario (room layout, motion, viewers)"
        missing = n - self.answered
        if not self.answered:
            return f"{head} no orientation flashes: the answer holds only for the scenario as given"
        moves = f"{self.median_deg:.1f}° typically (up to {self.spread_deg:.1f}°)"
        keeps = f"cut as recommended it keeps at least {self.keeps_min:.0%} of each variant's best"
        tail = f"; {missing} variant(s) without flash" if missing else ""
        if self.verdict == "inside":
            return f"{head} the best orientation moves by {moves}, inside its error bar (±{self.bar_deg:.1f}°); {keeps}{tail}"
        if self.verdict == "beside":
            return (f"{head} the best orientation moves by {moves}, beyond its error bar (±{self.bar_deg:.1f}°) but within "
                    f"its tolerance (±{self.tolerance_deg:.1f}°); {keeps}{tail}")
        return (f"the answer swings by {moves} {head}, more than its tolerance (±{self.tolerance_deg:.1f}°): it depends on "
                f"how the stone will really be lit and worn; {keeps}{tail}")

    def to_dict(self) -> dict[str, Any]:
        return {"variation": self.variation, "variants": list(self.variants), "spread_deg": self.spread_deg,
                "median_deg": self.median_deg, "keeps_min": self.keeps_min, "bar_deg": self.bar_deg,
                "tolerance_deg": self.tolerance_deg, "verdict": self.verdict, "sentence": self.sentence(),
                "seconds": self.seconds}

    @classmethod
    def from_dict(cls, data: Any) -> Robustness | None:
        if data is None:
            return None
        if not isinstance(data, dict):
            raise ParameterError("robustness must be a JSON object")
        try:
            return cls(dict(data["variation"]), tuple(dict(v) for v in data["variants"]), float(data["spread_deg"]),
                       float(data["median_deg"]), float(data["keeps_min"]), float(data["bar_deg"]),
                       float(data["tolerance_deg"]), float(data.get("seconds", 0.0)))
        except KeyError as exc:
            raise ParameterError(f"robustness: missing {exc.args[0]!r}") from None
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"robustness: {exc}") from None


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(np.dot(a, b))))))


def scenario_robustness(mesh: Any, ask: FlashQuestion, normal: Any, *, occlusion: bool, variation: Variation | int,
                        bar_deg: float, tolerance_deg: float, optimizer: str = "nlopt",
                        progress: Callable[[float], None] | None = None, volume: bool = False,
                        env_samples: int | None = None) -> Robustness:
    """Answer question ``ask`` about ``mesh`` (a checked trimesh) under each variant of its scenario
    (:func:`labcut.scene.variants.scenario_variants`) with the sample estimator (occlusion rays as
    the answer's plan had them; through the stone's volume with ``volume``, as the answer's
    estimator; an environment map through ``env_samples`` directions where the answer's plan set them), and measure the variants' best normals against ``normal`` (the
    sample estimator's answer, unit, mesh frame). ``bar_deg`` and ``tolerance_deg``: the answer's
    error bar and tolerance, which the verdict compares the spread with. ``progress``: called with
    the fraction of variants done."""
    var = Variation.coerce(variation)
    if var is None:
        raise ParameterError("scenario_robustness needs at least 2 variants")
    start = time.perf_counter()
    base = np.asarray(normal, dtype=np.float64)
    rows: list[dict[str, Any]] = []
    drawn = scenario_variants(ask.scenario, var)
    for k, variant in enumerate(drawn):
        row: dict[str, Any] = {"name": variant.scenario.name, "changes": variant.changes}
        try:
            scorer = ask.with_scenario(variant.scenario).scorer(mesh, occlusion=occlusion, volume=volume, env_samples=env_samples)
            found = search_best(scorer, ask.constraint, ask.quality, optimizer)
            if not found.score > 0.0:
                raise ParameterError("no orientation flashes")
            tilt, az = tilt_azimuth(found.normal)
            row.update({"normal": [float(x) for x in found.normal], "tilt_deg": tilt, "azimuth_deg": az,
                        "moved_deg": _angle(found.normal, base), "keeps": float(scorer.score(base) / found.score)})
        except ParameterError as exc:
            row["error"] = str(exc)
        rows.append(row)
        if progress is not None:
            progress((k + 1) / len(drawn))
    moved = [r["moved_deg"] for r in rows if "error" not in r]
    keeps = [r["keeps"] for r in rows if "error" not in r]
    return Robustness(var.to_dict(), tuple(rows), max(moved, default=0.0), float(np.median(moved)) if moved else 0.0,
                      min(keeps, default=0.0), float(bar_deg), float(tolerance_deg), time.perf_counter() - start)
