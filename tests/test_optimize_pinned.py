"""labcut.orientation.optimize pinned on stand-in scorers whose optima are known by hand (issue 37).

A stand-in scorer is a sum of axial von Mises lobes ``w exp(k (|n.p| - 1))`` over the lamella
normal ``n``: its peaks, their scores and the angle where a lobe falls to 90 % of its peak
(``acos(1 + ln 0.9 / k)``) are known in closed form, so the optimisers, the map, the polish, the
tolerance rings and the runners-up are checked against numbers worked out here, without a flash
problem. Fast: no Dr.Jit kernel, no mesh.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from labcut.backend import Launched
from labcut.errors import ParameterError
from labcut.orientation import optimize as op
from labcut.orientation.scoring import normal_to_stereo, stereo_to_normal
from lobes import Lobes, angle_deg, ninety_percent_deg, tilted, unit


# ---------------------------------------------------------------------- Constraint
def test_the_disc_radius_is_the_half_angles_tangent():
    assert op.Constraint().radius == pytest.approx(1.0, abs=1e-15)
    assert op.Constraint(60.0).radius == pytest.approx(math.tan(math.radians(30.0)), rel=1e-15)
    assert op.Constraint(20.0).radius == pytest.approx(math.tan(math.radians(10.0)), rel=1e-15)


@pytest.mark.parametrize("bad", [0.0, -5.0, 90.0001, float("nan"), float("inf"), "45"])
def test_a_tilt_limit_outside_0_90_is_refused(bad):
    with pytest.raises(ParameterError) as err:
        op.Constraint(bad)
    assert str(err.value) == f"max_tilt must lie in (0, 90] degrees, got {bad!r}" and err.value.parameter == "max_tilt"


def test_the_tilt_limits_edges():
    assert op.Constraint(90.0).max_tilt_deg == 90.0 and op.Constraint(1e-6).max_tilt_deg == 1e-6


@pytest.mark.parametrize("axis, message", [
    ((1.0, 0.0), "tilt axis must be three finite numbers"),
    ((1.0, float("nan"), 0.0), "tilt axis must be three finite numbers"),
    ((0.0, 0.0, 0.0), "tilt axis must not be the zero vector"),
    ((0.0, 0.0, 2.0), "tilt axis must be horizontal (it may not be the face-up axis)"),
])
def test_a_bad_tilt_axis_is_refused_in_words(axis, message):
    with pytest.raises(ParameterError) as err:
        op.Constraint(30.0, axis)
    assert str(err.value) == message and err.value.parameter == "tilt axis"


def test_a_tilt_axis_is_made_horizontal_and_unit():
    c = op.Constraint(30.0, (3.0, 4.0, 7.0))
    assert c.tilt_axis == pytest.approx((0.6, 0.8, 0.0), abs=1e-15) and type(c.tilt_axis) is tuple


def test_clamp_keeps_points_inside_and_pulls_outside_ones_onto_the_edge():
    c = op.Constraint(60.0)
    r = c.radius
    assert c.clamp(0.1, -0.2) == (0.1, -0.2)
    assert c.clamp(r, 0.0) == (r, 0.0)  # on the edge: kept
    u, v = c.clamp(3.0, 4.0)
    assert (u, v) == pytest.approx((0.6 * r, 0.8 * r), rel=1e-15)


def test_axis_normal_is_plus_z_turned_about_the_axis():
    c = op.Constraint(90.0, (1.0, 0.0, 0.0))
    assert c.axis_normal(0.0) == pytest.approx([0, 0, 1], abs=1e-15)
    assert c.axis_normal(90.0) == pytest.approx([0, -1, 0], abs=1e-15)  # right-handed about +X
    assert c.axis_normal(-30.0) == pytest.approx([0, 0.5, math.cos(math.radians(30))], abs=1e-15)
    c = op.Constraint(90.0, (0.0, 1.0, 0.0))
    assert c.axis_normal(30.0) == pytest.approx([0.5, 0, math.cos(math.radians(30))], abs=1e-15)


def test_allowed_is_within_the_tilt_limit_edge_included():
    c = op.Constraint(60.0)
    n = np.array([tilted(59.9), tilted(60.0), tilted(60.1), [0, 0, 1.0]])
    assert c.allowed(n).tolist() == [True, True, False, True]


# ---------------------------------------------------------------------- the map's grid
def test_the_hemisphere_grid_is_a_fibonacci_spiral_of_the_caps_area_over_the_spacing_squared():
    g = op.hemisphere_grid(10.0, op.Constraint(90.0))
    n = math.ceil(2 * math.pi / math.radians(10.0) ** 2)  # 207
    assert len(g) == n == 207
    i = np.arange(n) + 0.5
    assert g[:, 2] == pytest.approx(1.0 - i / n, abs=1e-15)
    assert np.linalg.norm(g, axis=1) == pytest.approx(np.ones(n), abs=1e-15)
    phi = np.arctan2(g[:, 1], g[:, 0])
    golden = (i * math.pi * (3.0 - math.sqrt(5.0)) + math.pi) % (2 * math.pi) - math.pi
    assert phi[1:] == pytest.approx(golden[1:], abs=1e-9)


def test_a_small_cap_has_at_least_eight_points_and_all_inside():
    c = op.Constraint(5.0)
    g = op.hemisphere_grid(10.0, c)
    assert len(g) == 8 and c.allowed(g).all()
    cap = 1.0 - math.cos(math.radians(5.0))
    assert g[:, 2].min() == pytest.approx(1.0 - cap * 7.5 / 8, abs=1e-15)
    g = op.hemisphere_grid(3.0, op.Constraint(40.0))
    assert len(g) == math.ceil(2 * math.pi * (1 - math.cos(math.radians(40))) / math.radians(3.0) ** 2)


def test_the_grid_about_a_fixed_axis_is_a_row_of_angles_edges_included():
    c = op.Constraint(30.0, (1.0, 0.0, 0.0))
    g = op.hemisphere_grid(10.0, c)
    assert len(g) == 7
    assert g == pytest.approx(np.array([c.axis_normal(a) for a in (-30, -20, -10, 0, 10, 20, 30)]), abs=1e-15)


# ---------------------------------------------------------------------- score_map
def test_the_energy_map_is_the_scorers_energy():
    s = Lobes([tilted(10.0)], [50.0])
    g = op.hemisphere_grid(20.0, op.Constraint(60.0))
    assert op.score_map(s, g) == pytest.approx(s._f(g), rel=1e-15)


def test_other_objectives_score_only_where_the_energy_reaches_two_percent_of_its_best():
    class Split(Lobes):  # energy from one lobe, the objective's score from a flat 7
        def score(self, normal):
            return 7.0

    s = Split([[0, 0, 1.0]], [10.0], objective="area")
    g = np.array([tilted(a) for a in (0.0, 30.0, 60.0, 80.0)])
    e = s._f(g)  # exp(10 (cos a - 1)): 1, 0.2618, 0.0067, 0.0002
    out = op.score_map(s, g)
    assert out.tolist() == [7.0 if x >= 0.02 * e.max() else 0.0 for x in e] == [7.0, 7.0, 0.0, 0.0]
    # exactly at 2 % of the best: scored
    s2 = Split([[0, 0, 1.0]], [10.0], objective="area")
    s2.energy_map = lambda normals: np.array([1.0, 0.02, 0.0199])
    assert op.score_map(s2, g[:3]).tolist() == [7.0, 7.0, 0.0]
    # no energy anywhere: every normal scored
    s2.energy_map = lambda normals: np.zeros(len(normals))
    assert op.score_map(s2, g[:3]).tolist() == [7.0, 7.0, 7.0]


# ---------------------------------------------------------------------- polish and the grid optimiser
def test_polish_finds_the_peak_on_its_grid():
    p = tilted(12.3, 40.0)
    s = Lobes([p], [400.0])
    n, v = op.polish_grid(s, tilted(11.0, 38.0), op.Constraint(), 3.0, 0.1)
    assert angle_deg(n, p) < 0.1 and v == pytest.approx(s._f(n)[0])
    # a step of 1 deg: the best of a coarse grid, not the peak
    n1, _ = op.polish_grid(s, tilted(11.0, 38.0), op.Constraint(), 3.0, 1.0)
    assert 0.05 < angle_deg(n1, p) < 1.0


def test_polish_pulls_candidates_onto_the_constraints_edge():
    s = Lobes([tilted(40.0)], [100.0])  # beyond a 30 deg limit
    n, _ = op.polish_grid(s, tilted(29.0), op.Constraint(30.0), 3.0, 0.1)
    assert angle_deg(n, [0, 0, 1]) == pytest.approx(30.0, abs=1e-9) and angle_deg(n, tilted(30.0)) < 0.1


def test_polish_about_a_fixed_axis_runs_along_its_angles():
    c = op.Constraint(45.0, (1.0, 0.0, 0.0))
    p = c.axis_normal(17.3)
    s = Lobes([p], [300.0])
    n, v = op.polish_grid(s, c.axis_normal(15.0), c, 4.0, 0.1)
    assert angle_deg(n, p) < 0.06
    # the segment is clipped at the tilt limit
    c = op.Constraint(20.0, (1.0, 0.0, 0.0))
    s = Lobes([op.Constraint(90.0, (1.0, 0.0, 0.0)).axis_normal(25.0)], [300.0])
    n, _ = op.polish_grid(s, c.axis_normal(19.0), c, 4.0, 0.1)
    assert n == pytest.approx(c.axis_normal(20.0), abs=1e-12)


def test_the_grid_optimiser_finds_the_best_of_three_polished_cells():
    p_small, p_big = tilted(30.0, 200.0), tilted(22.0, 20.0)
    s = Lobes([p_small, p_big], [300.0, 300.0], [0.9, 1.0])
    r = op.optimize_grid(s, op.Constraint(60.0), coarse_deg=4.0, fine_deg=0.1)
    assert r.method == "grid" and angle_deg(r.normal, p_big) < 0.1 and r.score == pytest.approx(1.0, abs=2e-3)
    assert r.evaluations == s.evaluations > 0


def test_run_optimizer_gives_each_optimiser_its_budget_from_the_quality(monkeypatch):
    seen = {}
    monkeypatch.setattr(op, "optimize_grid", lambda scorer, c, coarse_deg: seen.setdefault("grid", (scorer, c, coarse_deg)))
    monkeypatch.setattr(op, "optimize_nlopt", lambda scorer, c, global_evals, seed_map: seen.setdefault("nlopt", (scorer, c, global_evals, seed_map)))
    monkeypatch.setattr(op, "optimize_gradient", lambda scorer, c, starts: seen.setdefault("gradient", (scorer, c, starts)))
    from labcut.scene.quality import Quality

    q = Quality.coerce("draft")
    op.run_optimizer("grid", "S", "C", "draft")
    op.run_optimizer("nlopt", "S", "C", "draft", seed_map="seeds")
    op.run_optimizer("gradient", "S", "C", "draft")
    assert seen == {"grid": ("S", "C", q.grid_coarse_deg), "nlopt": ("S", "C", q.nlopt_evals, "seeds"),
                    "gradient": ("S", "C", q.gradient_starts)}
    seen.clear()
    op.run_optimizer("gradient", "S", "C")  # the standard budget by default
    assert seen == {"gradient": ("S", "C", Quality.coerce("standard").gradient_starts)}
    with pytest.raises(ParameterError) as err:
        op.run_optimizer("adam", None, None)
    assert str(err.value) == "optimizer must be one of nlopt, gradient, grid, got 'adam'"


# ---------------------------------------------------------------------- NLopt and gradient ascent
def test_nlopt_finds_a_narrow_peak_beside_a_wide_hill():
    p = tilted(33.0, 123.0)
    s = Lobes([p, tilted(10.0, 300.0)], [300.0, 20.0], [1.0, 0.3])  # a 5 deg lobe beside a wide hill
    r = op.optimize_nlopt(s, op.Constraint(), global_evals=60)
    assert r.method == "nlopt" and angle_deg(r.normal, p) < 0.05 and r.score == pytest.approx(s._f(p)[0], rel=1e-4)
    assert r.evaluations == s.evaluations


def test_nlopt_reads_the_seed_map_it_is_given():
    p = tilted(33.0, 123.0)
    s = Lobes([p, tilted(10.0, 300.0)], [300.0, 20.0], [1.0, 0.3])
    blind = np.array([tilted(10.0, 300.0), tilted(50.0, 0.0)])
    # a map whose best cell is the wide hill: the narrow peak is found only if DIRECT lands near it
    r = op.optimize_nlopt(s, op.Constraint(), global_evals=20, seed_map=(blind, Launched.ready(np.array([1.0, 0.5]))))
    r_own = op.optimize_nlopt(Lobes([p, tilted(10.0, 300.0)], [300.0, 20.0], [1.0, 0.3]), op.Constraint(), global_evals=20)
    assert angle_deg(r_own.normal, p) < 0.05  # its own 6 deg map's best cells seed the polish there
    assert angle_deg(r.normal, p) > 5.0       # the given map's cells seed it elsewhere
    # a plain array works as well as a launched one
    r2 = op.optimize_nlopt(s, op.Constraint(), global_evals=20, seed_map=(np.array([p]), np.array([1.0])))
    assert angle_deg(r2.normal, p) < 0.05


def test_nlopt_about_a_fixed_axis():
    c = op.Constraint(40.0, (0.0, 1.0, 0.0))
    p = c.axis_normal(-23.4)
    s = Lobes([p], [500.0])
    r = op.optimize_nlopt(s, c, global_evals=200)
    assert angle_deg(r.normal, p) < 0.05 and r.method == "nlopt"


def test_nlopt_keeps_to_the_tilt_limit():
    s = Lobes([tilted(50.0, 70.0)], [200.0])
    r = op.optimize_nlopt(s, op.Constraint(30.0), global_evals=100)
    assert angle_deg(r.normal, [0, 0, 1]) == pytest.approx(30.0, abs=1e-6) and angle_deg(r.normal, tilted(30.0, 70.0)) < 0.1


def test_nlopt_default_budget_is_standards():
    from labcut.scene.quality import Quality

    s = Lobes([tilted(5.0)], [50.0])
    op.optimize_nlopt(s, op.Constraint(), global_evals=None)
    # DIRECT-L's evaluations plus a few dozen of the polish: the standard budget, not draft's
    assert s.evaluations >= Quality.coerce("standard").nlopt_evals


@pytest.mark.parametrize("objective", ["energy", "area"])
def test_gradient_ascent_finds_the_peak(objective):
    p = tilted(27.0, 250.0)
    s = Lobes([p], [300.0], objective=objective)
    r = op.optimize_gradient(s, op.Constraint(), starts=6, iterations=60)
    assert r.method == "gradient" and angle_deg(r.normal, p) < 0.05 and r.evaluations == s.evaluations


def test_gradient_ascent_about_a_fixed_axis():
    c = op.Constraint(45.0, (1.0, 0.0, 0.0))
    p = c.axis_normal(12.0)
    s = Lobes([p], [50.0])  # wide enough for its finite-difference steps to settle
    r = op.optimize_gradient(s, c, starts=3, iterations=60)
    assert r.method == "gradient" and angle_deg(r.normal, p) < 0.05 and r.score == pytest.approx(1.0, abs=1e-4)


# ---------------------------------------------------------------------- seeds
def test_best_cells_are_the_best_distinct_positive_cells():
    n = np.array([tilted(0.0), tilted(5.0), tilted(20.0), tilted(40.0), tilted(60.0)])
    v = np.array([5.0, 4.0, 3.0, 0.0, 2.0])
    cells = op._best_cells(n, v, 3)
    assert [angle_deg(c, [0, 0, 1]) for c in cells] == pytest.approx([0.0, 20.0, 60.0])  # 5 deg is within 8
    assert len(op._best_cells(n, v, 2)) == 2
    assert len(op._best_cells(n, v, 3, separation_deg=4.0)) == 3
    assert [angle_deg(c, [0, 0, 1]) for c in op._best_cells(n, v, 3, separation_deg=4.0)] == pytest.approx([0.0, 5.0, 20.0])
    # no cell at or below zero, and the separation is axial (an antipode is the same orientation)
    assert op._best_cells(n, -v, 3) == []
    m = np.array([tilted(10.0), -tilted(10.0) + 1e-3 * np.array([1.0, 0, 0]), tilted(30.0)])
    assert len(op._best_cells(m / np.linalg.norm(m, axis=1, keepdims=True), np.array([3.0, 2.0, 1.0]), 3)) == 2


def test_the_map_seeds_come_from_a_coarse_map_over_the_allowed_region():
    s = Lobes([tilted(20.0, 0.0), tilted(20.0, 180.0)], [100.0, 100.0], [1.0, 0.8])
    seeds = op._map_seeds(s, op.Constraint(60.0), 6.0, 2)
    assert len(seeds) == 2 and angle_deg(seeds[0], tilted(20.0)) < 5.0 and angle_deg(seeds[1], tilted(20.0, 180.0)) < 5.0
    assert s.evaluations == len(op.hemisphere_grid(6.0, op.Constraint(60.0)))


# ---------------------------------------------------------------------- search_best
def test_search_best_makes_the_map_and_polishes_its_best_when_the_optimiser_lands_lower():
    p = tilted(14.0, 77.0)
    s = Lobes([p], [800.0])
    steps = []
    out = op.search_best(s, op.Constraint(), "draft", optimizer="grid", step=steps.append)
    assert steps == ["optimising"]
    assert angle_deg(out.normal, p) < 0.1 and out.normal[2] > 0
    assert out.map_normals == pytest.approx(op.hemisphere_grid(4.0, op.Constraint()))
    assert out.map_scores == pytest.approx(s._f(out.map_normals), rel=1e-12)

    class Poor(Lobes):  # an optimiser result far from the peak: the map's better cell wins, polished
        pass

    s = Poor([p], [800.0])
    orig = op.run_optimizer
    try:
        op.run_optimizer = lambda *a, **k: op.OptimumResult(tilted(60.0), 0.0, 0, "stub")
        out = op.search_best(s, op.Constraint(), "draft")
    finally:
        op.run_optimizer = orig
    assert angle_deg(out.normal, p) < 0.1 and out.score == pytest.approx(s._f(out.normal)[0])


def test_search_best_hands_the_map_to_nlopt_only_where_it_is_twice_as_fine_as_the_seed_map(monkeypatch):
    seen = []
    monkeypatch.setattr(op, "run_optimizer", lambda name, scorer, c, q, seed_map=None: seen.append(seed_map) or
                        op.OptimumResult(np.array([0.0, 0.0, 1.0]), 1.0, 0, name))
    s = Lobes([[0, 0, 1.0]], [100.0])
    op.search_best(s, op.Constraint(), "standard")   # 3 deg <= 6 / 2: handed over
    op.search_best(s, op.Constraint(), "draft")      # 4 deg: not
    op.search_best(s, op.Constraint(60.0, (1.0, 0, 0)), "standard")  # a fixed axis: not
    op.search_best(Lobes([[0, 0, 1.0]], [100.0], objective="area"), op.Constraint(), "standard")  # no launched map
    assert seen[0] is not None and seen[0][0].shape[1] == 3 and seen[1:] == [None, None, None]


def test_search_best_reports_the_normal_on_the_upper_hemisphere(monkeypatch):
    monkeypatch.setattr(op, "run_optimizer", lambda *a, **k: op.OptimumResult(-tilted(10.0), 1.0, 0, "stub"))
    s = Lobes([tilted(10.0)], [100.0])
    out = op.search_best(s, op.Constraint(), "draft")
    assert out.normal[2] > 0 and angle_deg(out.normal, tilted(10.0)) < 1e-9
    assert out.score == pytest.approx(1.0)


# ---------------------------------------------------------------------- tolerance
@pytest.mark.parametrize("kappa", [50.0, 200.0, 2000.0])
def test_the_tolerance_is_where_a_lobe_falls_to_90_percent_to_its_step(kappa):
    p = tilted(20.0, 30.0)
    s = Lobes([p], [kappa])
    tol = op.tolerance_deg(s._f, p, 1.0, op.Constraint())
    exact = ninety_percent_deg(kappa)
    assert exact - op.TOLERANCE_STEP_DEG - 1e-9 <= tol <= exact
    assert op.TOLERANCE_STEP_DEG == 0.05


def test_the_tolerance_keeps_the_asked_share():
    p = tilted(0.0)
    s = Lobes([p], [100.0])
    tol = op.tolerance_deg(s._f, p, 1.0, op.Constraint(), keep=0.5)
    exact = math.degrees(math.acos(1.0 + math.log(0.5) / 100.0))
    assert exact - 0.05 - 1e-9 <= tol <= exact


def test_the_tolerance_is_the_worst_direction_around_the_peak():
    # two lobes side by side along x: the score falls faster along y than along x
    best = tilted(0.0)
    s = Lobes([tilted(1.5, 0.0), tilted(1.5, 180.0)], [400.0, 400.0])
    b = float(s._f(best)[0])

    def exact(azimuth: float) -> float:
        along = s._f(np.array([tilted(a, azimuth) for a in np.arange(0.0, 8.0, 0.001)]))
        return 0.001 * int(np.argmax(along < 0.9 * b))

    tol = op.tolerance_deg(s._f, best, b, op.Constraint())
    assert exact(90.0) - 0.05 - 2e-3 <= tol <= exact(90.0) + 2e-3
    # front and back only (along x): wider, and as far as the score keeps along x
    tol_x = op.tolerance_deg(s._f, best, b, op.Constraint(), directions=[np.array([1.0, 0, 0])])
    assert exact(0.0) - 0.05 - 2e-3 <= tol_x <= exact(0.0) + 2e-3 and exact(0.0) > exact(90.0) + 0.15


def test_the_tolerance_about_a_fixed_axis_tilts_across_it_only():
    c = op.Constraint(60.0, (1.0, 0.0, 0.0))
    # a lobe narrow along y (tilting about x) and a ridge along x: the axis sees only the y fall
    s = Lobes([tilted(0.0)], [300.0])
    tol = op.tolerance_deg(s._f, tilted(0.0), 1.0, c)
    assert ninety_percent_deg(300.0) - 0.05 - 1e-9 <= tol <= ninety_percent_deg(300.0)


def test_the_tolerance_of_a_flat_score_is_its_limit_and_of_a_lost_centre_zero():
    flat = lambda n: np.ones(len(n))  # noqa: E731
    assert op.tolerance_deg(flat, tilted(0.0), 1.0, op.Constraint()) == 30.0
    assert op.tolerance_deg(flat, tilted(0.0), 1.0, op.Constraint(), limit_deg=12.5) == 12.5
    assert op.tolerance_deg(flat, tilted(0.0), 2.0, op.Constraint()) == 0.0  # the centre keeps half


def test_a_direction_along_the_normal_tilts_across_it():
    s = Lobes([tilted(0.0)], [300.0])
    tol = op.tolerance_deg(s._f, tilted(0.0), 1.0, op.Constraint(), directions=[np.array([0.0, 0.0, 1.0])])
    assert ninety_percent_deg(300.0) - 0.05 - 1e-9 <= tol <= ninety_percent_deg(300.0)


def test_rings_fold_onto_the_upper_hemisphere():
    # a peak at the horizon: rings dip below it; the axial score folds them back
    p = tilted(90.0, 0.0)
    s = Lobes([p], [300.0])
    tol = op.tolerance_deg(s._f, p, 1.0, op.Constraint())
    assert ninety_percent_deg(300.0) - 0.05 - 1e-9 <= tol <= ninety_percent_deg(300.0)
    seen = []
    op.tolerance_deg(lambda n: seen.append(np.array(n)) or s._f(n), p, 1.0, op.Constraint())
    assert all((x[:, 2] >= 0).all() for x in seen)


def test_the_tolerance_scores_its_rings_in_few_calls():
    s = Lobes([tilted(10.0)], [300.0])
    calls = []
    op.tolerance_deg(lambda n: calls.append(len(n)) or s._f(n), tilted(10.0), 1.0, op.Constraint())
    assert calls[0] == 17 and all(c in (16, 32) for c in calls[1:]) and len(calls) <= 8


# ---------------------------------------------------------------------- runners-up
def test_distinct_optima_are_the_other_peaks_polished_best_first():
    best, second, third = tilted(10.0, 0.0), tilted(30.0, 120.0), tilted(35.0, 250.0)
    s = Lobes([best, second, third], [300.0, 300.0, 300.0], [1.0, 0.8, 0.6])
    g = op.hemisphere_grid(2.0, op.Constraint())
    v = s._f(g)
    out = op.distinct_optima(s, op.Constraint(), g, v, best, 1.0)
    assert len(out) == 2
    assert angle_deg(out[0][0], second) < 0.25 and angle_deg(out[1][0], third) < 0.25
    assert out[0][1] == pytest.approx(0.8, abs=2e-3) and out[1][1] == pytest.approx(0.6, abs=2e-3)
    assert all(n[2] >= 0 for n, _ in out)
    # at most count; the floor leaves out what scores under it
    assert len(op.distinct_optima(s, op.Constraint(), g, v, best, 1.0, count=1)) == 1
    assert len(op.distinct_optima(s, op.Constraint(), g, v, best, 1.0, floor=0.7)) == 1
    assert op.distinct_optima(s, op.Constraint(), g, v, best, 1.0, floor=0.9) == []


def test_distinct_optima_keep_their_separation():
    best, near = tilted(10.0, 0.0), tilted(10.0, 60.0)  # 10 deg apart
    s = Lobes([best, near], [300.0, 300.0], [1.0, 0.8])
    g = op.hemisphere_grid(2.0, op.Constraint())
    v = s._f(g)
    assert op.distinct_optima(s, op.Constraint(), g, v, best, 1.0) == []  # within the 12 deg separation
    out = op.distinct_optima(s, op.Constraint(), g, v, best, 1.0, separation_deg=8.0)
    assert len(out) == 1 and angle_deg(out[0][0], near) < 0.25


def test_a_shoulder_is_not_a_runner_up():
    # a shoulder of the best peak's slope beyond the separation is not a local maximum
    best = tilted(20.0, 0.0)
    s = Lobes([best], [20.0])
    g = op.hemisphere_grid(2.0, op.Constraint())
    v = s._f(g)
    assert op.distinct_optima(s, op.Constraint(), g, v, best, 1.0, floor=0.05) == []


def test_a_runner_up_polished_onto_a_taken_one_is_dropped():
    best, a = tilted(10.0, 0.0), tilted(40.0, 90.0)
    s = Lobes([best, a], [300.0, 300.0], [1.0, 0.8])
    g = op.hemisphere_grid(2.0, op.Constraint())
    v = s._f(g)
    # a neighbour radius of 0: every map point is a "local maximum"; the polish brings the cells near
    # ``a`` onto it, and only the first of them is kept
    out = op.distinct_optima(s, op.Constraint(), g, v, best, 1.0, neighbour_deg=0.0, floor=0.5)
    assert len(out) == 1 and angle_deg(out[0][0], a) < 0.25


def test_axial_angles_and_dots():
    n = np.array([tilted(30.0), -tilted(30.0), [1.0, 0, 0]])
    assert op._axial_deg(n, np.array([0, 0, 1.0])) == pytest.approx([30.0, 30.0, 90.0])
    assert op._dots(n, np.array([1.0, 2.0, 3.0])) == pytest.approx(n @ np.array([1.0, 2.0, 3.0]), abs=1e-15)


def test_stereo_round_trip_used_by_the_optimisers():
    for t, p in ((0.0, 0.0), (30.0, 45.0), (89.0, 300.0)):
        n = tilted(t, p)
        assert stereo_to_normal(*normal_to_stereo(n)) == pytest.approx(n, abs=1e-12)


# ====================================================================== the first run's survivors (issue 37)
# Each test below pins a number a user would see move: the points the optimisers ask a scorer for,
# the optimisers' settings, the ring angles of the tolerance search, the evaluation counts, the
# defaults and the edges of each threshold.

class Recorder(Lobes):
    """Lobes that remember what they were asked, in order: ("map", normals), ("score", normal),
    ("grad", (u, v)), ("batch", (us, vs))."""

    def __init__(self, *a, **k) -> None:
        super().__init__(*a, **k)
        self.log: list = []

    def energy_map(self, normals):
        self.log.append(("map", np.array(normals, dtype=np.float64)))
        return super().energy_map(normals)

    def score(self, normal):
        self.log.append(("score", np.array(normal, dtype=np.float64)))
        return super().score(normal)

    def value_and_grad_uv(self, u, v):
        self.log.append(("grad", (float(u), float(v))))
        return super().value_and_grad_uv(u, v)

    def energy_batch_value_and_grad(self, us, vs):
        self.log.append(("batch", (np.array(us, dtype=np.float64), np.array(vs, dtype=np.float64))))
        out = [Lobes.value_and_grad_uv(self, float(u), float(v)) for u, v in zip(us, vs)]
        return np.array([o[0] for o in out]), np.array([o[1] for o in out])

    def kinds(self, kind):
        return [x for k, x in self.log if k == kind]


# ---------------------------------------------------------------------- Constraint's edges
def test_a_tilt_axis_exactly_1e_9_off_vertical_is_still_an_axis():
    c = op.Constraint(30.0, (1e-9, 0.0, 1.0))  # its horizontal part is exactly 1e-9 long: kept
    assert c.tilt_axis == (1.0, 0.0, 0.0)
    c = op.Constraint(30.0, (2, 0, 5))  # integers are read as numbers
    assert c.tilt_axis == (1.0, 0.0, 0.0)


def test_allowed_keeps_a_normal_exactly_at_the_limits_tolerance():
    c = op.Constraint(60.0)
    z = math.cos(math.radians(60.0)) - 1e-12
    assert c.allowed(np.array([[0.0, 0.0, z], [0.0, 0.0, np.nextafter(z, -1.0)]])).tolist() == [True, False]


def test_clamp_leaves_a_point_exactly_on_the_edge_untouched():
    c = op.Constraint(60.0)
    u, v = 0.44900843743671165, 0.362939053346393  # hypot(u, v) == radius to the last bit
    assert math.hypot(u, v) == c.radius
    assert c.clamp(u, v) == (u, v)  # bit for bit: not rescaled by radius / r


def test_the_fixed_axis_grid_ends_at_the_limit_for_fine_spacings():
    c = op.Constraint(30.0, (1.0, 0.0, 0.0))
    g = op.hemisphere_grid(0.5, c)
    assert len(g) == 121  # -30, -29.5, ..., 30: not one step past the limit
    assert g[-1] == pytest.approx(c.axis_normal(30.0), abs=1e-12) and c.allowed(g).all()


def test_axial_angle_of_a_normal_with_itself_is_zero_even_when_the_dot_rounds_above_one():
    n = unit(1.0, 1.0, 1.0)
    assert float(n @ n) > 1.0  # 1.0000000000000002
    assert op._axial_deg(n[None, :], n).tolist() == [0.0]


def test_score_map_keeps_two_percent_of_the_best_not_of_one():
    class Split(Lobes):
        def score(self, normal):
            return 7.0

    s = Split([[0, 0, 1.0]], [10.0], objective="area")
    s.energy_map = lambda normals: np.array([2.0, 0.04, 0.0399, 0.02])  # 2 % of 2 is 0.04
    g = np.array([tilted(a) for a in (0.0, 1.0, 2.0, 3.0)])
    assert op.score_map(s, g).tolist() == [7.0, 7.0, 0.0, 0.0]


# ---------------------------------------------------------------------- polish grids
def axis_angle(n: np.ndarray, axis: np.ndarray) -> float:
    """The angle (degrees) that turns +Z into ``n`` about the horizontal unit ``axis``."""
    z = np.array([0.0, 0.0, 1.0])
    return math.degrees(math.atan2(float(np.cross(z, n) @ axis), float(n @ z)))


def test_polish_about_a_fixed_axis_asks_for_a_segment_of_angles_around_the_centre():
    c = op.Constraint(45.0, (0.0, 1.0, 0.0))  # about +Y: +Z turns towards +X
    s = Recorder([c.axis_normal(16.0)], [300.0])
    n, v = op.polish_grid(s, c.axis_normal(15.0), c, 4.0, 0.1)
    (asked,) = s.kinds("map")
    angles = [axis_angle(x, np.array([0.0, 1.0, 0.0])) for x in asked]
    assert len(angles) == 81  # 11.0, 11.1, ..., 19.0: both ends included
    assert angles == pytest.approx(list(11.0 + 0.1 * np.arange(81)), abs=1e-9)
    assert axis_angle(n, np.array([0.0, 1.0, 0.0])) == pytest.approx(16.0, abs=1e-9) and v == pytest.approx(1.0)


def test_polish_about_a_fixed_axis_is_clipped_at_both_limits():
    c = op.Constraint(20.0, (1.0, 0.0, 0.0))
    s = Recorder([op.Constraint(90.0, (1.0, 0.0, 0.0)).axis_normal(-25.0)], [300.0])
    n, _ = op.polish_grid(s, c.axis_normal(-19.0), c, 4.0, 0.1)
    (asked,) = s.kinds("map")
    angles = np.array([axis_angle(x, np.array([1.0, 0.0, 0.0])) for x in asked])
    assert angles.min() == pytest.approx(-20.0, abs=1e-9) and angles.max() == pytest.approx(-15.0, abs=1e-9)
    assert n == pytest.approx(c.axis_normal(-20.0), abs=1e-12)


@pytest.mark.parametrize("centre_uv", [(0.2, -0.1), (-0.05, 0.3)])
def test_polish_asks_for_a_square_stereographic_grid_scaled_to_the_centre(centre_uv):
    u0, v0 = centre_uv
    s = Recorder([stereo_to_normal(u0, v0)], [300.0])
    op.polish_grid(s, stereo_to_normal(u0, v0), op.Constraint(), 2.0, 0.25)
    (asked,) = s.kinds("map")
    assert len(asked) == 17 * 17  # -2 deg, -1.75, ..., +2 deg in each of u and v
    uv = np.array([normal_to_stereo(x) for x in asked])
    us, vs = np.unique(np.round(uv[:, 0], 12)), np.unique(np.round(uv[:, 1], 12))
    spacing = math.radians(0.25) * (1.0 + u0 * u0 + v0 * v0) / 2.0  # radians scaled to stereographic
    assert len(us) == len(vs) == 17
    assert np.diff(us) == pytest.approx(np.full(16, spacing), rel=1e-9)
    assert np.diff(vs) == pytest.approx(np.full(16, spacing), rel=1e-9)
    assert us[8] == pytest.approx(u0, abs=1e-12) and vs[8] == pytest.approx(v0, abs=1e-12)  # symmetric about the centre


def test_polish_candidates_beyond_the_limit_are_asked_for_on_its_edge():
    c = op.Constraint(30.0)
    s = Recorder([tilted(29.5)], [300.0])
    op.polish_grid(s, tilted(29.5), c, 2.0, 0.25)
    (asked,) = s.kinds("map")
    tilt = np.degrees(np.arccos(asked[:, 2]))
    assert tilt.max() == pytest.approx(30.0, abs=1e-9) and (tilt > 30.0 - 1e-9).sum() > 10


# ---------------------------------------------------------------------- the grid optimiser
def test_the_grid_optimiser_maps_then_polishes_its_three_best_cells_in_order():
    s = Recorder([tilted(22.0, 20.0), tilted(30.0, 200.0), tilted(45.0, 100.0)], [300.0, 300.0, 300.0], [1.0, 0.9, 0.8])
    c = op.Constraint(60.0)
    s.evaluations = 1000
    r = op.optimize_grid(s, c, coarse_deg=4.0, fine_deg=0.5)
    maps = s.kinds("map")
    grid = op.hemisphere_grid(4.0, c)
    assert len(maps) == 4 and maps[0] == pytest.approx(grid)
    best3 = grid[np.argsort(s._f(grid))[::-1][:3]]
    for asked, cell in zip(maps[1:], best3):
        ref = Recorder([[0, 0, 1.0]], [1.0])
        op.polish_grid(ref, cell, c, 6.0, 0.5)  # 1.5 x the coarse spacing, at the fine step
        assert asked == pytest.approx(ref.kinds("map")[0])
    assert r.evaluations == sum(len(m) for m in maps) == s.evaluations - 1000


def test_the_grid_optimisers_default_spacings_are_1_5_and_0_1_degrees():
    s = Recorder([tilted(10.0)], [300.0])
    op.optimize_grid(s, op.Constraint(20.0))
    maps = s.kinds("map")
    assert len(maps[0]) == len(op.hemisphere_grid(1.5, op.Constraint(20.0)))
    assert all(len(m) == 46 * 46 for m in maps[1:])  # -2.25, -2.15, ..., +2.25 deg (1.5 x 1.5) in 0.1 deg steps


def test_the_grid_optimiser_keeps_the_best_cell_when_no_polish_beats_it():
    class Spike(Lobes):  # 1 at exactly one map cell, 0.5 everywhere else
        def _f(self, n):
            n = np.atleast_2d(np.asarray(n, dtype=np.float64))
            return np.where(np.all(n == self.cell, axis=1), 1.0, 0.5)

    c = op.Constraint(30.0)
    s = Spike([[0, 0, 1.0]], [1.0])
    s.cell = op.hemisphere_grid(5.0, c)[7]
    r = op.optimize_grid(s, c, coarse_deg=5.0, fine_deg=0.5)
    assert r.score == 1.0 and np.array_equal(r.normal, s.cell)
    # a plateau: nothing beats the best coarse cell (argsort's first of the ties), which stays
    flat = Lobes([[0, 0, 1.0]], [0.0])
    grid = op.hemisphere_grid(5.0, c)
    r = op.optimize_grid(flat, c, coarse_deg=5.0, fine_deg=0.5)
    assert np.array_equal(r.normal, grid[np.argsort(np.ones(len(grid)))[::-1][0]]) and r.score == 1.0


# ---------------------------------------------------------------------- NLopt's settings
@pytest.fixture
def nlopt_log(monkeypatch):
    """Every ``nlopt.opt`` made, with the calls made on it (a real optimiser does the work)."""
    import nlopt

    real = nlopt.opt
    log: list = []

    def plain(x):
        return [float(y) for y in x] if isinstance(x, list | tuple | np.ndarray) else x

    class Spy:
        def __init__(self, algorithm, n):
            self._o = real(algorithm, n)
            self.calls = [("opt", algorithm, n)]
            log.append(self.calls)

        def __getattr__(self, name):
            method = getattr(self._o, name)

            def call(*args):
                self.calls.append((name, *(plain(a) for a in args if not callable(a))))
                return method(*args)
            return call

    monkeypatch.setattr(nlopt, "opt", Spy)
    return log


def test_nlopt_runs_direct_l_over_the_discs_box_then_an_lbfgs_from_its_best_and_three_seeds(nlopt_log):
    import nlopt

    c = op.Constraint(60.0)
    r = c.radius
    s = Recorder([tilted(33.0, 123.0), tilted(10.0, 300.0)], [300.0, 20.0], [1.0, 0.3])
    s.evaluations = 1000
    res = op.optimize_nlopt(s, c, global_evals=50)
    assert res.evaluations == s.evaluations - 1000 > 50
    direct, *polishes = nlopt_log
    assert direct == [("opt", nlopt.GN_DIRECT_L, 2), ("set_max_objective",), ("set_lower_bounds", [-r, -r]),
                      ("set_upper_bounds", [r, r]), ("set_maxeval", 50), ("optimize", [0.0, 0.0])]
    assert len(polishes) == 4  # from DIRECT-L's best point and the three best distinct cells of the 6 deg map
    seeds = op._map_seeds(Lobes(s.p, s.k, s.w), c, 6.0, 3)
    assert len(seeds) == 3
    for calls in polishes:
        assert calls[:6] == [("opt", nlopt.LD_LBFGS, 2), ("set_max_objective",), ("set_lower_bounds", [-r, -r]),
                             ("set_upper_bounds", [r, r]), ("set_xtol_abs", 1e-5), ("set_maxeval", 60)]
    starts = [calls[6][1] for calls in polishes]
    assert np.array(starts[1:]) == pytest.approx(np.array([normal_to_stereo(n) for n in seeds]), abs=1e-15)


def test_nlopt_polishes_from_the_three_best_cells_of_a_given_map(nlopt_log):
    cells = np.array([tilted(a, 0.0) for a in (0.0, 10.0, 20.0, 30.0, 40.0)])
    s = Lobes([tilted(5.0)], [50.0])
    op.optimize_nlopt(s, op.Constraint(), global_evals=20, seed_map=(cells, Launched.ready(np.array([5.0, 4.0, 3.0, 2.0, 1.0]))))
    starts = [calls[6][1] for calls in nlopt_log[1:]]
    assert np.array(starts[1:]) == pytest.approx(np.array([normal_to_stereo(n) for n in cells[:3]]), abs=1e-15)


@pytest.mark.parametrize("evals, direct", [(100, 40), (400, 100)])
def test_nlopt_about_a_fixed_axis_runs_direct_l_then_bobyqa_with_their_budgets(nlopt_log, evals, direct):
    import nlopt

    c = op.Constraint(40.0, (0.0, 1.0, 0.0))
    s = Recorder([c.axis_normal(-23.4)], [500.0])
    s.evaluations = 1000
    res = op.optimize_nlopt(s, c, global_evals=evals)
    glob, loc = nlopt_log
    assert glob == [("opt", nlopt.GN_DIRECT_L, 1), ("set_max_objective",), ("set_lower_bounds", [-40.0]),
                    ("set_upper_bounds", [40.0]), ("set_maxeval", direct), ("optimize", [0.0])]
    assert loc[:7] == [("opt", nlopt.LN_BOBYQA, 1), ("set_max_objective",), ("set_lower_bounds", [-40.0]),
                       ("set_upper_bounds", [40.0]), ("set_xtol_abs", 1e-3), ("set_initial_step", 0.5), ("set_maxeval", 40)]
    assert loc[7][0] == "optimize" and len(loc) == 8
    asked = s.kinds("score")
    assert res.evaluations == len(asked) == s.evaluations - 1000
    assert res.score == s._f(res.normal)[0] and np.array_equal(asked[-1], res.normal)  # the answer scored last
    assert axis_angle(res.normal, np.array([0.0, 1.0, 0.0])) == pytest.approx(-23.4, abs=0.01)


def test_nlopt_on_a_plateau_keeps_direct_ls_first_point_the_face_up_normal():
    s = Lobes([[0, 0, 1.0]], [0.0])  # kappa 0: 1 everywhere, no gradient
    res = op.optimize_nlopt(s, op.Constraint(), global_evals=30)
    assert np.array_equal(res.normal, [0.0, 0.0, 1.0]) and res.score == 1.0


def test_lbfgs_keeps_its_first_point_on_a_plateau():
    s = Lobes([[0, 0, 1.0]], [0.0])
    assert op._local_lbfgs(s, 0.1, -0.2, op.Constraint()) == (0.1, -0.2, 1.0)


# ---------------------------------------------------------------------- Adam
def adam_expected_first_steps(scorer, c, x0):
    """The first two Adam steps from the stereographic points ``x0`` (rows), by hand (on a copy of
    ``scorer``): bias-corrected, the first is lr * g / (|g| + 1e-12), lr * sign(g) where g is not
    ~0; the second uses m1 = 0.09 g0 + 0.1 g1 over 1 - 0.9^2 and m2 = 0.000999 g0^2 + 0.001 g1^2
    over 1 - 0.999^2."""
    ref = Lobes(scorer.p, scorer.k, scorer.w)
    lr = 0.02 * max(c.radius, 0.05)
    g0 = np.array([ref.value_and_grad_uv(*x)[1] for x in x0])
    x1 = np.array([c.clamp(*x) for x in x0 + lr * g0 / (np.abs(g0) + 1e-12)])
    g1 = np.array([ref.value_and_grad_uv(*x)[1] for x in x1])
    m1 = (0.09 * g0 + 0.1 * g1) / (1 - 0.81)
    m2 = (0.000999 * g0 ** 2 + 0.001 * g1 ** 2) / (1 - 0.998001)
    x2 = np.array([c.clamp(*x) for x in x1 + lr * m1 / (np.sqrt(m2) + 1e-12)])
    return x1, x2, g0


def spread_starts(c, starts):
    """The optimiser's spread starting normals: a Fibonacci grid spaced for ``starts`` points over the
    allowed cap (at least 2 deg apart), ``starts`` of them picked evenly."""
    cap = 1.0 - math.cos(math.radians(c.max_tilt_deg))
    g = op.hemisphere_grid(max(2.0, math.degrees(math.sqrt(2.0 * math.pi * cap / starts))), c)
    return g[np.linspace(0, len(g) - 1, min(starts, len(g))).astype(int)]


@pytest.mark.parametrize("tilt, starts", [(60.0, 6), (90.0, 12), (10.0, 100)])
def test_adam_starts_from_the_map_seeds_and_the_spread_starts_and_takes_sign_steps_first(tilt, starts):
    c = op.Constraint(tilt)
    peaks = [tilted(0.3 * tilt, 40.0), tilted(0.7 * tilt, 250.0)]
    s = Recorder(peaks, [200.0, 200.0], [1.0, 0.7])
    s.evaluations = 1000
    res = op.optimize_gradient(s, c, starts=starts, iterations=3)
    seeds = op._map_seeds(Lobes(peaks, [200.0, 200.0], [1.0, 0.7]), c, 6.0, max(4, starts // 2))
    inits = np.vstack([np.array(seeds), spread_starts(c, starts)])
    batches = s.kinds("batch")
    assert len(batches) == 3 + 1  # three steps, then the end points scored
    x0 = np.column_stack(batches[0])
    assert x0 == pytest.approx(np.array([normal_to_stereo(n) for n in inits]), abs=1e-15)
    x1, x2, g0 = adam_expected_first_steps(s, c, x0)
    assert np.column_stack(batches[1]) == pytest.approx(x1, abs=1e-12)
    assert np.column_stack(batches[2]) == pytest.approx(x2, abs=1e-12)
    # the polish starts from the best end point
    end = np.column_stack(batches[3])
    values = s._f(np.array([stereo_to_normal(*x) for x in end]))
    assert np.array(s.kinds("grad")[0]) == pytest.approx(end[int(np.argmax(values))], abs=1e-15)
    signed = (np.abs(g0) > 1e-6) & (np.hypot(*x1.T) < c.radius - 1e-9)[:, None]
    assert np.abs(x1 - x0)[signed] == pytest.approx(np.full(signed.sum(), 0.02 * max(c.radius, 0.05)), rel=1e-9)
    assert res.evaluations == s.evaluations - 1000 and res.score == pytest.approx(s._f(res.normal)[0], rel=1e-12)


def test_adams_learning_rate_is_two_percent_of_the_radius_but_at_least_of_0_05():
    for tilt in (4.0, 30.0):  # radius 0.035 (floored at 0.05) and 0.268
        c = op.Constraint(tilt)
        s = Recorder([tilted(0.5 * tilt, 10.0)], [300.0])
        op.optimize_gradient(s, c, starts=4, iterations=1)
        b0, b1 = (np.column_stack(b) for b in s.kinds("batch")[:2])
        g0 = np.array([Lobes(s.p, s.k).value_and_grad_uv(*x)[1] for x in b0])
        signed = (np.abs(g0) > 1e-6) & (np.hypot(*b1.T) < c.radius - 1e-9)[:, None]
        assert signed.sum() >= 6
        assert np.abs(b1 - b0)[signed] == pytest.approx(np.full(signed.sum(), 0.02 * max(c.radius, 0.05)), rel=1e-9)


def test_adams_defaults_are_twelve_starts_and_sixty_steps():
    c = op.Constraint(90.0)
    s = Recorder([tilted(20.0)], [50.0])
    op.optimize_gradient(s, c)
    batches = s.kinds("batch")
    assert len(batches) == 61
    seeds = op._map_seeds(Lobes([tilted(20.0)], [50.0]), c, 6.0, 6)
    assert len(seeds) == 6 and len(batches[0][0]) == 6 + 12


def test_adam_steps_each_start_alone_for_other_objectives():
    c = op.Constraint(60.0)
    s = Recorder([tilted(20.0, 40.0)], [200.0], objective="area")
    s.evaluations = 1000
    res = op.optimize_gradient(s, c, starts=4, iterations=5)
    assert s.kinds("batch") == []
    seeds = op._map_seeds(Lobes([tilted(20.0, 40.0)], [200.0]), c, 6.0, 4)
    inits = np.vstack([np.array(seeds), spread_starts(c, 4)])
    # each start: its gradient steps (five, or until a step is under 1e-6), then its end scored
    per_start, current = [], []
    for kind, x in s.log:
        if kind == "grad":
            current.append(x)
        elif kind == "score" and current:
            per_start.append(current)
            current = []
    assert len(per_start) == len(inits) + 1  # and the polish's gradients, then its point scored
    ends = [x for k, x in s.log if k == "score"][:len(inits)]
    best_end = ends[int(np.argmax([s._f(e)[0] for e in ends]))]
    assert np.array(per_start[-1][0]) == pytest.approx(np.array(normal_to_stereo(best_end)), abs=1e-12)  # polished from the best end
    per_start = per_start[:len(inits)]
    x0 = np.array([p[0] for p in per_start])
    assert x0 == pytest.approx(np.array([normal_to_stereo(n) for n in inits]), abs=1e-15)
    x1, x2, g0 = adam_expected_first_steps(s, c, x0)
    moving = [i for i, p in enumerate(per_start) if len(p) == 5]
    assert len(moving) >= 3
    assert np.array([per_start[i][1] for i in moving]) == pytest.approx(x1[moving], abs=1e-12)
    assert np.array([per_start[i][2] for i in moving]) == pytest.approx(x2[moving], abs=1e-12)
    assert res.evaluations == s.evaluations - 1000 and res.method == "gradient"


def test_a_start_on_the_peak_stops_after_one_step():
    c = op.Constraint(60.0)
    cell = op.hemisphere_grid(6.0, c)[0]  # the seed map's first cell: the first start
    s = Recorder([cell], [5.0], objective="area")
    op.optimize_gradient(s, c, starts=1, iterations=5)
    # the start sits on the peak: its gradient ~1e-16, its step under 1e-6: one call
    first = []
    for kind, x in s.log:
        if kind == "score":
            break
        if kind == "grad":
            first.append(x)
    assert np.array(first) == pytest.approx(np.array([normal_to_stereo(cell)]), abs=1e-15)


def test_adam_never_returns_worse_than_its_best_start():
    c = op.Constraint(60.0)
    s = Recorder([tilted(20.0, 40.0)], [200.0])
    # the polish's scoring reads lower than the steps' kernel: the best start's end point stays
    s.score_uv = lambda u, v: 0.5 * Lobes.score_uv(s, u, v)
    res = op.optimize_gradient(s, c, starts=4, iterations=3)
    end = np.column_stack(s.kinds("batch")[-1])
    values = s._f(np.array([stereo_to_normal(*x) for x in end]))
    i = int(np.argmax(values))
    assert res.score == pytest.approx(values[i], rel=1e-15) and res.normal == pytest.approx(stereo_to_normal(*end[i]), abs=1e-15)


# ---------------------------------------------------------------------- gradient ascent about a fixed axis
class Linear:
    """A score growing by ``slope`` per degree about the axis (+X): the gradient is known exactly."""

    objective = "energy"

    def __init__(self, slope: float) -> None:
        self.slope, self.asked, self.evaluations = slope, [], 1000

    def score(self, normal):
        self.evaluations += 1
        a = axis_angle(np.asarray(normal), np.array([1.0, 0.0, 0.0]))
        self.asked.append(round(a, 9))
        return self.slope * a


def test_axis_gradient_steps_by_a_hundred_times_the_slope():
    c = op.Constraint(30.0, (1.0, 0.0, 0.0))
    s = Linear(0.001)  # 2 x min(50 x 0.001, 1) = 0.1 deg a step
    res = op.optimize_gradient(s, c, starts=3, iterations=3)
    assert s.asked == pytest.approx([
        -29.95, -30.0, -29.9, -30.0, -29.8, -29.9, -29.75,  # from -30: half the slope at the edge, then 0.1 steps
        0.05, -0.05, 0.15, 0.05, 0.25, 0.15, 0.3,           # from 0
        30.0, 29.95, 30.0,                                  # from +30: pushed against the limit, stops at once
    ], abs=1e-9)
    assert res.normal == pytest.approx(c.axis_normal(30.0), abs=1e-15) and res.score == pytest.approx(0.03)
    assert res.evaluations == 17 and res.method == "gradient"


def test_axis_gradient_steps_at_most_two_degrees_and_keeps_to_the_lower_limit():
    c = op.Constraint(30.0, (1.0, 0.0, 0.0))
    s = Linear(-0.1)  # falling: 2 x min(50 x 0.1, 1) = 2 deg a step towards -30
    res = op.optimize_gradient(s, c, starts=3, iterations=2)
    assert s.asked == pytest.approx([
        -29.95, -30.0, -30.0,
        0.05, -0.05, -1.95, -2.05, -4.0,
        30.0, 29.95, 28.05, 27.95, 26.0,
    ], abs=1e-9)
    assert res.normal == pytest.approx(c.axis_normal(-30.0), abs=1e-15) and res.score == pytest.approx(3.0)


def test_axis_gradient_on_a_plateau_stops_each_start_at_once_and_keeps_the_first():
    c = op.Constraint(30.0, (1.0, 0.0, 0.0))
    s = Linear(0.0)
    res = op.optimize_gradient(s, c, starts=2, iterations=60)  # at least three starts
    assert s.asked == pytest.approx([-29.95, -30.0, -30.0, 0.05, -0.05, 0.0, 30.0, 29.95, 30.0], abs=1e-9)
    assert res.normal == pytest.approx(c.axis_normal(-30.0), abs=1e-15) and res.evaluations == 9


# ---------------------------------------------------------------------- seeds
def test_seed_separation_defaults_to_eight_degrees():
    n = np.array([tilted(0.0), tilted(8.5), tilted(30.0)])
    assert len(op._best_cells(n, np.array([3.0, 2.0, 1.0]), 3)) == 3  # 8.5 deg apart: distinct
    s = Lobes([tilted(0.0)], [1.0])
    s.energy_map = lambda normals: np.array([3.0, 2.0, 1.0])
    op_grid = op.hemisphere_grid
    try:
        op.hemisphere_grid = lambda spacing, c: n
        assert len(op._map_seeds(s, op.Constraint(), 6.0, 3)) == 3
        assert len(op._map_seeds(s, op.Constraint(), 6.0, 3, separation_deg=20.0)) == 2
    finally:
        op.hemisphere_grid = op_grid


def test_a_cell_exactly_at_the_separation_is_not_distinct():
    c60 = math.cos(math.radians(60.0))
    n = np.array([[0.0, 0.0, 1.0], [math.sqrt(1 - c60 * c60), 0.0, c60]])
    assert float(n[1] @ n[0]) == c60
    assert len(op._best_cells(n, np.array([2.0, 1.0]), 3, separation_deg=60.0)) == 1


# ---------------------------------------------------------------------- the tolerance search, ring by ring
class Rings:
    """A score of the axial angle ``a`` (degrees) from ``centre``: ``profile(a)``; remembers each call's
    rings (their angles from the centre, rounded to 1e-9 deg; 0 for the centre) and points."""

    def __init__(self, centre, profile) -> None:
        self.centre, self.profile, self.calls, self.points = unit(*centre), profile, [], []

    def __call__(self, n):
        n = np.asarray(n, dtype=np.float64)
        self.points.append(n.copy())
        a = np.degrees(np.arccos(np.clip(np.abs(n @ self.centre), 0.0, 1.0)))
        self.calls.append(sorted({round(float(x), 9) for x in a}))
        return self.profile(a)


def quadratic(c: float, flat: float = 0.0):
    """1 - c (a - flat)^2 beyond ``flat`` degrees, 1 inside: 90 % at flat + sqrt(0.1 / c)."""
    return lambda a: 1.0 - c * np.maximum(a - flat, 0.0) ** 2


def test_a_quadratic_fall_is_bracketed_by_its_prediction_then_closed_with_two_rings():
    # 90 % at 0.6 deg: from the centre and the 0.25 deg ring the quadratic's root is 0.6 exactly;
    # the bracket asks 1.05 x 0.6 = 0.63 (fails), regula falsi in a^2 predicts 0.6 again, and the
    # two rings a step apart around it, 0.575 and 0.6 + 0.025 pulled to 0.63 - 0.0125, close it
    s = Rings([0, 0, 1.0], quadratic(0.1 / 0.36))
    tol = op.tolerance_deg(s, np.array([0, 0, 1.0]), 1.0, op.Constraint())
    assert s.calls == [[0.0, 0.25], [0.63], [0.575, 0.6175]]
    assert tol == pytest.approx(0.575, abs=1e-9)
    assert [len(p) for p in s.points] == [17, 16, 32]


def test_a_wide_fall_is_bracketed_in_steps_of_at_most_four_times():
    # 90 % at 10 deg: predictions 10.5 capped at 4 x 0.25 = 1, then 4, then 10.5 (fails)
    s = Rings([0, 0, 1.0], quadratic(0.1 / 100.0))
    tol = op.tolerance_deg(s, np.array([0, 0, 1.0]), 1.0, op.Constraint())
    assert s.calls == [[0.0, 0.25], [1.0], [4.0], [10.5], [9.975, 10.025]]
    assert tol == pytest.approx(9.975, abs=1e-9)
    # the same fall with the search stopped at 5 deg: the limit, asked for and kept
    s = Rings([0, 0, 1.0], quadratic(0.1 / 100.0))
    assert op.tolerance_deg(s, np.array([0, 0, 1.0]), 1.0, op.Constraint(), limit_deg=5.0) == 5.0
    assert s.calls == [[0.0, 0.25], [1.0], [4.0], [5.0]]


def test_a_bracket_guess_is_at_least_1_6_times_the_last_ring():
    # 90 % at 0.3 deg: the prediction 0.315 is raised to 1.6 x 0.25 = 0.4
    s = Rings([0, 0, 1.0], quadratic(0.1 / 0.09))
    tol = op.tolerance_deg(s, np.array([0, 0, 1.0]), 1.0, op.Constraint())
    assert s.calls == [[0.0, 0.25], [0.4], [0.275, 0.325]]
    assert tol == pytest.approx(0.275, abs=1e-9)


def test_a_fall_inside_the_first_ring_is_closed_between_the_centre_and_it():
    # 90 % at 0.2 deg: the 0.25 deg ring already fails; regula falsi from the centre predicts 0.2
    s = Rings([0, 0, 1.0], quadratic(0.1 / 0.04))
    tol = op.tolerance_deg(s, np.array([0, 0, 1.0]), 1.0, op.Constraint())
    assert s.calls == [[0.0, 0.25], [0.175, 0.225]]
    assert tol == pytest.approx(0.175, abs=1e-9)


def test_a_flat_top_is_crossed_in_steps_of_four_times():
    # flat to 7 deg, then quadratic to 90 % at 10: rings 1, 4 and 16 (the flat gives no slope to
    # predict from: four times the last), then regula falsi between 4 and 16
    s = Rings([0, 0, 1.0], quadratic(0.1 / 9.0, flat=7.0))
    tol = op.tolerance_deg(s, np.array([0, 0, 1.0]), 1.0, op.Constraint())
    assert s.calls[:4] == [[0.0, 0.25], [1.0], [4.0], [16.0]]
    assert 10.0 - 0.05 <= tol <= 10.0 and len(s.calls) == 10


def test_a_step_profile_halves_when_the_prediction_is_slow_and_keeps_a_ring_exactly_at_90_percent():
    # 0.9 (exactly the target: kept) up to 2 deg, 0.5 beyond: the prediction sits on the ring that
    # keeps, so every second move halves the bracket
    s = Rings([0, 0, 1.0], lambda a: np.where(a <= 2.0, 0.9, 0.5))
    tol = op.tolerance_deg(s, np.array([0, 0, 1.0]), 1.0, op.Constraint())
    assert s.calls == [[0.0, 0.25], [1.0], [4.0], [1.0125, 1.025], [2.5125], [1.0375, 1.05], [1.78125],
                       [1.79375, 1.80625], [2.159375], [1.81875, 1.83125], [1.9953125], [2.0078125, 2.0203125]]
    assert tol == pytest.approx(1.9953125, abs=1e-9)


def test_a_centre_exactly_at_the_target_keeps_and_one_below_it_gives_zero():
    assert op.tolerance_deg(lambda n: np.full(len(n), 0.9), tilted(0.0), 1.0, op.Constraint(), limit_deg=3.0) == 3.0
    # the centre fails while its rings keep: 0 (the centre is read as the first value)
    assert op.tolerance_deg(lambda n: np.r_[0.5, np.ones(len(n) - 1)], tilted(0.0), 1.0, op.Constraint()) == 0.0


def test_a_limit_under_the_first_ring_is_the_answer_when_nothing_fails():
    assert op.tolerance_deg(lambda n: np.ones(len(n)), tilted(0.0), 1.0, op.Constraint(), limit_deg=0.1) == 0.1


def ring_points(best, e1, e2, angle_deg, count=16):
    t = math.radians(angle_deg)
    return np.array([math.cos(t) * best + math.sin(t) * (math.cos(p) * e1 + math.sin(p) * e2)
                     for p in np.arange(count) * 2 * math.pi / count])


@pytest.mark.parametrize("best, helper", [
    (tilted(20.0, 30.0), [1.0, 0.0, 0.0]),
    (np.array([0.9, 0.0, math.sqrt(0.19)]), [0.0, 1.0, 0.0]),       # |x| at 0.9: about +Y
    (np.array([0.85, 0.3, math.sqrt(1 - 0.85 ** 2 - 0.09)]), [1.0, 0.0, 0.0]),
    (np.array([-0.95, 0.1, math.sqrt(1 - 0.9025 - 0.01)]), [0.0, 1.0, 0.0]),
])
def test_the_rings_sixteen_points_start_from_best_cross_x_or_y_near_x(best, helper):
    s = Rings(best, lambda a: np.ones(len(a)))
    op.tolerance_deg(s, 2.0 * best, 1.0, op.Constraint(), limit_deg=0.25)  # best need not be unit
    e1 = np.cross(best, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(best, e1)
    assert s.points[0][0] == pytest.approx(best, abs=1e-15)
    assert s.points[0][1:] == pytest.approx(ring_points(best, e1, e2, 0.25), abs=1e-15)


def test_given_directions_are_projected_onto_the_tangent_plane_and_made_unit():
    best = tilted(30.0, 0.0)
    s = Rings(best, lambda a: np.ones(len(a)))
    op.tolerance_deg(s, best, 1.0, op.Constraint(), directions=[np.array([2.0, 0.0, 0.0]), np.array([0.0, 0.0, 3.0])],
                     limit_deg=0.25)
    t1 = np.array([1.0, 0.0, 0.0]) - best[0] * best
    t1 /= np.linalg.norm(t1)
    t = math.radians(0.25)
    # one ring point per direction; x tilted towards the horizon, +Z towards the face-up normal
    assert s.points[0][1] == pytest.approx(math.cos(t) * best + math.sin(t) * t1, abs=1e-15)
    assert s.points[0][2] == pytest.approx(math.cos(t) * best - math.sin(t) * t1, abs=1e-15)


@pytest.mark.parametrize("best, d, across", [
    (np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0]), [0.0, 1.0, 0.0]),                   # z x x
    (np.array([0.2, 0.2, math.sqrt(0.92)]), None, None),                                     # |d_z| > 0.9: best x x
    (np.array([math.sqrt(0.19), 0.0, 0.9]), None, [0.0, 0.9, 0.0]),                          # |d_z| = 0.9: best x x
    (np.array([0.6, 0.8, 0.0]), np.array([0.3, 0.4, 0.0]), [0.8, -0.6, 0.0]),                # best x d = 0: best x z
])
def test_a_direction_along_the_normal_tilts_across_it_as_stated(best, d, across):
    d = best.copy() if d is None else d
    across = np.cross(best, [1.0, 0.0, 0.0]) if across is None else np.asarray(across)
    across = across / np.linalg.norm(across)
    s = Rings(best, lambda a: np.ones(len(a)))
    op.tolerance_deg(s, best, 1.0, op.Constraint(), directions=[d], limit_deg=0.25)
    t = math.radians(0.25)
    p = math.cos(t) * best + math.sin(t) * across
    assert s.points[0][1] == pytest.approx(p if p[2] >= 0 else -p, abs=1e-15)


def test_the_tolerance_about_a_fixed_axis_looks_both_ways():
    c = op.Constraint(60.0, (1.0, 0.0, 0.0))
    best = tilted(0.0)
    # falls fast towards -Y only (a lobe at 1 deg towards -Y over a wide one): one way is not enough
    s = Rings(best, lambda a: np.ones(len(a)))
    op.tolerance_deg(s, best, 1.0, c, limit_deg=0.25)
    t = math.radians(0.25)
    side = np.cross([1.0, 0.0, 0.0], best)  # -Y
    assert s.points[0][1:] == pytest.approx(np.array([math.cos(t) * best + math.sin(t) * side,
                                                      math.cos(t) * best - math.sin(t) * side]), abs=1e-15)


# ---------------------------------------------------------------------- runners-up, at their thresholds
def test_distinct_optima_defaults_count_separation_neighbour():
    z = np.array([0.0, 0.0, 1.0])
    # five peaks around a best one: the default count is three
    peaks = [tilted(40.0, a) for a in (0.0, 72.0, 144.0, 216.0, 288.0)]
    s = Lobes(peaks, [300.0] * 5, [0.9, 0.8, 0.7, 0.6, 0.5])
    out = op.distinct_optima(s, op.Constraint(), np.array(peaks), s._f(np.array(peaks)), z, 1.0)
    assert [angle_deg(n, p) < 0.25 for (n, _), p in zip(out, peaks)] == [True, True, True] and len(out) == 3
    # a peak 12.5 deg from the best is a runner-up (the separation is 12 deg)
    p = tilted(12.5, 0.0)
    s = Lobes([p], [3000.0], [0.8])
    out = op.distinct_optima(s, op.Constraint(), np.array([p]), np.array([0.8]), z, 1.0)
    assert len(out) == 1 and angle_deg(out[0][0], p) < 0.05
    # a higher map point 5 deg away does not stop a local maximum (the neighbourhood is 4.5 deg)
    a, b = tilted(15.0, 0.0), tilted(10.0, 0.0)  # b is within 12 deg of the best: not a runner-up itself
    s = Lobes([a], [3000.0], [0.8])
    out = op.distinct_optima(s, op.Constraint(), np.array([b, a]), np.array([0.9, 0.8]), z, 1.0)
    assert len(out) == 1 and angle_deg(out[0][0], a) < 0.05


def test_distinct_optima_at_exactly_the_separation_and_the_neighbourhood():
    x, y, z = np.eye(3)
    # a runner-up exactly 90 deg (axial) from the best and from the one found before it: kept
    s = Lobes([z, y], [300.0, 300.0], [0.8, 0.7])
    out = op.distinct_optima(s, op.Constraint(), np.array([z, y]), np.array([0.8, 0.7]), x, 1.0, separation_deg=90.0)
    assert len(out) == 2 and angle_deg(out[0][0], z) < 1e-6 and angle_deg(out[1][0], y) < 1e-6
    # a higher map point exactly at the neighbourhood's edge is not a neighbour
    s = Lobes([z], [300.0], [0.7])
    out = op.distinct_optima(s, op.Constraint(), np.array([y, z]), np.array([0.9, 0.7]), y, 1.0,
                             separation_deg=90.0, neighbour_deg=90.0)
    assert len(out) == 1 and angle_deg(out[0][0], z) < 1e-6


def test_distinct_optima_floor_is_a_share_of_the_best_score_edge_included():
    z = np.array([0.0, 0.0, 1.0])
    a, b = tilted(40.0, 0.0), tilted(40.0, 180.0)
    s = Lobes([a, b], [300.0, 300.0], [0.6, 0.2])
    # best score 2: the floor is 0.3 x 2 = 0.6, which ``a`` meets exactly and ``b`` does not
    out = op.distinct_optima(s, op.Constraint(), np.array([a, b]), np.array([0.6, 0.2]), z, 2.0)
    assert len(out) == 1 and angle_deg(out[0][0], a) < 0.05


def test_a_shoulder_does_not_end_the_search_for_runners_up():
    best, other = tilted(20.0, 0.0), tilted(55.0, 180.0)
    s = Lobes([best, other], [20.0, 300.0], [1.0, 0.5])  # the wide best's shoulder cells outscore ``other``
    g = op.hemisphere_grid(2.0, op.Constraint())
    v = s._f(g)
    out = op.distinct_optima(s, op.Constraint(), g, v, best, 1.0, floor=0.05)
    assert len(out) == 1 and angle_deg(out[0][0], other) < 0.25


def test_each_runner_up_is_polished_on_a_0_25_degree_grid_within_2_degrees_and_nearby_cells_are_not():
    best, a, b = tilted(10.0, 0.0), tilted(40.0, 90.0), tilted(45.0, 250.0)
    s = Recorder([best, a, b], [300.0, 300.0, 300.0], [1.0, 0.8, 0.6])
    g = op.hemisphere_grid(2.0, op.Constraint())
    v = s._f(g)
    s.log.clear()
    # every map point a local maximum: cells near ``a`` polish onto it and are dropped, then ``b`` is found
    out = op.distinct_optima(s, op.Constraint(), g, v, best, 1.0, neighbour_deg=0.0, floor=0.5)
    assert len(out) == 2 and angle_deg(out[0][0], a) < 0.25 and angle_deg(out[1][0], b) < 0.25
    polishes = s.kinds("map")
    assert all(len(p) == 17 * 17 for p in polishes)
    # polished: the first cell, and only the cells more than 12 deg from every optimum taken before them
    order = np.argsort(v)[::-1]
    order = order[v[order] >= 0.5]
    taken, expected = [best], 0
    for i in order:
        if min(angle_deg(g[i], t) for t in taken) < 12.0:
            continue
        expected += 1
        if len(taken) == 1 and angle_deg(g[i], a) < 3.0:
            taken.append(out[0][0])
        elif len(taken) == 2 and angle_deg(g[i], b) < 3.0:
            taken.append(out[1][0])
            break
    assert len(polishes) == expected


# ---------------------------------------------------------------------- search_best's choices
def test_search_best_runs_nlopt_by_default_and_sums_its_map_once(monkeypatch):
    names = []
    monkeypatch.setattr(op, "run_optimizer", lambda name, *a, **k: names.append(name) or
                        op.OptimumResult(tilted(14.0, 77.0), 1.0, 0, name))
    s = Recorder([tilted(14.0, 77.0)], [800.0])
    op.search_best(s, op.Constraint(), "draft")
    assert names == ["nlopt"]
    grid = op.hemisphere_grid(4.0, op.Constraint())
    assert sum(len(m) == len(grid) for m in s.kinds("map")) == 1  # launched once, read once


class Fixed:
    """A scorer whose map is given: ``score`` 1 everywhere, the launched map ``map_values``, and 2 on
    any polish grid (so a polish shows in the score)."""

    objective = "energy"

    def __init__(self, map_values) -> None:
        self.map_values, self.evaluations = map_values, 0

    def score(self, normal):
        return 1.0

    def launch_energy_map(self, normals):
        v = np.zeros(len(normals))
        v[: len(self.map_values)] = self.map_values
        return Launched.ready(v)

    def energy_map(self, normals):
        return np.full(len(normals), 2.0)


@pytest.mark.parametrize("map_best, polished", [
    (1.0 + 1e-4, False),  # exactly 1e-4 better than the optimiser's point: not better enough
    (np.nextafter(1.0 + 1e-4, 2.0), True),
    (1.5, True),
    (0.9999, False),
])
def test_search_best_polishes_the_map_only_when_it_beats_the_optimiser_by_1e_4(monkeypatch, map_best, polished):
    monkeypatch.setattr(op, "run_optimizer", lambda *a, **k: op.OptimumResult(tilted(10.0), 1.0, 0, "stub"))
    out = op.search_best(Fixed([map_best]), op.Constraint(), "draft")
    assert out.score == (2.0 if polished else 1.0)


def test_the_two_rings_keep_a_quarter_step_inside_a_wide_bracket():
    # a slow fall to 1 deg, 4 deg and ~7.7 deg, a near-flat stretch predicting far beyond the 30 deg limit
    # (asked: fails just under 90 %), then regula falsi between 7.73 and 30 (22 deg wide) predicts
    # 29.99998: the upper ring is pulled a quarter step (0.0125 deg) inside the failing one
    nodes, values = [0, 0.25, 1, 4, 8, 29.99, 30], [1, 0.9999, 0.999, 0.9711, 0.9710, 0.95, 0.8999999]
    s = Rings([0, 0, 1.0], lambda a: np.interp(a, nodes, values))
    tol = op.tolerance_deg(s, np.array([0, 0, 1.0]), 1.0, op.Constraint())
    assert s.calls[:3] == [[0.0, 0.25], [1.0], [4.0]] and s.calls[4] == [30.0]
    assert 7.6 < s.calls[3][0] < 7.8
    assert s.calls[5][1] == 30.0 - 0.0125 and tol == 29.9875


def test_a_cell_whose_polish_lands_near_a_taken_optimum_is_skipped_and_the_search_goes_on():
    z = np.array([0.0, 0.0, 1.0])
    p, q = tilted(13.0, 0.0), tilted(40.0, 180.0)
    # the map's cell at 13 deg is a local maximum there, but its polish climbs the best peak's slope
    # to 11 deg, within the 12 deg separation: dropped; the cell at 40 deg is still found
    s = Lobes([z, q], [50.0, 300.0], [1.0, 0.5])
    out = op.distinct_optima(s, op.Constraint(), np.array([p, q]), np.array([0.9, 0.5]), z, 1.0, floor=0.1)
    assert len(out) == 1 and angle_deg(out[0][0], q) < 0.25


def test_adam_on_a_plateau_keeps_its_first_start():
    c = op.Constraint(60.0)
    s = Recorder([[0, 0, 1.0]], [0.0], objective="area")  # 1 everywhere, no gradient: every start ties
    res = op.optimize_gradient(s, c, starts=4, iterations=5)
    first = s.kinds("grad")[0]
    assert res.normal == pytest.approx(stereo_to_normal(*first), abs=1e-15) and res.score == 1.0


def test_lbfgs_returns_the_first_of_equally_good_points():
    class Tilted(Lobes):  # a flat value with a gradient that leads L-BFGS on to points no better
        def value_and_grad_uv(self, u, v):
            return 1.0, np.array([1.0, 0.0])

    s = Tilted([[0, 0, 1.0]], [0.0])
    assert op._local_lbfgs(s, 0.1, -0.2, op.Constraint()) == (0.1, -0.2, 1.0)
