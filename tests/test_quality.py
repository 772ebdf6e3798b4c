"""One Quality: the presets, validation once, and that every layer reads it."""

from __future__ import annotations

import pytest

import labcut
from labcut.errors import ParameterError
from labcut.scene.quality import QUALITIES, Quality


def test_presets_by_name_and_ordered():
    qs = [Quality.coerce(n) for n in QUALITIES]
    assert [q.name for q in qs] == ["draft", "standard", "high"]
    assert Quality.coerce(" High ") is Quality.PRESETS["high"]
    # more accurate presets cost more on every knob
    for a, b in zip(qs, qs[1:]):
        assert a.surface_points < b.surface_points and a.lamp_samples < b.lamp_samples
        assert a.map_spacing_deg > b.map_spacing_deg and a.nlopt_evals < b.nlopt_evals
    assert labcut.Quality is Quality


def test_coerce_round_trips_and_validates():
    q = Quality.coerce("standard").replace(surface_points=20000, map_spacing_deg=2.0)
    assert q.name == "custom" and q.surface_points == 20000
    assert Quality.coerce(q) is q
    assert Quality.coerce(q.to_dict()) == q
    for bad in ("ultra", 3, None):
        with pytest.raises(ParameterError, match="quality"):
            Quality.coerce(bad)
    for field, value in (("surface_points", 0), ("surface_points", 1.5), ("map_spacing_deg", float("nan")),
                         ("lamp_samples", True), ("rock_steps", (1,)), ("strip_angles_deg", ())):
        with pytest.raises(ParameterError, match=field):
            Quality.coerce("draft").replace(**{field: value})
    with pytest.raises(ParameterError, match="unknown"):
        Quality.coerce({"surface_pts": 3})


def test_the_fields_reach_every_layer():
    """Scene direction counts, rocking poses, the problem's samples and the report's renders all
    follow the Quality given (a custom one too)."""
    from labcut.reports.compare import plan_comparison
    from labcut.scene import Scenario

    q = Quality.coerce("draft").replace(lamp_samples=3, ring_views=5, rock_steps=(3, 2), render_resolution=40,
                                        render_spp=2, strip_angles_deg=(0.0, 5.0))
    bench = Scenario.preset("bench", q)
    assert len(bench.lights) == 3 and bench.quality is q
    assert len(bench.poses()) == 1 + 2 + 2  # rest, rocking 3 (0 dropped), swaying 2
    assert len(Scenario.preset("ring", q).views) == 5
    plan = plan_comparison(["cab:oval,16x12,low"], scenarios=["bench"], quality=q)
    assert (plan.resolution, plan.spp, plan.strip_angles) == (40, 2, (0.0, 5.0))


def test_problem_samples_follow_the_quality():
    from labcut.orientation.problem import build_problem

    mesh = labcut.cabochon(outline="oval", length=16, width=12, dome="low")
    scene = labcut.Scenario.preset("bench", "draft")
    p = build_problem(mesh, labcut.Labradorite(), quality=Quality.coerce("draft").replace(surface_points=500),
                      settings=scene.settings())
    assert p.n_points == 500
    with pytest.raises(ParameterError, match="quality"):
        build_problem(mesh, labcut.Labradorite(), quality="fine", settings=scene.settings())


def test_the_render_estimators_settings_are_the_qualitys():
    """One quality table: the render estimator reads the quality's ``estimator_*`` fields (the
    values the estimator was tuned with), for a preset and for a custom quality alike."""
    from labcut.orientation.estimators import RenderEstimator
    from labcut.orientation.question import FlashQuestion
    from labcut.orientation.render_estimator import RenderQuality

    assert RenderQuality.of("draft") == RenderQuality(48, 4, 15, 20.0)
    assert RenderQuality.of("standard") == RenderQuality(96, 8, 25, 15.0)
    assert RenderQuality.of("high") == RenderQuality(160, 16, 40, 10.0)
    custom = Quality.coerce("draft").replace(estimator_resolution=24, estimator_spp=2, estimator_iterations=3)
    assert RenderQuality.of(custom) == RenderQuality(24, 2, 3, 20.0)
    assert RenderQuality.of(custom.to_dict()) == RenderQuality.of(custom)
    ask = FlashQuestion.build(None, "bench", None, None, quality=custom, estimator="render")
    mesh = labcut.cabochon(outline="oval", length=16, width=12, dome="low")
    objective = RenderEstimator(mesh, ask).render_objective()
    assert (objective.resolution, objective.spp) == (24, 2)
    with pytest.raises(ParameterError, match="estimator_coarse_deg"):
        Quality.coerce("draft").replace(estimator_coarse_deg=0.5)
