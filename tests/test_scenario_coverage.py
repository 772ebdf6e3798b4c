"""Error bars that cover every scenario (issue 39), on a small scale: two bundled stones (the low oval
cabochon and the GemCad SRB brilliant at 10 mm) x every scenario at draft, against references at
``high`` quality (two seeds' mean) recorded by ``benchmarks/scenario_coverage.py`` in
``tests/data/scenario_references.json``. The full study (three stones, draft and standard, three
seeds, the render estimator included) is in docs/accuracy.md.

The references are the code's own answers at a finer quality: a change of the physics, a scenario
or the estimator moves them, and this test then fails until the benchmark is rerun (as the golden
answers of tests/test_golden_answers.py are re-recorded)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.scene import SCENARIOS

ROOT = Path(__file__).resolve().parents[1]
REFERENCES = json.loads((ROOT / "tests" / "data" / "scenario_references.json").read_text())
STONES = {"oval": ("meshes/oval-16x12-low.ply", None), "srb": ("meshes/designs/SRB.asc", 10.0)}
#: the issue's targets: the share of answers whose bar covers the distance to the reference
NORMAL_TARGET, SCORE_TARGET = 0.90, 0.80


def _angle(a, b) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(np.dot(a, b))))))


#: the draft answers' seeds (the study's first two of three)
SEEDS = (1, 2)


@pytest.fixture(scope="module", params=sorted(STONES))
def answers(request):
    """Every scenario at draft for one stone and :data:`SEEDS`: (distance, bar, reference bar,
    score error, score bar, reference score bar) per case."""
    path, size = STONES[request.param]
    mesh = labcut.load_mesh(ROOT / path, size=size) if size else labcut.load_mesh(ROOT / path)
    out = {}
    for scenario in SCENARIOS.names():
        ref = REFERENCES["references"][f"{request.param}/{scenario}"]
        for seed in SEEDS:
            rec = labcut.recommend_orientation(mesh, "blue", scenario=scenario, quality="draft", seed=seed)
            u = rec.uncertainty
            out[f"{request.param}/{scenario}/{seed}"] = (_angle(rec.normal, ref["normal"]), u.angle_deg, ref["bar_deg"],
                                                         abs(ref["score"] / rec.score - 1.0), u.score_rel, ref["bar_score"])
    return out


def test_the_references_cover_every_scenario():
    names = set(SCENARIOS.names())
    for stone in STONES:
        assert {k.split("/")[1] for k in REFERENCES["references"] if k.startswith(stone + "/")} == names, (
            "tests/data/scenario_references.json lacks a scenario: rerun benchmarks/scenario_coverage.py")


def test_draft_bars_cover_the_distance_to_the_reference_under_every_scenario(answers):
    """At least 90 % of the normals and 80 % of the scores are covered (their bar plus the
    reference's); the misses are named."""
    normal_miss = [k for k, (d, bar, rbar, *_) in answers.items() if d > bar + rbar]
    score_miss = [k for k, (*_, e, sbar, rsbar) in answers.items() if e > sbar + rsbar]
    n = len(answers)
    # the allowance rounded to whole answers first: (1 - 0.9) * 20 is 1.9999999999999996 in floating point
    assert len(normal_miss) <= round((1.0 - NORMAL_TARGET) * n, 9), normal_miss
    assert len(score_miss) <= round((1.0 - SCORE_TARGET) * n, 9), score_miss


def test_the_bars_are_not_vacuous(answers):
    """Bars a third as wide would miss more than the targets allow: the bars are as wide as the
    errors need, not wider by a margin that makes any answer "covered"."""
    shrunk = [k for k, (d, bar, rbar, *_) in answers.items() if d > (bar + rbar) / 3.0]
    assert len(shrunk) > round((1.0 - NORMAL_TARGET) * len(answers), 9), shrunk
