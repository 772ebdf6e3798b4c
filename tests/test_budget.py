"""``time_budget=`` / ``--time-budget`` (labcut.commands.budget)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

import labcut
from labcut.errors import LabcutWarning, ParameterError
from labcut.commands.budget import choose, correction, ladder, record


def test_the_ladder_gets_more_accurate_in_every_knob():
    rungs = ladder()
    assert [q.name for q in rungs][1::2] == ["draft", "standard", "high"]
    for a, b in zip(rungs, rungs[1:]):
        assert b.surface_points > a.surface_points
        assert b.lamp_samples >= a.lamp_samples and b.cone_views >= a.cone_views
        assert b.rock_steps[0] >= a.rock_steps[0] and b.rock_steps[1] >= a.rock_steps[1]
        assert b.map_spacing_deg <= a.map_spacing_deg
        assert b.nlopt_evals >= a.nlopt_evals


@pytest.fixture(autouse=True)
def _own_corrections(monkeypatch, tmp_path):
    """Each test starts with no learnt correction (its own corrections file)."""
    monkeypatch.setattr("labcut.commands.budget.corrections_path", lambda: tmp_path / "corrections.json")


def _fake_timing(monkeypatch, per_point: float):
    """Predicted seconds proportional to the surface points (a machine of known speed)."""
    monkeypatch.setattr("labcut.planner.predict_sample_seconds",
                        lambda settings, points, occlusion: per_point * points * (2.0 if occlusion else 1.0))


def test_the_prediction_learns_from_runs(monkeypatch):
    """A machine twice as slow as its calibration: after a few runs the choice steps down a rung."""
    _fake_timing(monkeypatch, 1e-4)
    assert choose(1.0, ("bench", None, None), False).quality.name == "standard"
    for _ in range(4):
        record(False, 0.8, 1.6)
    assert correction(False) == pytest.approx(2.0, rel=0.07)
    assert correction(True) == 1.0  # the other kind is not touched
    c = choose(1.0, ("bench", None, None), False)
    assert c.quality.name == "budget-2" and c.correction == pytest.approx(correction(False))
    record(False, 0.0, 1.0)  # nonsense is ignored
    record(False, 1.0, math.nan)
    assert correction(False) == pytest.approx(c.correction)


def test_the_most_accurate_rung_that_fits_is_chosen(monkeypatch):
    _fake_timing(monkeypatch, 1e-4)  # standard (8000 points) 0.8 s, high (24000) 2.4 s
    assert choose(1.0, ("bench", None, None), False).quality.name == "standard"
    assert choose(2.5, ("bench", None, None), False).quality.name == "high"
    assert choose(2.3, ("bench", None, None), False).quality.name == "budget-4"
    # occlusion doubles the cost here: one rung down
    assert choose(1.0, ("bench", None, None), True).quality.name == "budget-2"
    c = choose(100.0, ("bench", None, None), False)
    assert c.quality.name == "budget-6" and c.note is None and c.predicted_seconds <= 100.0


def test_an_impossible_budget_runs_the_cheapest_and_says_so(monkeypatch):
    _fake_timing(monkeypatch, 1e-4)
    c = choose(0.01, ("bench", None, None), False)
    assert c.quality.name == "budget-0"
    assert c.note is not None and "\n" not in c.note and "below the cheapest" in c.note


@pytest.mark.parametrize("bad", [0, -1.0, math.nan, math.inf, "soon", True])
def test_a_bad_budget_is_a_parameter_error(bad):
    with pytest.raises(ParameterError, match="time budget"):
        choose(bad, ("bench", None, None), False)


def test_recommend_with_a_budget_records_the_choice(monkeypatch):
    _fake_timing(monkeypatch, 1e-4)
    mesh = labcut.load_mesh("meshes/oval-16x12-low.ply")
    rec = labcut.recommend_orientation(mesh, "blue", scenario="bench", time_budget=0.35)
    b = rec.settings["time_budget"]
    assert b["quality"] == "draft" and rec.settings["quality"] == "draft" and rec.settings["surface_samples"] == 3000
    assert rec.uncertainty is not None
    with pytest.warns(LabcutWarning, match="below the cheapest"):
        labcut.recommend_orientation(mesh, "blue", scenario="bench", time_budget=0.01)
    with pytest.raises(ParameterError, match="not both"):
        labcut.recommend_orientation(mesh, "blue", quality="draft", time_budget=1.0)


def test_cli_time_budget(cli, tmp_path, monkeypatch):
    # the call's user cache: this machine's calibrations, but no corrections learnt from the budgeted
    # runs of tests beside it (a correction learnt down to x0.2 fits the cheapest rung in 0.05 s)
    import shutil

    from platformdirs import user_cache_dir

    home = tmp_path / "cache-home"
    kept = Path(user_cache_dir("labcut"))
    if kept.is_dir():
        shutil.copytree(kept, home / "labcut", ignore=shutil.ignore_patterns("time-budget-corrections.json*"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(home))
    out = tmp_path / "rec.json"
    r = cli("recommend-orientation", "meshes/oval-16x12-low.ply", "--time-budget", "0.001", "--json", str(out))
    assert r.returncode == 0, r.stderr
    notes = [ln for ln in r.stderr.splitlines() if ln.startswith("note:")]
    assert len(notes) == 1 and "below the cheapest" in notes[0]
    data = json.loads(out.read_text())
    assert data["settings"]["time_budget"]["quality"] == "budget-0"
    assert "± " in r.stdout  # the error bars are printed
    for bad, msg in (((("--time-budget", "0"),), "time budget"), ((("--time-budget", "1", "--quality", "draft"),), "not both"),
                     ((("--time-budget", "1", "--quality", "standard"),), "not both")):
        r = cli("recommend-orientation", "meshes/oval-16x12-low.ply", *bad[0])
        assert r.returncode == 2
        lines = [ln for ln in r.stderr.strip().splitlines() if ln]
        assert len(lines) == 1 and msg in lines[0] and "Traceback" not in r.stderr



def test_render_budget_picks_the_most_samples_that_fit(monkeypatch):
    from labcut.commands.render_budget import MAX_SPP, choose_spp

    # 0.1 s fixed + 1e-7 s per sample: at 100² px one spp costs 1 ms
    monkeypatch.setattr("labcut.planner.render_command_timing", lambda mode, polarised, integrator, look="diagram": (0.1, 1e-7, 0.0))
    c = choose_spp(0.5, mode="rgb", polarised=False, integrator="direct", resolution=100, views=1)
    assert c.spp == 256 and c.predicted_seconds <= 0.5 and c.note is None  # 512 spp would be 0.61 s
    assert choose_spp(0.5, mode="rgb", polarised=False, integrator="direct", resolution=100, views=2).spp == 128
    assert choose_spp(8e4, mode="rgb", polarised=False, integrator="direct", resolution=100, views=1).spp == MAX_SPP
    low = choose_spp(0.05, mode="rgb", polarised=False, integrator="direct", resolution=100, views=1)
    assert low.spp == 1 and "below the predicted" in low.note
    with pytest.raises(ParameterError, match="time budget"):
        choose_spp(-2, mode="rgb", polarised=False, integrator="direct", resolution=100, views=1)


def test_render_with_a_budget(monkeypatch, cli, tmp_path):
    monkeypatch.setattr("labcut.planner.render_command_timing", lambda mode, polarised, integrator, look="diagram": (0.0, 1e-6, 0.0))
    mesh = labcut.load_mesh("meshes/oval-16x12-low.ply")
    r = labcut.render(mesh, labcut.Labradorite.preset("blue"), (0, 0, 1), resolution=32, time_budget=0.02, check_flash=False)
    assert r.spp == 16 and r.budget["spp"] == 16  # 32² px x 16 spp x 1e-6 s = 0.016 s
    out = tmp_path / "r.png"
    res = cli("render", "meshes/oval-16x12-low.ply", "-o", str(out), "--resolution", "16", "--time-budget", "1e-9",
              "--look", "diagram")
    assert res.returncode == 0, res.stderr
    assert [ln for ln in res.stderr.splitlines() if ln.startswith("note:")] and out.exists()
    for spp in ("8", "64"):  # also the default, given explicitly
        res = cli("render", "meshes/oval-16x12-low.ply", "-o", str(tmp_path / "x.png"), "--time-budget", "2", "--spp", spp)
        assert res.returncode == 2 and "not both" in res.stderr and not (tmp_path / "x.png").exists()


def test_a_render_estimator_budget_predicts_the_renders(monkeypatch):
    """When the planner answers with renders, the budget predicts the renders (and learns their correction)."""

    class RenderPlan:
        estimator, convex = "render", False

        @staticmethod
        def on(effect):
            return effect == "occlusion"

    cost = {"draft": 1.0, "standard": 3.0, "high": 9.0}
    monkeypatch.setattr("labcut.planner.estimator_seconds",
                        lambda scene, command, occ, ir, convex, zoned: {"samples": 0.01, "render": cost[scene.quality.name]})
    c = choose(4.0, ("bench", None, None), True, plan=RenderPlan())
    assert c.quality.name == "standard" and c.estimator == "render" and c.kind == "render"
    assert [name for name, _ in c.rungs] == ["draft", "standard", "high"]
    assert choose(4.0, ("bench", None, None), True).estimator == "samples"  # no plan: the samples' calibration
    for _ in range(4):
        record("render", 1.0, 3.0)
    assert correction("render") == pytest.approx(3.0, rel=0.07) and correction(True) == 1.0
    assert choose(4.0, ("bench", None, None), True, plan=RenderPlan()).quality.name == "draft"


def test_recommend_hands_its_plan_to_the_budget(monkeypatch):
    """recommend_orientation(..., time_budget=) predicts the estimator its plan picks."""
    seen = {}

    class Stop(Exception):
        pass

    def spy(budget, scene_spec, occlusion, *, plan=None):
        seen["estimator"] = plan.estimator
        raise Stop

    monkeypatch.setattr("labcut.commands.recommend.choose", spy)
    oval = labcut.cabochon("oval", 16, 12, resolution=48)
    for estimator in ("render", "samples"):
        with pytest.raises(Stop):
            labcut.recommend_orientation(oval, "blue", time_budget=5.0, estimator=estimator)
        assert seen["estimator"] == estimator


class _PlanWithPilots:
    """An effect plan of the sample estimator that spent ``pilot_seconds`` on pilot renders."""

    estimator = "samples"
    env_samples = None  # the scene's own map directions

    def __init__(self, pilot_seconds: float) -> None:
        self.pilot_seconds = pilot_seconds


def test_the_plans_time_is_the_budgets(monkeypatch):
    """The seconds the budget's own plan spent on a first plan's pilot renders are spent: the rungs
    must fit in the rest; with too little left the note says what the plan took."""
    _fake_timing(monkeypatch, 1e-4)  # standard 0.8 s, budget-4 1.39 s, high 2.4 s
    assert choose(2.0, ("bench", None, None), False).quality.name == "budget-4"
    got = choose(2.0, ("bench", None, None), False, plan=_PlanWithPilots(0.7))
    assert got.quality.name == "standard" and got.budget_seconds == 2.0
    assert got.pilot_seconds == 0.7 and got.note is None
    tight = choose(0.25, ("bench", None, None), False, plan=_PlanWithPilots(1.2))
    assert tight.quality.name == "budget-0" and tight.budget_seconds == 0.25
    assert "first plan took 1.2 s of the 0.25 s time budget on its pilot renders" in tight.note
    assert "predicted 0.15 s" in tight.note and "(budget-0) anyway" in tight.note
    plain = choose(0.01, ("bench", None, None), False)
    assert plain.note.startswith("a time budget of 0.01 s is below")


def test_every_quality_pilots_the_same_scene(monkeypatch, tmp_path):
    """The pilot renders sample the scene at PILOT_QUALITY whatever the plan's quality: a draft and
    a high plan of the same stone and scene measure once and decide alike; a budgeted
    recommendation's rung finds its plan's pilots made by the budget's."""
    from labcut import planner

    monkeypatch.setattr(planner, "_PILOT_CACHE", {})
    monkeypatch.setattr(planner, "_pilot_cache_path", lambda: tmp_path / "planner-pilot.json")
    seen = []
    from labcut.orientation import render_objective

    real = render_objective.interreflection_share
    monkeypatch.setattr(render_objective, "interreflection_share",
                        lambda mesh, material, settings, **k: seen.append(len(settings)) or real(mesh, material, settings, **k))
    mesh = labcut.load_mesh("meshes/carving-biplane.ply")
    plans = [planner.plan_effects(mesh, "blue", scenario="display", quality=q) for q in ("draft", "high", "standard")]
    assert len(seen) == 1
    assert len({p.facts["interreflection_measured"] for p in plans}) == 1
    assert plans[1].pilot_seconds == plans[2].pilot_seconds == 0.0 < plans[0].pilot_seconds


def test_a_first_plans_pilots_are_counted_and_kept_out_of_the_correction(monkeypatch):
    """A carving's first budgeted recommendation: the budget's plan measures the pilot renders (here
    a stand-in that takes 0.4 s), the choice counts them as spent, and the correction learns from the
    recommendation alone (its time without the pilots)."""
    import time

    from labcut import planner
    from labcut.commands import recommend as recommend_command

    monkeypatch.setattr(planner, "_PILOT_CACHE", {})
    slow = {"n": 0}

    def pilots(mesh, material, scene, timing=None, max_seconds=None):
        slow["n"] += 1
        time.sleep(0.4)
        if timing is not None:
            timing["pilot_seconds"] = 0.4
        return 0.001

    monkeypatch.setattr(planner, "measured_interreflection", pilots)
    seen = []
    monkeypatch.setattr(recommend_command, "record", lambda kind, predicted, actual, **kw: seen.append((predicted, actual)))
    mesh = labcut.load_mesh("meshes/carving-biplane.ply")
    t = time.perf_counter()
    rec = labcut.recommend_orientation(mesh, "blue", time_budget=30.0)
    total = time.perf_counter() - t
    choice = rec.settings["time_budget"]
    assert slow["n"] >= 1 and choice["pilot_seconds"] >= 0.4
    (predicted, actual), = seen
    assert actual <= total - 0.4 * slow["n"] + 0.05


def test_cached_pilots_cost_the_budget_nothing(monkeypatch, tmp_path):
    """A plan whose pilot renders are cached reports no pilot seconds (the cache's lookup is not a
    render): the budget spends nothing on them and no rung counts them again."""
    from labcut import planner

    monkeypatch.setattr(planner, "_PILOT_CACHE", {})
    monkeypatch.setattr(planner, "_pilot_cache_path", lambda: tmp_path / "planner-pilot.json")
    mesh = labcut.load_mesh("meshes/carving-biplane.ply")
    first = planner.plan_effects(mesh, "blue", scenario="bench", quality="draft")
    again = planner.plan_effects(mesh, "blue", scenario="bench", quality="draft")
    assert "interreflection_measured" in first.facts
    assert first.pilot_seconds > 0.0 and again.pilot_seconds == 0.0


def test_the_calibration_warms_the_occluded_path_before_timing_it():
    """time_three warms each stone (the occluded one's first call in a process loads a Mitsuba
    variant and builds its ray scene: timed, it made the per-ray cost ten times too large), then
    times draft, standard and the occluded draft once each."""
    from labcut.orientation.timing import time_three

    calls = []
    time_three(lambda mesh, quality: calls.append((mesh.metadata["labcut"].get("convex"), quality)))
    hidden = [c for c in calls if c[0] is False]
    assert len(calls) == 5 and calls[:2] == [calls[0], hidden[0]] and calls[0][0] is not False
    assert calls[2:] == [(calls[0][0], "draft"), (calls[0][0], "standard"), (False, "draft")]


def test_a_pilot_scene_that_is_not_a_scenario_is_a_parameter_error():
    from labcut import planner

    cab = labcut.cabochon("oval", 16, 12, resolution=48)
    with pytest.raises(ParameterError, match="pilot_scene must be a labcut.Scenario"):
        planner.plan_effects(cab, "blue", scenario="bench", pilot_scene="bench")


def test_a_first_call_in_a_process_learns_its_own_seconds(monkeypatch):
    """The first recommendation of a kind in a process (a CLI call) costs more than the warm ones
    the calibration times: that is learnt as seconds added to every rung, and leaves the factor alone."""
    from labcut.commands import budget as budget_module

    _fake_timing(monkeypatch, 1e-4)  # standard 0.8 s
    monkeypatch.setattr(budget_module, "_WARM", set())
    c = choose(1.0, ("bench", None, None), False)
    assert c.cold and c.first_call_seconds == 0.0 and c.quality.name == "standard"
    assert c.uncorrected(c.predicted_seconds) == pytest.approx(0.8)
    record(False, 0.8, 1.3, first_call=True)
    assert budget_module.first_call_seconds(False) == pytest.approx(0.5) and correction(False) == 1.0
    record(False, 0.8, 1.1, first_call=True)  # a running mean
    assert budget_module.first_call_seconds(False) == pytest.approx(0.4)
    assert budget_module.first_call_seconds(True) == 0.0  # the other kind is not touched
    c = choose(1.0, ("bench", None, None), False)  # still cold: 0.4 s more on every rung, one rung down
    assert c.first_call_seconds == pytest.approx(0.4) and c.quality.name == "budget-2"
    assert c.predicted_seconds == pytest.approx(1e-4 * c.quality.surface_points + 0.4)
    assert c.uncorrected(c.predicted_seconds) == pytest.approx(1e-4 * c.quality.surface_points)
    budget_module.mark_warm(False)
    w = choose(1.0, ("bench", None, None), False)  # warm: the calibration's prediction alone
    assert not w.cold and w.first_call_seconds == 0.0 and w.quality.name == "standard"
    budget_module.forget(False)
    assert budget_module.first_call_seconds(False) == 0.0


def test_recommend_tells_the_budget_whether_it_is_the_first_of_its_kind(monkeypatch):
    from labcut.commands import recommend as recommend_command
    from labcut.commands import budget as budget_module

    _fake_timing(monkeypatch, 1e-4)
    monkeypatch.setattr(budget_module, "_WARM", set())
    seen = []
    real = budget_module.record
    monkeypatch.setattr(recommend_command, "record", lambda *a, **kw: (seen.append(kw.get("first_call")), real(*a, **kw))[1])
    mesh = labcut.load_mesh("meshes/oval-16x12-low.ply")
    labcut.recommend_orientation(mesh, "blue", scenario="bench", time_budget=0.5)
    labcut.recommend_orientation(mesh, "blue", scenario="bench", time_budget=0.5)
    assert seen == [True, False]
    assert budget_module.is_warm(False) and not budget_module.is_warm("render")
    assert budget_module.first_call_seconds(False) >= 0.0
    monkeypatch.setattr(budget_module, "_WARM", set())
    labcut.recommend_orientation(mesh, "blue", scenario="bench", quality="draft")  # no budget: still warms the process
    assert budget_module.is_warm(False)


def test_a_plan_that_draws_the_map_densely_is_predicted_so(monkeypatch):
    """Where the plan has the map drawn through more directions (a carving's parts hide part of it),
    every rung is predicted with that many map directions: the seconds follow the lights."""
    seen = []

    def predict(settings, points, occlusion):
        seen.append(len(settings[0].lights))
        return 1e-6 * points * len(settings[0].lights)

    monkeypatch.setattr("labcut.planner.predict_sample_seconds", predict)

    class Dense(_PlanWithPilots):
        env_samples = 256

    plain = choose(5.0, ("ring-diffuse", None, None), True, plan=_PlanWithPilots(0.0))
    lights_plain = list(seen)
    seen.clear()
    dense = choose(5.0, ("ring-diffuse", None, None), True, plan=Dense(0.0))
    assert max(lights_plain) <= 128 and min(seen) > 128  # every rung's map drawn past the quality's count
    assert all(d > p for (_, d), (_, p) in zip(dense.rungs, plain.rungs))
