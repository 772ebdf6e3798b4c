"""What-ifs (issue 34, point 5): the recommendation's misorientation curve (flash kept against
degrees off, on average, at worst and towards each side) in its table, its JSON and the report."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.orientation import MisorientationCurve, Recommendation, misorientation_curve
from labcut.orientation.misorientation import SIDES, towards


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


OVAL = Path(__file__).resolve().parents[1] / "meshes" / "oval-16x12-low.ply"


@pytest.mark.parametrize("centre", [(0, 0, 1), (0.3, -0.2, 0.93), (0.9, 0.1, 0.2)])
@pytest.mark.parametrize("side", list(SIDES))
def test_a_lean_towards_a_side_is_that_many_degrees_that_way(centre, side):
    c = np.asarray(centre, dtype=float) / np.linalg.norm(centre)
    n = towards(c, SIDES[side], 7.0)
    assert math.degrees(math.acos(np.clip(n @ c, -1, 1))) == pytest.approx(7.0, abs=1e-9)
    assert (n - c) @ np.asarray(SIDES[side]) > 0  # it moved towards that side


def test_the_curve_by_hand_on_a_tilted_score():
    # a score that grows towards the back (+Y): leaning back keeps more than 100 %, front less
    def scores(normals):
        return 1.0 + 0.5 * np.asarray(normals)[:, 1]

    curve = misorientation_curve(scores, np.array([0.0, 0.0, 1.0]), tolerance=2.0, quality="draft")
    assert curve.miss_deg[0] == 0.0 and curve.miss_deg[-1] == pytest.approx(15.0)
    at = 10.0
    assert curve.kept_at(at, "back") == pytest.approx(1 + 0.5 * math.sin(math.radians(at)))
    assert curve.kept_at(at, "front") == pytest.approx(1 - 0.5 * math.sin(math.radians(at)))
    assert curve.kept_at(at, "left") == pytest.approx(1.0) and curve.kept_at(at, "right") == pytest.approx(1.0)
    assert curve.kept_at(at) == pytest.approx(1.0, abs=1e-12)  # the ring's mean: +Y and -Y cancel
    assert curve.worst[curve.miss_deg == at][0] == pytest.approx(1 - 0.5 * math.sin(math.radians(at)), rel=1e-3)
    again = MisorientationCurve.from_dict(json.loads(json.dumps(curve.to_dict())))
    assert np.array_equal(again.by_side["back"], curve.by_side["back"]) and again.tolerance_deg == 2.0


@pytest.fixture(scope="module")
def rec():
    return labcut.recommend_orientation(labcut.load_mesh(OVAL), quality="draft")


def test_a_recommendation_carries_its_curve(rec):
    curve = rec.misorientation
    assert curve is not None and set(curve.by_side) == set(SIDES)
    # the tolerance is where the ring's worst direction keeps 90 % (within the curve's step)
    assert curve.kept_at(0.0) == pytest.approx(1.0)
    assert all(np.diff(curve.mean[: int(len(curve.mean) * 0.6)]) <= 1e-9)  # falls off the peak
    data = rec.to_dict()
    assert data["misorientation"]["by_side"]["front"][0] == pytest.approx(1.0)
    assert "misorientation" in data["metric_definitions"]
    back = Recommendation.from_dict(json.loads(json.dumps(data)))
    assert back.misorientation is not None and back.misorientation.kept_at(5.0) == pytest.approx(curve.kept_at(5.0))


def test_the_table_shows_what_a_miss_keeps(cli):
    proc = cli("recommend-orientation", str(OVAL), "--quality", "draft", "--scenario", "pendant")
    assert proc.returncode == 0, proc.stderr
    assert "If the cut misses: flash energy kept" in proc.stdout
    head = next(line for line in proc.stdout.splitlines() if "off by" in line)
    assert all(w in head for w in ("mean", "worst", "bottom", "top", "left", "right"))  # a pendant: worn upright
    assert any(line.split("│")[1].strip() == "5°" for line in proc.stdout.splitlines() if line.count("│") > 3)


def test_a_parallel_instruction_says_how_it_fits_the_tilted_optimum(cli):
    # bench on the low oval: the optimum leans a few degrees, the base keeps 90 %: "cut it parallel"
    proc = cli("recommend-orientation", str(OVAL), "--quality", "draft")
    assert proc.returncode == 0, proc.stderr
    text = " ".join(proc.stdout.replace("│", " ").split())
    assert "keep the lamella plane parallel to the base" in text
    assert "how these fit" in text and "lamellae parallel to the base keep at least 90 %" in text
    assert "90° back" in text and "front-to-back" in text  # lying face-up: +Y is the back


def test_a_worn_upright_stone_names_plus_y_its_top_everywhere(cli):
    proc = cli("recommend-orientation", str(OVAL), "--quality", "draft", "--scenario", "pendant")
    text = " ".join(proc.stdout.replace("│", " ").split())
    assert "90° top (+Y, the bail end, as worn)" in text and "top-to-bottom" in text
    assert "90° back" not in text and "front-to-back" not in text
