"""The bundled stones' answers, bit for bit, as recorded before the third wave's redesign.

``tools/record_answers.py`` wrote ``tests/data/answers_golden.json``: for both bundled stones
under every scenario preset at draft and standard (the moving worn scenarios at draft only), the sample estimator's normal, score,
tolerance (and per axis) and error bars, each float as ``float.hex``, and the estimator the
effect planner chooses. A change meant to leave the answers alone (a refactor, a new home for a
function, a speed path) keeps every one of them to the last bit; one meant to change an answer
reruns the tool and says why in its commit.

The render estimator is not deterministic to the bit (Mitsuba accumulates its film and gradients
in thread order); one of its answers is held within a small angle and score difference instead.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import labcut

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import record_answers  # noqa: E402

GOLDEN = json.loads((ROOT / "tests" / "data" / "answers_golden.json").read_text())
SAMPLE_CASES = sorted(k for k in GOLDEN if not k.startswith(("render|", "volume|")))


@pytest.fixture(scope="module")
def meshes():
    return {name: labcut.load_mesh(ROOT / "meshes" / name) for name in record_answers.STONES}


def test_every_case_is_recorded():
    cases = {"|".join(case) for case in record_answers.cases()}
    assert cases == set(SAMPLE_CASES)
    assert len(cases) == len(record_answers.STONES) * (2 * len(record_answers.scenarios()) - len(record_answers.DRAFT_ONLY))
    # the planner's choices for the bundled stones (the render estimator's path: its own case, asked for)
    assert {GOLDEN[c]["planned_estimator"] for c in SAMPLE_CASES} == {"samples", "volume"}


@pytest.mark.parametrize("case", SAMPLE_CASES)
def test_sample_answer_is_unchanged_to_the_last_bit(meshes, case):
    stone, scenario, quality = case.split("|")
    want = dict(GOLDEN[case])
    planned = want.pop("planned_estimator")
    assert record_answers.answer(meshes[stone], scenario, quality) == want
    assert record_answers.planned_estimator(meshes[stone], scenario, quality) == planned


def test_planner_default_gives_the_same_sample_answer(meshes):
    """Where the planner chooses the sample estimator, the default call is the recorded answer."""
    case = "oval-16x12-low.ply|pendant|draft"
    want = dict(GOLDEN[case])
    assert want.pop("planned_estimator") == "samples"
    assert record_answers.answer(meshes["oval-16x12-low.ply"], "pendant", "draft", estimator="auto") == want


@pytest.mark.parametrize("case", record_answers.VOLUME_CASES, ids="|".join)
def test_volume_estimator_answer_is_unchanged_to_the_last_bit(meshes, case):
    """The planner's volume answers (the carving's thin wings), exact as the sample estimator's."""
    stone, scenario, quality = case
    want = GOLDEN["volume|" + "|".join(case)]
    got = record_answers.answer(meshes[stone], scenario, quality, estimator="auto")
    assert got["estimator"] == "volume" and got == want


def test_render_estimator_answer_is_unchanged_within_its_noise(meshes):
    """The render estimator's answer, on one Dr.Jit thread: its film and gradients add in thread
    order, and L-BFGS's stall test on float32 noise turns that into discrete paths whose spread
    grows with the thread count; on one thread the answer is the same run after run."""
    import drjit as dr

    stone, scenario, quality = record_answers.RENDER_CASE
    want = GOLDEN["render|" + "|".join(record_answers.RENDER_CASE)]
    threads = dr.thread_count()
    dr.set_thread_count(1)
    try:
        got = record_answers.answer(meshes[stone], scenario, quality, estimator="render")
    finally:
        dr.set_thread_count(threads)
    assert got["estimator"] == want["estimator"] == "render"
    a = np.array([float.fromhex(x) for x in got["normal"]])
    b = np.array([float.fromhex(x) for x in want["normal"]])
    # the record (several threads) lies 0.002° from the one-thread answer; a real change moves it more
    assert math.degrees(math.acos(min(1.0, abs(float(a @ b))))) < 0.02
    assert float.fromhex(got["score"]) == pytest.approx(float.fromhex(want["score"]), rel=1e-3)
