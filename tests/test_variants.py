"""Variants of a scenario and how far the answer moves across them (issue 39: answers robust to the
scenario's free parameters; labcut/scene/variants.py, labcut/orientation/robustness.py)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import labcut
from labcut.errors import ParameterError
from labcut.orientation.robustness import Robustness
from labcut.scene.presets import DOWNLIGHT_CUTOFF, downlight_grid
from labcut.scene.variants import Variation, scenario_variants


def _deg(a, b) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(np.dot(a, b))))))


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh("meshes/oval-16x12-low.ply")


# ---------------------------------------------------------------------- the draw
def test_a_downlight_grid_follows_its_spacing_height_and_offset():
    """The stone right under a fixture (offset 0): the brightest light straight above; a wider,
    lower grid puts the next fixtures further from the vertical."""
    d, w = downlight_grid(2.0, 2.0, (0.0, 0.0))
    top = d[int(np.argmax(w))]
    assert top == pytest.approx([0.0, 0.0, 1.0])
    nxt = sorted({round(math.degrees(math.acos(z)), 3) for z in d[:, 2]})[1]
    assert nxt == pytest.approx(45.0, abs=1e-6)  # 2 m along, 2 m up
    assert w.min() >= DOWNLIGHT_CUTOFF * w.max() - 1e-12 and w.sum() == pytest.approx(1.0)


def test_variants_draw_every_stratum_of_every_range_once():
    sc = labcut.Scenario.preset("ring", "draft")
    var = Variation(count=8, seed=3)
    drawn = scenario_variants(sc, var)
    assert [v.scenario.name for v in drawn] == [f"ring~{k}" for k in range(1, 9)]
    spacing = np.array([v.changes["downlight_spacing_m"] for v in drawn])
    lo, hi = var.downlight_spacing_m
    strata = np.floor((spacing - lo) / (hi - lo) * 8).astype(int)
    assert sorted(strata) == list(range(8))  # a Latin hypercube: each eighth of the range once
    scale = np.array([v.changes["motion_scale"] for v in drawn])
    scale_strata = np.floor((scale - 0.6) / 0.8 * 8).astype(int)
    assert sorted(scale_strata) == list(range(8))
    assert list(scale_strata) != list(strata)  # the ranges are paired at random, not stratum with stratum
    for v in drawn:
        s = v.scenario
        assert s.rock_deg == pytest.approx(25.0 * v.changes["motion_scale"], abs=0.01)
        assert _deg(s.views.main, sc.views.main) <= 10.0 + 1e-6
        moved = [_deg(a, b) for a, b in zip(s.views.directions, sc.views.directions)]
        assert max(moved) <= v.changes["view_tilt_deg"] + 0.01  # a turn about a horizontal axis: at most its angle
        assert 1.6 <= v.changes["downlight_height_m"] <= 2.6
        assert abs(v.changes["window_azimuth_deg"] - 270.0) <= 45.0 + 1e-6
        assert s.quality == sc.quality and s.motion_view_share == sc.motion_view_share
    # the same seed draws the same variants; another seed others
    again = scenario_variants(sc, var)
    assert [v.changes for v in again] == [v.changes for v in drawn]
    other = scenario_variants(sc, Variation(count=8, seed=4))
    assert [v.changes for v in other] != [v.changes for v in drawn]


def test_lights_other_than_a_room_are_turned_and_tilted():
    """The bench lamp straight above: a variant's lamp leans by its drawn tilt, at most 10°; the
    still display scenario stays still."""
    bench = labcut.Scenario.preset("bench", "draft")
    drawn = scenario_variants(bench, 6)
    for v in drawn:
        # the rotation taking the preset's lamp directions to the variant's (Kabsch), applied to +Z
        u, _, vt = np.linalg.svd(bench.lights.directions.T @ v.scenario.lights.directions)
        r = vt.T @ u.T
        lean = math.degrees(math.acos(min(1.0, (r @ [0.0, 0.0, 1.0])[2])))
        assert lean == pytest.approx(v.changes["light_tilt_deg"], abs=0.05)
        assert lean <= 10.0 + 1e-6
    assert all(v.scenario.rock_deg == 0.0 and "motion_scale" not in v.changes
               for v in scenario_variants(labcut.Scenario.preset("display", "draft"), 3))


def test_an_environment_map_stays_as_given():
    """Outdoors: the sun (a lamp) turns and tilts, the sky map's sampled directions stay (turning
    them would move the answer by their discretisation error alone)."""
    outdoor = labcut.Scenario.preset("outdoor", "draft")
    k = outdoor.lights.n_lamps
    assert 0 < k < len(outdoor.lights)
    for v in scenario_variants(outdoor, 4):
        lights = v.scenario.lights
        assert np.array_equal(lights.directions[k:], outdoor.lights.directions[k:])
        assert np.array_equal(lights.weights, outdoor.lights.weights) and lights.environment is outdoor.lights.environment
        assert _deg(lights.directions[0], outdoor.lights.directions[0]) > 0.1


@pytest.mark.parametrize("bad, match", [
    (dict(count=1), "variants must lie in"), (dict(light_tilt_deg=-1.0), "light_tilt_deg"),
    (dict(motion_scale=(1.4, 0.6)), "low <= high"), (dict(downlight_spacing_m=2.0), "pair"),
    (dict(view_tilt_deg=float("nan")), "view_tilt_deg"),
])
def test_bad_variations_are_one_line_errors(bad, match):
    with pytest.raises(ParameterError, match=match):
        Variation(**bad)


def test_variants_coerce():
    assert Variation.coerce(None) is None and Variation.coerce(0) is None
    assert Variation.coerce(5).count == 5
    for bad in (1, 65, True, "6", 2.5):
        with pytest.raises(ParameterError, match="variants"):
            Variation.coerce(bad)


# ---------------------------------------------------------------------- the verdict
def _robust(median: float, *, bar: float = 2.0, tol: float = 4.0, missing: bool = False, largest: float | None = None) -> Robustness:
    largest = median if largest is None else largest
    rows = [{"name": "s~1", "changes": {}, "moved_deg": median, "keeps": 0.8}]
    if missing:
        rows.append({"name": "s~2", "changes": {}, "error": "no orientation flashes"})
    return Robustness({}, tuple(rows), largest, median, 0.8, bar, tol)


def test_the_verdict_compares_the_typical_move_with_the_bar_and_the_tolerance():
    """The median move decides (the largest grows with the variants drawn, and is reported)."""
    assert _robust(1.9, largest=9.0).verdict == "inside" and _robust(2.0).verdict == "inside"
    assert "moves by 1.9° typically (up to 9.0°)" in _robust(1.9, largest=9.0).sentence()
    assert _robust(2.1).verdict == "beside" and _robust(4.0).verdict == "beside"
    assert _robust(4.1).verdict == "swings"
    assert _robust(0.5, missing=True).verdict == "swings"
    s = _robust(4.1).sentence()
    assert "swings by 4.1° typically (up to 4.1°)" in s and "tolerance (±4.0°)" in s and "keeps at least 80%" in s
    assert "inside its error bar (±2.0°)" in _robust(1.0).sentence()
    assert "1 variant(s) without flash" in _robust(0.5, missing=True).sentence()
    back = Robustness.from_dict(json.loads(json.dumps(_robust(3.0).to_dict())))
    assert back == _robust(3.0) and back.to_dict()["verdict"] == "beside"
    with pytest.raises(ParameterError, match="robustness"):
        Robustness.from_dict({"variants": []})


# ---------------------------------------------------------------------- the answers
def test_variants_identical_to_the_scenario_do_not_move_the_answer(oval):
    """With every range zero, each variant is the bench itself: the same surface samples find the
    same best normal (moved 0°) and the answer keeps all of each variant's best. A variant search
    with other samples, or moves measured from anything but the answer, would not."""
    still = Variation(count=2, light_turn_deg=0.0, light_tilt_deg=0.0, motion_scale=(1.0, 1.0), view_tilt_deg=0.0)
    rec = labcut.recommend_orientation(oval, "blue", scenario="bench", quality="draft", variants=still)
    r = rec.robustness
    assert r.answered == 2 and r.spread_deg < 0.05 and r.keeps_min > 0.999
    assert r.verdict == "inside"
    assert _deg(r.variants[0]["normal"], rec.normal) < 0.05


def test_a_lamp_far_from_overhead_swings_the_answer(oval, tmp_path):
    """Lamps leaning up to 40° move the bench answer by more than its tolerance: the verdict says it
    swings, and the saved answer keeps the report."""
    wide = Variation(count=3, light_tilt_deg=40.0, seed=1)
    rec = labcut.recommend_orientation(oval, "blue", scenario="bench", quality="draft", variants=wide)
    r = rec.robustness
    assert r.spread_deg > rec.tolerance_deg and r.verdict == "swings"
    assert r.keeps_min < 0.9
    assert r.tolerance_deg == pytest.approx(rec.tolerance_deg) and r.bar_deg == pytest.approx(rec.uncertainty.angle_deg)
    back = labcut.Recommendation.load(rec.save(tmp_path / "rec.json"))
    assert back.robustness == r
    assert "across scenario variants" in rec._repr_html_()


def test_the_cli_reports_the_variants(cli_main, tmp_path):
    out = tmp_path / "rec.json"
    done = cli_main("recommend-orientation", "meshes/oval-16x12-low.ply", "--scenario", "pendant", "--quality", "draft",
                    "--variants", "3", "--json", str(out))
    assert done.returncode == 0, done.stderr
    data = json.loads(out.read_text())
    r = data["robustness"]
    assert len(r["variants"]) == 3 and r["variation"]["count"] == 3
    assert r["sentence"][1:] in " ".join(done.stdout.split())
    done = cli_main("recommend-orientation", "meshes/oval-16x12-low.ply", "--variants", "1")
    assert done.returncode == 2 and "--variants must be 0 (none) or a count in [2, 64], got 1" in done.stderr


def test_lights_named_room_are_not_taken_for_the_room_preset():
    """The room's layout is redrawn only for the preset's own lights (told by their directions and
    weights): a lighting file that happens to be called "room" is turned and tilted as any lamp is."""
    ring = labcut.Scenario.preset("ring", "draft")
    mine = ring.with_lights(labcut.Lights([[0.0, -0.3, 1.0], [0.2, 0.1, 1.0]], name="room"))
    for v in scenario_variants(mine, 3):
        assert "light_turn_deg" in v.changes and "downlight_spacing_m" not in v.changes
        assert len(v.scenario.lights) == 2
    assert all("downlight_spacing_m" in v.changes for v in scenario_variants(ring, 3))
