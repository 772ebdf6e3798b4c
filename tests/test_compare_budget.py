"""``compare_cuts(..., time_budget=)`` / ``labcut compare --time-budget`` (labcut.reports.budget)."""

from __future__ import annotations

import json

import pytest

import labcut
from labcut.errors import LabcutWarning, ParameterError
from labcut.commands.budget import correction
from labcut.reports import budget as B
from labcut.reports.compare import plan_comparison, resolve_cuts
from labcut.scene.quality import Quality

CUTS = ["cab:oval,16x12,low,res=48", "cab:oval,16x12,high,res=48"]


@pytest.fixture(autouse=True)
def _own_corrections(monkeypatch, tmp_path):
    """Each test starts with no learnt correction (its own corrections file)."""
    monkeypatch.setattr("labcut.commands.budget.corrections_path", lambda: tmp_path / "corrections.json")


def _fake_machine(monkeypatch, per_point: float = 1e-4, per_sample: float = 1e-7, per_evaluated_point: float = 0.0):
    """A machine of known speed: each prediction proportional to the points or samples it counts."""
    monkeypatch.setattr("labcut.planner.predict_sample_seconds",
                        lambda settings, points, occlusion: per_point * points)
    monkeypatch.setattr("labcut.planner.predict_evaluate_seconds",
                        lambda settings, points, occlusion: per_evaluated_point * points)
    monkeypatch.setattr(B, "compare_render_timing", lambda integrator, refresh=False: (0.0, per_sample, 0.0))


def test_the_prediction_adds_every_part_of_every_pair(monkeypatch):
    _fake_machine(monkeypatch, per_point=1e-4, per_sample=0.0)
    cuts = resolve_cuts(CUTS)
    q = Quality.coerce("standard")
    one = B.predict_comparison(cuts[:1], ["bench"], q, {})
    assert one == pytest.approx(1e-4 * q.surface_points)
    assert B.predict_comparison(cuts, ["bench", "ring"], q, {}) == pytest.approx(4 * one)
    _fake_machine(monkeypatch, per_point=0.0, per_sample=0.0, per_evaluated_point=1e-5)  # the scorer and the tilt curve
    assert B.predict_comparison(cuts[:1], ["bench"], q, {}) == pytest.approx(1e-5 * (q.surface_points + q.tilt_points))
    _fake_machine(monkeypatch, per_point=0.0, per_sample=1e-7)
    samples = B.render_samples(q.render_resolution, q.render_spp, q.strip_angles_deg)
    assert samples == q.render_resolution ** 2 * (2 * q.render_spp + 4 * (q.render_spp // 2))
    assert B.predict_comparison(cuts[:1], ["bench"], q, {}) == pytest.approx(1e-7 * samples)
    assert B.predict_comparison(cuts[:1], ["bench"], q, {}, resolution=64, spp=2) == pytest.approx(
        1e-7 * B.render_samples(64, 2, q.strip_angles_deg))


def test_the_most_accurate_rung_that_fits_is_chosen(monkeypatch):
    _fake_machine(monkeypatch, per_point=1e-4, per_sample=0.0)  # per pair: standard 0.8 s, high 2.4 s
    cuts = resolve_cuts(CUTS)
    assert B.choose_quality(1.7, cuts, ["bench"], {}).quality.name == "standard"
    assert B.choose_quality(5.0, cuts, ["bench"], {}).quality.name == "high"
    assert B.choose_quality(1.5, cuts, ["bench"], {}).quality.name == "budget-2"
    c = B.choose_quality(0.01, cuts, ["bench"], {})
    assert c.quality.name == "budget-0" and "below the cheapest comparison's predicted" in c.note
    from labcut.commands.budget import record

    for _ in range(4):
        record(B.KIND, 1.0, 2.0)  # comparisons ran twice as long as predicted
    assert correction(B.KIND) == pytest.approx(2.0, rel=0.07) and correction(False) == 1.0
    assert B.choose_quality(2.0, cuts, ["bench"], {}).quality.name == "budget-2"  # one rung down now (standard: 3.1 s)
    from labcut.commands.budget import forget

    record(False, 1.0, 3.0)
    forget(B.KIND)  # only that kind's correction is dropped
    assert correction(B.KIND) == 1.0 and correction(False) > 1.0


def test_a_fast_machines_factor_holds_only_within_its_reach(monkeypatch):
    """Comparisons that ran at a quarter of their prediction up to 1.6 s (per pair: standard 0.8 s,
    high 2.4 s): the factor 0.25 holds up to 3.2 s predicted, so standard (1.6 s) counts as 0.4 s
    and high (4.8 s) as the calibration has it; a budget of 2 s takes budget-4 (2.77 s: 0.69 s), not
    high (1.2 s at the factor everywhere)."""
    from labcut.commands.budget import record

    _fake_machine(monkeypatch, per_point=1e-4, per_sample=0.0)
    cuts = resolve_cuts(CUTS)
    record(B.KIND, 1.6, 0.1)  # sqrt(1/16): 0.25
    c = B.choose_quality(2.0, cuts, ["bench"], {})
    rungs = dict(c.rungs)
    assert rungs["standard"] == pytest.approx(0.4) and rungs["high"] == pytest.approx(4.8)
    assert c.quality.name == "budget-4" and c.correction == pytest.approx(0.25)


def test_plan_comparison_with_a_budget(monkeypatch):
    _fake_machine(monkeypatch, per_point=1e-4, per_sample=0.0)
    plan = plan_comparison(CUTS, "blue", ["bench"], time_budget=1.7)
    assert plan.quality.name == "standard" and plan.budget.quality.name == "standard"
    assert plan.resolution == plan.quality.render_resolution
    plan = plan_comparison(CUTS, "blue", ["bench"], time_budget=0.6, resolution=40, spp=3)
    assert plan.quality.name == "draft" and (plan.resolution, plan.spp) == (40, 3)
    assert plan.scenarios[0].quality == "draft" or getattr(plan.scenarios[0].quality, "name", "draft") == "draft"
    with pytest.warns(LabcutWarning, match="below the cheapest"):
        assert plan_comparison(CUTS, "blue", ["bench"], time_budget=0.001).quality.name == "budget-0"
    with pytest.raises(ParameterError, match="not both"):
        plan_comparison(CUTS, "blue", ["bench"], quality="draft", time_budget=5)
    for bad in (0, -2, float("nan"), "soon"):
        with pytest.raises(ParameterError, match="time budget"):
            plan_comparison(CUTS, "blue", ["bench"], time_budget=bad)


def test_compare_with_a_budget_learns_and_reports(monkeypatch):
    _fake_machine(monkeypatch, per_point=1e-5, per_sample=1e-9)  # a fast fake: the cheapest rungs fit
    cmp = labcut.compare_cuts(CUTS[:1], "blue", ["bench"], time_budget=0.05, resolution=32, spp=2)
    assert cmp.budget["budget_seconds"] == 0.05 and cmp.budget["quality"] == str(cmp.quality)
    assert cmp.to_dict()["time_budget"]["quality"] == cmp.budget["quality"]
    # the run took far longer than the fake predicted: the correction grew
    assert correction(B.KIND) > 1.5


def test_cli_compare_time_budget(cli, tmp_path):
    out = tmp_path / "cmp.json"
    r = cli("compare", *CUTS[:1], "--time-budget", "8", "--resolution", "32", "--spp", "2", "--json", str(out))
    assert r.returncode == 0, r.stderr
    data = json.loads(out.read_text())
    assert data["time_budget"]["budget_seconds"] == 8 and data["quality"] == data["time_budget"]["quality"]
    assert "time budget 8 s: quality" in r.stdout
    r = cli("compare", *CUTS[:1], "--time-budget", "30", "--quality", "draft")
    assert r.returncode == 2 and "not both" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    r = cli("compare", *CUTS[:1], "--time-budget", "-1")
    assert r.returncode == 2 and "time budget" in r.stderr


def test_the_first_renders_of_a_kind_pay_for_their_kernels(monkeypatch):
    _fake_machine(monkeypatch, per_point=0.0, per_sample=0.0)
    monkeypatch.setattr(B, "compare_render_timing", lambda integrator, refresh=False: (0.0, 0.0, 1.0))
    monkeypatch.setattr(B, "_WARM", set())
    cuts = resolve_cuts(CUTS)  # two convex cabochons: the direct integrator's kernels, loaded once
    q = Quality.coerce("draft")
    assert B.predict_comparison(cuts, ["bench"], q, {}) == pytest.approx(1.0)
    B.mark_warm("direct")
    assert B.predict_comparison(cuts, ["bench"], q, {}) == 0.0
