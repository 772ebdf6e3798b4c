"""Error bars of a recommendation (labcut.orientation.uncertainty).

The bars must cover the distance to a converged answer (a much finer problem of the same
question), and must not be so wide that they say nothing. The pieces are checked against
exact answers: the quadratic peak fit on a known quadratic, the half-direction quality.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

import labcut
from labcut.errors import ParameterError
from labcut.orientation.recommend import Recommendation
from labcut.orientation.question import FlashQuestion
from labcut.orientation.uncertainty import (
    Uncertainty,
    estimate_uncertainty,
    fit_peaks,
    finer_directions,
    stencil,
)
from labcut.scene.quality import Quality


def _angle(a, b) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(np.dot(a, b))))))


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh("meshes/oval-16x12-low.ply")


def test_fit_peaks_finds_the_peak_of_a_quadratic():
    xy = stencil(np.array([0.0, 0.0, 1.0]), 2.0)[1]
    peak = np.array([0.4, -0.3])
    d = xy - peak
    values = 5.0 - 0.7 * d[:, 0] ** 2 - 0.2 * d[:, 0] * d[:, 1] - 1.1 * d[:, 1] ** 2
    peaks, heights = fit_peaks(xy, values[None, :], 2.0)
    assert np.allclose(peaks[0], peak, atol=1e-9)
    assert heights[0] == pytest.approx(5.0, abs=1e-9)
    # a bowl (no maximum) falls back on the best stencil point
    peaks, heights = fit_peaks(xy, -values[None, :], 2.0)
    assert heights[0] == pytest.approx(float((-values).max()))


def test_finer_directions_doubles_every_direction_count_at_a_quarter_of_the_points():
    q = Quality.coerce("standard")
    h = finer_directions(q)
    assert h.surface_points == q.surface_points // 4
    assert (h.lamp_samples, h.env_samples, h.cone_views, h.ring_views) == (26, 128, 26, 40)
    assert h.rock_steps == q.rock_steps and h.map_spacing_deg == q.map_spacing_deg
    assert finer_directions(q.replace(surface_points=1000)).surface_points == 500


def test_a_peak_beyond_the_stencil_is_followed():
    """A discretisation problem whose peak lies 6° from the answer, four stencil radii away: the
    followed peak is found there (a fit held to the first stencil read at most its radius)."""
    from labcut.orientation.uncertainty import follow_peak

    class Bowl:  # the objective exp(-angle² / 2 s²) about ``peak``, as stencil_values reads it
        peak = np.array([math.sin(math.radians(6.0)), 0.0, math.cos(math.radians(6.0))])
        pair_alpha = np.ones(1)
        kappa = 100.0

        def pair_radiance(self, normals, reach):
            a = np.degrees(np.arccos(np.clip(np.abs(normals @ self.peak), 0.0, 1.0)))
            return np.exp(-0.5 * (a / 4.0) ** 2)[None, :]

    found, value = follow_peak(Bowl(), np.array([0.0, 0.0, 1.0]), 1.5, "energy")
    assert _angle(found, Bowl.peak) < 0.1 and value == pytest.approx(1.0, abs=1e-3)


def test_every_recommendation_carries_error_bars_in_its_json_and_repr(oval, tmp_path):
    rec = labcut.recommend_orientation(oval, "blue", scenario="bench", quality="draft")
    u = rec.uncertainty
    assert isinstance(u, Uncertainty)
    assert 0.0 < u.angle_deg < rec.tolerance_deg
    assert 0.0 < u.score_rel < 1.0  # draft's few rocking poses leave the energy 30-40 % low (docs/accuracy.md)
    # the parts add in quadrature
    assert u.angle_deg == pytest.approx(math.sqrt(u.sampling_angle_deg ** 2 + u.discretisation_angle_deg ** 2
                                                  + u.fit_angle_deg ** 2))
    assert f"± {u.angle_deg:.1f}°" in repr(rec)
    data = rec.to_dict()
    assert data["uncertainty"]["angle_deg"] == pytest.approx(u.angle_deg)
    back = Recommendation.load(rec.save(tmp_path / "rec.json"))
    assert back.uncertainty == u
    assert back.angle_error_deg == pytest.approx(u.angle_deg)


@pytest.mark.parametrize("sampling, low, high", [("random", 0.3, 0.8), ("stratified", 0.12, 0.4)])
def test_the_sampling_bar_shrinks_with_more_surface_points(oval, sampling, low, high):
    """Four times the surface samples: the bootstrap spread of the normal about halves for
    independent draws (N^-1/2) and falls to about a quarter for stratified ones (N^-1 on a
    surface: each stratum's error shrinks with its size)."""
    draft = Quality.coerce("draft").replace(surface_sampling=sampling)
    few = labcut.recommend_orientation(oval, setup=FlashQuestion.build("blue", "bench", quality=draft))
    many = labcut.recommend_orientation(oval, setup=FlashQuestion.build(
        "blue", "bench", quality=draft.replace(surface_points=12000)))
    ratio = many.uncertainty.sampling_angle_deg / few.uncertainty.sampling_angle_deg
    assert low < ratio < high


@functools.lru_cache(maxsize=None)
def _converged(scenario: str):
    """A much finer problem of the same question (the bundled oval): 8x draft's surface samples,
    3-4x its directions and poses (computed once per scenario)."""
    q = Quality.coerce("high").replace(surface_points=24000)
    mesh = labcut.load_mesh("meshes/oval-16x12-low.ply")
    return labcut.recommend_orientation(mesh, "blue", scenario=scenario, quality=q, seed=101)


@pytest.mark.parametrize("scenario", ["bench"])
def test_the_bars_cover_the_distance_to_a_converged_answer(oval, scenario):
    """Draft answers of four seeds: each bar covers its distance to the converged normal and score
    (about 95 % coverage each: at most one miss of the eight in the two scenarios would already be
    unusual, so every one must hold); and the bars are not vacuous: within the tolerance. (Every
    scenario, against references kept by the coverage study: tests/test_scenario_coverage.py; the
    still pendant's draft bars, 3.3-4.4° for errors of 1.8-2.2°, exceed its tolerance of 3.2°:
    draft cannot promise it there, docs/accuracy.md.)"""
    ref = _converged(scenario)
    for seed in range(4):
        rec = labcut.recommend_orientation(oval, "blue", scenario=scenario, quality="draft", seed=seed)
        u = rec.uncertainty
        assert _angle(rec.normal, ref.normal) <= u.angle_deg + ref.uncertainty.angle_deg, (seed, u)
        # score_rel is relative to the answer's own score: "energy 0.054 ± 35 %"
        assert abs(ref.score / rec.score - 1.0) <= u.score_rel + ref.uncertainty.score_rel, (seed, u)
        assert u.angle_deg < rec.tolerance_deg


def test_a_bar_too_narrow_would_miss():
    """The coverage test can fail: bars shrunk 10x do not cover the draft answers' distances."""
    mesh = labcut.load_mesh("meshes/oval-16x12-low.ply")
    ref = _converged("bench")
    misses = 0
    for seed in range(4):
        rec = labcut.recommend_orientation(mesh, "blue", scenario="bench", quality="draft", seed=seed)
        small = rec.uncertainty.scaled(0.1)
        misses += _angle(rec.normal, ref.normal) > small.angle_deg
    assert misses >= 2

def test_bad_inputs_are_one_line_errors(oval):
    setup = FlashQuestion.build("blue", "bench", quality="draft")
    from labcut.commands.recommend import planned_scorer as _setup

    scorer, _ = _setup(oval, setup)
    with pytest.raises(ParameterError, match="normal must be"):
        estimate_uncertainty(scorer.problem, [0.0, 0.0, 0.0])
    with pytest.raises(ParameterError, match="replicates"):
        estimate_uncertainty(scorer.problem, [0.0, 0.0, 1.0], replicates=2)
    with pytest.raises(ParameterError, match="uncertainty"):
        Uncertainty.from_dict({"angle_deg": 1.0})


@pytest.mark.parametrize("kernel", [True, False])
@pytest.mark.parametrize("views", [None, "weighted"])
def test_stencil_energy_equals_the_pair_sums(oval, views, kernel, monkeypatch):
    """The discretisation parts' energy at the stencil (stencil_values: the pair sums, from the
    kernel or the numpy path, weighted by pair_alpha) equals the view-weighted pair sums the
    bootstrap uses (objective_values of pair_radiance, every point weighted 1), with views of
    unequal weight too."""
    from labcut.orientation.kernels import KernelOptions
    from labcut.orientation.problem import build_problem
    from labcut.orientation.uncertainty import _point_count, objective_values, pair_radiance, stencil_values
    from labcut.scene import resolve_scene

    lab = labcut.Labradorite.preset("blue")
    if views is None:
        kw = {"settings": resolve_scene("bench", None, None, "draft").settings()}
    else:
        kw = {"lights": labcut.Lights([[0.0, 0.1, 1.0], [0.2, 0.0, 0.98]]),
              "views": labcut.Views([[0.0, 0.0, 1.0], [0.3, 0.0, 0.95], [0.0, -0.4, 0.92]], weights=[0.6, 0.3, 0.1])}
    whole = build_problem(oval, lab, quality="draft", kernels=KernelOptions(pair_sums=kernel), **kw)
    m = np.array([0.02, -0.06, 1.0])
    m /= np.linalg.norm(m)
    normals, _ = stencil(m, 1.5)
    assert (whole._pair_sums is not None) == kernel
    want = objective_values(whole, pair_radiance(whole, normals), np.ones((1, _point_count(whole))), "energy")
    got = stencil_values(whole, normals, "energy")
    assert got.shape == want.shape == (1, len(normals))
    assert np.allclose(got, want, rtol=1e-6, atol=0.0)
    # the thresholded objectives go through the pairs
    area = stencil_values(whole, normals, "area")
    assert np.array_equal(area, objective_values(whole, pair_radiance(whole, normals), np.ones((1, _point_count(whole))), "area"))


@pytest.mark.parametrize("objective", ["energy", "area", "intensity", "balanced"])
def test_the_bootstraps_objective_with_unit_weights_is_the_scorers_metric(oval, objective):
    """objective_values with every surface point weighted 1 is the problem's own estimator: at each
    stencil normal the flash metric Scorer.metrics computes (its own bincounts), with views of
    unequal weight; every point weighted 2 gives the same (a ratio of sums per view)."""
    from labcut.orientation.problem import build_problem
    from labcut.orientation.scoring import Scorer
    from labcut.orientation.uncertainty import _point_count, objective_values

    lab = labcut.Labradorite.preset("blue")
    p = build_problem(oval, lab, quality="draft", lights=labcut.Lights([[0.0, 0.1, 1.0], [0.2, 0.0, 0.98]]),
                      views=labcut.Views([[0.0, 0.0, 1.0], [0.3, 0.0, 0.95], [0.0, -0.4, 0.92]], weights=[0.6, 0.3, 0.1]))
    m = np.array([0.02, -0.06, 1.0])
    m /= np.linalg.norm(m)
    normals, _ = stencil(m, 2.0)
    rad = p.pair_radiance(normals)
    n = _point_count(p)
    got = objective_values(p, rad, np.ones((1, n)), objective)[0]
    scorer = Scorer(p, objective)
    want = np.array([scorer.metrics(k).score(objective) for k in normals])
    assert want.max() > 0
    # the replicates' sums are float32 products (objective_values): ~1e-7 of the value each
    np.testing.assert_allclose(got, want, rtol=2e-6, atol=1e-12)
    np.testing.assert_allclose(objective_values(p, rad, np.full((1, n), 2.0), objective)[0], want, rtol=2e-6, atol=1e-12)


def test_bootstrap_weights_are_drawn_once_per_question_and_read_only():
    """The replicates' Poisson(1) point weights (a row of ones first) are the same stream for every
    recommendation of a question: drawn once, kept read-only, a new seed a new draw."""
    from labcut.orientation.uncertainty import bootstrap_weights

    w = bootstrap_weights(3, 500, 8)
    assert w.shape == (9, 500) and w.dtype == np.float64 and np.all(w[0] == 1.0)
    assert bootstrap_weights(3, 500, 8) is w  # kept
    assert abs(float(w[1:].mean()) - 1.0) < 0.1 and abs(float(w[1:].var()) - 1.0) < 0.15  # Poisson(1)
    assert np.all(w[1:] == np.round(w[1:])) and w.min() >= 0
    assert not np.array_equal(bootstrap_weights(4, 500, 8), w)
    with pytest.raises(ValueError):
        w[1, 0] = 5.0


def _fit_peaks_reference(xy, values, radius_deg):
    """fit_peaks row by row: the Hessian's eigenvalues and a linear solve (the closed form's reference)."""
    x, y = xy[:, 0], xy[:, 1]
    design = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=1)
    coef = np.linalg.lstsq(design, values.T, rcond=None)[0].T
    peaks, heights = np.empty((len(values), 2)), np.empty(len(values))
    for i, c in enumerate(coef):
        hess = np.array([[2 * c[3], c[4]], [c[4], 2 * c[5]]])
        best = int(np.argmax(values[i]))
        p = -np.linalg.solve(hess, c[1:3]) if np.all(np.linalg.eigvalsh(hess) < 0.0) else None
        if p is None or np.hypot(*p) > radius_deg:
            peaks[i], heights[i] = xy[best], values[i, best]
        else:
            peaks[i] = p
            heights[i] = c[0] + c[1] * p[0] + c[2] * p[1] + c[3] * p[0] ** 2 + c[4] * p[0] * p[1] + c[5] * p[1] ** 2
    return peaks, heights


def test_fit_peaks_in_closed_form_equals_the_row_by_row_fit():
    """Concave and saddle-shaped quadratics, peaks inside and beyond the stencil, with noise."""
    from labcut.orientation.uncertainty import fit_peaks

    rng = np.random.default_rng(1)
    _, xy = stencil(np.array([0.0, 0.0, 1.0]), 2.0)
    kinds = {"inside": 0, "fallback": 0}
    for _ in range(200):
        px, py = rng.normal(0.0, 1.5, 2)
        a, c, b = rng.uniform(-1.0, 0.3), rng.uniform(-1.0, 0.3), rng.uniform(-0.5, 0.5)
        v = 1.0 + 0.5 * a * (xy[:, 0] - px) ** 2 + b * (xy[:, 0] - px) * (xy[:, 1] - py) + 0.5 * c * (xy[:, 1] - py) ** 2
        values = v[None, :] + rng.normal(0.0, 1e-3, (5, len(xy)))
        got, got_h = fit_peaks(xy, values, 2.0)
        want, want_h = _fit_peaks_reference(xy, values, 2.0)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got_h, want_h, rtol=1e-12, atol=1e-12)
        on_grid = np.any(np.all(np.isclose(got[:, None, :], xy[None, :, :], atol=1e-12), axis=2), axis=1)
        kinds["fallback"] += int(on_grid.sum())
        kinds["inside"] += int((~on_grid).sum())
    assert kinds["inside"] > 100 and kinds["fallback"] > 100  # both branches exercised


@pytest.mark.parametrize("objective", ["energy", "balanced"])
def test_the_replicates_in_groups_of_views_equal_all_views_at_once(oval, objective, monkeypatch):
    """objective_values lays the pairs out by (point, view) a group of views at a time when all of
    them would take more than VALUES_BLOCK_BYTES: the same values, views of unequal weight and
    pairs not sorted by view."""
    from labcut.orientation import uncertainty as unc
    from labcut.orientation.problem import build_problem

    lab = labcut.Labradorite.preset("blue")
    p = build_problem(oval, lab, quality="draft", lights=labcut.Lights([[0.0, 0.1, 1.0], [0.2, 0.0, 0.98]]),
                      views=labcut.Views([[0.0, 0.0, 1.0], [0.3, 0.0, 0.95], [0.0, -0.4, 0.92], [-0.2, 0.2, 0.96]],
                                         weights=[0.4, 0.3, 0.1, 0.2]))
    assert np.any(np.diff(p.pair_view) < 0)  # pairs by point, then view
    m = np.array([0.02, -0.06, 1.0])
    m /= np.linalg.norm(m)
    normals, _ = stencil(m, 2.0)
    rad = p.pair_radiance(normals)
    weights = unc.bootstrap_weights(0, unc._point_count(p), 8)
    whole = unc.objective_values(p, rad, weights, objective)
    cols = normals.shape[0] * (1 if objective == "energy" else 3) + 1
    monkeypatch.setattr(unc, "VALUES_BLOCK_BYTES", 4 * weights.shape[1] * cols * 2)  # two views a group
    grouped = unc.objective_values(p, rad, weights, objective)
    np.testing.assert_allclose(grouped, whole, rtol=3e-6, atol=0)  # float32 products of other shapes round apart
    monkeypatch.setattr(unc, "VALUES_BLOCK_BYTES", 1)  # one view a group
    np.testing.assert_allclose(unc.objective_values(p, rad, weights, objective), whole, rtol=3e-6, atol=0)
