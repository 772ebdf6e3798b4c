"""labcut.Study: one stone and one flash question, re-asked without rebuilding what did not change
(issue 31 §2); its answers are recommend_orientation's and evaluate_orientation's to the bit."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.errors import MeshError, ParameterError
from labcut.geometry import stone as stone_module
from labcut.orientation.kernels import KernelOptions
from labcut.scene.directions import direction

ROOT = Path(__file__).resolve().parents[1]
OVAL = ROOT / "meshes" / "oval-16x12-low.ply"
BIPLANE = ROOT / "meshes" / "carving-biplane.ply"


def same_answer(a, b):
    """Two recommendations agree to the last bit in everything they answer."""
    np.testing.assert_array_equal(a.normal, b.normal)
    assert (a.score, a.tolerance_deg, a.tolerance_by_axis, a.metrics) == (b.score, b.tolerance_deg, b.tolerance_by_axis, b.metrics)
    assert a.uncertainty == b.uncertainty and a.runners_up == b.runners_up and a.evaluations == b.evaluations
    np.testing.assert_array_equal(a.map_scores, b.map_scores)
    assert a.settings == b.settings and a.mesh == b.mesh and a.plan["estimator"] == b.plan["estimator"]


@pytest.mark.parametrize("path, scenario, quality", [(OVAL, "bench", "standard"), (OVAL, "ring", "draft"),
                                                      (BIPLANE, "bench", "draft")])
def test_the_study_answers_as_recommend_orientation(path, scenario, quality):
    stone = labcut.Stone.load(path)
    want = labcut.recommend_orientation(stone, "blue", scenario=scenario, quality=quality)
    study = labcut.Study(stone, "blue", scenario, quality)
    same_answer(study.recommend(), want)
    assert study.recommend() is study.recommend()  # asked again: kept


def test_evaluate_by_normal_or_by_tilt_and_azimuth():
    stone = labcut.Stone.load(OVAL)
    study = labcut.Study(stone, scenario="pendant", quality="draft")
    n = direction(10.0, 90.0)
    want = labcut.evaluate_orientation(stone, n, scenario="pendant", quality="draft")
    assert study.evaluate(tilt=10, azimuth=90) == want == study.evaluate(normal=n) == study.evaluate(n)
    for bad in ({}, {"tilt": 10}, {"normal": n, "tilt": 10, "azimuth": 0}, {"tilt": 95, "azimuth": 0},
                {"tilt": float("nan"), "azimuth": 0}, {"normal": (0, 0, 0)}):
        with pytest.raises(ParameterError):
            study.evaluate(**bad)


def test_reasking_reuses_what_did_not_change(monkeypatch):
    from labcut.orientation.volume import depth_exposure

    stone = labcut.Stone.load(OVAL)
    depth_exposure(stone, labcut.Labradorite())  # the planner's, kept by the stone (or read from the user cache)
    draws = []
    real = stone_module.draw_samples
    monkeypatch.setattr(stone_module, "draw_samples", lambda *a, **k: draws.append(a[1:3]) or real(*a, **k))
    study = labcut.Study(stone, scenario="bench", quality="draft")
    rec = study.recommend()
    study.evaluate(rec.normal)
    study.score_map()
    assert study.builds == {"plan": 1, "problem": 1, "recommendation": 1}
    # the answer's samples and the error bars' finer-direction problem's
    assert draws == [(3000, 0), (750, 0)]
    drawn = len(draws)
    lamp = study.with_lights("spot")
    assert lamp.scenario.lights.name == "spot" and lamp.scenario.views.name == study.scenario.views.name
    lamp.recommend()
    green = study.with_material("green")
    green.evaluate(rec.normal)
    assert study.builds == {"plan": 3, "problem": 3, "recommendation": 2}
    assert len(draws) == drawn  # the stone's surface samples served them all
    by_area = study.with_objective("intensity")
    assert by_area.scorer.problem is study.scorer.problem and by_area.plan() is study.plan()
    other = study.with_kernels(KernelOptions.reference())
    assert other.plan() is study.plan() and other.scorer.problem.kernels == KernelOptions.reference()
    assert study.builds["plan"] == 3 and study.builds["problem"] == 4
    finer = study.with_quality("standard")
    assert finer.quality.name == "standard" and finer.stone is study.stone
    assert study.with_scenario("ring").scenario.name == "ring"


def test_other_lights_keep_the_default_scenarios_viewers_and_poses():
    study = labcut.Study(labcut.Stone.load(OVAL), quality="draft")  # no scenario: bench
    lamp = study.with_lights("spot")
    assert lamp.scenario.lights.name == "spot"
    assert lamp.scenario.views.name == study.scenario.views.name == "cutter"
    assert len(lamp.scenario.poses()) == len(study.scenario.poses())


def test_a_rebuilt_question_is_checked_as_any():
    study = labcut.Study(labcut.Stone.load(OVAL), scenario="bench", quality="draft")
    with pytest.raises(ParameterError):
        study.with_objective("sparkle")
    with pytest.raises(ParameterError):
        study.with_quality("ultra")
    with pytest.raises(ParameterError):
        study.with_kernels("fast")
    with pytest.raises(ParameterError):
        study.score_map(spacing_deg=0)
    with pytest.raises(ParameterError, match="from the Study"):
        study.render(scenario="ring")
    with pytest.raises(MeshError):
        labcut.Study("oval.ply")
    with pytest.raises(ParameterError):
        labcut.Study(labcut.Stone.load(OVAL), kernels="fast")


def test_score_map_is_the_recommendations_map():
    study = labcut.Study(labcut.Stone.load(OVAL), scenario="bench", quality="draft")
    rec = study.recommend()
    normals, scores = study.score_map()
    np.testing.assert_array_equal(normals, rec.map_normals)
    np.testing.assert_allclose(scores, rec.map_scores, rtol=0, atol=1e-9 * rec.map_scores.max())


def test_the_docs_study_example_runs(capsys):
    """docs/study.md's code blocks, in order, as a notebook runs them (from the repository root)."""
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "study.md").read_text(), re.S)
    assert len(blocks) >= 4
    here = os.getcwd()
    os.chdir(ROOT)
    try:
        namespace: dict = {}
        for block in blocks:
            exec(compile(block, "docs/study.md", "exec"), namespace)  # noqa: S102 (our own docs)
    finally:
        os.chdir(here)
    assert namespace["study"].builds == {"plan": 3, "problem": 3, "recommendation": 3}
    assert "tilt" in capsys.readouterr().out


def test_recommended_is_the_recommendation_once_made_and_nothing_before():
    import labcut

    study = labcut.Study(labcut.load_mesh("meshes/oval-16x12-low.ply"), quality="draft")
    assert study.recommended() is None and study.builds["recommendation"] == 0
    rec = study.recommend()
    assert study.recommended() is rec and study.recommended("grid") is None


def test_the_surface_scorer_is_the_scorer_where_the_plan_samples_the_surface():
    study = labcut.Study(labcut.Stone.load(OVAL), scenario="bench", quality="draft")
    assert study.plan().estimator == "samples" and study.surface_scorer is study.scorer
    normals, scores = study.score_map(surface=True)
    assert np.array_equal(scores, study.score_map()[1])
    with pytest.raises(ParameterError, match="pilot_seconds_max"):
        labcut.Study(labcut.Stone.load(OVAL), pilot_seconds_max=-1.0)
    assert labcut.Study(labcut.Stone.load(OVAL), pilot_seconds_max=0).pilot_seconds_max == 0.0
