"""Honest rankings and sizes that matter (issue 34, points 4 and 7).

Cuts whose scores lie within their error bars share a rank (a tie) in the table, the JSON and the
report; where no cut flashes, no winner is named; flash areas come in mm² beside the shares,
which are scale-free; ``compare`` takes a size per design (``SRB.asc@8``).
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import labcut
from labcut.errors import ParameterError
from labcut.reports.compare import competition_ranks, differ, overall_score, shared
from labcut.reports.cuts import split_size


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


ROOT = Path(__file__).resolve().parents[1]
SRB = ROOT / "meshes" / "designs" / "SRB.asc"
TINY = dict(quality="draft", resolution=24, spp=1)


# ----------------------------------------------------------------------------- the rule, by hand
def test_values_within_their_combined_error_bars_share_a_rank():
    # 1.0 ± 0.1 and 0.9 ± 0.05: apart by 0.1 < hypot(0.1, 0.05) = 0.112: tied
    assert competition_ranks([1.0, 0.9], [0.1, 0.05]) == [1, 1]
    # 1.0 ± 0.05 and 0.9 ± 0.05: 0.1 > 0.0707: told apart
    assert competition_ranks([1.0, 0.9], [0.05, 0.05]) == [1, 2]
    # at the bar exactly: not beyond it, a tie
    assert not differ(1.0, 0.3, 0.5, 0.4) and differ(1.0, 0.3, 0.5 - 1e-9, 0.4)
    # without bars: equal values tie, others do not ("1, 2, 2, 4")
    assert competition_ranks([3.0, 2.0, 2.0, 1.0]) == [1, 2, 2, 4]
    # a middle value tied with both neighbours, which differ from each other
    assert competition_ranks([1.0, 0.9, 0.8], [0.075, 0.075, 0.075]) == [1, 1, 2]
    assert shared([1, 1, 2]) == [True, True, False] and shared([1, 2, 3]) == [False, False, False]


def test_the_overall_error_bar_is_the_mean_of_the_ratios_bars_in_quadrature():
    bars = [SimpleNamespace(score_rel=0.1), SimpleNamespace(score_rel=0.2), None]
    score, err = overall_score([1.0, 0.5, None], bars)
    assert score == pytest.approx(0.75)
    assert err == pytest.approx(math.hypot(1.0 * 0.1, 0.5 * 0.2) / 2)
    assert overall_score([None, None], bars[:2]) == (0.0, 0.0)


# ----------------------------------------------------------------------------- a design at two sizes
def test_a_design_takes_its_own_size():
    assert split_size(f"{SRB}@8") == (SRB, 8.0)
    assert split_size(f"{SRB}@12.5mm") == (SRB, 12.5)
    assert split_size(SRB) == (SRB, None)
    for bad, words in ((f"{SRB}@big", "girdle width in mm"), (f"{SRB}@-3", "positive"), (f"{SRB}@nan", "positive"),
                       (f"{ROOT / 'meshes' / 'oval-16x12-low.ply'}@8", "keeps its own size")):
        with pytest.raises(ParameterError, match=words):
            split_size(bad)


@pytest.fixture(scope="module")
def two_sizes():
    return labcut.compare_cuts([f"{SRB}@8", f"{SRB}@12"], **TINY)


def test_one_design_at_two_sizes_ties_on_every_share_and_differs_in_mm2(two_sizes):
    small, big = (two_sizes.result(i, "bench") for i in (0, 1))
    assert [c.name for c in two_sizes.cuts] == ["SRB.asc@8", "SRB.asc@12"]
    assert big.cut == "SRB.asc@12" and two_sizes.cuts[1].summary.weight_ct == pytest.approx(
        two_sizes.cuts[0].summary.weight_ct * 1.5 ** 3, rel=1e-6)
    m_small, m_big = small.recommendation.metrics, big.recommendation.metrics
    assert m_big.flash_area == pytest.approx(m_small.flash_area, rel=1e-6)  # geometric optics: scale-free
    assert m_big.flash_area_mm2 == pytest.approx(m_small.flash_area_mm2 * 1.5 ** 2, rel=1e-6)
    assert m_big.visible_area_mm2 == pytest.approx(m_small.visible_area_mm2 * 1.5 ** 2, rel=1e-6)
    assert [c.rank for c in two_sizes.cuts] == [1, 1] and all(c.tied for c in two_sizes.cuts)
    assert "tie for the most flash" in two_sizes.verdict
    data = two_sizes.to_dict()
    assert [c["tied"] for c in data["cuts"]] == [True, True] and data["cuts"][0]["overall_score_error"] > 0
    assert data["cuts"][1]["source"]["design"]["girdle_width_mm"] == 12.0
    assert "error_bars" in data["metric_definitions"]


def test_the_report_shows_ties_and_error_bars(two_sizes, tmp_path):
    from labcut.reports.html import render_html

    text = render_html(two_sizes)
    assert text.count('<td class="num">=1</td>') >= 4  # summary and scenario tables
    assert "tie for the most flash" in text and "Every ± is an error bar" in text


# ----------------------------------------------------------------------------- the flash area in mm²
def test_the_flash_area_in_mm2_is_the_share_of_the_visible_area():
    oval = labcut.cabochon("oval", 16, 12, dome="low")
    big = labcut.cabochon("oval", 32, 24, dome="low")
    m = labcut.evaluate_orientation(oval, (0, 0, 1), quality="draft", lighting="spot", viewing="face-up")
    m2 = labcut.evaluate_orientation(big, (0, 0, 1), quality="draft", lighting="spot", viewing="face-up")
    # one view straight down: the visible area is the outline's, pi x 8 x 6 mm² (sampled)
    assert m.visible_area_mm2 == pytest.approx(math.pi * 8 * 6, rel=0.02)
    # a view-weighted mean of share x area: close to the mean share x the mean area (views alike)
    assert m.flash_area_mm2 == pytest.approx(m.flash_area * m.visible_area_mm2, rel=0.05) and m.flash_area_mm2 > 0
    assert m2.flash_area == pytest.approx(m.flash_area, abs=1e-9) and m2.flash_area_mm2 == pytest.approx(4 * m.flash_area_mm2)


# ----------------------------------------------------------------------------- no flash: no winner
#: lit only from behind and below the stone's horizon, seen from in front just above it: the light reaches
#: the back of the dome, which the viewers see at grazing, so no cut flashes at any orientation (under
#: the ring's even ceiling, by the scene's own threshold, they do: test_radiance.py, test_scenarios_flash.py)
BACKLIT = {"name": "backlit", "lighting": {"directions": [[0.0, 0.998, -0.06]]},
           "viewing": {"directions": [[0.0, -0.99, 0.14]]}}


@pytest.fixture(scope="module")
def backlit_json(tmp_path_factory):
    import json

    path = tmp_path_factory.mktemp("scenario") / "backlit.json"
    path.write_text(json.dumps(BACKLIT))
    return path


@pytest.fixture(scope="module")
def dark(backlit_json):
    return labcut.compare_cuts(["cab:oval,16x12,low,res=48", "cab:oval,16x12,high,res=48"], scenarios=[str(backlit_json)],
                               **TINY)


def test_where_no_cut_flashes_no_winner_is_named(dark):
    assert not dark.flashes("backlit")
    assert all(c.scenarios["backlit"].recommendation.metrics.flash_area == 0.0 for c in dark.cuts)
    assert dark.verdict.startswith("No cut shows flash under backlit")
    assert "best achievable" in dark.verdict and "try a directed light" in dark.verdict
    assert "flashes most" not in dark.verdict
    assert dark.scenario_verdict("backlit").startswith("under backlit no cut shows flash")
    data = dark.to_dict()
    assert data["scenario_verdicts"]["backlit"]["any_flash"] is False


def test_the_cli_says_no_cut_flashes(cli, backlit_json):
    proc = cli("compare", "cab:oval,16x12,low,res=48", "cab:oval,16x12,high,res=48", "--scenario", str(backlit_json),
               "--quality", "draft", "--resolution", "24", "--spp", "1")
    assert proc.returncode == 0, proc.stderr
    text = " ".join(proc.stdout.split())
    assert "No cut shows flash under backlit" in text and "flashes most" not in text


def test_the_table_keeps_long_cut_names_whole_at_80_columns(cli):
    names = ["cab:oval,16x12,low,res=48", "cab:oval,16x12,medium,res=48"]
    proc = cli("compare", *names, "--quality", "draft", "--resolution", "24", "--spp", "1", columns=80)
    assert proc.returncode == 0, proc.stderr
    assert "…" not in proc.stdout and all(len(line) <= 80 for line in proc.stdout.splitlines())
    table = proc.stdout[proc.stdout.index("Scenario bench"):].splitlines()
    cells: list[str] = []  # the cut column's text, row by row (a row goes on while its # cell is empty)
    for line in table:
        fields = line.split("│")
        if len(fields) > 3 and not line.startswith(("┏", "┡", "└")):
            if fields[1].strip():
                cells.append("")
            if cells:
                cells[-1] += fields[2].strip()
    assert cells == names  # folded, never cut


def test_the_csv_gives_the_areas_in_mm2(two_sizes):
    rows = [r for r in two_sizes.rows() if r["quantity"] in ("flash_area_mm2", "visible_area_mm2")]
    assert rows and all(r["unit"] == "mm2" for r in rows)


def test_each_scenario_of_the_report_names_plus_y_as_it_wears_the_stone():
    from labcut.reports.html import context

    cmp = labcut.compare_cuts(["cab:oval,16x12,low,res=48"], scenarios=["bench", "pendant"], **TINY)
    plus_y = {s["name"]: s["plus_y"] for s in context(cmp)["scenarios"]}
    assert plus_y == {"bench": "its back", "pendant": "its top, the bail end, as this scenario wears it upright"}


def test_the_report_gives_the_flash_area_in_mm2(two_sizes):
    from labcut.reports.html import render_html

    text = render_html(two_sizes)
    for i in (0, 1):
        assert f"{two_sizes.result(i, 'bench').recommendation.metrics.flash_area_mm2:.3g} mm²" in text
