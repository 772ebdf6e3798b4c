"""The speed layer is contained: one frozen KernelOptions, held by the problem and its scorer,
handed in by whoever wants another path; no module-level on/off switches (issue 31 §5)."""

from __future__ import annotations

import ast
import math
from dataclasses import FrozenInstanceError, replace
from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.errors import ParameterError
from labcut.orientation.kernels import DEFAULT_KERNELS, KernelOptions
from labcut.orientation.problem import build_problem
from labcut.orientation.scoring import Scorer
from labcut.orientation.question import FlashQuestion

ROOT = Path(__file__).resolve().parents[1]


def module_level_booleans(path: Path) -> list[str]:
    """Names bound to True or False at a module's top level (switches by another name)."""
    tree = ast.parse(path.read_text(), str(path))
    out = []
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) else []
        value = getattr(node, "value", None)
        if isinstance(value, ast.Constant) and isinstance(value.value, bool):
            out += [f"{path.relative_to(ROOT)}:{node.lineno} {t.id}" for t in targets if isinstance(t, ast.Name)]
    return out


def test_no_module_level_boolean_switches():
    found = [hit for path in sorted((ROOT / "labcut").rglob("*.py")) for hit in module_level_booleans(path)]
    assert found == []


def test_the_rule_sees_a_switch(tmp_path):
    bad = ROOT / "labcut" / "_probe_for_test.py"  # inside the tree, as the rule reads it
    try:
        bad.write_text("FAST_PATH = True\nlimit: bool = False\n")
        assert [h.split()[-1] for h in module_level_booleans(bad)] == ["FAST_PATH", "limit"]
    finally:
        bad.unlink()


def test_options_are_frozen_and_checked():
    with pytest.raises(FrozenInstanceError):
        DEFAULT_KERNELS.triples = False  # type: ignore[misc]
    for bad in ({"triples": 1}, {"dense_chunk": 0}, {"dense_chunk": 2.5}, {"map_min_normals": True},
                {"map_kernel_rtol": 0.0}, {"map_kernel_rtol": 1.5}):
        with pytest.raises(ParameterError, match="KernelOptions"):
            KernelOptions(**bad)
    ref = KernelOptions.reference()
    assert not any((ref.triples, ref.lit_cells, ref.pair_sums, ref.grid_keys, ref.bins, ref.energy_map))
    assert not KernelOptions(triples=False).lit_cells_on_device  # the lit cells need the triple kernel
    assert not KernelOptions(pair_sums=False).device_keys_apply(1000, 10)  # the keys need the device copy
    assert KernelOptions(pair_sums_max_triples=10).pair_kernel_takes(10)
    assert not KernelOptions(pair_sums_max_triples=10).pair_kernel_takes(11)


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")


def test_the_problem_and_its_scorer_hold_the_options_they_were_given(oval):
    settings = labcut.Scenario.preset("bench", "draft").settings()
    mine = KernelOptions(energy_map=False, dense_chunk=50_000)
    problem = build_problem(oval, labcut.Labradorite(), quality="draft", settings=settings, kernels=mine)
    assert problem.kernels is mine
    assert Scorer(problem).sparse_map.kernels is mine
    assert build_problem(oval, labcut.Labradorite(), quality="draft", settings=settings).kernels is DEFAULT_KERNELS


def test_a_setups_options_reach_the_whole_recommendation(oval):
    """The numpy reference paths through FlashQuestion: a different computation (float64 terms, not
    the kernels' float32: the bits differ) of the same answer (well within its error bar)."""
    asked = FlashQuestion.build(labcut.Labradorite(), "bench", quality="draft", estimator="samples")
    fast = labcut.recommend_orientation(oval, setup=asked)
    ref = labcut.recommend_orientation(oval, setup=replace(asked, kernels=KernelOptions.reference()))
    angle = math.degrees(float(np.linalg.norm(np.cross(fast.normal, ref.normal))))  # exact for tiny angles
    assert 0.0 < angle < 0.1 * fast.uncertainty.angle_deg
    assert fast.uncertainty.angle_deg != ref.uncertainty.angle_deg  # the bars' pair sums took the numpy path
    assert ref.score == pytest.approx(fast.score, rel=1e-4)
    assert "kernels" not in ref.settings  # how, not what: the question's record is the same
    assert ref.settings == fast.settings


def test_a_launched_result_is_read_once():
    """Kernels launched ahead (the hemisphere map while DIRECT-L steps, the error bars' stencils)
    hide behind a result object: its value waits for them the first time and is kept."""
    from labcut.backend import Launched

    reads = []
    launched = Launched(lambda: reads.append(1) or np.arange(3.0))
    assert reads == [] and "running" in repr(launched)
    first = launched.value
    assert launched.value is first and reads == [1] and "ready" in repr(launched)
    assert Launched.ready(5).value == 5


def test_the_recommendations_map_is_launched_and_read_as_the_map(oval):
    from labcut.orientation.optimize import Constraint, hemisphere_grid

    settings = labcut.Scenario.preset("bench", "draft").settings()
    scorer = Scorer(build_problem(oval, labcut.Labradorite(), quality="draft", settings=settings))
    grid = hemisphere_grid(4.0, Constraint())
    launched = scorer.launch_energy_map(grid)
    np.testing.assert_array_equal(launched.value, scorer.energy_map(grid))


def test_the_estimators_answer_through_one_interface(oval):
    """Both estimators implement FlashEstimator and are made by name; the recommendation and the
    evaluation have no branch per estimator."""
    from labcut.orientation.estimators import ESTIMATORS, RenderEstimator, SampleEstimator, estimator_for
    from labcut.planner import plan_question

    assert set(ESTIMATORS) == {"samples", "volume", "render"}
    asked = FlashQuestion.build(labcut.Labradorite(), "bench", quality="draft", estimator="samples")
    plan = plan_question(oval, asked, "evaluate", predict=False)
    settings = asked.scenario.settings()
    scorer = Scorer(build_problem(oval, asked.material, quality="draft", settings=settings))
    samples = estimator_for("samples", oval, asked, scorer, plan)
    render = estimator_for("render", oval, asked, scorer, plan)
    assert isinstance(samples, SampleEstimator) and isinstance(render, RenderEstimator)
    volume = estimator_for("volume", oval, asked, scorer, plan)  # the sample estimator over the volume's problem
    assert isinstance(volume, SampleEstimator) and volume.name == "volume" and volume.scorer is scorer
    m = np.array([0.0, 0.0, 1.0])
    for est in (samples, render):
        assert est.name in ESTIMATORS and 0 < est.progress_before_refine <= 1
        assert est.metrics(m).flash_energy > 0
        value, grad = est.value_and_grad(m)
        assert value > 0 and grad.shape == (3,)
    assert samples.refine(m, 1.0, lambda *a: None).normal is m  # the sample optimum is its own answer
    np.testing.assert_allclose(samples.objective(m[None, :]), [scorer.score(m)])
    with pytest.raises(ParameterError, match="no flash estimator"):
        estimator_for("magic", oval, asked, scorer, plan)
    for path in ("labcut/orientation/recommend.py", "labcut/commands/recommend.py", "labcut/study.py"):
        text = (ROOT / path).read_text()
        assert '== "render"' not in text and '"render" if' not in text and '== "volume"' not in text, path
