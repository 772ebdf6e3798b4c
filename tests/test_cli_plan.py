"""The effect planner from the CLI: --plan, --plan-only, --estimator and --effect on
recommend-orientation, evaluate-orientation, render and compare (docs/planner.md)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from conftest import run_cli

MESHES = Path(__file__).resolve().parents[1] / "meshes"
OVAL = str(MESHES / "oval-16x12-low.ply")
BIPLANE = str(MESHES / "carving-biplane.ply")


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


class _Res:
    def __init__(self, proc):
        self.exit_code, self.output, self.stdout, self.stderr = proc.returncode, proc.stdout + proc.stderr, proc.stdout, proc.stderr


def run(*args: str, cwd=None):
    return _Res(run_cli(*args, cwd=cwd))


def test_plan_only_prints_the_plan_and_why_and_runs_nothing(tmp_path):
    out = tmp_path / "plan.json"
    res = run("recommend-orientation", BIPLANE, "--scenario", "display", "--plan-only", "--json", str(out))
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())
    assert "Effect plan (recommend, carving-biplane.ply)" in text
    assert "occlusion ON" in text and "inter-reflection off" in text and "pilot renders" in text
    assert "depth ON" in text and "estimator volume" in text and "predicted" in text
    data = json.loads(out.read_text())
    assert set(data) == {"plan"}  # no recommendation: nothing ran
    plan = data["plan"]
    assert plan["command"] == "recommend" and plan["estimator"] == "volume"
    assert plan["effects"]["occlusion"]["on"] and not plan["effects"]["inter_reflection"]["on"]
    assert set(plan["predicted_seconds"]) == {"samples", "volume", "render"}
    seconds = plan["predicted_seconds"]
    assert 0 < seconds["samples"] < seconds["volume"] < seconds["render"]


def test_recommendation_json_holds_its_plan_and_the_render_estimator_is_reachable(tmp_path):
    out = tmp_path / "rec.json"
    res = run("recommend-orientation", OVAL, "--scenario", "display", "--quality", "draft", "--estimator", "render",
              "--plan", "--json", str(out))
    assert res.exit_code == 0, res.output
    assert "Effect plan" in res.output and "render estimator (direct, depth 2" in " ".join(res.output.split())
    data = json.loads(out.read_text())
    assert data["estimator"] == "render" and data["plan"]["estimator"] == "render"
    assert data["plan"]["estimator_why"] == "asked for"
    assert data["render_estimator"]["evaluations"] > 0 and data["render_estimator"]["angle_to_samples_deg"] < 3.0
    plain = tmp_path / "plain.json"
    res = run("recommend-orientation", OVAL, "--quality", "draft", "--json", str(plain))
    assert res.exit_code == 0, res.output
    data = json.loads(plain.read_text())
    assert data["estimator"] == "samples" and data["plan"]["effects"]["occlusion"]["on"] is False
    assert data["render_estimator"] == {}


def test_evaluate_and_render_and_compare_carry_the_plan(tmp_path):
    ev = tmp_path / "ev.json"
    res = run("evaluate-orientation", OVAL, "--normal", "0,0,1", "--quality", "draft", "--json", str(ev))
    assert res.exit_code == 0, res.output
    data = json.loads(ev.read_text())
    assert data["plan"]["command"] == "evaluate" and data["estimator"] == "samples"
    res = run("render", BIPLANE, "-o", str(tmp_path / "x.png"), "--polarizer", "30", "--plan-only")
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())
    assert "Effect plan (render" in text and "polarisation ON" in text and "colour ON spectral" in text
    assert not (tmp_path / "x.png").exists()
    cmp = tmp_path / "cmp.json"
    res = run("compare", OVAL, BIPLANE, "--quality", "draft", "--plan-only", "--json", str(cmp))
    assert res.exit_code == 0, res.output
    plans = json.loads(cmp.read_text())["plans"]
    assert [p["cut"] for p in plans] == ["oval-16x12-low.ply", "carving-biplane.ply"]
    assert all(p["plan"]["estimator"] == "samples" for p in plans)


@pytest.mark.parametrize("args, message", [
    (("recommend-orientation", OVAL, "--estimator", "bogus"), "--estimator must be one of auto, samples, volume, render"),
    (("recommend-orientation", OVAL, "--effect", "occlusion=on"), "occlusion cannot be switched on for a convex stone"),
    (("recommend-orientation", OVAL, "--effect", "polarisation=on"), "polarisation"),
    (("recommend-orientation", OVAL, "--effect", "occlusion"), "occlusion"),
    (("render", OVAL, "-o", "x.png", "--mode", "mono", "--polarizer", "30", "--plan"), "a polariser view needs colour"),
    (("compare", OVAL, "--estimator", "render"), "compare runs the sample estimator"),
    (("evaluate-orientation", OVAL, "--effect", "inter-reflection=on"), "inter-reflection cannot be switched on"),
])
def test_bad_combinations_are_one_line_errors(args, message, tmp_path):
    res = run(*args, cwd=tmp_path)
    assert res.exit_code == 2, res.output
    assert message in res.stderr and "Traceback" not in res.output
    assert len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert not (tmp_path / "x.png").exists()


def test_plans_show_the_predicted_seconds_of_evaluate_render_and_compare(tmp_path):
    """--plan-only of every command prints the predicted time of its choices, and writes it."""
    ev = tmp_path / "ev.json"
    res = run("evaluate-orientation", OVAL, "--normal", "0,0,1", "--quality", "draft", "--plan-only", "--json", str(ev))
    assert res.exit_code == 0, res.output
    assert "predicted" in res.output and "samples ~" in res.output and "render ~" in res.output
    p = json.loads(ev.read_text())["plan"]["predicted_seconds"]
    assert set(p) == {"samples", "volume", "render"} and 0 < p["samples"] < p["volume"] and p["samples"] < p["render"]
    rj = tmp_path / "r.json"
    res = run("render", OVAL, "-o", str(tmp_path / "x.png"), "--plan-only", "--json", str(rj))
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())
    assert "predicted render ~" in text and "512² px, 16 spp, 1 view" in text
    assert json.loads(rj.read_text())["plan"]["predicted_seconds"]["render"] > 0
    cj = tmp_path / "c.json"
    res = run("compare", OVAL, BIPLANE, "--quality", "draft", "--plan-only", "--json", str(cj))
    assert res.exit_code == 0, res.output
    for p in json.loads(cj.read_text())["plans"]:
        assert p["plan"]["predicted_seconds"]["samples"] > 0, p["cut"]


def test_a_full_render_json_holds_the_effect_plan(tmp_path):
    out = tmp_path / "r.json"
    res = run("render", BIPLANE, "-o", str(tmp_path / "x.png"), "--resolution", "24", "--spp", "1", "--look", "diagram",
              "--json", str(out))
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    effects = data["plan"]["effects"]
    assert effects["command"] == "render" and effects["estimator"] is None and effects["convex"] is False
    on = {k: v["on"] for k, v in effects["effects"].items()}
    assert on == {"occlusion": True, "inter_reflection": True, "depth": False, "environment": False, "polarisation": False,
                  "colour": True, "zoning": False}
    assert effects["effects"]["colour"]["how"] == "rgb"
    assert data["plan"]["integrator"] == "path" and (tmp_path / "x.png").exists()


def test_a_full_compare_json_holds_each_cuts_plan(tmp_path):
    out = tmp_path / "cmp.json"
    res = run("compare", "cab:oval,16x12,low,res=48", BIPLANE, "--scenario", "bench", "--quality", "draft",
              "--resolution", "16", "--spp", "1", "--json", str(out), cwd=tmp_path)
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    plans = {c["name"]: c["scenarios"]["bench"]["best"]["plan"] for c in data["cuts"]}  # each recommendation's plan
    assert len(plans) == 2 and all(p["command"] == "compare" for p in plans.values())
    convex, carving = (next(p for p in plans.values() if p["convex"] is flag) for flag in (True, False))
    assert convex["estimator"] == carving["estimator"] == "samples"
    assert not convex["effects"]["occlusion"]["on"] and carving["effects"]["occlusion"]["on"]
    assert not carving["effects"]["inter_reflection"]["on"] and "left out" in carving["estimator_why"]
    assert carving["predicted_seconds"]["samples"] > 0 and convex["predicted_seconds"]["samples"] > 0
