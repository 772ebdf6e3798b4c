"""The tolerance means what it says: the angle at which the score first drops below 90 % of the best.

A brute-force search on fine rings of normals (256 directions, 0.02° apart in angle) around the
recommended normal finds the first ring with a point below 90 % of the best score; the
recommendation's ``tolerance_deg`` (16-direction rings, bisected to 0.05°) must match it.
With the 90 % changed (say to 80 %) in the code the tolerance grows by a third and this fails.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import labcut
from labcut.reports.analysis import ring, scorer_for

KEEP_STATED = 0.9  # "keeps 90 % of the score" (docs/orientation.md, the CLI's tolerance row)


def brute_tolerance(scores, best: np.ndarray, best_score: float, step: float = 0.02, limit: float = 30.0,
                    directions: int = 256) -> float:
    """The largest angle (degrees, a multiple of ``step``) up to which every ring keeps 90 %."""
    angles = np.arange(step, limit + step / 2, step)
    for chunk in np.array_split(angles, max(1, len(angles) // 100)):
        rings = np.concatenate([ring(best, float(a), directions) for a in chunk])
        values = np.asarray(scores(rings)).reshape(len(chunk), directions).min(axis=1)
        below = np.nonzero(values < KEEP_STATED * best_score)[0]
        if below.size:
            first = float(chunk[below[0]])
            return first - step
    return limit


@pytest.mark.parametrize("scenario", ["bench", "ring"])
def test_tolerance_is_where_the_score_first_drops_below_90_percent(scenario):
    mesh = labcut.cabochon(outline="oval", length=16, width=12, dome="medium")
    lab = labcut.Labradorite()
    rec = labcut.recommend_orientation(mesh, lab, scenario=scenario, quality="draft")
    scorer = scorer_for(mesh, lab, rec.scenario, "draft")
    assert math.isclose(scorer.score(rec.normal), rec.score, rel_tol=1e-5)
    brute = brute_tolerance(scorer.energy_map, rec.normal, rec.score)
    assert 0.3 < brute < 29.0, brute  # a real peak, not the search limit
    # 16 directions may miss the worst direction by a little; bisection stops within 0.05°
    assert abs(rec.tolerance_deg - brute) <= 0.05 + 0.04 * brute, (rec.tolerance_deg, brute)
