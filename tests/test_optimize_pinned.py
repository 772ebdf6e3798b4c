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
from labcut.orientation.scoring import normal_to_stereo, stereo_jacobian, stereo_to_normal


def unit(*v: float) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    return a / np.linalg.norm(a)


def tilted(tilt_deg: float, azimuth_deg: float = 0.0) -> np.ndarray:
    t, p = math.radians(tilt_deg), math.radians(azimuth_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(unit(*a) @ unit(*b))))))


class Lobes:
    """A stand-in :class:`~labcut.orientation.scoring.Scorer`: ``sum_i w_i exp(k_i (|n.p_i| - 1))``."""

    def __init__(self, peaks, kappas, weights=None, objective: str = "energy") -> None:
        self.p = np.array([unit(*p) for p in peaks])
        self.k = np.asarray(kappas, dtype=np.float64)
        self.w = np.ones(len(self.p)) if weights is None else np.asarray(weights, dtype=np.float64)
        self.objective = objective
        self.evaluations = 0

    def _f(self, n: np.ndarray) -> np.ndarray:
        n = np.atleast_2d(np.asarray(n, dtype=np.float64))
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        return (self.w * np.exp(self.k * (np.abs(n @ self.p.T) - 1.0))).sum(axis=1)

    def score(self, normal) -> float:
        self.evaluations += 1
        return float(self._f(normal)[0])

    def scores(self, normals) -> np.ndarray:
        self.evaluations += len(normals)
        return self._f(normals)

    def score_uv(self, u: float, v: float) -> float:
        return self.score(stereo_to_normal(u, v))

    def value_and_grad_uv(self, u: float, v: float):
        self.evaluations += 1
        n = stereo_to_normal(u, v)
        d = n @ self.p.T
        g_n = ((self.w * self.k * np.sign(d) * np.exp(self.k * (np.abs(d) - 1.0)))[:, None] * self.p).sum(axis=0)
        return float(self._f(n)[0]), stereo_jacobian(u, v).T @ g_n

    def energy_map(self, normals) -> np.ndarray:
        self.evaluations += len(normals)
        return self._f(normals)

    def launch_energy_map(self, normals) -> Launched:
        return Launched.ready(self.energy_map(normals))

    def energy_batch_value_and_grad(self, us, vs):
        out = [self.value_and_grad_uv(float(u), float(v)) for u, v in zip(us, vs)]
        return np.array([o[0] for o in out]), np.array([o[1] for o in out])


def ninety_percent_deg(kappa: float) -> float:
    """The angle at which one lobe falls to 90 % of its peak."""
    return math.degrees(math.acos(1.0 + math.log(0.9) / kappa))


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
    monkeypatch.setattr(op, "optimize_grid", lambda scorer, c, coarse_deg: seen.setdefault("grid", coarse_deg))
    monkeypatch.setattr(op, "optimize_nlopt", lambda scorer, c, global_evals, seed_map: seen.setdefault("nlopt", (global_evals, seed_map)))
    monkeypatch.setattr(op, "optimize_gradient", lambda scorer, c, starts: seen.setdefault("gradient", starts))
    from labcut.scene.quality import Quality

    q = Quality.coerce("draft")
    op.run_optimizer("grid", None, None, "draft")
    op.run_optimizer("nlopt", None, None, "draft", seed_map="seeds")
    op.run_optimizer("gradient", None, None, "draft")
    assert seen == {"grid": q.grid_coarse_deg, "nlopt": (q.nlopt_evals, "seeds"), "gradient": q.gradient_starts}
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
