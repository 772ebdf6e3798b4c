"""``labcut.reports.compare`` pinned by hand (issue 37, mutation testing): how a comparison ranks
cuts within their error bars, aggregates the scenarios into one overall score, words its verdicts,
and lays out its summary, JSON and CSV; what ``plan_comparison`` checks and hands on, and how
``run_comparison`` wires a study, curves, renders and the compromise together.

Every expected number is worked out from the docstrings' definitions on toy inputs chosen so the
arithmetic is exact in binary (energies 0.5, 0.25, 0.4375 ...). The recommendations, renders and
studies are tiny fakes (``SimpleNamespace``) or recorders put in place of the expensive calls, so
the file runs in a couple of seconds: no recommendation, render or report page is made.
"""

from __future__ import annotations

import json
import math
import sys
import time
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

import labcut
from labcut.errors import LabcutWarning, ParameterError
from labcut.orientation.scoring import FlashMetrics
from labcut.reports import compare as C
from labcut.reports.cuts import Cut

NAN = float("nan")


def fm(energy: float, area: float = 0.125, intensity: float = 2.0, coverage: float = 0.5, **extra) -> FlashMetrics:
    """Flash metrics of one view (weight 1): the aggregates are the view's values."""
    return FlashMetrics(flash_area=area, flash_intensity=intensity, flash_energy=energy, coverage=coverage,
                        balanced=math.sqrt(area * intensity),
                        per_view={"flash_area": [area], "flash_intensity": [intensity], "flash_energy": [energy],
                                  "weight": [1.0]}, **extra)


def bar(rel):
    return None if rel is None else SimpleNamespace(score_rel=rel)


def rec(energy, area=0.125, intensity=2.0, coverage=0.5, tol=4.0, rel=None, description="d", best=None):
    """A recommendation: its metrics, error bar, tolerance, words and JSON."""
    out = {"description": description, "score": energy, "metric_definitions": {"x": 1}, "frame": "f", "mesh": {"m": 1},
           "misorientation": {"own": 1}, "tolerance_deg": tol} if best is None else best
    return SimpleNamespace(metrics=fm(energy, area, intensity, coverage), uncertainty=bar(rel), tolerance_deg=tol,
                           description=description, to_dict=lambda: dict(out))


def sres(cut, energy, *, area=0.125, rank=1, tied=False, rel=None, tol=4.0, normalised=None, scen="bench", **kw):
    return C.ScenarioResult(cut, scen, rec(energy, area, tol=tol, rel=rel, description=f"{cut} at best"), None, None,
                            None, None, rank=rank, tied=tied, normalised=normalised or {}, **kw)


def summary(weight=1.5):
    return SimpleNamespace(weight_ct=weight, weight_ct_range=[weight - 0.25, weight + 0.25], volume_mm3=300.0,
                           length_mm=16.0, width_mm=12.0, height_mm=4.0)


def cutres(name, scenarios, *, rank=1, tied=False, score=1.0, error=0.0, weight=1.5, kind="cabochon", source=None,
           normal=(0.0, 0.0, 1.0), parallel=None):
    cp = SimpleNamespace(normal=np.array(normal), parallel_within_deg=parallel, score=0.75,
                         relative={s: 1.0 for s in scenarios}, tolerance_deg=3.0,
                         tolerance_by_axis={"front_back_deg": 3.5, "side_to_side_deg": 2.5})
    cut = Cut(name, trimesh.creation.box((2.0, 3.0, 4.0)), kind, source, {"length_mm": 2.0})
    return C.CutResult(cut, summary(weight), scenarios, cp, f"{name} compromise", {"raise_deg": 1.0}, score, rank, error,
                       tied)


def scen(name, upright=False):
    return SimpleNamespace(name=name, worn_upright=upright, to_dict=lambda: {"name": name})


def comparison(cuts, names=("bench",), *, reference=0, upright=None, seconds=12.34, budget=None, exposures=None):
    upright = upright or [False] * len(names)
    return C.Comparison(cuts, [scen(n, u) for n, u in zip(names, upright)], SimpleNamespace(to_dict=lambda: {"name": "blue"}),
                        reference, "draft", exposures if exposures is not None else {n: 0.5 for n in names},
                        {"resolution": 32}, seconds, **({} if budget is None else {"budget": budget}))


# ---------------------------------------------------------------------- ranks within error bars
def test_ranks_without_error_bars_are_competition_ranks():
    """Largest first; equal values share a rank and the next rank skips ("1, 1, 3, 4"); values
    0.25 apart (closer than any default bar of 1 would allow) are told apart."""
    assert C.competition_ranks([0.5, 2.0, 2.0, 1.0]) == [4, 1, 1, 3]
    assert C.competition_ranks([1.25, 1.0]) == [1, 2]
    assert C.competition_ranks([7.0]) == [1]
    assert C.competition_ranks([]) == []


def test_two_values_differ_only_beyond_their_bars_combined_in_quadrature():
    # 0.5 apart, bars 0.3 and 0.4: hypot 0.5 exactly, not beyond: a tie
    assert C.differ(1.0, 0.3, 0.5, 0.4) is False
    assert C.differ(1.0, 0.3, 0.49, 0.4) is True
    assert C.differ(0.5, 0.3, 1.0, 0.4) is False  # the smaller is never larger
    assert C.differ(1.0, 0.0, 1.0, 0.0) is False
    assert C.competition_ranks([1.0, 0.5], [0.3, 0.4]) == [1, 1]
    assert C.competition_ranks([1.0, 0.49], [0.3, 0.4]) == [1, 2]
    # one bar alone decides too (0.25 apart, bar 0.25 on either side)
    assert C.competition_ranks([1.0, 0.75], [0.25, 0.0]) == [1, 1]
    assert C.competition_ranks([1.0, 0.75], [0.0, 0.25]) == [1, 1]
    assert C.competition_ranks([1.0, 0.75], [0.0, 0.24]) == [1, 2]


def test_shared_ranks_are_ties():
    assert C.shared([1, 1, 3]) == [True, True, False]
    assert C.shared([1, 2, 3]) == [False, False, False]
    assert C.shared([2, 2, 2]) == [True, True, True]
    assert C.shared((1, 3, 1)) == [True, False, True]


def test_names_are_joined_with_commas_and_a_last_and():
    assert C._and(["a"]) == "a"
    assert C._and(("a", "b")) == "a and b"
    assert C._and(["a", "b", "c"]) == "a, b and c"
    assert C._and(["a", "b", "c", "d"]) == "a, b, c and d"


def test_a_ratio_needs_a_positive_base():
    assert C._ratio(1.0, 4.0) == 0.25 and type(C._ratio(np.float32(1.0), 4.0)) is float
    assert C._ratio(3.0, 2.0) == 1.5
    assert C._ratio(1.0, 0.0) is None and C._ratio(1.0, -2.0) is None
    assert C._ratio(0.0, 1e-300) == 0.0


def test_the_naming_scenario_is_the_first_when_all_wear_the_stone_alike():
    a, b, c = scen("a"), scen("b"), scen("c", upright=True)
    assert C.naming_scenario([a, b]) is a
    d, e = scen("d", True), scen("e", True)
    assert C.naming_scenario([d, e]) is d and C.naming_scenario([c]) is c
    assert C.naming_scenario([a, c]) is None and C.naming_scenario([c, a, b]) is None


def test_plain_json():
    out = C._json({1: np.float64(0.5), "t": (np.int64(3), np.bool_(True)), "a": np.array([[1.0, NAN]]),
                   "f": np.float32(0.25), "n": None, "s": "x", "inf": -math.inf, "b": False, "i": 7, "nested": [{"z": math.nan}]})
    assert out == {"1": 0.5, "t": [3, True], "a": [[1.0, None]], "f": 0.25, "n": None, "s": "x", "inf": None, "b": False,
                   "i": 7, "nested": [{"z": None}]}
    assert type(out["t"][0]) is int and type(out["t"][1]) is bool and type(out["f"]) is float
    assert type(out["1"]) is float and type(out["a"]) is list and type(out["t"]) is list
    assert type(C._json(np.bool_(False))) is bool and C._json(np.bool_(False)) is False
    assert type(C._json(np.int32(-2))) is int and C._json(np.int32(-2)) == -2
    assert C._json(np.float32(NAN)) is None and C._json(math.inf) is None


# ---------------------------------------------------------------------- the overall score
def test_the_overall_score_is_the_mean_ratio_and_its_bar_the_quadrature_mean():
    # ratios 1 and 0.5 with 10 % and 20 % bars (None: the reference had no energy, left out)
    score, err = C.overall_score([1.0, 0.5, None], [bar(0.1), bar(0.2), bar(0.9)])
    assert score == 0.75 and err == pytest.approx(math.hypot(0.1, 0.1) / 2, rel=1e-15)
    # a ratio without error bars adds nothing to the bar, but counts in the mean and the count
    score, err = C.overall_score([0.75, 0.25], [None, bar(0.5)])
    assert (score, err) == (0.5, 0.0625)
    assert C.overall_score([2.0], [bar(0.25)]) == (2.0, 0.5)
    assert C.overall_score([None, None], [bar(0.1), None]) == (0.0, 0.0)
    assert C.overall_score([], []) == (0.0, 0.0)
    score, err = C.overall_score([0.5, 0.25, 0.75], [bar(0.5), bar(1.0), bar(0.0)])
    assert score == 0.5 and err == pytest.approx(math.hypot(0.25, 0.25) / 3, rel=1e-15)
    assert type(score) is float and type(err) is float


# ---------------------------------------------------------------------- one cut under one scenario
def test_a_scenario_result_reads_its_recommendation():
    r = C.ScenarioResult("A", "bench", rec(0.5, area=0.25, intensity=1.5, coverage=0.75, tol=3.0, rel=0.125), 1, 2, 3, 4)
    assert r.energy == 0.5 and r.energy_error == 0.0625
    assert r.flashes is True
    assert [r.value(k) for k in C.NORMALISED] == [0.5, 0.25, 1.5, 0.75, 3.0]
    # defaults: no compromise yet, relative 1, unranked, untied, nothing normalised, no time
    assert (r.compromise_metrics, r.compromise_relative, r.rank, r.tied, r.normalised, r.seconds) == (None, 1.0, 0, False, {}, 0.0)
    assert C.ScenarioResult("A", "b", rec(0.5), 1, 2, 3, 4).energy_error == 0.0  # no error bars
    assert C.ScenarioResult("A", "b", rec(0.5, rel=0.0), 1, 2, 3, 4).energy_error == 0.0
    dark = C.ScenarioResult("A", "b", rec(0.25, area=0.0), 1, 2, 3, 4)
    assert dark.flashes is False
    assert C.ScenarioResult("A", "b", rec(0.25, area=1e-12), 1, 2, 3, 4).flashes is True
    assert C.NORMALISED == ("flash_energy", "flash_area", "flash_intensity", "coverage", "tolerance_deg")
    assert C.CSV_COLUMNS == ("cut", "scenario", "orientation", "quantity", "value", "unit", "x", "x_unit", "y", "y_unit")


def test_a_cut_result_defaults_and_its_name():
    c = C.CutResult(Cut("oval", None, "mesh"), None, {}, None, "", {})
    assert (c.name, c.overall_score, c.rank, c.overall_error, c.tied) == ("oval", 0.0, 0, 0.0, False)


# ---------------------------------------------------------------------- ranking and normalising, by hand
def fake_cut(name, bench, ring, comp):
    """A cut with (energy, area, intensity, coverage, tolerance, rel) under bench and ring, and its
    energy at its compromise orientation under each."""
    per = {}
    for s, (e, a, i, cov, tol, rel), ce in zip(("bench", "ring"), (bench, ring), comp):
        per[s] = C.ScenarioResult(name, s, rec(e, a, i, cov, tol, rel), None, None, None, None, compromise_metrics=fm(ce))
    return C.CutResult(Cut(name, None, "mesh"), None, per, None, "", {})


@pytest.fixture
def exposures(monkeypatch):
    looks = []
    monkeypatch.setattr("labcut.rendering.exposure.reference_exposure", lambda studio="unset": looks.append(studio) or 1.5)
    return looks


def test_rank_and_normalise_by_hand(exposures):
    """Three cuts, the reference B the second.

    bench (energy ± 12.5 %): A 0.5 ± 0.0625, B 0.25 ± 0.03125, C 0.4375 ± 0.0546875: A - C = 0.0625 lies
    within hypot(0.0625, 0.0547) = 0.083 (a tie), both beat B beyond their bars: ranks 1, 3, 1.
    ring (± 50 %): A 0.125 ± 0.0625, B 0.25 ± 0.125, C 0.5 ± 0.25: C beats A (0.375 > 0.258), neither
    beats B nor B A beyond their bars: ranks 2, 1, 1.
    Compromise energies over B's: A (2, 0.5), B (1, 1), C (1.5, 2): overall 1.25, 1, 1.75, bars
    sqrt((2 x 0.125)² + (0.5 x 0.5)²) / 2 = 0.177, sqrt(0.125² + 0.5²) / 2 = 0.258,
    sqrt((1.5 x 0.125)² + (2 x 0.5)²) / 2 = 0.509; C - A = 0.5 within 0.539 (tie), C - B = 0.75
    beyond 0.570, A - B = 0.25 within 0.312: overall ranks 1, 2, 1."""
    a = fake_cut("A", (0.5, 0.375, 1.0, 0.5, 2.0, 0.125), (0.125, 0.0625, 4.0, 0.25, 8.0, 0.5), (0.5, 0.125))
    b = fake_cut("B", (0.25, 0.125, 2.0, 0.0, 4.0, 0.125), (0.25, 0.25, 2.0, 0.5, 4.0, 0.5), (0.25, 0.25))
    c = fake_cut("C", (0.4375, 0.25, 1.5, 0.75, 3.0, 0.125), (0.5, 0.5, 1.0, 1.0, 1.0, 0.5), (0.375, 0.5))
    out = C.rank_and_normalise([a, b, c], [scen("bench"), scen("ring")], 1)
    assert out == {"bench": 1.5, "ring": 1.5} and exposures == [None, None]
    bench = [x.scenarios["bench"] for x in (a, b, c)]
    ring = [x.scenarios["ring"] for x in (a, b, c)]
    assert [(r.rank, r.tied) for r in bench] == [(1, True), (3, False), (1, True)]
    assert [(r.rank, r.tied) for r in ring] == [(2, False), (1, True), (1, True)]
    assert [r.normalised for r in bench] == [
        {"flash_energy": 2.0, "flash_area": 3.0, "flash_intensity": 0.5, "coverage": None, "tolerance_deg": 0.5},
        {"flash_energy": 1.0, "flash_area": 1.0, "flash_intensity": 1.0, "coverage": None, "tolerance_deg": 1.0},
        {"flash_energy": 1.75, "flash_area": 2.0, "flash_intensity": 0.75, "coverage": None, "tolerance_deg": 0.75}]
    assert [r.normalised for r in ring] == [
        {"flash_energy": 0.5, "flash_area": 0.25, "flash_intensity": 2.0, "coverage": 0.5, "tolerance_deg": 2.0},
        {"flash_energy": 1.0, "flash_area": 1.0, "flash_intensity": 1.0, "coverage": 1.0, "tolerance_deg": 1.0},
        {"flash_energy": 2.0, "flash_area": 2.0, "flash_intensity": 0.5, "coverage": 2.0, "tolerance_deg": 0.25}]
    assert [x.overall_score for x in (a, b, c)] == [1.25, 1.0, 1.75]
    assert [x.overall_error for x in (a, b, c)] == pytest.approx(
        [math.hypot(0.25, 0.25) / 2, math.hypot(0.125, 0.5) / 2, math.hypot(0.1875, 1.0) / 2], rel=1e-15)
    assert [(x.rank, x.tied) for x in (a, b, c)] == [(1, True), (2, False), (1, True)]


def test_a_scenario_where_the_reference_has_no_compromise_energy_is_left_out_of_the_score(exposures):
    a = fake_cut("A", (0.5, 0.375, 1.0, 0.5, 2.0, None), (0.125, 0.0625, 4.0, 0.25, 8.0, None), (0.5, 0.125))
    b = fake_cut("B", (0.25, 0.125, 2.0, 0.5, 4.0, None), (0.25, 0.25, 2.0, 0.5, 4.0, None), (0.0, 0.25))
    C.rank_and_normalise([a, b], [scen("bench"), scen("ring")], -1)
    assert (a.overall_score, b.overall_score) == (0.5, 1.0)  # ring alone: 0.125 / 0.25, 0.25 / 0.25
    assert (a.overall_error, b.overall_error) == (0.0, 0.0)
    assert [(x.rank, x.tied) for x in (a, b)] == [(2, False), (1, False)]
    assert [(x.scenarios["bench"].rank, x.scenarios["ring"].rank) for x in (a, b)] == [(1, 2), (2, 1)]


# ---------------------------------------------------------------------- verdicts
def three(energies=(0.25, 0.5, 0.3125), ranks=(3, 1, 2), areas=(0.125, 0.125, 0.125), overall=(1.0, 2.0, 1.25),
          cut_ranks=(3, 1, 2), names=("bench",)):
    cuts = []
    for n, e, r, a, o, cr in zip("ABC", energies, ranks, areas, overall, cut_ranks):
        cuts.append(cutres(n, {s: sres(n, e, area=a, rank=r, scen=s) for s in names}, rank=cr, score=o))
    return cuts


def test_sides_are_named_as_the_scenarios_wear_the_stone():
    cuts = three(names=("bench", "ring"))
    assert comparison(cuts, ("bench", "ring"), upright=[True, True]).sides_note == (
        "sides are named as the stone is worn upright: +Y is its top (the bail end), -Y its bottom")
    assert comparison(cuts, ("bench", "ring")).sides_note == (
        "sides are named as the stone lies face-up: -Y is its front, +Y its back")
    for mixed in ([True, False], [False, True]):
        assert comparison(cuts, ("bench", "ring"), upright=mixed).sides_note == (
            "sides are named as the stone lies face-up: +Y is its back lying face-up and its top (the bail end) "
            "worn upright, -Y its front and its bottom")


def test_looking_up_a_result():
    cmp = comparison(three(names=("bench", "ring")), ("bench", "ring"), reference=2)
    assert cmp.scenario_names == ["bench", "ring"] and cmp.reference_cut.name == "C"
    assert cmp.result(1, "ring") is cmp.cuts[1].scenarios["ring"]
    assert cmp.result("C", "bench") is cmp.cuts[2].scenarios["bench"]
    assert cmp.result(-1, "bench") is cmp.cuts[2].scenarios["bench"]
    with pytest.raises(ParameterError) as e:
        cmp.result("D", "bench")
    assert str(e.value) == "no cut named 'D' in this comparison: A, B, C"
    with pytest.raises(ParameterError) as e:
        cmp.result("B", "pendant")
    assert str(e.value) == "no scenario 'pendant' in this comparison: bench, ring"
    with pytest.raises(ParameterError) as e:
        cmp.result(0, "Bench")
    assert str(e.value) == "no scenario 'Bench' in this comparison: bench, ring"


def test_ranked_is_by_rank_then_the_order_given():
    cmp = comparison(three(cut_ranks=(2, 1, 1)))
    assert [c.name for c in cmp.ranked()] == ["B", "C", "A"]
    cmp = comparison(three(cut_ranks=(1, 1, 1)))
    assert [c.name for c in cmp.ranked()] == ["A", "B", "C"]
    cmp = comparison(three(cut_ranks=(3, 2, 1)))
    assert [c.name for c in cmp.ranked()] == ["C", "B", "A"]


def test_a_scenario_flashes_when_any_cut_does():
    assert comparison(three(areas=(0.0, 0.0, 1e-9))).flashes("bench") is True
    assert comparison(three(areas=(0.0, 0.0, 0.0))).flashes("bench") is False
    assert comparison(three(areas=(0.5, 0.5, 0.5))).flashes("bench") is True


def test_a_scenario_verdict_names_the_leader_the_tie_or_the_faint_best():
    assert comparison(three()).scenario_verdict("bench") == "under bench B flashes most"
    # C and A share rank 1: named by energy, the larger first
    tie = comparison(three(energies=(0.5, 0.25, 0.53125), ranks=(1, 3, 1)))
    assert tie.scenario_verdict("bench") == ("under bench C and A tie for the most flash: their flash energies lie within "
                                             "their error bars")
    tie3 = comparison(three(energies=(0.5, 0.25, 0.53125), ranks=(1, 1, 1)))
    assert tie3.scenario_verdict("bench").startswith("under bench C, A and B tie for the most flash")
    dark = comparison(three(energies=(0.01, 0.04321, 0.02), ranks=(3, 1, 2), areas=(0.0, 0.0, 0.0)))
    assert dark.scenario_verdict("bench") == (
        "under bench no cut shows flash: none reaches the flash threshold at its best orientation; the best achievable "
        "is the faint schiller of B (flash energy 0.0432); try a directed light (--scenario bench, or --lighting spot) "
        "to see which cut flashes")


def test_the_verdict_over_all_scenarios():
    one = comparison(three())
    assert one.verdict == "B flashes most over bench."
    cuts = three(names=("bench", "ring"))
    assert comparison(cuts, ("bench", "ring")).verdict == (
        "B flashes most over bench and ring (each cut at one orientation for all).")
    tied = comparison(three(cut_ranks=(1, 3, 1)))
    assert tied.verdict == ("A and C tie for the most flash over bench: their overall scores lie within their error bars, "
                            "so this comparison cannot tell them apart.")
    # one of three scenarios dark: named after the leader
    names = ("bench", "ring", "pendant")
    cuts = three(names=names)
    for c in cuts:
        c.scenarios["ring"] = sres(c.name, 0.0625, area=0.0, scen="ring")
    assert comparison(cuts, names).verdict == (
        "B flashes most over bench, ring and pendant (each cut at one orientation for all). Under ring no cut reaches the "
        "flash threshold: faint schiller only.")
    for c in cuts:
        c.scenarios["pendant"] = sres(c.name, 0.0625, area=0.0, scen="pendant")
    assert comparison(cuts, names).verdict.endswith(" Under ring and pendant no cut reaches the flash threshold: faint "
                                                    "schiller only.")


def test_the_verdict_where_no_cut_flashes_anywhere_names_no_winner():
    names = ("bench", "ring")
    cuts = three(areas=(0.0, 0.0, 0.0), names=names, overall=(1.0, 0.875, 1.125), cut_ranks=(2, 3, 1))
    assert comparison(cuts, names).verdict == (
        "No cut shows flash under bench and ring: none reaches the flash threshold at its best orientation; the best "
        "achievable is the faint schiller of C (overall score 1.12); try a directed light (--scenario bench, or "
        "--lighting spot) to see which cut flashes.")


# ---------------------------------------------------------------------- notebooks
def test_repr_and_the_notebook_table():
    cuts = three(names=("bench", "a<b"), cut_ranks=(2, 1, 3), overall=(1.0, 1.23456, 0.5))
    cuts[0].cut.name = "A&co"
    for c, rel in zip(cuts, (1.0, 0.756, None)):
        c.scenarios["bench"].normalised = {"flash_energy": rel}
        c.scenarios["a<b"].normalised = {"flash_energy": 0.5 if rel else None}
    cmp = comparison(cuts, ("bench", "a<b"), seconds=12.36)
    assert repr(cmp) == "Comparison(3 cuts x 2 scenarios (bench, a<b), best 'B', reference 'A&co', 12.4 s)"
    assert cmp._repr_html_() == (
        "<table><caption>flash energy relative to A&amp;co</caption><thead><tr><th>rank</th><th>cut</th><th>ct</th>"
        "<th>overall</th><th>bench</th><th>a&lt;b</th></tr></thead><tbody>"
        "<tr><td>1</td><td>B</td><td>1.50</td><td>1.23</td><td>76%</td><td>50%</td></tr>"
        "<tr><td>2</td><td>A&amp;co</td><td>1.50</td><td>1</td><td>100%</td><td>50%</td></tr>"
        "<tr><td>3</td><td>C</td><td>1.50</td><td>0.5</td><td>-</td><td>-</td></tr>"
        "</tbody></table>")


def test_the_summary_rows_in_rank_order():
    cuts = three(names=("bench", "ring"), cut_ranks=(2, 1, 2), overall=(1.0, 2.0, 1.25))
    for c, n in zip(cuts, (1.0, 0.5, None)):
        c.scenarios["ring"].normalised = {"flash_energy": n, "coverage": 0.5}
        c.overall_error = 0.125
    cuts[2].tied = True
    cuts[1].scenarios["ring"] = sres("B", 0.5, rank=1, tied=True, rel=0.125, tol=2.5, scen="ring",
                                     normalised={"flash_energy": 0.5})
    rows = comparison(cuts, ("bench", "ring")).summary_rows()
    assert [r["cut"] for r in rows] == ["B", "A", "C"]
    assert rows[0] == {"rank": 1, "tied": False, "cut": "B", "weight_ct": 1.5, "overall_score": 2.0,
                       "overall_score_error": 0.125, "compromise": "B compromise", "compromise_tolerance_deg": 3.0,
                       "scenarios": {
                           "bench": {"rank": 1, "tied": False, "flash_energy": 0.5, "flash_energy_error": 0.0,
                                     "flash_energy_normalised": None, "tolerance_deg": 4.0, "description": "B at best"},
                           "ring": {"rank": 1, "tied": True, "flash_energy": 0.5, "flash_energy_error": 0.0625,
                                    "flash_energy_normalised": 0.5, "tolerance_deg": 2.5, "description": "B at best"}}}
    assert rows[2]["tied"] is True and rows[2]["scenarios"]["ring"]["flash_energy_normalised"] is None
    assert rows[1]["scenarios"]["ring"]["flash_energy_normalised"] == 1.0 and rows[1]["rank"] == 2


# ---------------------------------------------------------------------- JSON
def full_result(cut, scenario, energy, *, renders=True, colour=True, compromise=True, rank=2, tied=True):
    best = {"description": f"{cut} best", "score": energy, "metric_definitions": {"x": 1}, "frame": "f", "mesh": {},
            "misorientation": {"own": 1}, "tolerance_deg": 4.0, "normal": np.array([0.0, 0.0, 1.0])}
    r = C.ScenarioResult(
        cut, scen(scenario), rec(energy, best=best, rel=0.25),
        SimpleNamespace(to_dict=lambda: {"angles_deg": np.array([-1.0, 0.0, 1.0])}),
        SimpleNamespace(to_dict=lambda: {"miss_deg": (0.0, 2.0)}),
        SimpleNamespace(view="v", resolution=32, spp=2, strip_angles_deg=(-5.0, 5.0), plan={"integrator": "direct"})
        if renders else None,
        SimpleNamespace(stats={"flash_fraction": np.float64(0.25)}) if colour else None,
        compromise_metrics=fm(energy / 2, area=0.0, intensity=0.0, coverage=0.0) if compromise else None,
        compromise_relative=0.5, rank=rank, tied=tied, normalised={"flash_energy": 1.0, "coverage": None}, seconds=1.25)
    return r


def test_to_dict_holds_every_number_as_plain_json():
    from labcut.orientation.recommend import FRAME, METRIC_DEFINITIONS
    from labcut.reports.html import COMPARE_DEFINITIONS

    a = cutres("A", {"bench": full_result("A", "bench", 0.5)}, rank=2, tied=True, score=1.0, error=0.125,
               kind="file", source="/stones/a.ply", normal=(0.0, 0.6, 0.8), parallel=2.5)
    b = cutres("B", {"bench": full_result("B", "bench", 1.0, renders=False, colour=False, compromise=False, rank=1,
                                                tied=False)}, rank=1,
               score=2.0, normal=(0.0, 0.0, 1.0))
    cmp = comparison([a, b], ("bench",), exposures={"bench": 0.75}, budget={"quality": "draft"})
    cmp.tau, cmp.seed = 0.2, 7
    data = cmp.to_dict()
    assert json.loads(json.dumps(data, allow_nan=False)) == data
    assert data["kind"] == "labcut.compare" and data["labcut_version"] == labcut.__version__
    assert (data["quality"], data["tau"], data["seed"], data["material"]) == ("draft", 0.2, 7, {"name": "blue"})
    assert data["reference"] == {"index": 0, "name": "A"} and data["scenarios"] == [{"name": "bench"}]
    assert data["render"] == {"resolution": 32} and data["exposures"] == {"bench": 0.75}
    assert data["verdict"] == "B flashes most over bench."
    assert data["scenario_verdicts"] == {"bench": {"any_flash": True, "verdict": "under bench B flashes most"}}
    assert data["summary"] == C._json(cmp.summary_rows()) and [r["cut"] for r in data["summary"]] == ["B", "A"]
    assert data["compromise_sides"] == "sides are named as the stone lies face-up: -Y is its front, +Y its back"
    assert data["frame"] == FRAME and data["metric_definitions"] == {**METRIC_DEFINITIONS, **COMPARE_DEFINITIONS}
    assert data["seconds"] == 12.34 and data["time_budget"] == {"quality": "draft"}
    ca, cb = data["cuts"]
    box = {"kind": "given", "units": "mm", "repairs": [], "bodies": 1, "dimensions_mm": [2.0, 3.0, 4.0], "triangles": 12}
    tilt = math.degrees(math.acos(0.8))
    assert ca == {
        "name": "A", "source": {"name": "A", "kind": "file", "source": "/stones/a.ply", "design": {"length_mm": 2.0},
                                "warnings": []},
        "mesh": {**box, "path": "/stones/a.ply"}, "weight_ct": 1.5, "weight_ct_range": [1.25, 1.75], "volume_mm3": 300.0,
        "dimensions_mm": [16.0, 12.0, 4.0], "rank": 2, "tied": True, "overall_score": 1.0, "overall_score_error": 0.125,
        "compromise": {"normal": [0.0, 0.6, 0.8], "tilt_deg": pytest.approx(tilt, rel=1e-12), "azimuth_deg": 90.0,
                       "description": "A compromise", "workshop": {"raise_deg": 1.0}, "parallel_to_base": True,
                       "parallel_within_deg": 2.5, "score": 0.75, "relative_to_best": {"bench": 1.0}, "tolerance_deg": 3.0,
                       "tolerance_by_axis": {"front_back_deg": 3.5, "side_to_side_deg": 2.5}},
        "scenarios": {"bench": {
            "rank": 2, "tied": True, "flash_energy_error": 0.125,
            "best": {"description": "A best", "score": 0.5, "tolerance_deg": 4.0, "normal": [0.0, 0.0, 1.0]},
            "normalised": {"flash_energy": 1.0, "coverage": None}, "tilt_curve": {"angles_deg": [-1.0, 0.0, 1.0]},
            "misorientation": {"miss_deg": [0.0, 2.0]}, "flash_colour": {"flash_fraction": 0.25},
            "render": {"view": "v", "resolution": 32, "spp": 2, "exposure": 0.75, "strip_angles_deg": [-5.0, 5.0],
                       "strip_axis": "front_back", "plan": {"integrator": "direct"}},
            "compromise": {"relative_to_best": 0.5, "metrics": {
                "flash_area": 0.0, "flash_intensity": 0.0, "flash_energy": 0.25, "coverage": 0.0, "balanced": 0.0,
                "per_view": {"flash_area": [0.0], "flash_intensity": [0.0], "flash_energy": [0.25], "weight": [1.0]},
                "visible_area_mm2": None, "flash_area_mm2": None, "energy_in_flash": 0.0, "energy_below_threshold": 0.25}},
            "seconds": 1.25}},
    }
    assert cb["mesh"] == box and cb["compromise"]["parallel_to_base"] is False
    assert cb["compromise"]["parallel_within_deg"] is None
    assert (cb["compromise"]["tilt_deg"], cb["compromise"]["azimuth_deg"]) == (0.0, 0.0)
    sb = cb["scenarios"]["bench"]
    assert (sb["render"], sb["flash_colour"], sb["compromise"]["metrics"]) == (None, None, None)
    assert sb["flash_energy_error"] == 0.25
    cmp.budget = {}
    assert cmp.to_dict()["time_budget"] is None


def test_the_mesh_block_of_a_built_cut_has_no_path():
    c = Cut("cab", trimesh.creation.box((1.0, 1.0, 2.0)), "cabochon", "cab:round,10")
    assert "path" not in C._mesh_block(c) and C._mesh_block(c)["dimensions_mm"] == [1.0, 1.0, 2.0]
    assert C._mesh_block(Cut("f", c.mesh, "file", "x.ply"))["path"] == "x.ply"
    assert C._tilt([0.0, -1.0, 0.0]) == (90.0, 270.0) and C._metrics(None) is None


def test_save_json_writes_the_dict_indented(tmp_path):
    cmp = comparison([cutres("A", {"bench": full_result("A", "bench", 0.5, rank=1)})])
    path = cmp.save_json(tmp_path / "c.json")
    assert path == tmp_path / "c.json" and isinstance(path, Path)
    assert path.read_text() == json.dumps(cmp.to_dict(), indent=2) + "\n"
    with pytest.raises(ParameterError, match=r"must end in one of \.json"):
        cmp.save_json(tmp_path / "c.csv")


def test_save_html_hands_the_comparison_to_the_report_writer(tmp_path, monkeypatch):
    seen = []
    monkeypatch.setattr("labcut.reports.html.write_report", lambda cmp, path: seen.append((cmp, path)) or "written")
    cmp = comparison(three())
    assert cmp.save_html(tmp_path / "r.html") == "written" and seen == [(cmp, tmp_path / "r.html")]


# ---------------------------------------------------------------------- CSV
def row(cut, scen, orient, qty, value, unit="", x=None, x_unit="", y=None, y_unit=""):
    return {"cut": cut, "scenario": scen, "orientation": orient, "quantity": qty, "value": value, "unit": unit,
            "x": x, "x_unit": x_unit, "y": y, "y_unit": y_unit}


METRIC_UNITS = {"flash_area": "fraction", "flash_intensity": "L_ref", "flash_energy": "L_ref", "coverage": "fraction",
                "balanced": "", "energy_in_flash": "L_ref", "energy_below_threshold": "L_ref", "visible_area_mm2": "mm2",
                "flash_area_mm2": "mm2", "made_up": ""}
COLOUR_UNITS = {"flash_fraction": "fraction", "dominant_wavelength_nm": "nm", "p10_nm": "nm", "p90_nm": "nm",
                "purple_fraction": "fraction", "mean_dominant_wavelength_nm": "nm", "mean_purity": "fraction",
                "peak_level": "tau L_ref", "estimator_flash_area": "fraction"}


def toy_json():
    """The JSON of a one-cut, one-scenario comparison, small enough to list its rows by hand."""
    metrics = {k: float(i + 1) for i, k in enumerate(METRIC_UNITS)}
    metrics["per_view"] = {"flash_area": [1.0]}
    orient = {"normal": [0.0, 0.6, 0.8], "tilt_deg": 36.9, "azimuth_deg": 90.0, "tolerance_deg": 4.0,
              "tolerance_by_axis": {"front_back_deg": 5.0, "side_to_side_deg": 3.0}}
    return {
        "scenarios": [{"name": "bench"}, {"name": "ring"}], "exposures": {"bench": 2.5},
        "cuts": [{
            "name": "A", "rank": 1, "tied": True, "overall_score": 1.0, "overall_score_error": 0.05, "weight_ct": 3.25,
            "weight_ct_range": [3.0, 3.5], "volume_mm3": 260.0, "dimensions_mm": [16.0, 12.0, 4.0],
            "compromise": {**orient, "parallel_within_deg": 2.0, "workshop": {"raise_deg": 36.9, "raise_mm": 1.25,
                                                                               "span_mm": 12.0},
                           "score": 0.9, "relative_to_best": {"bench": 0.95}},
            "scenarios": {"bench": {
                "rank": 2, "tied": False, "flash_energy_error": 0.01,
                "best": {**orient, "parallel_within_deg": None, "description": "words", "score": 0.2,
                         "metrics": metrics, "map": {"tilt_deg": [0.0, 10.0], "azimuth_deg": [0.0, 90.0],
                                                     "score": [0.2, 0.1]}},
                "normalised": {"flash_energy": 1.5, "coverage": None},
                "compromise": {"metrics": {"flash_energy": 0.19, "flash_area": None, "per_view": {"x": [1.0]},
                                           "made_up": 0.5}},
                "flash_colour": {k: 10.0 + i for i, k in enumerate(COLOUR_UNITS)},
                "tilt_curve": {"angles_deg": [-10.0, 10.0], "flash_energy": {"front_back": [0.1, 0.2]},
                               "flash_area": {"side_to_side": [0.3, 0.4]}},
                "misorientation": {"miss_deg": [0.0, 2.0], "mean_relative": [1.0, 0.9], "worst_relative": [1.0, 0.8],
                                   "by_side": {"front": [1.0, 0.7]}},
            }},
        }],
    }


def orientation_rows(orient, scen, block_parallel, shop):
    rows = [row("A", scen, orient, "normal_x", 0.0, "unit"), row("A", scen, orient, "normal_y", 0.6, "unit"),
            row("A", scen, orient, "normal_z", 0.8, "unit"), row("A", scen, orient, "tilt_deg", 36.9, "deg"),
            row("A", scen, orient, "azimuth_deg", 90.0, "deg"), row("A", scen, orient, "tolerance_deg", 4.0, "deg"),
            row("A", scen, orient, "tolerance_front_back_deg", 5.0, "deg"),
            row("A", scen, orient, "tolerance_side_to_side_deg", 3.0, "deg")]
    if block_parallel is not None:
        rows.append(row("A", scen, orient, "parallel_within_deg", block_parallel, "deg"))
    if shop:
        rows += [row("A", scen, orient, "raise_deg", 36.9, "deg"), row("A", scen, orient, "raise_mm", 1.25, "mm"),
                 row("A", scen, orient, "span_mm", 12.0, "mm")]
    return rows


def test_the_csv_rows_of_a_toy_comparison_by_hand():
    expected = [row("", "bench", "", "exposure", 2.5, "multiplier"),  # ring has no exposure: no row
                row("A", "", "", "rank", 1), row("A", "", "", "tied", 1, "0/1"),
                row("A", "", "", "overall_score", 1.0, "ratio"), row("A", "", "", "overall_score_error", 0.05, "ratio"),
                row("A", "", "", "weight_ct", 3.25, "ct"), row("A", "", "", "weight_ct_min", 3.0, "ct"),
                row("A", "", "", "weight_ct_max", 3.5, "ct"), row("A", "", "", "volume_mm3", 260.0, "mm3"),
                row("A", "", "", "length_mm", 16.0, "mm"), row("A", "", "", "width_mm", 12.0, "mm"),
                row("A", "", "", "height_mm", 4.0, "mm"),
                *orientation_rows("compromise", "", 2.0, True),
                row("A", "", "compromise", "score", 0.9, "ratio"),
                row("A", "bench", "compromise", "relative_to_best", 0.95, "ratio"),
                row("A", "bench", "best", "rank", 2), row("A", "bench", "best", "tied", 0, "0/1"),
                row("A", "bench", "best", "flash_energy_error", 0.01, "L_ref"),
                *orientation_rows("best", "bench", None, False),
                row("A", "bench", "best", "score", 0.2, "L_ref"),
                *[row("A", "bench", "best", k, float(i + 1), u) for i, (k, u) in enumerate(METRIC_UNITS.items())],
                row("A", "bench", "best", "flash_energy_normalised", 1.5, "ratio"),
                row("A", "bench", "compromise", "flash_energy", 0.19, "L_ref"),
                row("A", "bench", "compromise", "made_up", 0.5),  # a metric of no known unit: none
                *[row("A", "bench", "best", f"colour_{k}", 10.0 + i, u) for i, (k, u) in enumerate(COLOUR_UNITS.items())],
                row("A", "bench", "best", "tilt_flash_energy_front_back", 0.1, "L_ref", -10.0, "deg"),
                row("A", "bench", "best", "tilt_flash_energy_front_back", 0.2, "L_ref", 10.0, "deg"),
                row("A", "bench", "best", "tilt_flash_area_side_to_side", 0.3, "fraction", -10.0, "deg"),
                row("A", "bench", "best", "tilt_flash_area_side_to_side", 0.4, "fraction", 10.0, "deg"),
                row("A", "bench", "best", "misorientation_mean_relative", 1.0, "ratio", 0.0, "deg"),
                row("A", "bench", "best", "misorientation_mean_relative", 0.9, "ratio", 2.0, "deg"),
                row("A", "bench", "best", "misorientation_worst_relative", 1.0, "ratio", 0.0, "deg"),
                row("A", "bench", "best", "misorientation_worst_relative", 0.8, "ratio", 2.0, "deg"),
                row("A", "bench", "best", "misorientation_towards_front", 1.0, "ratio", 0.0, "deg"),
                row("A", "bench", "best", "misorientation_towards_front", 0.7, "ratio", 2.0, "deg"),
                row("A", "bench", "", "score_map_flash_energy", 0.2, "L_ref", 0.0, "deg tilt", 0.0, "deg azimuth"),
                row("A", "bench", "", "score_map_flash_energy", 0.1, "L_ref", 10.0, "deg tilt", 90.0, "deg azimuth")]
    got = C.csv_rows(toy_json())
    assert got == expected
    # no colour statistics, no misorientation by side, no workshop block: no rows for them
    data = toy_json()
    s = data["cuts"][0]["scenarios"]["bench"]
    s["flash_colour"] = None
    del s["misorientation"]["by_side"]
    del data["cuts"][0]["compromise"]["workshop"]
    got = C.csv_rows(data)
    assert not [r for r in got if r["quantity"].startswith(("colour_", "misorientation_towards", "raise_", "span_"))]
    assert len(got) == len(expected) - 9 - 2 - 3


def test_the_csv_skips_what_is_no_number():
    data = toy_json()
    c = data["cuts"][0]
    c["weight_ct"], c["volume_mm3"], c["overall_score"] = None, "big", True
    got = C.csv_rows(data)
    assert not [r for r in got if r["quantity"] in ("weight_ct", "volume_mm3", "overall_score")]
    assert [r["value"] for r in got if r["quantity"] == "rank"] == [1, 2]


def test_rows_are_the_csv_rows_of_the_json_and_save_csv_writes_them(tmp_path):
    cmp = comparison(three())
    cmp.to_dict = toy_json
    assert cmp.rows() == C.csv_rows(toy_json()) and len(cmp.rows()) == 72
    cmp.rows = lambda: [row("A", "bench", "best", "n", 3), row("A", "", "", "x", 0.1, "L_ref", 2.0, "deg", None, "")]
    path = cmp.save_csv(tmp_path / "c.csv")
    assert path == tmp_path / "c.csv" and isinstance(path, Path)
    assert path.read_bytes() == (b"cut,scenario,orientation,quantity,value,unit,x,x_unit,y,y_unit\r\n"
                                 b"A,bench,best,n,3,,,,,\r\n"
                                 b"A,,,x,0.1,L_ref,2.0,deg,,\r\n")
    with pytest.raises(ParameterError, match=r"must end in one of \.csv"):
        cmp.save_csv(tmp_path / "c.json")


# ---------------------------------------------------------------------- the reference cut
def test_the_reference_by_name_or_index():
    cuts = [Cut("a", None, "mesh"), Cut("b", None, "mesh")]
    assert C._reference("b", cuts) == 1 and C._reference("a", cuts) == 0
    assert [C._reference(i, cuts) for i in (0, 1, -1, -2)] == [0, 1, 1, 0]
    assert C._reference(1.0, cuts) == 1
    for bad, words in ((2, "reference 2 is out of range: 2 cut(s), indices 0 to 1"),
                       (-3, "reference -3 is out of range: 2 cut(s), indices 0 to 1"),
                       ("c", "reference 'c' is none of the cuts: a, b"),
                       (0.5, "reference (a cut's index or name) must be a whole number, got 0.5")):
        with pytest.raises(ParameterError) as e:
            C._reference(bad, cuts)
        assert str(e.value) == words


# ---------------------------------------------------------------------- planning
SMALL = "cab:round,10,low,res=16"


@pytest.fixture
def plans(monkeypatch):
    """plan_effects replaced by a recorder of what each (cut, scenario) was planned with."""
    calls = []

    def plan_effects(mesh, lab, **kw):
        calls.append((mesh, lab, kw))
        return ("plan", len(calls))

    monkeypatch.setattr("labcut.planner.plan_effects", plan_effects)
    return calls


def test_the_largest_seed_is_kept_to_the_last_unit(plans):
    """Not rounded through a float: 2**63 - 1 and 2**53 + 1 are themselves."""
    for seed in (2**63 - 1, 2**53 + 1):
        assert C.plan_comparison([SMALL], "green", ["bench"], 0, "draft", seed=seed).seed == seed


def test_plan_comparison_defaults(plans):
    plan = C.plan_comparison([SMALL, ("other", SMALL)])
    assert plan.quality.name == "standard" and plan.seed == 0 and plan.reference == 0 and plan.budget is None
    q = plan.quality
    assert (plan.resolution, plan.spp, plan.strip_spp) == (q.render_resolution, q.render_spp, q.render_spp // 2)
    assert plan.strip_angles == q.strip_angles_deg and plan.tau == 0.1 and plan.effects == {}
    assert [s.name for s in plan.scenarios] == ["bench"] and plan.material.to_dict() == labcut.Labradorite().to_dict()
    assert [c.name for c in plan.cuts] == [SMALL, "other"] and plan.steps == 2
    assert plan.effect_plans == {(SMALL, "bench"): ("plan", 1), ("other", "bench"): ("plan", 2)}
    for (mesh, lab, kw), cut in zip(plans, plan.cuts):
        assert mesh is cut.mesh and lab is plan.material
        assert kw == {"command": "compare", "scenario": plan.scenarios[0], "quality": q, "effects": {}, "predict": True}


def test_plan_comparison_hands_on_what_it_was_given(plans):
    plan = C.plan_comparison([SMALL, ("b", SMALL)], "green", ["bench", "pendant"], "b", "draft", seed=2**53,
                             resolution=16, spp=5, effects={"occlusion": True})
    assert plan.material.to_dict() == labcut.Labradorite.coerce("green").to_dict() and plan.quality.name == "draft"
    assert (plan.reference, plan.seed, plan.resolution, plan.spp, plan.strip_spp) == (1, 2**53, 16, 5, 2)
    assert [s.name for s in plan.scenarios] == ["bench", "pendant"] and plan.steps == 4
    assert plan.effects == {"occlusion": True} and len(plans) == 4
    assert list(plan.effect_plans) == [(SMALL, "bench"), (SMALL, "pendant"), ("b", "bench"), ("b", "pendant")]
    assert [kw["scenario"].name for _, _, kw in plans] == ["bench", "pendant", "bench", "pendant"]
    assert all(kw["effects"] == {"occlusion": True} and kw["quality"] is plan.quality for _, _, kw in plans)
    assert all(s.quality is plan.quality for s in plan.scenarios)
    assert C.plan_comparison([SMALL], spp=1, resolution=2048).strip_spp == 1
    assert C.plan_comparison([SMALL], spp=4096).spp == 4096
    assert C.plan_comparison([SMALL], spp=4).strip_spp == 2
    assert C.ComparisonPlan([], None, [], 0, None, 0, 16, 1, 1, ()).steps == 0
    plain = C.ComparisonPlan([1, 2, 3], None, ["x", "y"], 0, None, 0, 16, 1, 1, ())
    assert (plain.steps, plain.tau, plain.effects, plain.effect_plans, plain.budget) == (6, 0.1, {}, {}, None)


def test_plan_comparison_reads_files_as_told(plans, monkeypatch):
    seen = []
    real = C.resolve_cuts
    monkeypatch.setattr(C, "resolve_cuts", lambda cuts, **kw: seen.append(kw) or real(cuts))
    C.plan_comparison([SMALL], units="cm", up_axis="y", size=8.0)
    C.plan_comparison([SMALL])
    assert seen == [{"units": "cm", "up_axis": "y", "size": 8.0}, {"units": "auto", "up_axis": "auto", "size": None}]


@pytest.mark.parametrize("kwargs, words", [
    ({"resolution": 15}, "render resolution (pixels) must lie in [16, 2048], got 15"),
    ({"resolution": 2049}, "render resolution (pixels) must lie in [16, 2048], got 2049"),
    ({"resolution": 16.5}, "render resolution (pixels) must be a whole number, got 16.5"),
    ({"spp": 0}, "render samples per pixel must lie in [1, 4096], got 0"),
    ({"spp": 4097}, "render samples per pixel must lie in [1, 4096], got 4097"),
    ({"spp": 2.5}, "render samples per pixel must be a whole number, got 2.5"),
    ({"seed": -1}, "seed must lie in [0, 9223372036854775807], got -1"),
    ({"seed": 2**63}, "seed must lie in [0, 9223372036854775807], got 9223372036854775808"),
    ({"seed": 1.5}, "seed must be a whole number, got 1.5"),
    ({"reference": 1}, "reference 1 is out of range: 1 cut(s), indices 0 to 0"),
    ({"quality": "draft", "time_budget": 5}, None),
])
def test_plan_comparison_refuses_bad_numbers(plans, kwargs, words):
    with pytest.raises(ParameterError) as e:
        C.plan_comparison([SMALL], **kwargs)
    if words is not None:
        assert str(e.value) == words
    else:
        assert "not both" in str(e.value)
    assert plans == []


def test_a_bad_budget_fails_before_the_cuts_are_read(plans):
    with pytest.raises(ParameterError, match="time budget"):
        C.plan_comparison(["nowhere.ply"], time_budget=-1)


@pytest.fixture
def choices(monkeypatch):
    from labcut.scene.quality import Quality

    calls = []

    def choose_quality(budget, cuts, scenarios, switches, resolution, spp):
        calls.append((budget, [c.name for c in cuts], scenarios, switches, resolution, spp))
        return SimpleNamespace(quality=Quality.coerce("draft"), note=calls and note[0])

    note = [""]
    monkeypatch.setattr("labcut.reports.budget.choose_quality", choose_quality)
    return calls, note


def test_a_time_budget_chooses_the_quality(plans, choices):
    calls, note = choices
    plan = C.plan_comparison([SMALL], time_budget=30)
    assert calls == [(30, [SMALL], ["bench"], {}, None, None)]
    assert plan.quality.name == "draft" and plan.budget.quality is plan.quality
    assert (plan.resolution, plan.spp, plan.strip_spp) == (96, 8, 4)  # the chosen quality's renders
    assert plan.scenarios[0].quality is plan.quality and plans[0][2]["quality"] is plan.quality
    assert plan.strip_angles == plan.quality.strip_angles_deg
    plan = C.plan_comparison([SMALL], scenarios=["pendant"], time_budget=5, resolution=40, spp=3, effects={"occlusion": False})
    assert calls[-1] == (5, [SMALL], ["pendant"], {"occlusion": False}, 40, 3)
    assert (plan.resolution, plan.spp) == (40, 3) and plan.scenarios[0].name == "pendant"
    note[0] = "below the cheapest: the cheapest runs"
    with pytest.warns(LabcutWarning) as caught:
        C.plan_comparison([SMALL], time_budget=0.5)
    assert [str(w.message) for w in caught] == ["below the cheapest: the cheapest runs"]
    note[0] = ""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        C.plan_comparison([SMALL], time_budget=0.5)


@pytest.mark.skipif("mutmut" in sys.modules, reason="mutmut's trampolines add frames: the warning's line moves")
def test_the_budget_warning_points_at_the_line_that_called_compare_cuts(plans, choices, monkeypatch):
    _, note = choices
    note[0] = "below"
    monkeypatch.setattr(C, "run_comparison", lambda plan, progress: None)
    with pytest.warns(LabcutWarning) as caught:
        C.compare_cuts([SMALL], time_budget=0.5)
    assert caught[0].filename == __file__


def test_compare_cuts_plans_then_runs(monkeypatch):
    got = {}
    monkeypatch.setattr(C, "plan_comparison", lambda *a, **kw: got.update(args=a, kwargs=kw) or "plan")
    monkeypatch.setattr(C, "run_comparison", lambda plan, progress: got.update(run=(plan, progress)) or "done")

    def tick(done, total):
        return None

    assert C.compare_cuts(["x"], "m", ["s"], 1, "q", units="cm", up_axis="y", seed=3, resolution=20, spp=6,
                          progress=tick, effects={"occlusion": True}, size=9.0, time_budget=12.0) == "done"
    assert got == {"args": (["x"], "m", ["s"], 1, "q"),
                   "kwargs": {"units": "cm", "up_axis": "y", "seed": 3, "resolution": 20, "spp": 6,
                              "effects": {"occlusion": True}, "size": 9.0, "time_budget": 12.0},
                   "run": ("plan", tick)}
    C.compare_cuts(["x"])
    assert got["args"] == (["x"], None, None, 0, "standard") and got["run"] == ("plan", None)
    assert got["kwargs"] == {"units": "auto", "up_axis": "auto", "seed": 0, "resolution": None, "spp": None,
                             "effects": None, "size": None, "time_budget": None}


# ---------------------------------------------------------------------- the run, wired with fakes
@pytest.fixture
def fakes(monkeypatch, exposures):
    """Every expensive part of run_comparison replaced by a fake that records its arguments:
    cut X under scenario S recommends an energy ENERGY[X][S] at normal N[X][S]."""
    log = {k: [] for k in ("study", "tilt", "render", "warm", "colour", "compromise", "describe", "workshop",
                           "summarize", "radiance", "record", "rest", "metrics")}
    energy = {"A": {"bench": 0.5, "pendant": 0.25, "display": 0.5}, "B": {"bench": 0.25, "pendant": 0.5, "display": 0.5}}
    state = {"rest": 0.25, "parallel": 1.5}

    class Scorer:
        def __init__(self, cut, sc):
            self.cut, self.sc = cut, sc

        def metrics(self, normal):
            log["metrics"].append((self.cut, self.sc, normal))
            return fm(energy[self.cut][self.sc] / 2)

    class Study:
        def __init__(self, mesh, lab, sc, quality, **kw):
            log["study"].append((mesh, lab, sc, quality, kw))
            self.cut = mesh.metadata["cut"]
            self.sc = sc.name
            self._scorer = Scorer(self.cut, self.sc)

        @property
        def scorer(self):
            return self._scorer

        def recommend(self):
            time.sleep(0.002)  # each (cut, scenario) takes measurable time
            e = energy[self.cut][self.sc]
            return SimpleNamespace(metrics=fm(e), uncertainty=None, tolerance_deg=4.0, normal=("normal", self.cut, self.sc),
                                   misorientation=("mis", self.cut, self.sc), map_normals=("mn", self.cut, self.sc),
                                   map_scores=("ms", self.cut, self.sc))

    def tilt_curve(mesh, lab, normal, sc, quality, tau, seed):
        log["tilt"].append((mesh, lab, normal, sc, quality, tau, seed))
        return SimpleNamespace(at_rest=lambda key: log["rest"].append(key) or state["rest"], name=("tilt", normal))

    def render_cut(mesh, lab, normal, sc, axis, res, spp, angles, seed, **kw):
        log["render"].append((mesh, lab, normal, sc, axis, res, spp, angles, seed, kw))
        flash = SimpleNamespace(threshold=0.25, ratio_at=lambda h, w: ("ratio", h, w))
        return SimpleNamespace(plan={"integrator": f"int-{sc.name}"}, schiller=np.zeros((3, 5, 3)), mask="mask",
                               flash=flash)

    def flash_colour_map(schiller, mask, level, ratio, threshold):
        log["colour"].append((schiller.shape, mask, level, ratio, threshold))
        return SimpleNamespace(stats={})

    def compromise(scorers, names, normals, quality, maps=None):
        log["compromise"].append(([(s.cut, s.sc) for s in scorers], names, normals, quality, maps))
        cut = scorers[0].cut
        return SimpleNamespace(normal=("cp", cut), relative={n: 0.5 + i / 4 for i, n in enumerate(names)},
                               parallel_within_deg=state["parallel"])

    monkeypatch.setattr("labcut.study.Study", Study)
    monkeypatch.setattr("labcut.reports.analysis.tilt_curve", tilt_curve)
    monkeypatch.setattr("labcut.reports.analysis.tilt_axes", lambda sc: {"front_back": ("axis", sc.name), "side": 0})
    monkeypatch.setattr("labcut.reports.analysis.compromise", compromise)
    monkeypatch.setattr("labcut.reports.renders.render_cut", render_cut)
    monkeypatch.setattr("labcut.reports.budget.mark_warm", lambda integrator: log["warm"].append(integrator))
    monkeypatch.setattr("labcut.reports.flashcolour.flash_colour_map", flash_colour_map)
    monkeypatch.setattr("labcut.orientation.recommend.describe",
                        lambda normal, naming, within: log["describe"].append((normal, naming, within)) or f"said {normal}")
    monkeypatch.setattr("labcut.orientation.recommend.workshop",
                        lambda normal, mesh, naming, parallel: log["workshop"].append((normal, mesh, naming, parallel))
                        or {"shop": normal})
    monkeypatch.setattr("labcut.geometry.inspect.summarize",
                        lambda mesh, name: log["summarize"].append((mesh, name)) or SimpleNamespace(name=name))
    monkeypatch.setattr("labcut.orientation.radiance.reference_radiance",
                        lambda lab, irradiance: log["radiance"].append((lab, irradiance)) or 2.0)
    monkeypatch.setattr("labcut.commands.budget.record", lambda kind, predicted, seconds: log["record"].append(
        (kind, predicted, seconds)))
    return log, state


def toy_plan(scenarios=("bench", "pendant"), budget=None):
    from labcut.scene import Scenario

    cuts = []
    for name in ("A", "B"):
        mesh = trimesh.creation.box((1.0, 1.0, 1.0))
        mesh.metadata["cut"] = name
        cuts.append(Cut(name, mesh, "mesh"))
    scens = [Scenario.preset(s, "draft") for s in scenarios]
    plans = {(c.name, s.name): f"plan {c.name} {s.name}" for c in cuts for s in scens}
    return C.ComparisonPlan(cuts, "lab", scens, 1, "quality", 5, 24, 6, 3, (-4.0, 4.0), tau=0.2,
                            effects={"occlusion": False}, effect_plans=plans, budget=budget)


def test_run_comparison_wires_every_part(fakes):
    log, _ = fakes
    plan = toy_plan()
    ticks = []
    cmp = C.run_comparison(plan, lambda done, total: ticks.append((done, total)))
    assert ticks == [(0, 4), (1, 4), (2, 4), (3, 4), (4, 4)]
    a, b = plan.cuts
    bench, pendant = plan.scenarios
    pairs = [(a, bench), (a, pendant), (b, bench), (b, pendant)]
    assert log["study"] == [(c.mesh, "lab", s, "quality", {"seed": 5, "tau": 0.2, "estimator": "samples",
                                                           "effects": {"occlusion": False}, "plan": f"plan {c.name} {s.name}"})
                            for c, s in pairs]
    assert log["tilt"] == [(c.mesh, "lab", ("normal", c.name, s.name), s, "quality", 0.2, 5) for c, s in pairs]
    assert log["render"] == [(c.mesh, "lab", ("normal", c.name, s.name), s, ("axis", s.name), 24, 6, (-4.0, 4.0), 5,
                              {"strip_spp": 3, "tau": 0.2}) for c, s in pairs]
    assert log["warm"] == ["int-bench", "int-pendant"] * 2
    # the colour map's level is the flash threshold in L_ref units times L_ref (2.0), its ratio the (h, w) image's
    assert log["colour"] == [((3, 5, 3), "mask", 0.5, ("ratio", 3, 5), 0.25)] * 4
    assert log["radiance"] == [("lab", 3.0)] and log["rest"] == ["flash_area"] * 4
    assert log["compromise"] == [([(n, "bench"), (n, "pendant")], ["bench", "pendant"],
                                  [("normal", n, "bench"), ("normal", n, "pendant")], "quality",
                                  [(("mn", n, "bench"), ("ms", n, "bench")), (("mn", n, "pendant"), ("ms", n, "pendant"))])
                                 for n in "AB"]
    # bench lies face-up, pendant is worn upright: no naming scenario, face-up names
    assert log["describe"] == [(("cp", n), None, 1.5) for n in "AB"]
    assert log["workshop"] == [(("cp", "A"), a.mesh, None, True), (("cp", "B"), b.mesh, None, True)]
    assert log["summarize"] == [(a.mesh, "A"), (b.mesh, "B")] and log["record"] == []
    # each scenario's compromise metrics are its own scorer's at the compromise normal
    assert log["metrics"] == [(n, s, ("cp", n)) for n in "AB" for s in ("bench", "pendant")]
    assert [c.name for c in cmp.cuts] == ["A", "B"] and cmp.scenarios == plan.scenarios
    assert (cmp.material, cmp.reference, cmp.quality, cmp.tau, cmp.seed, cmp.budget) == ("lab", 1, "quality", 0.2, 5, {})
    assert cmp.exposures == {"bench": 1.5, "pendant": 1.5}
    assert cmp.render == {"resolution": 24, "spp": 6, "strip_spp": 3, "strip_angles_deg": [-4.0, 4.0], "l_ref": 2.0,
                          "irradiance": 3.0}
    assert 0.008 <= cmp.seconds < 60.0
    for c in cmp.cuts:
        assert c.compromise_description == f"said {('cp', c.name)}" and c.compromise_workshop == {"shop": ("cp", c.name)}
        assert c.summary.name == c.name and c.compromise.normal == ("cp", c.name) and c.cut in plan.cuts
        assert list(c.scenarios) == ["bench", "pendant"]
        for i, s in enumerate(("bench", "pendant")):
            r = c.scenarios[s]
            assert (r.cut, r.scenario) == (c.name, plan.scenarios[i])
            assert r.misorientation == ("mis", c.name, s) and r.tilt.name == ("tilt", ("normal", c.name, s))
            assert r.renders.plan == {"integrator": f"int-{s}"} and r.colour.stats == {"estimator_flash_area": 0.25}
            assert r.compromise_metrics.flash_energy == {"A": {"bench": 0.5, "pendant": 0.25},
                                                         "B": {"bench": 0.25, "pendant": 0.5}}[c.name][s] / 2
            assert r.compromise_relative == 0.5 + i / 4 and 0.002 <= r.seconds < 60.0
    # ranked and normalised over B, the reference: A 2x B on bench, half on pendant
    ra, rb = cmp.cuts
    assert ra.scenarios["bench"].normalised["flash_energy"] == 2.0 and ra.scenarios["pendant"].rank == 2
    assert (ra.overall_score, rb.overall_score) == (1.25, 1.0) and (ra.rank, rb.rank) == (1, 2)


def test_run_comparison_edge_on_rest_and_no_progress(fakes):
    log, state = fakes
    state["rest"], state["parallel"] = NAN, None
    cmp = C.run_comparison(toy_plan(scenarios=("bench", "display")))
    assert all(r.colour.stats == {"estimator_flash_area": None} for c in cmp.cuts for r in c.scenarios.values())
    # both scenarios lie face-up: the first names the sides; nothing parallel to the base
    bench = cmp.scenarios[0]
    assert log["describe"] == [(("cp", n), bench, None) for n in "AB"]
    assert [w[2:] for w in log["workshop"]] == [(bench, False), (bench, False)]


def test_run_comparison_with_a_budget_records_the_run(fakes):
    log, _ = fakes
    choice = SimpleNamespace(predicted_seconds=6.0, correction=2.0, to_dict=lambda: {"quality": "draft", "seconds": 6.0})
    cmp = C.run_comparison(toy_plan(scenarios=("bench",), budget=choice))
    assert log["record"] == [("compare", 3.0, cmp.seconds)] and 0.0 <= cmp.seconds < 60.0
    assert cmp.budget == {"quality": "draft", "seconds": 6.0}
