"""Error bars (labcut.orientation.uncertainty) pinned to hand-computed small cases (issue 37).

tests/test_uncertainty.py checks the bars against converged answers on a real stone; these pin
each piece on stand-in problems small enough to work out by hand: the calibrated factors to what
calibrated them, the stencil's 17 normals, the quadratic fit at its edges, the peak that is
followed, the bootstrap's view-weighted objective (two points, two views, numbers below), the
combination ``sqrt((K σ)² + D² + fit²)``, the JSON block's every legal form and the finer
problems a recommendation's bars are measured against. Every test runs in milliseconds.
"""

from __future__ import annotations

import math
import threading
from types import SimpleNamespace

import numpy as np
import pytest

from labcut.errors import ParameterError
from labcut.orientation import uncertainty as unc
from labcut.orientation.problem import lobe_reach
from labcut.orientation.uncertainty import Uncertainty
from labcut.orientation.volume import BAR_PATH_BUDGET
from labcut.scene.quality import Quality

Z = np.array([0.0, 0.0, 1.0])
S2 = math.sqrt(0.5)


def at(x: float, y: float) -> np.ndarray:
    """The unit normal at tangent-plane coordinates (x, y) degrees about +Z, by hand: +Z's tangent
    basis is e1 = Z x X = +Y, e2 = Z x e1 = -X, so the normal is (-sin t sin p, sin t cos p, cos t)."""
    t, p = math.radians(math.hypot(x, y)), math.atan2(y, x)
    return np.array([-math.sin(t) * math.sin(p), math.sin(t) * math.cos(p), math.cos(t)])


def coords(normals) -> np.ndarray:
    """The inverse of :func:`at`: tangent-plane coordinates (degrees) about +Z of each normal."""
    n = np.atleast_2d(np.asarray(normals, dtype=np.float64))
    t = np.degrees(np.arccos(np.clip(n[:, 2], -1.0, 1.0)))
    s = np.hypot(n[:, 0], n[:, 1])
    s = np.where(s > 0, s, 1.0)
    return np.stack([t * n[:, 1] / s, -t * n[:, 0] / s], axis=1)


def angle(a, b) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(np.dot(a, b))))))


# --- the calibrated factors -------------------------------------------------------------------

def test_the_calibrated_factors_are_what_calibrated_them():
    """DIRECTION_FACTOR 2: calibrated on the study of every scenario in docs/accuracy.md (the median
    distance 0.48 of the bar, a 2-D normal error's at 95 % coverage), not derived from a rate,
    which benchmarks/direction_convergence.py finds is no constant. Poses: errors fall 1.7x per
    doubling; a difference to twice as many is then (1 - 1/r) of the error, so the error is
    r / (r - 1) times the difference: 2.5 (1.7 / 0.7 = 2.43, rounded up). COVER: two
    standard deviations (about 95 %); 32 bootstrap replicates; up to 8 stencil moves; two rings of
    8 (17 normals) at half and all of the radius (docs/orientation.md's "Error bars")."""
    assert unc.DIRECTION_FACTOR == 2.0
    assert unc.POSE_FACTOR == 2.5 and round(1.7 / 0.7, 1) == 2.4
    assert unc.COVER == 2.0
    assert unc.BOOTSTRAP == 32
    assert unc.FOLLOW_STEPS == 8
    assert unc.RINGS == (0.5, 1.0) and unc.RING_DIRECTIONS == 8
    assert unc.VALUES_BLOCK_BYTES == 32 * 1024 * 1024
    assert unc.SAMPLED_METRICS == ("flash_energy", "flash_area", "flash_intensity")


def test_discretisation_is_each_difference_times_its_factor_in_quadrature():
    assert unc.discretisation() == (0.0, 0.0)
    assert unc.discretisation(directions_angle_deg=2.0) == (4.0, 0.0)
    assert unc.discretisation(directions_score_rel=0.1) == pytest.approx((0.0, 0.2), abs=1e-15)
    assert unc.discretisation(poses_angle_deg=2.0) == (5.0, 0.0)
    assert unc.discretisation(poses_score_rel=0.2) == (0.0, 0.5)
    # 2 x 3 = 6 and 2.5 x 3.2 = 8: 10; 2 x 0.15 = 0.3 and 2.5 x 0.16 = 0.4: 0.5
    d = unc.discretisation(3.0, 0.15, 3.2, 0.16)
    assert d == pytest.approx((10.0, 0.5), rel=1e-12)


# --- the finer problems ---------------------------------------------------------------------

def test_finer_directions_by_hand_on_draft():
    q = Quality.coerce("draft")  # 3000 points, 7 lamp, 32 map, 7 cone, 12 ring, rock (5, 2)
    h = unc.finer_directions(q)
    assert (h.surface_points, h.lamp_samples, h.env_samples, h.cone_views, h.ring_views) == (750, 14, 64, 14, 24)
    assert h.rock_steps == (5, 2) and h.nlopt_evals == q.nlopt_evals and h.map_spacing_deg == q.map_spacing_deg
    # a quarter of the points, at least 500
    assert unc.finer_directions(q.replace(surface_points=2004)).surface_points == 501
    assert unc.finer_directions(q.replace(surface_points=2007)).surface_points == 501  # rounded down
    assert unc.finer_directions(q.replace(surface_points=2000)).surface_points == 500
    assert unc.finer_directions(q.replace(surface_points=1999)).surface_points == 500
    assert unc.finer_directions(q.replace(surface_points=100)).surface_points == 500


def test_finer_poses_doubles_the_moved_poses_about_the_rest_pose():
    """k poses are the rest pose and k - 1 moved ones (an even count of moved poses): 2 x moved + 1."""
    q = Quality.coerce("draft")
    f = unc.finer_poses(q)
    assert f.rock_steps == (9, 5) and f.surface_points == 750
    assert (f.lamp_samples, f.env_samples, f.cone_views, f.ring_views) == (7, 32, 7, 12)
    cases = {(1, 1): (1, 1), (2, 3): (5, 5), (3, 4): (5, 9), (6, 7): (13, 13), (17, 6): (33, 13)}
    for steps, want in cases.items():
        assert unc.finer_poses(q.replace(rock_steps=steps)).rock_steps == want, steps
    assert unc.finer_poses(q.replace(surface_points=2004)).surface_points == 501
    assert unc.finer_poses(q.replace(surface_points=2006)).surface_points == 501
    assert unc.finer_poses(q.replace(surface_points=1000)).surface_points == 500


# --- the stencil ------------------------------------------------------------------------------

def test_tangent_basis_by_hand():
    e1, e2 = unc.tangent_basis(Z)  # helper X: Z x X = +Y, Z x Y = -X
    assert np.allclose(e1, [0, 1, 0], atol=0) and np.allclose(e2, [-1, 0, 0], atol=0)
    e1, e2 = unc.tangent_basis(np.array([1.0, 0.0, 0.0]))  # |m_x| >= 0.9: helper Y; X x Y = Z, X x Z = -Y
    assert np.allclose(e1, [0, 0, 1], atol=0) and np.allclose(e2, [0, -1, 0], atol=0)
    e1, e2 = unc.tangent_basis(np.array([-1.0, 0.0, 0.0]))  # the absolute value: helper Y
    assert np.allclose(e1, [0, 0, -1], atol=0) and np.allclose(e2, [0, -1, 0], atol=0)
    # exactly 0.9: not below it, helper Y: m x Y = (-m_z, 0, m_x)
    m = np.array([0.9, 0.0, math.sqrt(0.19)])
    e1, e2 = unc.tangent_basis(m)
    assert np.allclose(e1, [-math.sqrt(0.19), 0.0, 0.9], atol=1e-15)
    # just below: helper X: m x X = (0, m_z, -m_y) = +Y once made unit (here of length 0.8)
    e1, e2 = unc.tangent_basis(np.array([0.6, 0.0, 0.8]))
    assert np.allclose(e1, [0, 1, 0], atol=1e-15) and np.allclose(e2, [-0.8, 0, 0.6], atol=1e-15)
    m = np.array([0.3, -0.5, 0.6])
    m /= np.linalg.norm(m)
    e1, e2 = unc.tangent_basis(m)  # helper X: m x X = (0, m_z, -m_y), made unit
    np.testing.assert_allclose(e1, np.array([0.0, 0.6, 0.5]) / math.sqrt(0.61), rtol=0, atol=1e-15)
    for v in (e1, e2):
        assert np.linalg.norm(v) == pytest.approx(1.0, abs=1e-15) and abs(v @ m) < 1e-15
    assert abs(e1 @ e2) < 1e-15 and np.allclose(np.cross(e1, e2), m, atol=1e-15)  # right-handed


def test_the_stencil_is_a_centre_and_two_rings_of_eight_by_hand():
    normals, xy = unc.stencil(Z, 2.0)
    assert normals.shape == (17, 3) and xy.shape == (17, 2)
    c, s = math.cos(math.radians(22.5)), math.sin(math.radians(22.5))
    want = [(0, 0),
            (1, 0), (S2, S2), (0, 1), (-S2, S2), (-1, 0), (-S2, -S2), (0, -1), (S2, -S2),  # r/2, 0°, 45° ...
            (2 * c, 2 * s), (2 * s, 2 * c), (-2 * s, 2 * c), (-2 * c, 2 * s),  # r, 22.5°, 67.5° ...
            (-2 * c, -2 * s), (-2 * s, -2 * c), (2 * s, -2 * c), (2 * c, -2 * s)]
    np.testing.assert_allclose(xy, want, rtol=0, atol=1e-14)
    np.testing.assert_allclose(normals, [at(x, y) for x, y in want], rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, rtol=0, atol=1e-15)
    # the radius scales the coordinates; the angle of each normal from the centre is its distance
    normals3, xy3 = unc.stencil(Z, 3.0)
    np.testing.assert_allclose(xy3, 1.5 * xy, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.degrees(np.arccos(np.clip(normals3 @ Z, -1, 1))), np.hypot(*xy3.T), atol=1e-6)


def test_offset_normal_is_the_inverse_of_the_stencils_coordinates():
    assert np.allclose(unc.offset_normal(Z, (0.0, 0.0)), Z, atol=0)
    for x, y in [(1.0, 0.0), (0.0, 2.0), (-1.5, 0.5), (0.3, -2.5), (30.0, 40.0)]:
        np.testing.assert_allclose(unc.offset_normal(Z, [x, y]), at(x, y), rtol=0, atol=1e-15)
    m = np.array([0.3, -0.5, 0.6])
    m /= np.linalg.norm(m)
    normals, xy = unc.stencil(m, 2.5)
    for n, p in zip(normals, xy):
        np.testing.assert_allclose(unc.offset_normal(m, p), n, rtol=0, atol=1e-15)
    assert angle(unc.offset_normal(m, (3.0, 4.0)), m) == pytest.approx(5.0, abs=1e-9)


@pytest.mark.parametrize("tolerance, radius", [
    (None, 1.5), (0.0, 1.5), (float("nan"), 1.5), (float("inf"), 1.5),  # no tolerance: 3°, halved
    (2.0, 1.0), (4.0, 2.0), (0.6, 0.3), (0.5, 0.3), (0.1, 0.3), (-2.0, 0.3), (6.0, 3.0), (6.5, 3.0), (20.0, 3.0)])
def test_stencil_radius_is_half_the_tolerance_within_0_3_to_3_degrees(tolerance, radius):
    got = unc.stencil_radius(tolerance)
    assert type(got) is float and got == pytest.approx(radius, rel=1e-15)


# --- the quadratic fit ------------------------------------------------------------------------

def _quadratic(xy, peak, top=5.0, a=0.7, b=0.2, c=1.1):
    d = xy - np.asarray(peak)
    return top - a * d[:, 0] ** 2 - b * d[:, 0] * d[:, 1] - c * d[:, 1] ** 2


def test_fit_peaks_rows_inside_and_fallen_back():
    _, xy = unc.stencil(Z, 2.0)
    inside = _quadratic(xy, (0.4, -0.3))
    bowl = -_quadratic(xy, (0.4, -0.3))  # a minimum inside: not concave, the best stencil point
    saddle = 1.0 - 0.5 * (xy[:, 0] - 0.2) ** 2 + 0.3 * (xy[:, 1] + 0.1) ** 2  # a < 0, det < 0
    far = _quadratic(xy, (5.0, 1.0))  # concave, its peak beyond the radius
    values = np.stack([inside, bowl, saddle, far])
    peaks, heights = unc.fit_peaks(xy, values, 2.0)
    assert peaks.shape == (4, 2) and heights.shape == (4,)
    np.testing.assert_allclose(peaks[0], (0.4, -0.3), rtol=0, atol=1e-12)
    assert heights[0] == pytest.approx(5.0, abs=1e-12)
    for row in (1, 2, 3):
        best = int(np.argmax(values[row]))
        assert np.array_equal(peaks[row], xy[best]) and heights[row] == values[row, best]
    assert np.array_equal(peaks[3], xy[9])  # (2 cos 22.5°, 2 sin 22.5°): nearest (5, 1)
    # the private fit says which rows were inside
    _, _, inside_rows = unc._fit(xy, values, 2.0)
    assert inside_rows.tolist() == [True, False, False, False]
    # a concave row with a = 0.7 and c = -1.1 (det < 0, a > 0 would not be concave either way)
    other = 1.0 + 0.35 * xy[:, 0] ** 2 - 0.55 * xy[:, 1] ** 2
    assert unc._fit(xy, other[None, :], 2.0)[2].tolist() == [False]


def test_fit_peaks_radius_is_inclusive():
    """A fitted peak exactly at the radius is inside; a hair beyond, the best stencil point."""
    _, xy = unc.stencil(Z, 2.0)
    values = _quadratic(xy, (1.2, 0.9))[None, :]
    peaks, heights = unc.fit_peaks(xy, values, 10.0)
    r = float(np.hypot(peaks[0, 0], peaks[0, 1]))
    assert r == pytest.approx(1.5, abs=1e-12)
    at_edge, h_edge = unc.fit_peaks(xy, values, r)
    assert np.array_equal(at_edge, peaks) and np.array_equal(h_edge, heights)
    beyond, h_beyond = unc.fit_peaks(xy, values, float(np.nextafter(r, 0.0)))
    best = int(np.argmax(values[0]))
    assert np.array_equal(beyond[0], xy[best]) and h_beyond[0] == values[0, best]


def test_fit_peaks_heights_and_cross_terms():
    """The fitted height at the peak of a quadratic with a cross term, by hand: 1 - (x - 0.5)² -
    (x - 0.5)(y + 0.25) - (y + 0.25)² peaks at (0.5, -0.25) with height 1; a tilted plane added
    (0.2 x - 0.1 y) moves it: the gradient of the whole vanishes at H p = -g."""
    _, xy = unc.stencil(Z, 1.5)
    x, y = xy[:, 0], xy[:, 1]
    v = 1.0 - (x - 0.5) ** 2 - (x - 0.5) * (y + 0.25) - (y + 0.25) ** 2
    peaks, heights = unc.fit_peaks(xy, v[None, :], 1.5)
    np.testing.assert_allclose(peaks[0], (0.5, -0.25), atol=1e-12)
    assert heights[0] == pytest.approx(1.0, abs=1e-12)
    # f = 3 - x² - y² + 0.6 x - 0.4 y + 0.2 xy: gradient (-2x + 0.6 + 0.2y, -2y - 0.4 + 0.2x) = 0
    # at x = (0.6 - 0.04) / 1.98... solved: [[2, -0.2], [-0.2, 2]] p = (0.6, -0.4)
    w = 3.0 - x ** 2 - y ** 2 + 0.6 * x - 0.4 * y + 0.2 * x * y
    p = np.linalg.solve([[2.0, -0.2], [-0.2, 2.0]], [0.6, -0.4])
    peaks, heights = unc.fit_peaks(xy, w[None, :], 1.5)
    np.testing.assert_allclose(peaks[0], p, atol=1e-12)
    top = 3.0 - p[0] ** 2 - p[1] ** 2 + 0.6 * p[0] - 0.4 * p[1] + 0.2 * p[0] * p[1]
    assert heights[0] == pytest.approx(top, abs=1e-12)


# --- stand-in problems ------------------------------------------------------------------------

class Quadratics:
    """A stand-in FlashProblem: points each seen as one pair from one view, each pair's L_s/L_ref
    at a normal the quadratic ``top - curv |xy - peak|²`` of the normal's tangent coordinates
    about +Z (degrees): the mean over the points is a quadratic peaking at the points' mean peak."""

    def __init__(self, peaks, top=1.0, curv=0.1, kappa=400.0):
        self.peaks = np.atleast_2d(np.asarray(peaks, dtype=np.float64))
        n = len(self.peaks)
        self.top, self.curv, self.kappa = top, curv, kappa
        self.pair_weight = np.ones(n)
        self.pair_view = np.zeros(n, dtype=np.int64)
        self.view_weight = np.ones(1)
        self.info = {"pair_point": np.arange(n)}
        self.n_points = n
        self.threshold = 0.5
        self.pair_alpha = np.full(n, 1.0 / n)
        self.calls: list = []

    def values(self, normals):
        xy = coords(normals)
        d2 = (xy[None, :, 0] - self.peaks[:, None, 0]) ** 2 + (xy[None, :, 1] - self.peaks[:, None, 1]) ** 2
        return self.top - self.curv * d2

    def pair_radiance(self, normals, reach):
        self.calls.append((np.asarray(normals), reach))
        return self.values(normals)

    def launch_pair_radiance(self, normals, reach):
        self.launched = (np.array(normals), reach, normals.dtype)
        return SimpleNamespace(value=self.values(normals))


class Landscape(Quadratics):
    """One pair whose value at a normal is ``f(normal)``."""

    def __init__(self, f, kappa=400.0):
        super().__init__([(0.0, 0.0)], kappa=kappa)
        self.f = f

    def values(self, normals):
        return np.array([[self.f(n) for n in np.atleast_2d(normals)]])


# --- following a peak -------------------------------------------------------------------------

def test_follow_peak_inside_the_first_stencil_is_one_fit():
    p = Quadratics([(0.6, -0.8)], top=2.0, kappa=100.0)
    found, value = unc.follow_peak(p, Z, 1.5, "energy")
    assert angle(found, at(0.6, -0.8)) < 1e-6 and value == pytest.approx(2.0, abs=1e-9)
    assert type(value) is float
    assert len(p.calls) == 1  # one stencil, reached as the error bars' pair sums
    normals, reach = p.calls[0]
    np.testing.assert_allclose(normals, unc.stencil(Z, 1.5)[0], atol=0)
    assert reach == pytest.approx(math.radians(1.5) + 5.0 / 10.0, abs=1e-9)


def test_follow_peak_uses_the_given_sums_at_the_first_stencil_only():
    """The launched sums stand for the first stencil; the problem is asked at every later one."""
    p = Quadratics([(6.0, 0.0)], top=2.0)  # 6° along e1 (+Y)
    normals, _ = unc.stencil(Z, 1.5)
    given = Quadratics([(0.2, 0.3)], top=7.0).pair_radiance(normals, 0.0)
    found, value = unc.follow_peak(p, Z, 1.5, "energy", radiance=given)
    assert p.calls == [] and angle(found, at(0.2, 0.3)) < 1e-6 and value == pytest.approx(7.0, abs=1e-9)
    # given sums whose fit leaves the stencil towards the peak: the problem's own values from then on
    towards = Quadratics([(3.0, 0.0)], top=7.0).pair_radiance(normals, 0.0)
    found, value = unc.follow_peak(p, Z, 1.5, "energy", radiance=towards)
    assert angle(found, at(6.0, 0.0)) < 1e-3 and value == pytest.approx(2.0, abs=1e-6)
    assert 2 <= len(p.calls) <= 4


def test_a_best_centre_stays_after_one_stencil():
    """A fit that is not concave (high at the centre and the outer ring, low between) whose best
    point is the centre: the centre and its value, from a single stencil."""
    def f(n):
        t = angle(n, Z)
        return 1.0 if t < 0.1 else (0.9 if t > 1.2 else 0.0)

    p = Landscape(f)
    found, value = unc.follow_peak(p, Z, 1.5, "energy")
    assert np.array_equal(found, Z) and value == 1.0 and len(p.calls) == 1


def test_a_peak_never_reached_stops_after_eight_moves():
    """A convex ramp towards +X (exp(5 n_x), 90° away): no fit is concave, the stencil moves to its
    best point each time; nine stencils (the first and eight moves) and a ninth move, then the
    centre reached and its value (the best point of the last stencil)."""
    d = np.array([1.0, 0.0, 0.0])
    p = Landscape(lambda n: math.exp(5.0 * float(n @ d)))
    found, value = unc.follow_peak(p, Z, 1.5, "energy")
    assert len(p.calls) == unc.FOLLOW_STEPS + 1 == 9
    assert np.linalg.norm(found) == pytest.approx(1.0, abs=1e-12)
    assert value == pytest.approx(math.exp(5.0 * float(found @ d)), rel=1e-12)
    # each move is at most the radius and at least its cosine of 22.5° (the outer ring's spacing)
    assert 9 * 1.5 * math.cos(math.radians(22.5)) - 1e-9 <= angle(found, Z) <= 9 * 1.5 + 1e-9
    assert found[0] > 0.2  # towards +X


# --- the pair sums and their reach -----------------------------------------------------------

def test_pair_radiance_asks_within_the_stencils_spread_plus_five_lobe_widths():
    p = Quadratics([(0.0, 0.0)], kappa=400.0)  # 5 / sqrt(400) = 0.25 rad
    normals, _ = unc.stencil(Z, 2.0)
    flipped = normals.copy()
    flipped[5] *= -1.0  # axial: a flipped normal is as far
    got = unc.pair_radiance(p, flipped.tolist())
    sent, reach = p.calls[0]
    assert got.shape == (1, 17)
    assert isinstance(sent, np.ndarray) and sent.dtype == np.float64
    unc.pair_radiance(p, [[0, 0, 1], [0, 1, 0]])  # whole numbers: asked as float64 normals
    assert p.calls[1][0].dtype == np.float64
    assert reach == pytest.approx(0.25 + math.radians(2.0), abs=1e-12)
    assert unc._reach(400.0, normals) == pytest.approx(0.25 + math.radians(2.0), abs=1e-12)
    # the farthest normal counts, measured from the first
    assert unc._reach(25.0, np.stack([Z, at(0.5, 0.0), at(0.0, -3.0)])) == pytest.approx(1.0 + math.radians(3.0))
    assert unc._reach(25.0, np.stack([at(0.0, -3.0), Z])) == pytest.approx(1.0 + math.radians(3.0))
    # a unit normal whose dot with itself rounds above 1: no NaN, no spread
    m = np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0)
    assert float(m @ m) > 1.0
    assert unc._reach(25.0, np.stack([m, m])) == 1.0
    assert lobe_reach(25.0, 0.0) == 1.0


def test_the_launched_stencil_sums():
    assert unc._launch_stencil_sums(None, np.stack([Z])) is None
    p = Quadratics([(0.0, 0.0)], kappa=400.0)
    normals, _ = unc.stencil(Z, 1.0)
    got = unc._launch_stencil_sums(p, normals.astype(np.float32))
    sent, reach, dtype = p.launched
    assert dtype == np.float64 and np.allclose(sent, normals, atol=1e-7)
    assert reach == pytest.approx(0.25 + math.radians(1.0), abs=1e-5)
    assert got.value.shape == (1, 17)


# --- the bootstrap's objective: two points, two views, by hand ----------------------------------

class Pairs:
    """Two surface points, two views (weights 0.25 and 0.75), three pairs listed out of view order:

    ======  =====  ====  ===========  ============================
    pair    point  view  pair weight  L_s/L_ref at normals 0 and 1
    ======  =====  ====  ===========  ============================
    c       1      1     0.5          0.3, 0.9
    a       0      0     0.5          0.8, 0.2
    b       1      0     0.25         0.5, 0.6
    ======  =====  ====  ===========  ============================

    The flash threshold is 0.5: b's first value is exactly at it (a flash).
    """

    def __init__(self, points=True, views=(0.25, 0.75), kappa=400.0):
        self.pair_weight = np.array([0.5, 0.5, 0.25])
        self.pair_view = np.array([1, 0, 0])
        self.pair_point = np.array([1, 0, 1])
        self.info = {"pair_point": self.pair_point} if points else {}
        self.view_weight = np.array(views)
        self.threshold = 0.5
        self.n_points = 2
        self.kappa = kappa
        self.radiance = np.array([[0.3, 0.9], [0.8, 0.2], [0.5, 0.6]])
        self.calls: list = []

    def pair_radiance(self, normals, reach):
        self.calls.append((np.array(normals), reach))
        return self.radiance[:, :len(np.atleast_2d(normals))]


#: point weights (rows) and, by hand, each view's weighted means at normals 0 and 1, then the
#: view-weighted objective: row (1, 1): view 0's energy (0.5 x 0.8 + 0.25 x 0.5) / 0.75 = 0.7 and
#: (0.5 x 0.2 + 0.25 x 0.6) / 0.75 = 1/3, its flashing area 1 and 1/3, intensity 0.7 and 0.6;
#: view 1's energy 0.3 and 0.9, area 0 and 1, intensity 0 (nothing flashes) and 0.9;
#: energy 0.25 x 0.7 + 0.75 x 0.3 = 0.4 ... Row (1, 0) leaves view 1 without weight (0, not NaN).
ROWS = np.array([[1.0, 1.0], [2.0, 1.0], [0.0, 3.0], [1.0, 0.0]])
ENERGY = np.array([[0.4, 0.25 / 3 + 0.675], [0.41, 0.745], [0.35, 0.825], [0.2, 0.05]])
AREA = np.array([[0.25, 0.25 / 3 + 0.75], [0.25, 0.8], [0.25, 1.0], [0.25, 0.0]])
INTENSITY = np.array([[0.175, 0.825], [0.185, 0.825], [0.125, 0.825], [0.2, 0.0]])


@pytest.mark.parametrize("objective, want", [
    ("energy", ENERGY), ("area", AREA), ("intensity", INTENSITY),
    ("balanced", np.sqrt(AREA * INTENSITY)), ("all", np.stack([ENERGY, AREA, INTENSITY]))])
def test_objective_values_by_hand(objective, want):
    p = Pairs()
    got = unc.objective_values(p, p.radiance, ROWS, objective)
    assert got.shape == want.shape and got.dtype == np.float64
    np.testing.assert_allclose(got, want, rtol=2e-7, atol=1e-12)


def test_a_view_of_weight_only_and_a_scale_of_the_weights():
    """Views one at a time: the objective is that view's mean; every point weight doubled, the same."""
    p = Pairs(views=(1.0, 0.0))
    np.testing.assert_allclose(unc.objective_values(p, p.radiance, ROWS[:1], "energy"), [[0.7, 1 / 3]], rtol=2e-7)
    np.testing.assert_allclose(unc.objective_values(p, p.radiance, 2 * ROWS[:1], "intensity"), [[0.7, 0.6]], rtol=2e-7)
    p = Pairs(views=(0.0, 1.0))
    np.testing.assert_allclose(unc.objective_values(p, p.radiance, ROWS[:1], "all")[:, 0],
                               [[0.3, 0.9], [0.0, 1.0], [0.0, 0.9]], rtol=2e-7, atol=1e-12)


def test_the_replicates_sums_are_float32_products():
    """The weighted sums per view are float32 matrix products (the weights are small whole
    numbers, exact in float32; objective_values' docstring): 1 + 1e-8 sums to 1 in float32, so the
    view's mean of the two pairs is exactly 0.5 (1.000000005 in float64)."""
    p = Pairs(views=(1.0,))
    p.pair_weight, p.pair_view, p.info = np.array([1.0, 1.0]), np.array([0, 0]), {"pair_point": np.array([0, 1])}
    got = unc.objective_values(p, np.array([[1.0], [1e-8]]), np.ones((1, 2)), "energy")
    assert got[0, 0] == 0.5


def test_without_points_the_bootstrap_weighs_pairs():
    """A problem without ``pair_point``: one weight per pair (c, a, b); counted as pairs."""
    p = Pairs(points=False)
    assert unc._point_count(p) == 3 and unc._point_count(Pairs()) == 2
    per_pair = np.array([[1.0, 1.0, 1.0], [1.0, 2.0, 1.0], [0.0, 1.0, 0.0]])
    got = unc.objective_values(p, p.radiance, per_pair, "all")
    np.testing.assert_allclose(got[:, :2], np.stack([ENERGY[:2], AREA[:2], INTENSITY[:2]]), rtol=2e-7, atol=1e-12)
    # only pair a (point 0, view 0): view 1 has no weight
    np.testing.assert_allclose(got[:, 2], [[0.2, 0.05], [0.25, 0.0], [0.2, 0.0]], rtol=2e-7, atol=1e-12)


class FourViews(Pairs):
    """:class:`Pairs` and two more views of their own pairs: d (point 0, view 3, 0.5; 0.9, 0.1) and
    e (point 1, view 2, 1.0; 0.2, 0.7); views weighted 0.1, 0.2, 0.3, 0.4."""

    def __init__(self):
        super().__init__(views=(0.1, 0.2, 0.3, 0.4))
        self.pair_weight = np.array([0.5, 0.5, 0.25, 0.5, 1.0])
        self.pair_view = np.array([1, 0, 0, 3, 2])
        self.info = {"pair_point": np.array([1, 0, 1, 0, 1])}
        self.radiance = np.array([[0.3, 0.9], [0.8, 0.2], [0.5, 0.6], [0.9, 0.1], [0.2, 0.7]])


def _views_energy_by_hand(w0, w1):
    """FourViews' energy at normal 0 for point weights (w0, w1), view by view."""
    v0 = (w0 * 0.5 * 0.8 + w1 * 0.25 * 0.5) / (w0 * 0.5 + w1 * 0.25)
    return 0.1 * v0 + 0.2 * 0.3 * (w1 > 0) + 0.3 * 0.2 * (w1 > 0) + 0.4 * 0.9 * (w0 > 0)


@pytest.mark.parametrize("block, shapes", [
    (None, [(2, 4, 3)]),  # every view at once
    (4 * 2 * 3 * 2, [(2, 2, 3), (2, 2, 3)]),  # exactly two views' bytes a group
    (4 * 2 * 3 * 2 - 1, [(2, 1, 3)] * 4),  # a byte less: one view a group
    (4 * 2 * 3 * 3, [(2, 3, 3), (2, 1, 3)]),  # three, and the one left
    (1, [(2, 1, 3)] * 4)])  # less than a view: still one view a group
def test_views_in_groups_by_hand(monkeypatch, block, shapes):
    """The (point, view, column) layout a group of views at a time: each group's buffer holds
    ``points x views x (columns + 1)`` float32 (energy at two normals: 3 columns), the same values."""
    if block is not None:
        monkeypatch.setattr(unc, "VALUES_BLOCK_BYTES", block)
    seen = []
    real = unc._zeroed_buffer

    def spy(shape):
        seen.append(shape)
        return real(shape)

    monkeypatch.setattr(unc, "_zeroed_buffer", spy)
    p = FourViews()
    got = unc.objective_values(p, p.radiance, ROWS, "energy")
    assert seen == shapes
    want = [_views_energy_by_hand(*w) for w in ROWS]
    np.testing.assert_allclose(got[:, 0], want, rtol=2e-7)
    # normal 1 of row (1, 1): 0.1 x 1/3 + 0.2 x 0.9 + 0.3 x 0.7 + 0.4 x 0.1
    assert got[0, 1] == pytest.approx(0.1 / 3 + 0.18 + 0.21 + 0.04, rel=2e-7)
    area = unc.objective_values(p, p.radiance, ROWS, "balanced")  # 7 columns a view
    flat = unc.objective_values(FourViews(), p.radiance, ROWS, "balanced")
    np.testing.assert_allclose(area, flat, rtol=0, atol=0)
    assert area[0, 0] == pytest.approx(math.sqrt((0.1 + 0.4) * (0.1 * 0.7 + 0.4 * 0.9)), rel=2e-7)


def test_the_zeroed_buffer_is_kept_per_thread_and_shape(monkeypatch):
    monkeypatch.setattr(unc, "VALUES_BLOCK_BYTES", 4 * 2 * 3 * 4)  # 96 bytes
    monkeypatch.setattr(unc, "_BUFFERS", threading.local())
    a = unc._zeroed_buffer((2, 3, 4))  # exactly the limit: kept
    assert a.dtype == np.float32 and a.shape == (2, 3, 4) and not a.any()
    a[...] = 5.0
    b = unc._zeroed_buffer((2, 3, 4))
    assert b is a and not b.any()  # the same array, zeroed
    c = unc._zeroed_buffer((2, 3, 5))  # over the limit: a fresh one, not kept
    assert c is not a and c.shape == (2, 3, 5) and not c.any()
    c[...] = 1.0
    d = unc._zeroed_buffer((2, 3, 5))
    assert d is not c and not d.any()
    e = unc._zeroed_buffer((1, 3, 4))
    assert e is not a and e.shape == (1, 3, 4)
    assert unc._zeroed_buffer((1, 3, 4)) is e
    other = []
    t = threading.Thread(target=lambda: other.append(unc._zeroed_buffer((1, 3, 4))))
    t.start()
    t.join()
    assert other[0] is not e and other[0].shape == (1, 3, 4)


def test_stencil_values_with_every_point_weighted_one():
    p = Pairs()
    p.pair_alpha = np.array([0.25, 0.5, 1.0])
    # energy: the pair_alpha-weighted sum, 0.25 x 0.3 + 0.5 x 0.8 + 0.5 = 0.975 and 0.225 + 0.1 + 0.6 = 0.925
    got = unc.stencil_values(p, np.stack([Z, Z]), "energy", radiance=p.radiance)
    np.testing.assert_allclose(got, [[0.975, 0.925]], rtol=1e-15)
    assert p.calls == []
    np.testing.assert_allclose(unc.stencil_values(p, np.stack([Z, Z]), "area", radiance=p.radiance), AREA[:1], rtol=2e-7)
    # without sums: asked of the problem within reach of the normals
    got = unc.stencil_values(p, np.stack([Z, at(1.0, 0.0)]), "intensity")
    np.testing.assert_allclose(got, INTENSITY[:1], rtol=2e-7)
    assert p.calls[0][1] == pytest.approx(0.25 + math.radians(1.0), abs=1e-12)
    q = Pairs(points=False)  # one weight per pair
    np.testing.assert_allclose(unc.stencil_values(q, np.stack([Z, Z]), "balanced", radiance=q.radiance),
                               np.sqrt(AREA[:1] * INTENSITY[:1]), rtol=2e-7)


# --- the bootstrap weights ----------------------------------------------------------------------

def test_bootstrap_weights_are_ones_then_the_seeds_poisson_stream():
    w = unc.bootstrap_weights(5, 7, 4)
    want = np.random.default_rng(5 + 7919).poisson(1.0, (4, 7))
    assert w.shape == (5, 7) and w.dtype == np.float64
    assert np.array_equal(w[0], np.ones(7)) and np.array_equal(w[1:], want)
    assert not w.flags.writeable
    assert unc.bootstrap_weights(5, 7, 4) is w
    assert np.array_equal(unc.bootstrap_weights(0, 3, 4)[1:], np.random.default_rng(7919).poisson(1.0, (4, 3)))


def test_stratified_bootstrap_weights_pair_neighbouring_strata():
    """Stratified samples: each pair of neighbouring points weighs (2, 0) or (0, 2), even odds, from
    the seed's stream; an odd last point weighs 1; so a replicate's mean moves by ±(x_2k - x_2k+1)/N
    a pair, and over replicates the spread of the mean is sqrt(Σ d² / N²)."""
    w = unc.bootstrap_weights(5, 7, 4000, True)
    assert w.shape == (4001, 7) and not w.flags.writeable and np.array_equal(w[0], np.ones(7))
    rows = w[1:]
    assert np.array_equal(rows[:, 6], np.ones(4000))
    assert set(np.unique(rows[:, :6])) == {0.0, 2.0}
    np.testing.assert_array_equal(rows[:, 0:6:2] + rows[:, 1:6:2], 2.0)
    assert np.array_equal(rows[:, 0:6:2], 2.0 * np.random.default_rng(5 + 7919).integers(0, 2, (4000, 3)))
    assert 0.47 < float(np.mean(rows[:, 0] == 2.0)) < 0.53
    x = np.array([1.0, 3.0, 2.0, 2.0, 5.0, 1.0, 7.0])
    spread = np.std(rows @ x / 7.0)
    assert spread == pytest.approx(math.sqrt((2.0**2 + 0.0 + 4.0**2) / 49.0), rel=0.05)
    assert unc.bootstrap_weights(5, 7, 4000, True) is w and unc.bootstrap_weights(5, 7, 4000) is not w


# --- sampling_error ---------------------------------------------------------------------------

def test_sampling_error_is_two_standard_deviations_of_each_metric(monkeypatch):
    """The replicates' rows (the row of ones left out) of :data:`ROWS`: energy 0.41, 0.35, 0.2,
    area 0.25 each, intensity 0.185, 0.125, 0.2 at normal 0 (the table above)."""
    asked = []

    def weights(seed, points, replicates, stratified):
        asked.append((seed, points, replicates, stratified))
        return ROWS

    monkeypatch.setattr(unc, "bootstrap_weights", weights)
    p = Pairs()
    got = unc.sampling_error(p, [0.0, 0.0, 3.0], replicates=4, seed=7)
    assert asked == [(7, 2, 4, False)]  # a problem that does not say how it was sampled: random
    p.info["sampling"] = "stratified"
    unc.sampling_error(p, [0.0, 0.0, 3.0], replicates=4, seed=7)
    assert asked[-1] == (7, 2, 4, True)
    assert list(got) == ["flash_energy", "flash_area", "flash_intensity"]
    # energy 0.41, 0.35, 0.2: mean 0.32, squares 0.0081 + 0.0009 + 0.0144 = 0.0234 over 2
    assert got["flash_energy"] == pytest.approx(2.0 * math.sqrt(0.0117), rel=1e-6)
    assert got["flash_area"] == pytest.approx(0.0, abs=1e-7)
    # intensity 0.185, 0.125, 0.2: mean 0.17, squares 0.000225 + 0.002025 + 0.0009 = 0.00315 over 2
    assert got["flash_intensity"] == pytest.approx(2.0 * math.sqrt(0.001575), rel=1e-6)
    assert all(type(v) is float for v in got.values())
    sent, reach = p.calls[0]
    np.testing.assert_allclose(sent, [Z], atol=0)  # the unit normal, one row
    assert reach == pytest.approx(0.25, abs=1e-12)
    monkeypatch.undo()
    default = unc.sampling_error(Pairs(), Z)  # 32 replicates of seed 0
    w = unc.bootstrap_weights(0, 2, 32)[1:]
    e = np.array([unc.objective_values(Pairs(), Pairs().radiance[:, :1], r[None, :], "energy")[0, 0] for r in w])
    assert default["flash_energy"] == pytest.approx(2.0 * float(np.std(e, ddof=1)), rel=1e-6)


@pytest.mark.parametrize("call", [unc.sampling_error, unc.estimate_uncertainty])
def test_bad_normals_and_replicates_are_one_line_errors(call):
    p = Quadratics([(0.0, 0.0)])
    for normal in ([0.0, 0.0, 0.0], [0.0, 1.0], [0.0, 0.0, 1.0, 0.0], [float("nan"), 0.0, 1.0], [0.0, float("inf"), 1.0]):
        with pytest.raises(ParameterError) as err:
            call(p, normal)
        assert str(err.value) == f"normal must be three finite numbers, not all zero, got {normal!r}"
    for bad in (3, 0, -4, 4.0, "8", None):
        with pytest.raises(ParameterError) as err:
            call(p, Z, replicates=bad)
        assert str(err.value) == f"replicates must be a whole number >= 4, got {bad!r}"
    call(p, Z, replicates=4)  # the least
    # a missing coordinate (JSON null) is not a number either: the same one-line error
    with pytest.raises(ParameterError, match="normal must be three finite numbers, not all zero, got "):
        call(p, [None, 0.0, 1.0])
    # numbers as text are read as numbers
    assert call(p, ["0", "0", "1"]) == call(p, Z)


# --- the combination --------------------------------------------------------------------------

def test_the_bars_combine_by_hand_with_the_fit_stubbed(monkeypatch):
    """Hand-made fitted peaks and heights: the answer's peak (0.3, 0.4) (fit 0.5°, height 2), four
    replicates at (1.3, 0.4), (-0.7, 0.4), (0.3, 1.4), (0.3, -0.6) (each 1° from their mean: RMS
    spread 1°, x2 = 2°) with heights 1, 2, 3, 2 (standard deviation sqrt(2/3), a share of 2, x2)."""
    rows = np.array([[0.3, 0.4], [1.3, 0.4], [-0.7, 0.4], [0.3, 1.4], [0.3, -0.6]])
    tops = np.array([2.0, 1.0, 2.0, 3.0, 2.0])
    seen = []

    def fit(xy, values, radius):
        seen.append((values.shape, radius))
        return rows.copy(), tops.copy()

    monkeypatch.setattr(unc, "fit_peaks", fit)
    p = Quadratics([(0.0, 0.0)] * 3)
    u = unc.estimate_uncertainty(p, Z, replicates=4, tolerance_deg=2.0)
    assert seen == [((5, 17), 1.0)]  # the ones row and 4 replicates at 17 normals; half the tolerance
    assert u.sampling_angle_deg == pytest.approx(2.0, rel=1e-12)
    assert u.sampling_score_rel == pytest.approx(2.0 * math.sqrt(2.0 / 3.0) / 2.0, rel=1e-12)
    assert u.fit_angle_deg == pytest.approx(0.5, rel=1e-12)
    assert (u.discretisation_angle_deg, u.discretisation_score_rel) == (0.0, 0.0)
    assert u.angle_deg == pytest.approx(math.sqrt(4.0 + 0.25), rel=1e-12)
    assert u.score_rel == pytest.approx(math.sqrt(2.0 / 3.0), rel=1e-12)
    assert (u.radius_deg, u.replicates) == (1.0, 4)
    assert (u.directions_angle_deg, u.poses_angle_deg, u.directions_score_rel, u.poses_score_rel) == (0, 0, 0, 0)
    assert u.method == "bootstrap over surface points + finer-direction and finer-pose differences"
    for v in (u.angle_deg, u.score_rel, u.sampling_angle_deg, u.sampling_score_rel, u.fit_angle_deg):
        assert type(v) is float
    # a negative height: shares of its size
    tops[:] = [-2.0, -1.0, -2.0, -3.0, -2.0]
    assert unc.estimate_uncertainty(p, Z, replicates=4).sampling_score_rel == pytest.approx(math.sqrt(2.0 / 3.0))
    # a height of exactly 0: shares of 1
    tops[:] = [0.0, 1.0, 2.0, 3.0, 2.0]
    assert unc.estimate_uncertainty(p, Z, replicates=4).sampling_score_rel == pytest.approx(2.0 * math.sqrt(2.0 / 3.0))
    # the finer problems' differences against the answer's height 0: shares of 1 too
    dense = Quadratics([(0.3, 0.4)], top=0.25)
    u = unc.estimate_uncertainty(p, Z, replicates=4, dense=dense)
    assert u.directions_score_rel == pytest.approx(0.25, rel=1e-6)
    assert u.directions_angle_deg == pytest.approx(0.0, abs=1e-5)


def _mixture(weights, peaks, top, curv):
    """Per row of point weights: the weighted mean of the points' quadratics, by hand a quadratic
    peaking at the weighted mean peak p, its height ``top - curv x`` the weighted mean of |peak - p|²."""
    w = weights / weights.sum(axis=1, keepdims=True)
    p = w @ peaks
    spread = np.einsum("rp,rp->r", w, ((peaks[None, :, :] - p[:, None, :]) ** 2).sum(axis=2))
    return p, top - curv * spread


def test_the_bars_of_a_two_cluster_problem_by_hand():
    """Ten surface points whose flash peaks at (0.3, 0.1)° and ten at (-0.2, 0.4)°: each bootstrap
    replicate's objective is a quadratic that peaks at its weighted mean peak (:func:`_mixture`);
    a finer-direction problem peaking at (0.9, -0.6)° with height 1.1 and a finer-pose one at
    (-0.5, -0.5)° with height 0.8: the bars are sqrt((2 σ)² + (2 d)² + (2.5 d')² + fit²)."""
    peaks = np.array([(0.3, 0.1)] * 10 + [(-0.2, 0.4)] * 10)
    p = Quadratics(peaks, top=1.0, curv=0.1)
    dense = Quadratics([(0.9, -0.6)], top=1.1)
    fine = Quadratics([(-0.5, -0.5)], top=0.8)
    u = unc.estimate_uncertainty(p, [0.0, 0.0, 2.0], dense=dense, fine=fine, seed=3)
    w = unc.bootstrap_weights(3, 20, 32)
    mean_peaks, heights = _mixture(w, peaks, 1.0, 0.1)
    boot = mean_peaks[1:]
    spread = math.sqrt(float(np.mean(np.sum((boot - boot.mean(axis=0)) ** 2, axis=1))))
    base, h0 = mean_peaks[0], heights[0]
    np.testing.assert_allclose(base, (0.05, 0.25), atol=1e-12)
    sd = float(np.std(heights[1:], ddof=1)) / h0
    assert u.sampling_angle_deg == pytest.approx(2.0 * spread, rel=1e-4)
    assert u.sampling_score_rel == pytest.approx(2.0 * sd, rel=1e-3)
    assert u.fit_angle_deg == pytest.approx(math.hypot(0.05, 0.25), rel=1e-5)
    d_dir = angle(at(0.9, -0.6), at(*base))
    d_pose = angle(at(-0.5, -0.5), at(*base))
    assert u.directions_angle_deg == pytest.approx(d_dir, rel=1e-5)
    assert u.poses_angle_deg == pytest.approx(d_pose, rel=1e-5)
    assert u.directions_score_rel == pytest.approx(abs(1.1 - h0) / h0, rel=1e-5)
    assert u.poses_score_rel == pytest.approx(abs(0.8 - h0) / h0, rel=1e-5)
    assert u.discretisation_angle_deg == pytest.approx(math.hypot(2.0 * d_dir, 2.5 * d_pose), rel=1e-5)
    assert u.discretisation_score_rel == pytest.approx(math.hypot(2.0 * (1.1 - h0) / h0, 2.5 * (h0 - 0.8) / h0), rel=1e-5)
    assert u.angle_deg == pytest.approx(math.sqrt((2 * spread) ** 2 + u.discretisation_angle_deg ** 2
                                                  + u.fit_angle_deg ** 2), rel=1e-5)
    assert u.score_rel == pytest.approx(math.hypot(2 * sd, u.discretisation_score_rel), rel=1e-4)
    assert (u.radius_deg, u.replicates) == (1.5, 32)
    # every problem's stencil sums were launched at the answer's 17 normals, and those sums used:
    # the finer problems' peaks lie inside their first stencils, nothing asked again
    assert p.calls == dense.calls == fine.calls == []
    for q in (p, dense, fine):
        sent, reach, dtype = q.launched
        np.testing.assert_allclose(sent, unc.stencil(Z, 1.5)[0], atol=1e-15)
        assert reach == pytest.approx(0.25 + math.radians(1.5), abs=1e-9)
    # directions only: no pose part; nothing finer: the sampling and the fit alone
    only = unc.estimate_uncertainty(p, Z, dense=Quadratics([(0.9, -0.6)], top=1.1), seed=3)
    assert only.poses_angle_deg == 0.0 and only.poses_score_rel == 0.0
    assert only.discretisation_angle_deg == pytest.approx(2.0 * d_dir, rel=1e-5)
    assert only.directions_angle_deg == pytest.approx(d_dir, rel=1e-5)
    poses = unc.estimate_uncertainty(p, Z, fine=Quadratics([(-0.5, -0.5)], top=0.8), seed=3)
    assert poses.directions_angle_deg == 0.0 and poses.discretisation_angle_deg == pytest.approx(2.5 * d_pose, rel=1e-5)
    alone = unc.estimate_uncertainty(p, Z, seed=3)
    assert alone.angle_deg == pytest.approx(math.hypot(2 * spread, u.fit_angle_deg), rel=1e-4)
    assert alone.score_rel == pytest.approx(2 * sd, rel=1e-3)
    # another seed: another draw, another spread; no seed: seed 0's
    assert unc.estimate_uncertainty(p, Z, seed=4).sampling_angle_deg != pytest.approx(alone.sampling_angle_deg, rel=1e-3)
    zero = unc.estimate_uncertainty(p, Z, seed=0)
    assert unc.estimate_uncertainty(p, Z) == zero
    assert unc.estimate_uncertainty(p, Z, seed=1).sampling_angle_deg != pytest.approx(zero.sampling_angle_deg, rel=1e-3)


def test_the_same_peak_is_no_difference_even_when_its_dot_rounds_above_one(monkeypatch):
    """The answer's fitted peak at the stencil's centre and a finer problem that keeps its centre
    (its best point): both normals are the answer's own, whose dot with itself rounds to 1 + 2e-16."""
    monkeypatch.setattr(unc, "fit_peaks", lambda xy, values, radius: (np.zeros((len(values), 2)), np.ones(len(values))))
    m = np.array([1.0, 1.0, 1.0]) / np.linalg.norm([1.0, 1.0, 1.0])
    assert float(m @ m) > 1.0

    def top(n):  # best at the centre, a fit that is not concave (as in test_a_best_centre_stays...)
        t = angle(n, m)
        return 1.0 if t < 0.1 else (0.9 if t > 1.2 else 0.0)

    u = unc.estimate_uncertainty(Quadratics([(0.0, 0.0)] * 3), [1.0, 1.0, 1.0], dense=Landscape(top), replicates=4)
    assert u.directions_angle_deg == 0.0 and u.directions_score_rel == 0.0 and u.angle_deg == 0.0


def test_a_finer_problems_peak_beyond_the_stencil_is_followed_and_the_objective_passed_on():
    """The finer problem's peak 5° away along +Y (-X for the answer's): followed, not read as the
    stencil's edge; the thresholded objective reaches both fits."""
    peaks = np.array([(0.0, 0.0)] * 6)
    p = Quadratics(peaks, top=1.0, curv=0.01)
    dense = Quadratics([(5.0, 0.0)], top=1.0, curv=0.01)
    u = unc.estimate_uncertainty(p, Z, dense=dense, tolerance_deg=2.0)
    assert u.directions_angle_deg == pytest.approx(5.0, abs=2e-3)
    assert len(dense.calls) >= 1  # stencils beyond the first
    # "area": every value above the threshold 0.5 flashes, the area is 1 at every normal: a flat
    # top, the centre kept, no difference
    v = unc.estimate_uncertainty(p, Z, "area", dense=Quadratics([(5.0, 0.0)], top=1.0, curv=0.01), tolerance_deg=2.0)
    assert v.directions_angle_deg == pytest.approx(0.0, abs=1e-6) and v.fit_angle_deg == pytest.approx(0.0, abs=1e-6)
    # "intensity": the quadratic itself where it flashes
    w = unc.estimate_uncertainty(p, Z, "intensity", dense=Quadratics([(5.0, 0.0)], top=1.0, curv=0.01),
                                 tolerance_deg=2.0)
    assert w.directions_angle_deg == pytest.approx(5.0, abs=2e-3)


# --- the JSON block -----------------------------------------------------------------------------

FULL = {"angle_deg": 1.5, "score_rel": 0.25, "sampling_angle_deg": 0.5, "sampling_score_rel": 0.125,
        "discretisation_angle_deg": 1.25, "discretisation_score_rel": 0.2, "fit_angle_deg": 0.0625,
        "radius_deg": 1.0, "replicates": 32, "method": "m",
        "directions_angle_deg": 0.75, "directions_score_rel": 0.0375, "poses_angle_deg": 0.1, "poses_score_rel": 0.05}


def test_to_dict_and_back_field_by_field():
    u = Uncertainty(**FULL)
    assert u.to_dict() == FULL and list(u.to_dict()) == list(FULL)
    assert Uncertainty.from_dict(u.to_dict()) == u
    assert Uncertainty.from_dict(FULL) == u


def test_from_dict_reads_every_legal_form():
    for empty in (None, {}, [], "", 0):
        assert Uncertainty.from_dict(empty) is None
    # numbers as text and integers; replicates as text or a whole float; extra keys ignored
    texts = {k: (str(v) if k != "method" else v) for k, v in FULL.items()}
    assert Uncertainty.from_dict(texts) == Uncertainty(**FULL)
    assert Uncertainty.from_dict({**FULL, "replicates": 32.0, "later": "x"}) == Uncertainty(**FULL)
    u = Uncertainty.from_dict({**FULL, "angle_deg": 2, "method": 7})
    assert u.angle_deg == 2.0 and type(u.angle_deg) is float and u.method == "7"
    assert type(Uncertainty.from_dict({**FULL, "replicates": "8"}).replicates) is int
    # older JSON: no raw differences (0), no method (the default)
    old = {k: v for k, v in FULL.items() if not k.startswith(("directions_", "poses_")) and k != "method"}
    u = Uncertainty.from_dict(old)
    assert (u.directions_angle_deg, u.directions_score_rel, u.poses_angle_deg, u.poses_score_rel) == (0, 0, 0, 0)
    assert u.method == "bootstrap over surface points + finer-direction and finer-pose differences"
    assert u.angle_deg == 1.5 and u.replicates == 32
    # any one of them alone
    for k in ("directions_angle_deg", "directions_score_rel", "poses_angle_deg", "poses_score_rel"):
        assert getattr(Uncertainty.from_dict({**old, k: "0.5"}), k) == 0.5


@pytest.mark.parametrize("data, message", [
    ([1, 2], "uncertainty must be a JSON object"),
    ("1.5", "uncertainty must be a JSON object"),
    ({k: v for k, v in FULL.items() if k != "fit_angle_deg"}, "uncertainty: bad or missing field ('fit_angle_deg')"),
    ({k: v for k, v in FULL.items() if k != "replicates"}, "uncertainty: bad or missing field ('replicates')"),
    ({k: v for k, v in FULL.items() if k != "radius_deg"}, "uncertainty: bad or missing field ('radius_deg')"),
    ({**FULL, "angle_deg": "wide"}, "uncertainty: bad or missing field (could not convert string to float: 'wide')"),
    ({**FULL, "poses_angle_deg": None},
     "uncertainty: bad or missing field (float() argument must be a string or a real number, not 'NoneType')"),
    ({**FULL, "replicates": "8.5"}, "uncertainty: bad or missing field (invalid literal for int() with base 10: '8.5')"),
])
def test_from_dict_refuses_in_one_line(data, message):
    with pytest.raises(ParameterError) as err:
        Uncertainty.from_dict(data)
    assert str(err.value) == message


def test_scaled_scales_every_bar_but_the_radius_and_count():
    u = Uncertainty(**FULL)
    s = u.scaled("2")
    assert s.to_dict() == {**{k: 2 * v for k, v in FULL.items() if k not in ("radius_deg", "replicates", "method")},
                           "radius_deg": 1.0, "replicates": 32, "method": "m"}
    assert u.scaled(1.0) == u


# --- a recommendation's finer problems ------------------------------------------------------

class Setup:
    """A stand-in FlashQuestion: records the qualities asked for and the map's directions."""

    def __init__(self, rock=0.0, sway=0.0):
        self.quality = Quality.coerce("draft")
        self.material, self.tau, self.seed, self.objective = "stone", 0.7, 11, "area"
        self.scenario = SimpleNamespace(rock_deg=rock, sway_deg=sway)
        self.asked: list = []

    def at_quality(self, q):
        asked = self.asked

        class Scenario:
            def with_env_samples(self, env):
                return SimpleNamespace(settings=lambda: ("settings", q.env_samples, q.rock_steps, env))

        asked.append(q)
        return SimpleNamespace(quality=q, scenario=Scenario())


@pytest.fixture
def built(monkeypatch):
    """build_pairs, build_volume_problem and estimate_uncertainty recorded."""
    import labcut.orientation.pairs as pairs

    log = []
    monkeypatch.setattr(pairs, "build_pairs", lambda *a, **k: log.append(("pairs", a, k)) or f"pairs{len(log)}")
    monkeypatch.setattr(unc, "build_volume_problem", lambda *a, **k: log.append(("volume", a, k)) or f"volume{len(log)}")
    monkeypatch.setattr(unc, "estimate_uncertainty", lambda *a, **k: ("bars", a, k))
    return log


def test_uncertainty_for_a_still_scenario_builds_the_finer_directions_only(built):
    setup = Setup()
    got = unc.uncertainty_for("mesh", setup, "problem", Z, occlusion=True, tolerance_deg=2.5)
    dense_q = unc.finer_directions(setup.quality)
    assert setup.asked == [dense_q]
    assert built == [("pairs", ("mesh", "stone", dense_q, 0.7, 11, ("settings", 64, (5, 2), None)), {"occlusion": True})]
    assert got == ("bars", ("problem", Z, "area"), {"dense": "pairs1", "fine": None, "tolerance_deg": 2.5, "seed": 11})


@pytest.mark.parametrize("rock, sway", [(3.0, 0.0), (0.0, 1e-9), (2.0, 2.0)])
def test_uncertainty_for_a_rocking_scenario_builds_the_finer_poses_too(built, rock, sway):
    setup = Setup(rock, sway)
    got = unc.uncertainty_for("mesh", setup, "problem", Z, occlusion=None, tolerance_deg=None, env_samples=100)
    dense_q, fine_q = unc.finer_directions(setup.quality), unc.finer_poses(setup.quality)
    assert setup.asked == [dense_q, fine_q]
    assert [b[1][5] for b in built] == [("settings", 64, (5, 2), 200), ("settings", 32, (9, 5), 100)]  # twice the map's
    assert [b[1][2] for b in built] == [dense_q, fine_q]
    assert got[2] == {"dense": "pairs1", "fine": "pairs2", "tolerance_deg": None, "seed": 11}


def test_uncertainty_for_the_volume_estimator_builds_volume_problems(built):
    setup = Setup(rock=1.0)
    unc.uncertainty_for("mesh", setup, "problem", Z, occlusion=False, tolerance_deg=1.0, volume=True)
    dense_q, fine_q = unc.finer_directions(setup.quality), unc.finer_poses(setup.quality)
    assert built == [
        ("volume", ("mesh", "stone", dense_q, 0.7, 11),
         {"settings": ("settings", 64, (5, 2), None), "occlusion": False, "path_budget": BAR_PATH_BUDGET}),
        ("volume", ("mesh", "stone", fine_q, 0.7, 11),
         {"settings": ("settings", 32, (9, 5), None), "occlusion": False, "path_budget": BAR_PATH_BUDGET})]
