"""Designers work in notebooks: the example tour runs cell by cell as a notebook would, and
labcut's results display as a short repr and a small HTML table; a saved recommendation reads
back as the same answer."""

from __future__ import annotations

import ast
import json
import os
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
TOUR = ROOT / "examples" / "notebook_tour.py"


def _cells(path: Path) -> list[str]:
    """Code cells of a jupytext percent-format script (markdown cells skipped)."""
    cells, current, markdown = [], [], False
    for line in path.read_text().splitlines():
        if line.startswith("# %%"):
            if current and not markdown:
                cells.append("\n".join(current))
            current, markdown = [], "[markdown]" in line
            continue
        current.append(line)
    if current and not markdown:
        cells.append("\n".join(current))
    return [c for c in cells if c.strip()]


def _run_cell(source: str, namespace: dict) -> object:
    """Execute a cell; return the value of its last expression (what Jupyter displays), else None."""
    tree = ast.parse(source)
    last = tree.body[-1] if tree.body and isinstance(tree.body[-1], ast.Expr) else None
    if last is not None:
        tree.body = tree.body[:-1]
    exec(compile(tree, "<cell>", "exec"), namespace)  # noqa: S102 (our own example)
    return eval(compile(ast.Expression(last.value), "<cell>", "eval"), namespace) if last is not None else None  # noqa: S307


@pytest.fixture(scope="module")
def tour():
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        namespace: dict = {"__name__": "notebook"}
        shown = [_run_cell(cell, namespace) for cell in _cells(TOUR)]
    finally:
        os.chdir(cwd)
    return namespace, shown


def test_tour_runs_and_displays_short_reprs(tour):
    namespace, shown = tour
    from labcut import Recommendation
    from labcut.orientation.scoring import FlashMetrics

    kinds = [type(x).__name__ for x in shown if x is not None]
    assert kinds.count("Recommendation") == 2 and kinds.count("FlashMetrics") == 2, kinds
    for value in shown:
        if isinstance(value, (Recommendation, FlashMetrics)):
            text = repr(value)
            assert len(text) < 160 and "\n" not in text, text
            html = value._repr_html_()
            assert html.startswith("<table>") and html.endswith("</table>") and "<tr>" in html
    rec = namespace["rec"]
    assert f"tilt={rec.tilt_deg:.1f}°" in repr(rec) and f"±{rec.tolerance_deg:.1f}°" in repr(rec)
    assert "bench" in repr(rec) and "bench" in rec._repr_html_()
    assert f"{rec.metrics.flash_area:.1%}" in rec._repr_html_()


def test_plan_render_and_comparison_display_in_a_notebook(tour):
    namespace, shown = tour
    from labcut import Comparison, EffectPlan, RenderResult

    kinds = [type(x).__name__ for x in shown if x is not None]
    assert {"EffectPlan", "RenderResult", "Comparison"} <= set(kinds), kinds
    plan = next(x for x in shown if isinstance(x, EffectPlan))
    assert repr(plan).startswith("EffectPlan(recommend") and "<table>" in plan._repr_html_()
    picture = next(x for x in shown if isinstance(x, RenderResult))
    text = repr(picture)
    assert "64x64 px" in text and "4 spp" in text and "\n" not in text and len(text) < 160
    png = picture._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    from io import BytesIO

    from PIL import Image

    img = np.asarray(Image.open(BytesIO(png)))
    assert img.shape == (64, 64, 3) and img.max() > 0  # the stone, not a black square
    cmp = next(x for x in shown if isinstance(x, Comparison))
    text = repr(cmp)
    assert text.startswith("Comparison(2 cuts x 1 scenarios (bench)") and "\n" not in text
    html = cmp._repr_html_()
    assert html.startswith("<table>") and html.count("<tr>") == 3 and "100%" in html  # the reference against itself


def test_saved_recommendation_reads_back(tour, tmp_path):
    namespace, _ = tour
    rec, again = namespace["rec"], namespace["again"]
    assert np.allclose(again.normal, rec.normal, atol=0.0) and again.score == rec.score
    assert again.metrics == rec.metrics and again.tolerance_deg == rec.tolerance_deg
    assert again.scenario is not None and again.scenario.name == rec.scenario.name
    assert np.allclose(again.map_normals, rec.map_normals, atol=1e-12)
    assert np.array_equal(again.map_scores, rec.map_scores)
    assert again.description == rec.description
    # a second round trip is exact
    path = again.save(tmp_path / "again.json")
    assert json.loads(path.read_text()) == json.loads(json.dumps(again.to_dict()))


def test_load_rejects_what_is_not_a_recommendation(tmp_path):
    from labcut import Recommendation
    from labcut.errors import ParameterError

    with pytest.raises(ParameterError, match="does not exist"):
        Recommendation.load(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ParameterError, match="not readable JSON"):
        Recommendation.load(bad)
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"normal": [0, 0, 1]}))
    with pytest.raises(ParameterError, match="not a labcut recommendation .missing"):
        Recommendation.load(other)
    wrong = tmp_path / "wrong.json"
    wrong.write_text(json.dumps([1, 2, 3]))
    with pytest.raises(ParameterError, match="expected a JSON object"):
        Recommendation.load(wrong)


def test_changed_preset_scenario_is_not_claimed(tour, tmp_path):
    """A saved answer whose scenario was a preset with other lights is not given the preset back."""
    from labcut import Recommendation

    data = json.loads(json.dumps(tour[0]["rec"].to_dict()))
    data["settings"]["scenario"]["lighting"] = "ceiling"
    assert Recommendation.from_dict(data).scenario is None
