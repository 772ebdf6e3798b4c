"""labcut.orientation.scoring pinned to hand-computed cases (issue 37).

Tiny problems built by hand (a :class:`FlashProblem` of three triples, a lobe map of one or two
bins) whose metrics, objectives, energy maps, binning and gradients can be worked out on paper;
every Dr.Jit path is checked against the numpy path and against the hand value. Thresholds are
tested exactly at their edges (a radiance equal to the flash threshold flashes; a view's flash
area exactly :data:`COVERAGE_AREA` does not count towards coverage). Fast: no mesh, no
recommendation.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from labcut.errors import ParameterError
from labcut.orientation import scoring as S
from labcut.orientation.kernels import DEFAULT_KERNELS, KernelOptions
from labcut.orientation.problem import FlashProblem
from labcut.orientation.scoring import (
    COVERAGE_AREA,
    FlashMetrics,
    Scorer,
    SparseLobeMap,
    grid_inverse,
    normal_to_stereo,
    stereo_jacobian,
    stereo_to_normal,
)

REFERENCE = KernelOptions.reference()
KERNELS = {"numpy": REFERENCE, "drjit": DEFAULT_KERNELS}
LN2 = math.log(2.0)


def problem(kernels: KernelOptions = DEFAULT_KERNELS, **changes) -> FlashProblem:
    """Three triples in two (point, view) pairs, a third pair with no triple, three views.

    kappa = ln 2 and q_norm = 2: the lobe density q = 2 exp(ln2 (|h·m| - 1)) = 2^|h·m| is 2 at
    |h·m| = 1 and 1 at 0. Triples: h = z (c = 1, pair 0), h = x (c = 3, pair 0), h = z (c = 0.5,
    pair 1). Pairs: view (0, 1, 1), weight (0.5, 2, 4); views weighted (0.2, 0.3, 0.5).
    Threshold 1."""
    base = dict(host_h=np.array([[0, 0, 1], [1, 0, 0], [0, 0, 1]], dtype=np.float32),
                c=np.array([1.0, 3.0, 0.5], dtype=np.float32), pair=np.array([0, 0, 1], dtype=np.int32),
                pair_view=np.array([0, 1, 1]), pair_weight=np.array([0.5, 2.0, 4.0]),
                view_weight=np.array([0.2, 0.3, 0.5]), kappa=LN2, q_norm=2.0, tau=0.1, threshold=1.0,
                material=None, lights=None, views=None, convex=True, n_points=3, kernels=kernels)
    base.update(changes)
    if "h" in base:  # the host orientations (FlashProblem.host_h, read as FlashProblem.h)
        base["host_h"] = base.pop("h")
    return FlashProblem(**base)


def q_np(p: FlashProblem, m: np.ndarray) -> np.ndarray:
    """The lobe density of every triple at the unit normal m, float64."""
    return p.q_norm * np.exp(p.kappa * (np.abs(p.h.astype(np.float64) @ m) - 1.0))


def objective_np(p: FlashProblem, m: np.ndarray, objective: str, smooth: bool) -> float:
    """The objective of DESIGN.md §4 written out in float64 numpy (the reference of the Dr.Jit one)."""
    radiance = np.bincount(p.pair, weights=p.c * q_np(p, m), minlength=p.pair_view.size)
    if objective == "energy":
        return float(np.sum(p.alpha() * q_np(p, m)))
    if smooth:
        flash = 1.0 / (1.0 + np.exp(-(radiance - p.threshold) / (0.02 * p.threshold)))
    else:
        flash = (radiance >= p.threshold).astype(float)
    V = p.view_weight.size
    area_v = np.bincount(p.pair_view, weights=p.pair_weight * flash, minlength=V)
    inflash_v = np.bincount(p.pair_view, weights=p.pair_weight * flash * radiance, minlength=V)
    intensity_v = np.where(area_v > 1e-12, inflash_v / np.maximum(area_v, 1e-12), 0.0)
    area, intensity = float(p.view_weight @ area_v), float(p.view_weight @ intensity_v)
    return {"area": area, "intensity": intensity,
            "balanced": math.sqrt(max(area * intensity, 1e-20 if smooth else 0.0))}[objective]


# ---------------------------------------------------------------------- the stereographic maps
def test_stereo_to_normal_by_hand():
    """m = (2u, 2v, 1 - u² - v²)/(1 + u² + v²): the pole at 0, the equator on the unit circle,
    tilt θ at radius tan(θ/2)."""
    assert np.array_equal(stereo_to_normal(0.0, 0.0), [0.0, 0.0, 1.0])
    assert np.allclose(stereo_to_normal(1.0, 0.0), [1.0, 0.0, 0.0], rtol=0, atol=1e-15)
    assert np.allclose(stereo_to_normal(0.0, -1.0), [0.0, -1.0, 0.0], rtol=0, atol=1e-15)
    assert np.allclose(stereo_to_normal(0.5, 0.0), [0.8, 0.0, 0.6], rtol=0, atol=1e-15)
    assert np.allclose(stereo_to_normal(0.0, 0.5), [0.0, 0.8, 0.6], rtol=0, atol=1e-15)
    assert np.allclose(stereo_to_normal(0.5, -0.5), np.array([1.0, -1.0, 0.5]) / 1.5, rtol=0, atol=1e-15)
    tilt = math.radians(30.0)
    assert stereo_to_normal(math.tan(tilt / 2), 0.0)[2] == pytest.approx(math.cos(tilt), abs=1e-15)


@pytest.mark.parametrize("u, v", [(0.0, 0.0), (0.5, 0.25), (-0.3, 0.7), (0.9, -0.2)])
def test_stereo_jacobian_is_the_derivative(u, v):
    """Central differences of stereo_to_normal, column by column; at the pole exactly 2 I."""
    jac = stereo_jacobian(u, v)
    assert jac.shape == (3, 2)
    eps = 1e-6
    fd = np.stack([(stereo_to_normal(u + eps, v) - stereo_to_normal(u - eps, v)) / (2 * eps),
                   (stereo_to_normal(u, v + eps) - stereo_to_normal(u, v - eps)) / (2 * eps)], axis=1)
    assert np.allclose(jac, fd, rtol=0, atol=1e-8)


def test_stereo_jacobian_by_hand():
    assert np.array_equal(stereo_jacobian(0.0, 0.0), [[2.0, 0.0], [0.0, 2.0], [0.0, 0.0]])
    # (0.5, 0): d = 1.25, d² = 1.5625
    assert np.allclose(stereo_jacobian(0.5, 0.0), [[0.96, 0.0], [0.0, 1.6], [-1.28, 0.0]], rtol=0, atol=1e-15)
    # (0.5, 0.5): d = 1.5, d² = 2.25: [[2, -1], [-1, 2], [-2, -2]] / 2.25
    assert np.allclose(stereo_jacobian(0.5, 0.5), np.array([[2.0, -1.0], [-1.0, 2.0], [-2.0, -2.0]]) / 2.25,
                       rtol=0, atol=1e-15)


def test_normal_to_stereo_by_hand():
    """The inverse map; a normal of any length is made unit, a lower-hemisphere one is flipped
    (the lamella is axial), one on the equator is kept as it is."""
    assert normal_to_stereo(np.array([0.0, 0.0, 1.0])) == (0.0, 0.0)
    u, v = normal_to_stereo(np.array([1.6, 0.0, 1.2]))
    assert type(u) is float and type(v) is float
    assert (u, v) == pytest.approx((0.5, 0.0), abs=1e-15)
    assert normal_to_stereo(np.array([-0.8, 0.0, -0.6])) == pytest.approx((0.5, 0.0), abs=1e-15)
    assert normal_to_stereo(np.array([0.0, -0.8, -0.6])) == pytest.approx((0.0, 0.5), abs=1e-15)
    assert normal_to_stereo([0, 0, 2]) == (0.0, 0.0)
    assert normal_to_stereo(np.array([1.0, 0.0, 0.0])) == (1.0, 0.0)  # on the equator: not flipped
    assert normal_to_stereo(np.array([0.0, -1.0, 0.0])) == (0.0, -1.0)
    for uv in [(0.3, -0.4), (-0.9, 0.1)]:
        assert normal_to_stereo(stereo_to_normal(*uv)) == pytest.approx(uv, abs=1e-14)


# ---------------------------------------------------------------------- segment rows and grid keys
def test_padded_rows_sorted_and_unsorted_by_hand():
    from labcut.backend import ad_types

    _, t = ad_types()
    index, valid, width = S._padded_rows(np.array([0, 0, 2]), 3, t)
    assert width == 2
    assert np.asarray(index).tolist() == [0, 1, 0, 0, 2, 0]
    assert np.asarray(valid).tolist() == [True, True, False, False, True, False]
    index, valid, width = S._padded_rows(np.array([2, 0, 0]), 3, t)  # not sorted
    assert width == 2
    assert np.asarray(index).tolist() == [1, 2, 0, 0, 0, 0]
    assert np.asarray(valid).tolist() == [True, True, False, False, True, False]
    index, valid, width = S._padded_rows(np.array([1, 0]), 2, t)  # two, not sorted
    assert width == 1
    assert np.asarray(index).tolist() == [1, 0] and np.asarray(valid).tolist() == [True, True]
    index, valid, width = S._padded_rows(np.array([1]), 2, t)
    assert (width, np.asarray(index).tolist(), np.asarray(valid).tolist()) == (1, [0, 0], [False, True])
    index, valid, width = S._padded_rows(np.zeros(0, dtype=np.int64), 2, t)  # no owner at all: width 1, all empty
    assert (width, np.asarray(valid).tolist()) == (1, [False, False])


def test_padded_rows_in_chunks(monkeypatch):
    """Sorted owners placed CHUNK positions at a time: the same rows as in one pass."""
    from labcut.backend import ad_types

    _, t = ad_types()
    owner = np.array([0, 0, 0, 1, 3, 3, 3, 3])
    want = ([0, 1, 2, 0, 3, 0, 0, 0, 0, 0, 0, 0, 4, 5, 6, 7],
            [True] * 3 + [False] + [True] + [False] * 7 + [True] * 4)
    for chunk in (3, 1, 100):
        monkeypatch.setattr(S, "CHUNK", chunk)
        index, valid, width = S._padded_rows(owner, 4, t)
        assert width == 4
        assert (np.asarray(index).tolist(), np.asarray(valid).tolist()) == want


def test_device_grid_keys_by_hand():
    """Cells of a bins x bins stereographic grid of [-1, 1]²: iu = floor((u + 1) bins / 2) clipped
    to [0, bins - 1], key iu bins + iv; the same as the numpy binning's keys."""
    from labcut.backend import ad_types

    _, t = ad_types()
    h = np.array([[0, 0, 1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0.8, 0, 0.6], [0, -0.8, 0.6]],
                 dtype=np.float32)
    keys = S._device_grid_keys(t.Array3f(*(np.ascontiguousarray(h[:, k]) for k in range(3))), 4)
    # u = 0.5 (0.8/1.6): (1.5) x 2 = 3; v = -0.5: 0.5 x 2 = 1
    assert keys.dtype == np.int32
    assert keys.tolist() == [2 * 4 + 2, 3 * 4 + 2, 0 * 4 + 2, 2 * 4 + 3, 2 * 4 + 0, 3 * 4 + 2, 2 * 4 + 1]
    assert S._device_grid_keys(t.Array3f(*(np.ascontiguousarray(h[:, k]) for k in range(3))), 5).tolist() == \
        [12, 22, 2, 14, 10, 17, 11]


def test_grid_inverse_by_hand(monkeypatch):
    key = np.array([[5, 2], [5, 9]])
    for limit in (S.DENSE_KEY_LIMIT, 10, 9):  # dense bincount, exactly at the limit, and the sort
        monkeypatch.setattr(S, "DENSE_KEY_LIMIT", limit)
        got = grid_inverse(key, 10)
        assert got.dtype == np.int64 and got.tolist() == [1, 0, 1, 2]
    assert grid_inverse(np.array([0, 0, 0]), 1).tolist() == [0, 0, 0]
    assert grid_inverse(np.array([3, 0]), 4).tolist() == [1, 0]


def test_grid_inverse_sorts_only_past_the_dense_limit(monkeypatch):
    calls = []
    real = np.unique

    def spy(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(S, "DENSE_KEY_LIMIT", 10)
    monkeypatch.setattr(S.np, "unique", spy)
    grid_inverse(np.array([1, 3]), 10)
    assert calls == []
    grid_inverse(np.array([1, 3]), 11)
    assert calls == [1]


# ---------------------------------------------------------------------- lobe sums
def test_cos_matrix_and_lobe_sums_by_hand():
    m = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    ht = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, -1.0]])  # h = z, x, -z
    assert np.allclose(S._cos_matrix(m, ht), [[1.0, 0.0, -1.0], [0.8, 0.6, -0.8]], rtol=0, atol=1e-15)
    a = np.array([1.0, 2.0, 4.0])
    # Σ a exp(ln2 (|cos| - 1)) = Σ a 2^(|cos| - 1): (1 + 2 x 0.5 + 4) and (2^-0.2 + 2 x 2^-0.4 + 4 x 2^-0.2)
    got = S._lobe_sums(m, ht, a, LN2)
    assert got == pytest.approx([6.0, 5 * 2 ** -0.2 + 2 * 2 ** -0.4], rel=1e-14)


# ---------------------------------------------------------------------- FlashMetrics
def test_flash_metrics_from_views_by_hand():
    fm = FlashMetrics.from_views([0.5, 0.2, 0.0], [4.0, 1.0, 0.0], [2.0, 1.0, 0.5], [0.5, 0.25, 0.25])
    assert fm.flash_area == pytest.approx(0.3, abs=1e-15)
    assert fm.flash_intensity == pytest.approx(2.25, abs=1e-15)
    assert fm.flash_energy == pytest.approx(1.375, abs=1e-15)
    assert fm.coverage == 0.75
    assert fm.balanced == pytest.approx(math.sqrt(0.3 * 2.25), abs=1e-15)
    assert fm.per_view == {"flash_area": [0.5, 0.2, 0.0], "flash_intensity": [4.0, 1.0, 0.0],
                           "flash_energy": [2.0, 1.0, 0.5], "weight": [0.5, 0.25, 0.25]}
    assert fm.visible_area_mm2 is None and fm.flash_area_mm2 is None
    assert [fm.score(o) for o in ("energy", "area", "intensity", "balanced")] == \
        [fm.flash_energy, fm.flash_area, fm.flash_intensity, fm.balanced]
    with pytest.raises(KeyError):
        fm.score("coverage")
    assert fm.to_dict() == {"flash_area": fm.flash_area, "flash_intensity": fm.flash_intensity,
                            "flash_energy": fm.flash_energy, "coverage": 0.75, "balanced": fm.balanced,
                            "per_view": fm.per_view, "visible_area_mm2": None, "flash_area_mm2": None}


def test_coverage_counts_views_strictly_above_five_percent():
    assert COVERAGE_AREA == 0.05
    at = FlashMetrics.from_views([0.05, math.nextafter(0.05, 1.0), 0.049], [1, 1, 1], [1, 1, 1], [0.25, 0.5, 0.25])
    assert at.coverage == 0.5


def test_flash_metrics_visible_areas():
    fm = FlashMetrics.from_views([0.5, 0.25], [1, 1], [1, 1], [0.25, 0.75], view_area_mm2=[100.0, 40.0])
    assert fm.visible_area_mm2 == pytest.approx(0.25 * 100 + 0.75 * 40, abs=1e-12)
    assert fm.flash_area_mm2 == pytest.approx(0.25 * 50 + 0.75 * 10, abs=1e-12)
    wrong = FlashMetrics.from_views([0.5, 0.25], [1, 1], [1, 1], [0.25, 0.75], view_area_mm2=[100.0])
    assert wrong.visible_area_mm2 is None and wrong.flash_area_mm2 is None


def test_balanced_of_a_negative_product_is_zero():
    fm = FlashMetrics.from_views([-0.5], [1.0], [0.0], [1.0])
    assert fm.balanced == 0.0


def test_flash_metrics_repr_and_html():
    fm = FlashMetrics.from_views([0.5, 0.2], [4.0, 1.0], [2.0, 1.0], [0.5, 0.5])
    assert repr(fm) == "FlashMetrics(area=35.0%, intensity=2.500, energy=1.5000, coverage=100%, views=2)"
    html = fm._repr_html_()
    assert html == ("<table><thead><tr><th>flash metric</th><th>value</th></tr></thead><tbody>"
                    "<tr><td>flash area</td><td style='text-align:right'>35.0%</td></tr>"
                    "<tr><td>flash intensity</td><td style='text-align:right'>2.500</td></tr>"
                    "<tr><td>flash energy</td><td style='text-align:right'>1.5000</td></tr>"
                    "<tr><td>coverage</td><td style='text-align:right'>100%</td></tr>"
                    "<tr><td>balanced</td><td style='text-align:right'>0.9354</td></tr></tbody></table>")
    empty = FlashMetrics(0.0, 0.0, 0.0, 0.0, 0.0, {})
    assert repr(empty).endswith("views=0)")


# ---------------------------------------------------------------------- the scorer on the toy problem
@pytest.mark.parametrize("which", list(KERNELS))
def test_metrics_of_the_toy_problem_by_hand(which):
    """At m = z: q = (2, 1, 2); c q = (2, 3, 1); pair radiances (5, 1, 0). Pair 1's radiance is exactly
    the threshold 1: it flashes. Per view: area (0.5, 2, 0), energy (2.5, 2, 0), intensity (5, 1, 0);
    view-weighted: area 0.7, intensity 1.3, energy 1.1; coverage 0.2 + 0.3 (the third view has no
    flash); balanced sqrt(0.91). The normal (0, 0, 3) is made unit."""
    p = problem(KERNELS[which], info={"view_area_mm2": [10.0, 20.0, 30.0]})
    fm = Scorer(p, "area").metrics(np.array([0.0, 0.0, 3.0]))
    assert fm.per_view["flash_area"] == [0.5, 2.0, 0.0]
    assert fm.per_view["flash_energy"] == pytest.approx([2.5, 2.0, 0.0], rel=1e-15)
    assert fm.per_view["flash_intensity"] == pytest.approx([5.0, 1.0, 0.0], rel=1e-15)
    assert fm.per_view["weight"] == [0.2, 0.3, 0.5]
    assert fm.flash_area == pytest.approx(0.7, rel=1e-15)
    assert fm.flash_intensity == pytest.approx(1.3, rel=1e-15)
    assert fm.flash_energy == pytest.approx(1.1, rel=1e-15)
    assert fm.coverage == pytest.approx(0.5, rel=1e-15)
    assert fm.balanced == pytest.approx(math.sqrt(0.91), rel=1e-15)
    assert fm.visible_area_mm2 == pytest.approx(2 + 6 + 15, rel=1e-15)
    assert fm.flash_area_mm2 == pytest.approx(0.2 * 5 + 0.3 * 40, rel=1e-15)
    assert Scorer(problem(KERNELS[which])).metrics(np.array([0.0, 0.0, 1.0])).visible_area_mm2 is None


@pytest.mark.parametrize("which", list(KERNELS))
def test_metrics_threshold_and_coverage_at_their_edges(which):
    """A radiance just under the threshold does not flash; a view's area of exactly 0.05 is not
    coverage, just above it is."""
    p = problem(KERNELS[which], threshold=float(np.nextafter(np.float32(1.0), np.float32(2.0))))
    fm = Scorer(p).metrics(np.array([0.0, 0.0, 1.0]))
    assert fm.per_view["flash_area"] == [0.5, 0.0, 0.0]
    assert fm.flash_intensity == pytest.approx(1.0, rel=1e-15)  # view 0 only: 0.2 x 5
    p = problem(KERNELS[which], pair_weight=np.array([0.05, 0.05000000000000001, 4.0]))
    fm = Scorer(p).metrics(np.array([0.0, 0.0, 1.0]))
    assert fm.per_view["flash_area"] == [0.05, 0.05000000000000001, 0.0]
    assert fm.coverage == pytest.approx(0.3, rel=1e-15)


@pytest.mark.parametrize("which", list(KERNELS))
@pytest.mark.parametrize("objective, want", [("energy", 1.1), ("area", 0.7), ("intensity", 1.3),
                                             ("balanced", math.sqrt(0.91))])
def test_scores_of_the_toy_problem_by_hand(which, objective, want):
    s = Scorer(problem(KERNELS[which]), objective)
    assert s.objective == objective and s.n_pairs == 3 and s.n_views == 3
    assert s.score(np.array([0.0, 0.0, 2.0])) == pytest.approx(want, rel=1e-6)
    assert s.score(np.array([0.0, 0.0, -1.0])) == pytest.approx(want, rel=1e-6)  # axial
    assert s.score_uv(0.0, 0.0) == pytest.approx(want, rel=1e-6)
    assert s.evaluations == 3
    # at m = x: q = (1, 2, 1): radiances (1 + 6, 0.5, 0): area (0.5, 0, 0), energy 0.2 x 3.5 + 0.3 x 1
    at_x = {"energy": 1.0, "area": 0.1, "intensity": 1.4, "balanced": math.sqrt(0.14)}[objective]
    assert s.score_uv(1.0, 0.0) == pytest.approx(at_x, rel=1e-6)
    assert s.score(np.array([1.0, 0.0, 0.0])) == pytest.approx(at_x, rel=1e-6)
    got = s.scores(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]))
    assert got.shape == (2,) and got == pytest.approx([want, at_x], rel=1e-6)
    assert s.scores(np.array([0.0, 0.0, 1.0])) == pytest.approx([want], rel=1e-6)


@pytest.mark.parametrize("which", list(KERNELS))
@pytest.mark.parametrize("objective", ["energy", "area", "intensity", "balanced"])
def test_scores_equal_the_numpy_objective_off_axis(which, objective):
    p = problem(KERNELS[which], threshold=1.3)
    s = Scorer(p, objective)
    for uv in [(0.3, -0.2), (0.7, 0.4), (-0.5, 0.1)]:
        m = stereo_to_normal(*uv)
        assert s.score_uv(*uv) == pytest.approx(objective_np(p, m, objective, False), rel=2e-6, abs=1e-7)


def test_an_unknown_objective_is_refused():
    with pytest.raises(ParameterError, match=r"^objective must be one of energy, area, intensity, balanced, got 'flash'$") as e:
        Scorer(problem(), "flash")
    assert e.value.parameter == "objective"


@pytest.mark.parametrize("which", list(KERNELS))
def test_smooth_objectives_at_the_pole_by_hand(which):
    """The logistic step of width 0.02 τ: radiances (5, 1, 0) at τ = 1 flash (1, 1/2, ~2e-22); area
    0.2 x 0.5 + 0.3 x 2 x 0.5 = 0.4; intensity 0.2 x 5 + 0.3 x (2 x 0.5 x 1)/(2 x 0.5) = 1.3 (the third
    view's area, 4 x 2e-22 < 1e-12, counts as none); balanced sqrt(0.52)."""
    p = problem(KERNELS[which])
    for objective, want in [("area", 0.4), ("intensity", 1.3), ("balanced", math.sqrt(0.52))]:
        value, grad = Scorer(p, objective).value_and_grad_uv(0.0, 0.0)
        assert value == pytest.approx(want, rel=1e-6)
        assert grad.shape == (2,)


@pytest.mark.parametrize("which", list(KERNELS))
@pytest.mark.parametrize("objective", ["energy", "area", "intensity", "balanced"])
def test_smooth_values_and_gradients_equal_the_numpy_objective(which, objective):
    p = problem(KERNELS[which], threshold=1.3)
    s = Scorer(p, objective)
    eps = 1e-6
    for uv in [(0.3, -0.2), (0.45, 0.4), (-0.5, 0.1)]:
        value, grad = s.value_and_grad_uv(*uv)
        assert value == pytest.approx(objective_np(p, stereo_to_normal(*uv), objective, True), rel=2e-6, abs=1e-7)
        fd = [(objective_np(p, stereo_to_normal(uv[0] + eps * du, uv[1] + eps * dv), objective, True)
               - objective_np(p, stereo_to_normal(uv[0] - eps * du, uv[1] - eps * dv), objective, True)) / (2 * eps)
              for du, dv in ((1, 0), (0, 1))]
        assert np.allclose(grad, fd, rtol=2e-3, atol=2e-4), (uv, grad, fd)
    assert s.evaluations == 3


@pytest.mark.parametrize("which", list(KERNELS))
def test_balanced_where_nothing_flashes(which):
    """Hard threshold: 0; smooth: the floor 1e-20 under the square root (1e-10), with a finite gradient."""
    p = problem(KERNELS[which], threshold=100.0)
    s = Scorer(p, "balanced")
    assert s.score_uv(0.2, 0.1) == 0.0
    value, grad = s.value_and_grad_uv(0.2, 0.1)
    assert value == pytest.approx(1e-10, rel=1e-5)
    assert np.all(np.isfinite(grad))
    assert Scorer(p, "intensity").score_uv(0.2, 0.1) == 0.0


def test_energy_value_and_gradient_by_hand():
    """Energy weights alpha = c x pair weight x view weight = (0.1, 0.3, 0.3): bins z (0.4), x (0.3).
    At (u, v) = (0.5, 0): m = (0.8, 0, 0.6), E = 0.4 x 2^0.6 + 0.3 x 2^0.8; dE/dm = ln2 (0.3 x 2^0.8,
    0, 0.4 x 2^0.6); through the Jacobian [[0.96, 0], [0, 1.6], [-1.28, 0]]."""
    s = Scorer(problem(REFERENCE))
    value, grad = s.value_and_grad_uv(0.5, 0.0)
    assert value == pytest.approx(0.4 * 2 ** 0.6 + 0.3 * 2 ** 0.8, rel=1e-7)
    assert grad == pytest.approx([LN2 * (0.96 * 0.3 * 2 ** 0.8 - 1.28 * 0.4 * 2 ** 0.6), 0.0], rel=1e-7, abs=1e-12)
    assert s.evaluations == 1
    value, grad = s.value_and_grad_uv(0.0, 0.0)
    assert value == pytest.approx(1.1, rel=1e-7) and grad == pytest.approx([0.0, 0.0], abs=1e-12)


@pytest.mark.parametrize("which", list(KERNELS))
def test_energy_maps_by_hand(which):
    """E(m) = 0.4 x 2^|m_z| + 0.3 x 2^|m_x|: every form of the map (sparse, launched, dense on the
    device, the batch with gradients) gives it; each counts its normals."""
    s = Scorer(problem(KERNELS[which]))
    uvs = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.0], [0.3, -0.6], [-0.2, 0.9]])
    normals = np.array([stereo_to_normal(*uv) for uv in uvs])
    want = 0.4 * 2 ** np.abs(normals[:, 2]) + 0.3 * 2 ** np.abs(normals[:, 0])
    assert s.energy_map(normals) == pytest.approx(want, rel=1e-12)
    assert s.evaluations == 5
    assert s.launch_energy_map(normals).value == pytest.approx(want, rel=1e-12)
    assert s.evaluations == 10
    assert s.energy_map_dense(normals) == pytest.approx(want, rel=1e-6)
    assert s.evaluations == 15
    assert s.energy_map(normals[0]) == pytest.approx(want[:1], rel=1e-12)
    values, grads = s.energy_batch_value_and_grad(uvs[:, 0], uvs[:, 1])
    assert s.evaluations == 21
    assert values == pytest.approx(want, rel=1e-6)
    for (u, v), g in zip(uvs, grads):
        m = stereo_to_normal(u, v)
        g_m = LN2 * (0.4 * 2 ** abs(m[2]) * np.sign(m[2]) * np.array([0, 0, 1.0])
                     + 0.3 * 2 ** abs(m[0]) * np.sign(m[0]) * np.array([1.0, 0, 0]))
        assert g == pytest.approx(stereo_jacobian(u, v).T @ g_m, rel=1e-5, abs=1e-6)


def test_energy_of_the_other_objectives_reads_the_same_bins():
    """The energy map of an area scorer is the energy too (the bins do not depend on the objective);
    the batch and the dense map are the same numbers."""
    s = Scorer(problem(), "area")
    normals = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    want = 0.4 * 2 ** normals[:, 2] + 0.3 * 2 ** normals[:, 0]
    assert s.energy_map(normals) == pytest.approx(want, rel=1e-12)
    assert s.energy_map_dense(normals) == pytest.approx(want, rel=1e-6)


# ---------------------------------------------------------------------- the binning
@pytest.mark.parametrize("which", ["numpy", "keys", "drjit"])
def test_bins_of_the_toy_problem_by_hand(which):
    options = {"numpy": REFERENCE, "keys": KernelOptions(bins=False), "drjit": DEFAULT_KERNELS}[which]
    s = Scorer(problem(options))
    hb, ab = s._bin_triples()
    assert hb.tolist() == [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]  # ascending key order: z's cell (256, 256) < x's (511, 256)
    assert ab == pytest.approx([0.4, 0.3], rel=1e-15)
    assert s._bins_numpy() is s._bins_numpy()
    assert s.n_bins == 2 and np.asarray(s.bin_a).tolist() == pytest.approx([0.4, 0.3], rel=1e-7)
    assert np.asarray(s.bin_h).tolist() == [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]] or \
        np.asarray(s.bin_h).T.tolist() == [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]
    assert int(np.asarray(s._nb)[0] if np.ndim(np.asarray(s._nb)) else np.asarray(s._nb)) == 2
    assert s._binned() is s._binned()
    assert s.sparse_map is s.sparse_map and s.sparse_map.kernels is options
    assert (s.sparse_map.kappa, s.sparse_map.norm) == (LN2, 2.0)


def random_problem(kernels: KernelOptions, n: int = 3000, kappa: float = 400.0, seed: int = 5,
                   zeros: bool = True) -> FlashProblem:
    """Many triples over the upper hemisphere in 40 pairs of 4 views, some with zero weight."""
    rng = np.random.default_rng(seed)
    h = rng.normal(size=(n, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h[:, 2] = np.abs(h[:, 2])
    c = rng.random(n).astype(np.float32)
    if zeros:
        c[::7] = 0.0
    pair = np.sort(rng.integers(0, 40, n)).astype(np.int32)
    pair_view = np.arange(40) % 4
    return problem(kernels, h=h.astype(np.float32), c=c, pair=pair, pair_view=pair_view,
                   pair_weight=rng.random(40), view_weight=np.array([0.1, 0.2, 0.3, 0.4]), kappa=kappa,
                   q_norm=kappa / (2 * math.pi * (1 - math.exp(-kappa))))


def reference_bins(p: FlashProblem, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """The binning written out: each triple's cell of the bins x bins grid of (h_x, h_y)/(1 + h_z) on
    [-1, 1]² (float32), the positive weights summed per occupied cell in ascending cell order, the weighted
    directions' sums normalised."""
    alpha = p.c.astype(np.float64) * p.pair_weight[p.pair] * p.view_weight[p.pair_view[p.pair]]
    h32 = p.h[alpha > 0]
    h = h32.astype(np.float64)
    a = alpha[alpha > 0]
    one, half = np.float32(1.0), np.float32(0.5)  # the cells in float32, as the triples are stored
    cell = [np.clip(np.floor((h32[:, k] / (one + h32[:, 2]) + one) * half * np.float32(bins)), 0, bins - 1)
            for k in (0, 1)]
    key = cell[0].astype(np.int64) * bins + cell[1].astype(np.int64)
    keys, inv = np.unique(key, return_inverse=True)
    weight = np.bincount(inv, weights=a)
    centroid = np.stack([np.bincount(inv, weights=a * h[:, k]) for k in range(3)], axis=1)
    return centroid / np.linalg.norm(centroid, axis=1, keepdims=True), weight


@pytest.mark.parametrize("which", ["numpy", "keys", "drjit"])
@pytest.mark.parametrize("kappa, bins", [(400.0, 640), (10.0, 512), (300_000.0, 16384)])
def test_bins_equal_the_written_out_binning(which, kappa, bins):
    """Cells at most 1/8 of the lobe width: 32 sqrt(κ) cells across, at least 512, at most 16384."""
    options = {"numpy": REFERENCE, "keys": KernelOptions(bins=False), "drjit": DEFAULT_KERNELS}[which]
    p = random_problem(options, kappa=kappa)
    hb, ab = Scorer(p)._bin_triples()
    want_h, want_a = reference_bins(p, bins)
    assert len(ab) == len(want_a)
    assert np.allclose(ab, want_a, rtol=1e-12, atol=1e-15)
    # the device's fixed-point sums: a light bin's direction within 2^-61 x total / weight
    assert np.allclose(hb, want_h, rtol=0, atol=1e-9 if which == "drjit" else 1e-12)


@pytest.mark.parametrize("which", ["numpy", "keys", "drjit"])
def test_bins_in_chunks_and_past_the_dense_limit(which, monkeypatch):
    """Chunks of 100 triples (a pair split between two), and a grid past the dense key limit
    (the distinct keys sorted): the same bins."""
    options = {"numpy": REFERENCE, "keys": KernelOptions(bins=False), "drjit": DEFAULT_KERNELS}[which]
    p = random_problem(options, n=1000)
    want_h, want_a = reference_bins(p, 640)
    for chunk, limit in [(100, S.DENSE_KEY_LIMIT), (S.CHUNK, 640 * 640), (S.CHUNK, 640 * 640 - 1), (100, 1000)]:
        monkeypatch.setattr(S, "CHUNK", chunk)
        monkeypatch.setattr(S, "DENSE_KEY_LIMIT", limit)
        hb, ab = Scorer(p)._bin_triples()
        assert len(ab) == len(want_a), (chunk, limit)
        assert np.allclose(ab, want_a, rtol=1e-12, atol=1e-15)
        assert np.allclose(hb, want_h, rtol=0, atol=1e-9 if which == "drjit" else 1e-12)


@pytest.mark.parametrize("which", ["numpy", "keys", "drjit"])
def test_no_positive_weight_no_bins(which):
    """Every weight zero: one empty bin at the pole, and an energy of zero everywhere."""
    options = {"numpy": REFERENCE, "keys": KernelOptions(bins=False), "drjit": DEFAULT_KERNELS}[which]
    s = Scorer(problem(options, c=np.zeros(3, dtype=np.float32)))
    hb, ab = s._bin_triples()
    assert hb.tolist() == [[0.0, 0.0, 1.0]] and ab.tolist() == [0.0]
    assert s.energy_map(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])).tolist() == [0.0, 0.0]


def test_fixed_point_bin_sums_by_hand():
    """The device's bin sums are integers in units of 2^-S, S = 62 - 1 - max(0, ceil(log2 Σ alpha)):
    a total of 0.75 + tiny gives S = 61, so weights 1.4 and 0.75 units round to 1 unit each (S = 62
    would give 3 and 2 halves, S = 60 none and 1); a weight 2^-64 rounds to nothing and its bin is
    dropped. A total of 3 (S = 59) rounds 1.4 units of 2^-61 to 0 and 0.75 x 2^-59 to 2^-59."""
    unit = 2.0 ** -61
    h = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], dtype=np.float32)
    weight = np.array([0.5, 0.25, 1.4 * unit, 0.75 * unit, 2.0 ** -64])
    p = problem(DEFAULT_KERNELS, h=h, c=np.ones(5, dtype=np.float32), pair=np.arange(5, dtype=np.int32),
                pair_view=np.zeros(5, dtype=np.int64), pair_weight=weight, view_weight=np.array([1.0]))
    hb, ab = Scorer(p)._bin_triples()
    # ascending key order at 512 cells: -x (0, 256), -y (256, 0), z (256, 256), +y (256, 511), +x (511, 256)
    assert hb.tolist() == [[-1, 0, 0], [0, 0, 1], [0, 1, 0], [1, 0, 0]]
    assert ab.tolist() == [unit, 0.5, unit, 0.25]
    hn, an = Scorer(replace(p, kernels=REFERENCE))._bin_triples()
    assert an.tolist() == [0.75 * unit, 2.0 ** -64, 0.5, 1.4 * unit, 0.25]  # float64 keeps every weight
    big = replace(p, pair_weight=np.array([2.0, 1.0, 1.4 * unit, 0.75 * 4 * unit, 0.0]))
    hb, ab = Scorer(big)._bin_triples()
    assert ab.tolist() == [4 * unit, 2.0, 1.0]
    assert hb.tolist() == [[-1, 0, 0], [0, 0, 1], [1, 0, 0]]


def test_fixed_point_directions_by_hand():
    """A bin's direction is its weighted mean direction: two triples of weights 0.5 and 0.25 at
    (0.6, 0, 0.8) and (0.8, 0, 0.6) in one cell of a coarse grid... the grid is fine (512 cells):
    their cells differ, so two bins; then the same cell: h = (0.6, 0, 0.8) and (0.6, 0.001, 0.8)."""
    h = np.array([[0.6, 0.0, 0.8], [0.6, 0.0008, 0.8]], dtype=np.float32)
    for options in (DEFAULT_KERNELS, REFERENCE):
        p = problem(options, h=h, c=np.ones(2, dtype=np.float32), pair=np.array([0, 1], dtype=np.int32),
                    pair_view=np.zeros(2, dtype=np.int64), pair_weight=np.array([0.5, 0.25]), view_weight=np.array([1.0]))
        hb, ab = Scorer(p)._bin_triples()
        want = 0.5 * h[0].astype(np.float64) + 0.25 * h[1].astype(np.float64)
        assert ab == pytest.approx([0.75], rel=1e-15)
        assert hb[0] == pytest.approx(want / np.linalg.norm(want), abs=1e-15)


# ---------------------------------------------------------------------- the sparse lobe map
def lobe_norm(kappa: float) -> float:
    return kappa / (2 * math.pi * (1 - math.exp(-kappa)))


def test_empty_maps_are_zero():
    for h, a in [(np.zeros((0, 3)), np.zeros(0)), (np.array([[0.0, 0.0, 1.0]]), np.zeros(1))]:
        sm = SparseLobeMap(h, a, 100.0, 1.0)
        assert sm.n_tiles == 0 and sm.cos_cut == -1.0
        assert sm(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])).tolist() == [0.0, 0.0]
        assert sm.value_and_grad(np.array([0.0, 0.0, 1.0]))[0] == 0.0
        assert sm.value_and_grad(np.array([0.0, 0.0, 1.0]))[1].tolist() == [0.0, 0.0, 0.0]
        assert sm.launch(np.array([[0.0, 0.0, 1.0]])).value.tolist() == [0.0]
    sm = SparseLobeMap(np.array([[0.0, 0.0, 1.0]]), np.ones(1), 100.0, 1.0)
    assert sm(np.zeros((0, 3))).tolist() == []


def test_one_bin_map_by_hand_and_its_cut():
    """One bin at the pole, weight 1, κ = 100, norm 1: the best energy is 1 (at the bin), so the
    lobe is cut at T = ln(1 / 1e-8) = 18.42 (> 12.5): cos_cut = 1 - T/100; the bin's tile has radius
    1e-6; the device's cut at T = ln(1e6). A normal just inside the reach gets its term exactly,
    just beyond it none (on either side: the lobe is axial)."""
    kappa = 100.0
    sm = SparseLobeMap(np.array([[0.0, 0.0, 1.0]]), np.ones(1), kappa, 1.0)
    t_cut = math.log(1e8)
    assert sm.cos_cut == pytest.approx(1.0 - t_cut / kappa, rel=1e-14)
    cut = math.acos(1.0 - t_cut / kappa)
    assert sm.cos_reach == pytest.approx([math.cos(cut + 1e-6)], rel=1e-12)
    assert sm.cos_reach_device == pytest.approx([math.cos(math.acos(1.0 - math.log(1e6) / kappa) + 1e-6)], rel=1e-12)
    assert sm.n_tiles == 1
    for theta, inside in [(cut, True), (cut + 0.9e-6, True), (cut + 1.1e-6, False), (cut + 1e-3, False)]:
        for sign in (1.0, -1.0):
            m = sign * np.array([[math.sin(theta), 0.0, math.cos(theta)]])
            want = math.exp(kappa * (math.cos(theta) - 1.0)) if inside else 0.0
            for path in ("auto", "union", "tiles"):
                assert sm(m, path=path)[0] == pytest.approx(want, rel=1e-12, abs=0), (theta, path)
            value, grad = sm.value_and_grad(m[0])
            assert value == pytest.approx(want, rel=1e-12, abs=0)
            assert grad == pytest.approx(sign * kappa * want * np.array([0.0, 0.0, 1.0]), rel=1e-12, abs=0)
    dev_cut = math.acos(1.0 - math.log(1e6) / kappa)
    for theta, inside in [(dev_cut, True), (dev_cut + 2e-6, False)]:
        m = np.array([[math.sin(theta), 0.0, math.cos(theta)]])
        want = math.exp(kappa * (math.cos(theta) - 1.0)) if inside else 0.0
        assert sm(m, path="device")[0] == pytest.approx(want, rel=1e-5, abs=0)


def test_the_cut_scales_with_the_norm_the_total_and_the_rtol():
    """T = max(12.5, ln(norm x total / (rtol x lower))): weights 2 and 3 far apart at κ = 200, norm 5:
    the best probe energy is 5 x 3 (the heavier bin), total 5; T = ln(25 / (1e-8 x 15)); a large
    rtol floors T at 12.5 (the device's cut too)."""
    h = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    a = np.array([2.0, 3.0])
    sm = SparseLobeMap(h, a, 200.0, 5.0)
    t_cut = math.log(5 * 5 / (1e-8 * 15))
    assert sm.cos_cut == pytest.approx(1 - t_cut / 200, rel=1e-13)
    assert sm.cos_reach_device == pytest.approx(
        [math.cos(math.acos(1 - math.log(5 * 5 / (1e-6 * 15)) / 200) + 1e-6)] * 2, rel=1e-12)
    loose = SparseLobeMap(h, a, 200.0, 5.0, rtol=0.1)
    assert loose.cos_cut == pytest.approx(1 - 12.5 / 200, rel=1e-14)
    assert loose.cos_reach_device == pytest.approx([math.cos(math.acos(1 - 12.5 / 200) + 1e-6)] * 2, rel=1e-12)
    tight = SparseLobeMap(h, a, 200.0, 5.0, kernels=KernelOptions(map_kernel_rtol=1e-9))  # the device's cut no looser than numpy's
    assert tight.cos_reach_device == pytest.approx(tight.cos_reach, rel=1e-14)


def test_the_lower_bound_comes_from_the_sixteen_heaviest_bins():
    """Twenty bins: one of weight 10 at the pole and nineteen light ones (weight 0.01 + ...) spread on
    the equator: the lower bound is the pole's energy, 10 x norm."""
    t = np.linspace(0, 2 * math.pi, 19, endpoint=False)
    h = np.vstack([[0.0, 0.0, 1.0], np.stack([np.cos(t), np.sin(t), np.zeros(19)], axis=1)])
    a = np.r_[10.0, 0.01 + 0.001 * np.arange(19)]
    kappa = 300.0
    sm = SparseLobeMap(h, a, kappa, 1.0)
    lower = float(sm.dense(h[:1])[0])
    assert lower == pytest.approx(10.0, rel=1e-12)
    assert sm.cos_cut == pytest.approx(1 - math.log(a.sum() / (1e-8 * lower)) / kappa, rel=1e-13)
    heavy_last = SparseLobeMap(h[::-1].copy(), a[::-1].copy(), kappa, 1.0)
    assert heavy_last.cos_cut == sm.cos_cut


def test_tiles_and_their_radii():
    """Tiles about a quarter of the cut across: ceil(16/cut) cells of the stereographic grid, between
    4 and 128; a tile's centre is its bins' mean direction, its radius its farthest bin's angle from
    the centre (plus 1e-6). κ = 50: cut = acos(1 - T/50) near 0.89 rad: 18 or 19 cells across; the
    pole sits in cell 9 of either, a bin at u = 0.04 too, one at u = 0.15 in cell 10 of either."""
    kappa = 50.0
    a = np.ones(2)
    for x, tiles in [(0.08, 1), (0.3, 2)]:
        m = np.array([[0.0, 0.0, 1.0], [x, 0.0, 1.0]])
        m /= np.linalg.norm(m, axis=1, keepdims=True)
        sm = SparseLobeMap(m, a, kappa, 1.0)
        t_cut = math.log(2.0 / (1e-8 * float(sm.dense(m).max())))
        cut = math.acos(1 - t_cut / kappa)
        g = math.ceil(16 / cut)
        assert g in (18, 19)
        u = m[1, 0] / (1 + m[1, 2])
        assert int((u + 1) * 0.5 * g) == (9 if tiles == 1 else 10)
        assert sm.n_tiles == tiles
        if tiles == 1:
            centre = m.sum(axis=0) / np.linalg.norm(m.sum(axis=0))
            radius = math.acos(float(m[1] @ centre)) + 1e-6
            assert sm.centre == pytest.approx(centre[None, :], abs=1e-15)
            assert sm.cos_reach == pytest.approx([math.cos(radius + cut)], rel=1e-12)
        else:
            # a one-bin tile's radius: 1e-6 and the arccos of its rounded cos 1 (up to 2e-8)
            assert sm.cos_reach == pytest.approx([math.cos(1e-6 + cut)] * 2, rel=0, abs=3e-8)
    # narrow lobes: at most 128 cells across; the broadest: cut = π, ceil(16/π) = 6
    rng = np.random.default_rng(0)
    h = rng.normal(size=(20000, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h[:, 2] = np.abs(h[:, 2])

    def cells(g):
        u, v = h[:, 0] / (1 + h[:, 2]), h[:, 1] / (1 + h[:, 2])
        return len({(int((a + 1) * 0.5 * g), int((b + 1) * 0.5 * g)) for a, b in zip(u, v)})

    assert SparseLobeMap(h, np.ones(len(h)), 1e6, 1.0).n_tiles == cells(128) != cells(129)
    assert SparseLobeMap(h, np.ones(len(h)), 0.5, 1.0).n_tiles == cells(6) == 36


def test_broad_lobes_reach_every_normal():
    """κ = 5: the cut is past a quarter turn, so every tile reaches every normal (cos_reach = -1)
    and the map is the dense sum."""
    rng = np.random.default_rng(1)
    h = rng.normal(size=(300, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h[:, 2] = np.abs(h[:, 2])
    sm = SparseLobeMap(h, rng.random(300), 5.0, lobe_norm(5.0))
    assert np.all(sm.cos_reach == -1.0)
    m = rng.normal(size=(20, 3))
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    m[0] = [1.0, 0.0, 0.0]
    want = sm.dense(m)
    for path in ("union", "tiles", "device", "auto"):
        assert sm(m, path=path) == pytest.approx(want, rel=1e-6 if path in ("device", "auto") else 1e-13)


def test_dense_is_every_term_by_hand():
    sm = SparseLobeMap(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), np.array([1.0, 2.0]), LN2, 3.0)
    m = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, 1.0, 0.0]])
    assert sm.dense(m) == pytest.approx(3 * np.array([1 + 2 * 0.5, 2 ** -0.2 + 2 * 2 ** -0.4, 0.5 + 1.0]), rel=1e-14)
    assert sm.dense(np.zeros((0, 3))).tolist() == []
    many = np.tile(m, (200, 1))  # past one block of 256
    assert sm.dense(many) == pytest.approx(np.tile(sm.dense(m), 200), rel=1e-14)


def two_tile_map(**options) -> SparseLobeMap:
    """Two bins 90° apart (each its own tile) with κ = 1000: a normal near one reaches only its tile."""
    return SparseLobeMap(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), np.array([1.0, 2.0]), 1000.0, 1.0,
                         kernels=KernelOptions(**options))


def spy(monkeypatch, sm, name):
    calls = []
    real = getattr(sm, name)

    def wrapped(*a, **k):
        calls.append(len(a[0]) if a and hasattr(a[0], "__len__") else a)
        return real(*a, **k)

    monkeypatch.setattr(sm, name, wrapped)
    return calls


def near(*points):
    m = np.array(points, dtype=np.float64)
    return m / np.linalg.norm(m, axis=1, keepdims=True)


def test_the_path_is_checked():
    with pytest.raises(ParameterError, match=r"^path must be 'auto', 'union', 'tiles' or 'device', got 'fast'$"):
        two_tile_map()(near([0, 0, 1]), path="fast")


def test_auto_sends_calls_of_enough_normals_to_the_kernel(monkeypatch):
    """map_min_normals = 8: a call of 8 normals goes to the kernel, one of 7 to numpy (map_min_terms
    out of reach); energy_map off: never."""
    sm = two_tile_map(map_min_terms=10**9)
    assert sm._kernel_takes(8) and not sm._kernel_takes(7)
    assert not two_tile_map(energy_map=False)._kernel_takes(100)
    calls = spy(monkeypatch, sm, "_launch_device_sums")
    m8 = near(*([[0.01 * k, 0, 1] for k in range(8)]))
    want = sm.dense(m8)
    assert sm(m8) == pytest.approx(want, rel=1e-6)
    assert calls == [8]
    assert sm(m8[:7]) == pytest.approx(want[:7], rel=1e-13)
    assert calls == [8]
    launched = sm.launch(m8)
    assert calls == [8, 8] and launched.value == pytest.approx(want, rel=1e-6)
    assert sm.launch(m8[:7]).value == pytest.approx(want[:7], rel=1e-13) and calls == [8, 8]


def test_auto_sends_calls_of_enough_terms_to_the_kernel(monkeypatch):
    """map_min_terms: the (normal, bin) terms within reach: 3 normals near the pole need its one bin
    (3 terms): the kernel from 3 terms on."""
    m = near([0, 0, 1], [0.01, 0, 1], [0, 0.01, 1])
    for min_terms, kernel in [(3, True), (4, False)]:
        sm = two_tile_map(map_min_terms=min_terms)
        calls = spy(monkeypatch, sm, "_launch_device_sums")
        assert sm(m) == pytest.approx(sm.dense(m), rel=1e-6 if kernel else 1e-13)
        assert calls == ([3] if kernel else [])
    sm = two_tile_map(map_min_terms=1, energy_map=False)
    calls = spy(monkeypatch, sm, "_launch_device_sums")
    sm(m)
    assert calls == []


def test_auto_takes_the_union_or_the_tiles_by_their_cost(monkeypatch):
    """Two normals, one near each bin: the union costs 2 normals x 2 bins = 4 terms, the tiles 1 + 1
    terms and a call each (tile_call_terms): 4 with tile_call_terms 1 (a tie: the union), 6 with 2
    (the union), and three normals (6 against 3 + 2) take the tiles."""
    m2 = near([0, 0, 1], [1, 0, 0.01])
    m3 = near([0, 0, 1], [1, 0, 0.01], [0.01, 0, 1])
    for m, cost, union in [(m2, 1, True), (m2, 2, True), (m3, 1, False), (m3, 2, True)]:
        sm = two_tile_map(tile_call_terms=cost, map_min_terms=10**9)
        calls = spy(monkeypatch, sm, "_union")
        assert sm(m) == pytest.approx(sm.dense(m), rel=1e-13)
        assert (calls != []) == union, (len(m), cost)


def test_normals_out_of_every_tiles_reach_get_zero():
    sm = two_tile_map()
    m = near([0, 1, 0], [0.5, 0.5, 0.5])
    for path in ("auto", "union", "tiles", "device"):
        assert sm(m, path=path).tolist() == [0.0, 0.0]
    assert sm.value_and_grad(m[0])[0] == 0.0 and sm.value_and_grad(m[0])[1].tolist() == [0.0, 0.0, 0.0]


def test_two_tile_map_by_hand_on_every_path():
    """E(m) = exp(1000(|m_z| - 1)) + 2 exp(1000(|m_x| - 1)), each normal near one bin only."""
    sm = two_tile_map()
    m = near([0, 0, 1], [1, 0, 0.01], [0.01, 0, -1], [-1, 0.02, 0], [0, 0.01, 1])
    want = np.exp(1000 * (np.abs(m[:, 2]) - 1)) + 2 * np.exp(1000 * (np.abs(m[:, 0]) - 1))
    for path in ("union", "tiles", "auto"):
        assert sm(m, path=path) == pytest.approx(want, rel=1e-13)
    assert sm(m, path="device") == pytest.approx(want, rel=1e-6)
    value, grad = sm.value_and_grad(m[3])
    assert value == pytest.approx(want[3], rel=1e-13)
    assert grad == pytest.approx(-1000 * 2 * np.exp(1000 * (abs(m[3, 0]) - 1)) * np.array([1.0, 0, 0]), rel=1e-12)


def test_blocks_of_normals(monkeypatch):
    """The union's (normals x bins) blocks and the kernel's (tile, normal) blocks, a block with no
    pair in reach among them: the same map."""
    sm = two_tile_map()
    m = near([0, 0, 1], [1, 0, 0.01], [0, 1, 0], [0, 1, 0.01], [0.01, 0, 1], [0, 1, 0])
    want = sm.dense(m)
    monkeypatch.setattr(S, "UNION_BLOCK", 4)  # 2 normals a block over the 2 bins
    assert sm(m, path="union") == pytest.approx(want, rel=1e-13)
    monkeypatch.setattr(S, "DEVICE_PAIR_BLOCK", 4)  # 2 normals a block over the 2 tiles
    assert sm(m, path="device") == pytest.approx(want, rel=1e-6)
    assert want[2] == want[3] == want[5] == 0.0 and np.all(want[[0, 1, 4]] > 0.1)


def test_unions_are_kept_eight_at_a_time():
    rng = np.random.default_rng(2)
    h = rng.normal(size=(500, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h[:, 2] = np.abs(h[:, 2])
    sm = SparseLobeMap(h, rng.random(500), 2000.0, 1.0)
    assert sm.n_tiles > 12
    first = sm._union(np.array([0, 3]))
    ht, a = first
    want = np.r_[np.arange(sm.starts[0], sm.starts[0] + sm.counts[0]), np.arange(sm.starts[3], sm.starts[3] + sm.counts[3])]
    assert np.array_equal(ht, sm.ht[:, want]) and np.array_equal(a, sm.a[want])
    assert ht.flags["C_CONTIGUOUS"]
    assert sm._union(np.array([0, 3])) is first
    for j in range(1, 8):
        sm._union(np.array([j]))
    assert len(sm._unions) == 8 and sm._union(np.array([0, 3])) is first
    sm._union(np.array([9]))
    assert len(sm._unions) == 8 and sm._union(np.array([0, 3])) is not first


def test_random_maps_equal_the_dense_sum_on_every_path():
    """Bins over the hemisphere, normals on both sides of it and on bins: every path within the
    stated accuracy of the dense float64 sum; the gradient the derivative of the same sum."""
    rng = np.random.default_rng(4)
    h = rng.normal(size=(3000, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h[:, 2] = np.abs(h[:, 2])
    for kappa in (3.0, 80.0, 2500.0):
        sm = SparseLobeMap(h, rng.random(3000) ** 3, kappa, lobe_norm(kappa))
        m = rng.normal(size=(40, 3))
        m /= np.linalg.norm(m, axis=1, keepdims=True)
        m = np.vstack([m, h[:5], -h[5:8]])
        want = sm.dense(m)
        for path in ("union", "tiles"):
            assert np.all(np.abs(sm(m, path=path) - want) <= 1e-8 * want.max()), (kappa, path)
        for path in ("auto", "device"):  # the kernel: float32 terms
            assert np.all(np.abs(sm(m, path=path) - want) <= 1e-6 * want.max()), (kappa, path)
        for k in (0, 41, 46):
            value, grad = sm.value_and_grad(m[k])
            assert value == pytest.approx(want[k], rel=1e-8, abs=1e-8 * want.max())
            w = sm.a * np.exp(kappa * (np.abs(sm.h @ m[k]) - 1))
            g = sm.norm * kappa * (w * np.sign(sm.h @ m[k])) @ sm.h
            assert np.allclose(grad, g, rtol=1e-7, atol=1e-8 * np.abs(g).max())


# ---------------------------------------------------------------------- survivors of the first mutation run
def test_float32_normals_are_read_in_float64():
    """A float32 normal is made unit in float64: the answer is the float64 one of the same numbers
    (in float32 it differs in the eighth digit)."""
    n32 = np.array([0.3, 0.4, 0.866], dtype=np.float32)
    assert normal_to_stereo(n32) == normal_to_stereo(n32.astype(np.float64))
    s = Scorer(random_problem(REFERENCE, n=300, kappa=40.0), "area")
    assert s.metrics(n32).to_dict() == s.metrics(n32.astype(np.float64)).to_dict()


def test_padded_rows_edge_cases(monkeypatch):
    """No rows at all; owners not sorted though each is at least the first (the sorted path must not
    take them); sorted owners placed without a sort; unsorted ones keep each row in triple order
    (a stable sort: the sums run in the same order whatever the sort's algorithm)."""
    from labcut.backend import ad_types

    _, t = ad_types()
    index, valid, width = S._padded_rows(np.zeros(0, dtype=np.int64), 0, t)
    assert (width, len(index), len(valid)) == (1, 0, 0)
    index, valid, width = S._padded_rows(np.array([0, 2, 1]), 3, t)
    assert width == 1 and np.asarray(index).tolist() == [0, 2, 1] and np.asarray(valid).all()
    owner = np.random.default_rng(0).integers(0, 3, 1000)
    index, valid, width = S._padded_rows(owner, 3, t)
    index, valid = np.asarray(index).reshape(3, width), np.asarray(valid).reshape(3, width)
    for r in range(3):
        assert index[r][valid[r]].tolist() == np.flatnonzero(owner == r).tolist()

    def no_sort(*a, **k):
        raise AssertionError("sorted owners need no sort")

    monkeypatch.setattr(S.np, "argsort", no_sort)
    index, valid, width = S._padded_rows(np.array([0, 0, 1, 1, 1, 3]), 4, t)
    assert width == 3 and np.asarray(index).tolist() == [0, 1, 0, 2, 3, 4, 0, 0, 0, 5, 0, 0]


def test_per_view_values_are_floats():
    """Whole-number inputs give float per-view lists (the JSON writes 1.0, not 1)."""
    fm = FlashMetrics.from_views([1, 0], [2, 0], [3, 0], [1, 0])
    assert all(type(x) is float for values in fm.per_view.values() for x in values)


def random_small(kernels: KernelOptions = DEFAULT_KERNELS) -> FlashProblem:
    return random_problem(kernels, n=400, kappa=30.0, seed=11, zeros=False)


@pytest.mark.parametrize("which", list(KERNELS))
@pytest.mark.parametrize("objective", ["area", "intensity", "balanced"])
def test_scores_and_gradients_of_a_random_problem(which, objective):
    """Triples in every direction (h_y too): the Dr.Jit objectives equal the numpy one written out,
    at normals off every axis, hard and smooth, with the gradient of the smooth one."""
    p = random_small(KERNELS[which])
    p = replace(p, threshold=float(np.median(p.pair_radiance(np.array([[0.0, 0.3, 0.95]]))[:, 0])))
    s = Scorer(p, objective)
    eps = 1e-6
    for uv in [(0.05, 0.15), (-0.3, 0.4), (0.2, -0.6)]:
        m = stereo_to_normal(*uv)
        assert s.score_uv(*uv) == pytest.approx(objective_np(p, m, objective, False), rel=1e-5, abs=1e-7)
        value, grad = s.value_and_grad_uv(*uv)
        assert value == pytest.approx(objective_np(p, m, objective, True), rel=1e-5, abs=1e-7)
        fd = [(objective_np(p, stereo_to_normal(uv[0] + eps * du, uv[1] + eps * dv), objective, True)
               - objective_np(p, stereo_to_normal(uv[0] - eps * du, uv[1] - eps * dv), objective, True)) / (2 * eps)
              for du, dv in ((1, 0), (0, 1))]
        assert np.allclose(grad, fd, rtol=5e-3, atol=1e-3 * max(1.0, np.abs(fd).max())), (uv, grad, fd)


@pytest.mark.parametrize("which", list(KERNELS))
def test_energy_of_a_random_problem_on_every_path(which):
    """The energy at normals off every axis: score, value (float64, the sparse map's), the dense
    device map and the batch (float32) against Σ alpha_t q(h_t·m) written out."""
    p = random_small(KERNELS[which])
    s = Scorer(p)
    uvs = np.array([[0.05, 0.15], [-0.3, 0.4], [0.2, -0.6], [0.0, 0.9]])
    normals = np.array([stereo_to_normal(*uv) for uv in uvs])
    want = np.array([objective_np(p, m, "energy", False) for m in normals])
    # the binning moves each triple by at most a cell (1/8 of the lobe's width): 1e-3 of the energy
    assert np.allclose([s.score_uv(*uv) for uv in uvs], want, rtol=1e-3)
    sparse = np.array([s.sparse_map(m[None, :])[0] for m in normals])  # float64, one normal at a time
    assert np.array([s.score_uv(*uv) for uv in uvs]) == pytest.approx(sparse, rel=1e-13)
    assert np.array([s.value_and_grad_uv(*uv)[0] for uv in uvs]) == pytest.approx(sparse, rel=1e-13)
    assert s.scores(normals) == pytest.approx(sparse, rel=1e-8)  # the map's relative accuracy
    assert s.energy_map_dense(normals) == pytest.approx(sparse, rel=1e-5)  # float32 terms
    values, grads = s.energy_batch_value_and_grad(uvs[:, 0], uvs[:, 1])
    assert values.dtype == np.float64 and grads.dtype == np.float64 and grads.shape == (4, 2)
    assert values == pytest.approx(sparse, rel=1e-5)
    for (u, v), g in zip(uvs, grads):
        assert g == pytest.approx(s.value_and_grad_uv(u, v)[1], rel=1e-4, abs=1e-5 * np.abs(g).max())


def test_the_dense_map_writes_every_entry(monkeypatch):
    """energy_map_dense fills a fresh array block by block: poisoned, nothing of it is left."""
    real_empty = np.empty

    def poisoned(shape, dtype=float, **k):
        out = real_empty(shape, dtype, **k)
        if np.dtype(dtype).kind == "f":
            out.fill(np.nan)
        return out

    s = Scorer(problem())
    monkeypatch.setattr(S.np, "empty", poisoned)
    got = s.energy_map_dense(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.6, 0.0, 0.8]]))
    assert got == pytest.approx([1.1, 1.0, 0.4 * 2 ** 0.8 + 0.3 * 2 ** 0.6], rel=1e-6)


def test_scores_of_the_energy_objective_are_one_map(monkeypatch):
    s = Scorer(problem())
    calls = spy(monkeypatch, s, "energy_map")
    s.scores(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]))
    assert calls == [2]


@pytest.mark.parametrize("which", list(KERNELS))
def test_a_view_flash_area_of_1e_12_counts_as_none(which):
    """The intensity's guard: a view whose flash area is at most 1e-12 has intensity 0 (no division
    by a vanishing area); just above it, its mean radiance. Pair 0 flashes with radiance 5."""
    # the metrics sum in float64 (the guard is 1e-12), the Dr.Jit objective in float32 (float32(1e-12))
    for weight, intensity in [(1e-12, 0.0), (1.0000000000000002e-12, 5.0)]:
        p = problem(KERNELS[which], pair_weight=np.array([weight, 2.0, 4.0]), view_weight=np.array([1.0, 0.0, 0.0]))
        assert Scorer(p).metrics(np.array([0.0, 0.0, 1.0])).flash_intensity == pytest.approx(intensity, rel=1e-12)
    f32 = float(np.float32(1e-12))
    for weight, intensity in [(f32, 0.0), (float(np.nextafter(np.float32(f32), np.float32(1.0))), 5.0)]:
        p = problem(KERNELS[which], pair_weight=np.array([weight, 2.0, 4.0]), view_weight=np.array([1.0, 0.0, 0.0]))
        assert Scorer(p, "intensity").score_uv(0.0, 0.0) == pytest.approx(intensity, rel=1e-6)


def test_float32_normals_in_the_map_are_read_in_float64():
    sm = two_tile_map(energy_map=False)
    m32 = near([0.01, 0.002, 1], [1, 0.003, 0.01]).astype(np.float32)
    m64 = m32.astype(np.float64)
    for path in ("union", "tiles"):
        assert sm(m32, path=path).tolist() == sm(m64, path=path).tolist()
    assert sm.dense(m32).tolist() == sm.dense(m64).tolist()
    v32, g32 = sm.value_and_grad(m32[1])
    v64, g64 = sm.value_and_grad(m64[1])
    assert v32 == v64 and g32.tolist() == g64.tolist()


def test_a_normal_exactly_at_the_reach_gets_its_term():
    """|m·centre| equal to the tile's reach (cos_reach, for the kernel cos_reach_device) counts:
    m = (sqrt(1 - r²), 0, r) against the pole's bin gives m·centre = r exactly."""
    kappa = 100.0
    sm = SparseLobeMap(np.array([[0.0, 0.0, 1.0]]), np.ones(1), kappa, 1.0)
    for reach, paths in [(sm.cos_reach[0], ("union", "tiles")), (sm.cos_reach_device[0], ("device",))]:
        m = np.array([[math.sqrt(1 - reach * reach), 0.0, reach]])
        assert float(S._cos_matrix(sm.centre, m.T)[0, 0]) == reach
        want = math.exp(kappa * (reach - 1.0))
        for path in paths:
            assert sm(m, path=path)[0] == pytest.approx(want, rel=1e-5), path
        if paths != ("device",):
            assert sm.value_and_grad(m[0])[0] == pytest.approx(want, rel=1e-12)


def test_forced_paths_take_their_path(monkeypatch):
    m = near([0, 0, 1], [1, 0, 0.01], [0.01, 0, 1])
    sm = two_tile_map(energy_map=False)
    union = spy(monkeypatch, sm, "_union")
    device = spy(monkeypatch, sm, "_launch_device_sums")
    sm(m, path="union")
    assert len(union) == 1 and device == []
    sm(m, path="tiles")
    assert len(union) == 1 and device == []
    sm(m, path="device")
    assert len(union) == 1 and device == [3]


def edge_problem(kernels: KernelOptions) -> FlashProblem:
    """Triples in the grid's edge cells at 512 cells (κ = ln 2) and in the cells next to them: -x in
    cell (0, 256), one at u = -1 + 1.5/256 in (1, 256); +x in (511, 256) and u = 1 - 1.5/256 in
    (510, 256); the same for ±y; and one at (u, v) = (1.5/256, -0.9999) in cell (257, 0), the cell an
    unclipped +y key (256 x 512 + 512) would fall into. Weights 1, 2, 4, ... tell them apart."""
    d = 1.5 / 256
    uv = [(-1.0, 0.0), (-1 + d, 0.0), (1.0, 0.0), (1 - d, 0.0), (0.0, -1.0), (0.0, -1 + d), (0.0, 1.0), (0.0, 1 - d),
          (d, -0.9999)]
    h = np.array([stereo_to_normal(u, v) for u, v in uv], dtype=np.float32)
    h[:, 2] = np.maximum(h[:, 2], 0.0)
    n = len(uv)
    return problem(kernels, h=h, c=np.ones(n, dtype=np.float32), pair=np.arange(n, dtype=np.int32),
                   pair_view=np.zeros(n, dtype=np.int64), pair_weight=2.0 ** np.arange(n), view_weight=np.array([1.0]))


@pytest.mark.parametrize("which", ["numpy", "keys", "drjit"])
def test_edge_cells_by_hand(which):
    """Each of the nine triples alone in its bin, in ascending cell order:
    (0,256) (1,256) (256,0) (256,1) (256,510) (256,511) (257,0) (510,256) (511,256)."""
    options = {"numpy": REFERENCE, "keys": KernelOptions(bins=False), "drjit": DEFAULT_KERNELS}[which]
    hb, ab = Scorer(edge_problem(options))._bin_triples()
    assert ab.tolist() == [1.0, 2.0, 16.0, 32.0, 128.0, 64.0, 256.0, 8.0, 4.0]


def test_the_device_bins_up_to_the_dense_key_limit(monkeypatch):
    """The fixed-point device sums serve grids up to DENSE_KEY_LIMIT cells (a bin of 2^-64 dropped);
    one cell more, the float64 host sums (that bin kept)."""
    h = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
    p = problem(DEFAULT_KERNELS, h=h, c=np.ones(3, dtype=np.float32), pair=np.arange(3, dtype=np.int32),
                pair_view=np.zeros(3, dtype=np.int64), pair_weight=np.array([0.5, 0.25, 2.0 ** -64]),
                view_weight=np.array([1.0]))
    monkeypatch.setattr(S, "DENSE_KEY_LIMIT", 512 * 512)
    assert Scorer(p)._bin_triples()[1].tolist() == [0.5, 0.25]
    monkeypatch.setattr(S, "DENSE_KEY_LIMIT", 512 * 512 - 1)
    assert Scorer(p)._bin_triples()[1].tolist() == [0.5, 2.0 ** -64, 0.25]


def test_the_host_bins_sort_only_past_the_dense_key_limit(monkeypatch):
    calls = []
    real = np.unique

    def counted(*a, **k):
        calls.append(1)
        return real(*a, **k)

    p = problem(REFERENCE)
    monkeypatch.setattr(S.np, "unique", counted)
    monkeypatch.setattr(S, "DENSE_KEY_LIMIT", 512 * 512)
    assert Scorer(p)._bin_triples()[1].tolist() == pytest.approx([0.4, 0.3], rel=1e-15)
    assert calls == []
    monkeypatch.setattr(S, "DENSE_KEY_LIMIT", 512 * 512 - 1)
    assert Scorer(p)._bin_triples()[1].tolist() == pytest.approx([0.4, 0.3], rel=1e-15)
    assert calls != []


@pytest.mark.parametrize("limit", [S.DENSE_KEY_LIMIT, 10])
def test_a_problem_without_triples_has_one_empty_bin(limit, monkeypatch):
    monkeypatch.setattr(S, "DENSE_KEY_LIMIT", limit)
    p = problem(DEFAULT_KERNELS, h=np.zeros((0, 3), dtype=np.float32), c=np.zeros(0, dtype=np.float32),
                pair=np.zeros(0, dtype=np.int32))
    hb, ab = Scorer(p)._bin_triples()
    assert hb.tolist() == [[0.0, 0.0, 1.0]] and ab.tolist() == [0.0]


def test_fixed_point_bins_too_light_for_a_direction():
    """A bin whose weight rounds to a unit but whose direction's sums each round to zero (0.6 units
    along (1, 1, 1)/sqrt 3: 0.35 each) has no direction: dropped. Every bin dropped: the one empty
    bin at the pole; one bin left: that bin. A zero weight (c = 0) does not count towards the total
    that sets the units."""
    unit = 2.0 ** -61
    s3 = 1 / math.sqrt(3)
    h = np.array([[0, 0, 1], [s3, s3, s3], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
    c = np.array([1.0, 1.0, 1.0, 0.0], dtype=np.float32)

    def bins(weights):
        p = problem(DEFAULT_KERNELS, h=h, c=c, pair=np.arange(4, dtype=np.int32),
                    pair_view=np.zeros(4, dtype=np.int64), pair_weight=np.array(weights), view_weight=np.array([1.0]))
        return Scorer(p)._bin_triples()

    hb, ab = bins([0.5, 0.6 * unit, 0.25, 1.0])
    assert ab.tolist() == [0.5, 0.25] and hb.tolist() == [[0, 0, 1], [1, 0, 0]]
    hb, ab = bins([0.75 * unit, 0.6 * unit, 0.0, 1.0])  # total below 1: S = 61; the pole's 0.75 units -> 1
    assert ab.tolist() == [unit] and hb.tolist() == [[0, 0, 1]]
    hb, ab = bins([0.25 * unit, 0.6 * unit, 0.0, 1.0])
    assert ab.tolist() == [0.0] and hb.tolist() == [[0, 0, 1]]


def test_float32_bins_are_read_in_float64():
    rng = np.random.default_rng(6)
    h = rng.normal(size=(200, 3)).astype(np.float32)
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h[:, 2] = np.abs(h[:, 2])
    a = rng.random(200).astype(np.float32)
    m = near([0.1, 0.2, 1], [0.5, -0.2, 0.4])
    one = SparseLobeMap(h, a, 300.0, 2.0, kernels=REFERENCE)
    other = SparseLobeMap(h.astype(np.float64), a.astype(np.float64), 300.0, 2.0, kernels=REFERENCE)
    assert one(m).tolist() == other(m).tolist() and one.dense(m).tolist() == other.dense(m).tolist()
    assert one.cos_cut == other.cos_cut and one.cos_reach.tolist() == other.cos_reach.tolist()


def test_a_bin_a_hair_longer_than_unit_still_counts():
    """A bin whose length rounds to just above 1 (1 + 1e-15): its cosine to its tile's centre is
    clipped to 1 (not an arccos of NaN that would cull the tile from every normal)."""
    sm = SparseLobeMap(np.array([[0.0, 0.0, 1.0 + 1e-15]]), np.ones(1), 100.0, 1.0)
    assert np.isfinite(sm.cos_reach).all()
    assert sm(near([0.01, 0, 1]), path="union")[0] == pytest.approx(math.exp(100 * (1 / math.sqrt(1.0001) - 1)), rel=1e-9)


def test_a_cut_short_of_a_quarter_turn():
    """κ = 20, one bin at the pole: T = ln 1e8, cos_cut = 1 - T/20 = 0.079 (cut 1.49 rad, short of π/2):
    a normal 1.2 rad away keeps its term, one 1.52 rad away (|cos| 0.05 < 0.079) loses it."""
    kappa = 20.0
    sm = SparseLobeMap(np.array([[0.0, 0.0, 1.0]]), np.ones(1), kappa, 1.0)
    cos_cut = 1 - math.log(1e8) / kappa
    assert sm.cos_reach == pytest.approx([math.cos(math.acos(cos_cut) + 1e-6)], rel=1e-9)
    for theta, inside in [(1.2, True), (1.52, False)]:
        m = np.array([[math.sin(theta), 0.0, math.cos(theta)]])
        want = math.exp(kappa * (math.cos(theta) - 1)) if inside else 0.0
        assert sm(m, path="union")[0] == pytest.approx(want, rel=1e-12, abs=0)


def test_tiles_are_cells_of_a_clipped_grid():
    """ceil(16/cut) cells across for a cut short of 128 cells; the grid's last cells hold the
    equator's ±x and ±y (clipped, not a cell of their own beyond the grid)."""
    rng = np.random.default_rng(7)
    h = rng.normal(size=(20000, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h[:, 2] = np.abs(h[:, 2])
    sm = SparseLobeMap(h, np.ones(len(h)), 1000.0, 1.0)
    cut = math.acos(sm.cos_cut)
    g = math.ceil(16 / cut)
    assert 6 < g < 128 and math.ceil(17 / cut) > g

    def cells(points, g):
        u, v = points[:, 0] / (1 + points[:, 2]), points[:, 1] / (1 + points[:, 2])
        iu, iv = (np.clip(((w + 1) * 0.5 * g).astype(int), 0, g - 1) for w in (u, v))
        return len(set(zip(iu.tolist(), iv.tolist())))

    assert sm.n_tiles == cells(h, g) != cells(h, math.ceil(17 / cut))
    d = 0.5 / g  # the cells next to the equator's four points
    edge = np.array([stereo_to_normal(u, v) for u, v in
                     [(1, 0), (1 - d, 0), (-1, 0), (-1 + d, 0), (0, 1), (0, 1 - d), (0, -1), (0, -1 + d)]])
    edge[:, 2] = np.maximum(edge[:, 2], 0.0)
    small = SparseLobeMap(edge, np.ones(8), 1000.0, 1.0)
    g = math.ceil(16 / math.acos(small.cos_cut))
    assert small.n_tiles == cells(edge, g) == 4


def test_the_gradient_of_a_normal_given_as_a_row():
    sm = two_tile_map()
    m = near([0.01, 0, 1])
    value, grad = sm.value_and_grad(m)
    assert (value, grad.tolist()) == (sm.value_and_grad(m[0])[0], sm.value_and_grad(m[0])[1].tolist())
    assert value == pytest.approx(math.exp(1000 * (m[0, 2] - 1)), rel=1e-12)


def test_bins_keep_their_order_within_a_tile():
    """The tiles' bins are sorted by tile stably: within a tile, in the order given (so each tile's sums
    run in one order whatever numpy's sort algorithm, and the map's last bits with them). Weights
    1, 2, 3, ... name the bins; broad lobes make few tiles of hundreds of bins."""
    rng = np.random.default_rng(8)
    h = rng.normal(size=(5000, 3))
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    h[:, 2] = np.abs(h[:, 2])
    sm = SparseLobeMap(h, np.arange(1.0, 5001.0), 1.0, 1.0)
    assert sm.counts.max() > 100
    for s0, c in zip(sm.starts, sm.counts):
        assert np.all(np.diff(sm.a[s0:s0 + c]) > 0)
    assert np.array_equal(sm.h, h[(sm.a - 1).astype(int)])
    # and the tiles in ascending cell order iu g + iv of a g x g grid (cut = π here: g = ceil(16/π) = 6)
    first = sm.h[sm.starts]
    u, v = first[:, 0] / (1 + first[:, 2]), first[:, 1] / (1 + first[:, 2])
    iu, iv = (np.clip(((w + 1) * 0.5 * 6).astype(int), 0, 5) for w in (u, v))
    assert np.all(np.diff(iu * 6 + iv) > 0) and sm.n_tiles == 36
