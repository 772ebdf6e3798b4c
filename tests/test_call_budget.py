"""A time budget is the whole call's (issue 34, point 3): the CLI's clock starts with the command,
the mesh's loading is spent of it, and a never-seen stone's pilot renders are skipped where the
budget has no room for them (the plan says why); the pilot cache is keyed by labcut's version."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import labcut
import labcut.planner as planner
from labcut.planner import PILOT_BUDGET_SHARE, PILOT_SECONDS_PER_POSE, PILOT_TIMING_KEY, plan_effects, pilot_seconds_predicted

ROOT = Path(__file__).resolve().parents[1]
BIPLANE = ROOT / "meshes" / "carving-biplane.ply"
OVAL = ROOT / "meshes" / "oval-16x12-low.ply"


@pytest.fixture()
def pilot_cache(tmp_path, monkeypatch):
    """A pilot cache of its own (file and process), empty."""
    path = tmp_path / "planner-pilot.json"
    monkeypatch.setattr(planner, "_pilot_cache_path", lambda: path)
    monkeypatch.setattr(planner, "_PILOT_CACHE", {})
    return path


def test_the_pilots_predicted_seconds_learn_from_this_machine(pilot_cache):
    assert pilot_seconds_predicted(5) == pytest.approx(5 * PILOT_SECONDS_PER_POSE)
    assert pilot_seconds_predicted(9) == pytest.approx(planner.PILOT_POSES * PILOT_SECONDS_PER_POSE)  # at most PILOT_POSES
    pilot_cache.write_text(json.dumps({PILOT_TIMING_KEY: 0.1}))
    assert pilot_seconds_predicted(3) == pytest.approx(0.3)


def test_a_budget_without_room_for_the_pilots_skips_them_and_says_why(pilot_cache):
    mesh = labcut.load_mesh(BIPLANE)
    pilot_cache.write_text(json.dumps({PILOT_TIMING_KEY: 1.0}))  # 1 s a pose: 5 s of pilots
    plan = plan_effects(mesh, command="recommend", scenario="bench", predict=False, pilot_seconds_max=4.9)
    d = plan["inter_reflection"]
    assert not d.on and d.why.startswith("not measured: the time budget leaves 4.9 s for pilot renders predicted to take 5 s")
    assert plan.pilot_seconds == 0.0 and plan.facts["interreflection_pilots_skipped_seconds"] == pytest.approx(5.0)
    assert "interreflection_measured" not in plan.facts and plan.estimator == "volume"  # its thin wings: the depth
    # a convex stone needs no pilots: nothing to skip
    oval = plan_effects(labcut.load_mesh(OVAL), command="recommend", scenario="bench", predict=False, pilot_seconds_max=0.0)
    assert "interreflection_pilots_skipped_seconds" not in oval.facts


def test_a_cached_measurement_is_used_whatever_the_budget(pilot_cache, monkeypatch):
    mesh = labcut.load_mesh(BIPLANE)
    from labcut.scene import resolve_scene

    scene = resolve_scene("bench", None, None, "standard")
    calls = []
    monkeypatch.setattr("labcut.orientation.render_objective.interreflection_share",
                        lambda *a, **k: calls.append(1) or 0.125)
    assert planner.measured_interreflection(mesh, labcut.Labradorite(), scene) == 0.125 and calls == [1]
    monkeypatch.setattr(planner, "_PILOT_CACHE", {})  # a new process: read from the file
    assert planner.measured_interreflection(mesh, labcut.Labradorite(), scene, max_seconds=0.0) == 0.125 and calls == [1]
    stored = json.loads(pilot_cache.read_text())
    assert stored[PILOT_TIMING_KEY] > 0  # the seconds per pose it took, learnt
    # another labcut version does not read it: a new release may render or decide otherwise
    monkeypatch.setattr(planner, "_PILOT_CACHE", {})
    monkeypatch.setattr(labcut, "__version__", "0.0.0-other")
    assert planner.measured_interreflection(mesh, labcut.Labradorite(), scene, max_seconds=0.0) is None and calls == [1]


def test_the_cli_budget_is_the_calls(cli, tmp_path):
    out = tmp_path / "r.json"
    proc = cli("recommend-orientation", str(OVAL), "--time-budget", "2", "--json", str(out))
    assert proc.returncode == 0, proc.stderr
    b = json.loads(out.read_text())["settings"]["time_budget"]
    assert b["call_budget_seconds"] == 2.0 and b["before_seconds"] > 0
    # the recommendation had what the loading left, less the answer's writing, and never less than
    # 0.05 s (a loaded machine can spend the whole 2 s loading)
    assert b["budget_seconds"] == pytest.approx(max(2.0 - b["before_seconds"] - 0.1, 0.05), abs=1e-9)
    assert "time budget 2 s for the call" in " ".join(proc.stdout.split())


def test_the_budget_limits_the_pilots_to_their_share(monkeypatch):
    seen = {}

    def plan_question(mesh, setup, command="recommend", *, predict=True, pilot_seconds_max=None):
        seen.setdefault("limits", []).append(pilot_seconds_max)
        return real(mesh, setup, command, predict=predict, pilot_seconds_max=pilot_seconds_max)

    import labcut.commands.recommend as cmd

    real = cmd.plan_question
    monkeypatch.setattr(cmd, "plan_question", plan_question)
    labcut.recommend_orientation(labcut.load_mesh(OVAL), time_budget=3.0)
    assert seen["limits"] and all(x == pytest.approx(PILOT_BUDGET_SHARE * 3.0) for x in seen["limits"])
