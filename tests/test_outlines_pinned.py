"""labcut.geometry.outlines pinned by mutation testing (issue 37; docs/testing.md, "labcut/geometry/outlines.py").

The girdle outlines worked by hand from the module docstring: each name's curve (every point
on its ellipse, superellipse, circles or straight sides), its extreme points as exact vertices,
counter-clockwise, about ``n`` points; the dense curves and their mirroring; the resampling
(keys kept exactly, a circle resampled to equal angles, at least one point a segment); the
polygon helpers on hand-made polygons (area, crossing and touching edges, the star centre and
the kernel's centroid, the convexity test, densify's counts); every error word for word and
each size limit at its value. No mesh: a few seconds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from labcut.errors import ParameterError
from labcut.geometry import outlines as ol
from labcut.geometry.outlines import (CUSHION_EXPONENT, MAX_SIZE_MM, MIN_SIZE_MM, OUTLINES, check_size, densify,
                                      is_convex_polygon, make_outline, polygon_area, resample, segments_intersect,
                                      star_centre, validate_outline)

SQUARE = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
BOWTIE = np.array([[0.0, 0.0], [10.0, 10.0], [10.0, 0.0], [0.0, 10.0]])
#: an arrowhead pointing at +X with a deep notch at (8, 5): star-shaped, its centroid (6, 5) outside its kernel
DART = np.array([[0.0, 0.0], [10.0, 5.0], [0.0, 10.0], [8.0, 5.0]])
C_SHAPE = np.array([[0, 0], [10, 0], [10, 2], [2, 2], [2, 8], [10, 8], [10, 10], [0, 10]], dtype=float)


def ccw_simple(p: np.ndarray) -> None:
    assert p.dtype == np.float64 and p.ndim == 2 and p.shape[1] == 2
    assert polygon_area(p) > 0
    assert segments_intersect(p) is None
    assert np.all(np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1) > 1e-9)  # distinct, not closed


# ------------------------------------------------------------------ constants and sizes
def test_constants():
    assert OUTLINES == ("round", "oval", "cushion", "pear", "marquise", "rectangle")
    assert (MIN_SIZE_MM, MAX_SIZE_MM) == (0.1, 1000.0)
    assert CUSHION_EXPONENT == 3.0


@pytest.mark.parametrize("value", [0.1, 1000, 1000.0, 16, "12.5"])
def test_check_size_accepts(value):
    assert check_size("length", value) == float(value)
    assert isinstance(check_size("length", value), float)


@pytest.mark.parametrize("value", [0.0999, 1000.001, 0, -5])
def test_check_size_refuses_word_for_word(value):
    with pytest.raises(ParameterError) as info:
        check_size("width", value)
    assert str(info.value) == f"width must lie in [0.1, 1000] mm (a stone's size), got {float(value):g}"
    assert info.value.parameter == "width"


# ------------------------------------------------------------------ dense curves
def test_mirror_quarter_by_hand():
    """(2, 0) -> (1, 1) -> (0, 3) mirrored: counter-clockwise from +X, no point repeated, the four
    extreme points at 0, m, 2m, 3m."""
    pts, keys = ol._mirror_quarter([[2, 0], [1, 1], [0, 3]])
    want = [[2, 0], [1, 1], [0, 3], [-1, 1], [-2, 0], [-1, -1], [0, -3], [1, -1]]
    assert pts.dtype == np.float64 and pts.tolist() == want
    assert keys == [0, 2, 4, 6]


def test_quarter_curve():
    q = ol._quarter_curve(np.cos, np.sin)
    assert q.shape == (4097, 2)
    assert q[0].tolist() == [1.0, 0.0] and q[-1] == pytest.approx([0.0, 1.0], abs=1e-15)
    assert np.allclose(np.hypot(q[:, 0], q[:, 1]), 1.0, atol=1e-15)
    ang = np.arctan2(q[:, 1], q[:, 0])
    assert np.allclose(np.diff(ang), math.pi / 2 / 4096, atol=1e-12)  # equal parameter steps


def test_ellipse_and_superellipse_dense():
    pts, keys = ol._ellipse_dense(5.0, 3.0)
    assert len(pts) == 4 * 4096 and keys == [0, 4096, 8192, 12288]
    assert np.allclose((pts[:, 0] / 5) ** 2 + (pts[:, 1] / 3) ** 2, 1.0, atol=1e-12)
    assert pts[keys] == pytest.approx(np.array([[5, 0], [0, 3], [-5, 0], [0, -3]]), abs=1e-12)
    pts, keys = ol._superellipse_dense(5.0, 3.0, 3.0)
    assert np.allclose(np.abs(pts[:, 0] / 5) ** 3 + np.abs(pts[:, 1] / 3) ** 3, 1.0, atol=1e-12)
    # (0, b) from cos(pi/2)^(2/3) = (6e-17)^(2/3): 8e-11 off the axis, the extreme y exact
    assert pts[keys] == pytest.approx(np.array([[5, 0], [0, 3], [-5, 0], [0, -3]]), abs=1e-10)
    assert pts[4096, 1] == 3.0 and np.abs(pts[:, 1]).max() == 3.0
    # the point at 45 degrees of the parameter: (a, b) cos(pi/4)^(2/3)
    assert pts[2048] == pytest.approx([5 * 0.5 ** (1 / 3), 3 * 0.5 ** (1 / 3)], abs=1e-12)


def test_lens_arc_by_hand():
    """Half-length 4, half-width 2: R = (16 + 4) / 4 = 5, centre (x0, -3); from (x0, 2) (horizontal
    tangent) to the tip (x0 + 4, 0), n + 1 points at equal angles."""
    arc = ol._lens_arc(4.0, 2.0, 1.0, 8)
    assert arc.shape == (9, 2)
    assert arc[0] == pytest.approx([1.0, 2.0], abs=1e-12) and arc[-1] == pytest.approx([5.0, 0.0], abs=1e-12)
    assert np.allclose(np.hypot(arc[:, 0] - 1.0, arc[:, 1] + 3.0), 5.0, atol=1e-12)
    ang = np.arctan2(arc[:, 1] + 3.0, arc[:, 0] - 1.0)
    assert np.allclose(np.diff(ang), (math.atan2(3, 4) - math.pi / 2) / 8, atol=1e-12)


def test_marquise_and_pear_dense():
    a, b = 8.0, 3.0  # marquise: R = (64 + 9) / 6, centres (0, 3 - R) and (0, R - 3)
    pts, keys = ol._marquise_dense(a, b)
    R = (a * a + b * b) / (2 * b)
    assert pts[keys] == pytest.approx(np.array([[a, 0], [0, b], [-a, 0], [0, -b]]), abs=1e-12)
    up = pts[:, 1] >= 0
    assert np.allclose(np.hypot(pts[up, 0], pts[up, 1] - (b - R)), R, atol=1e-9)
    assert np.allclose(np.hypot(pts[~up, 0], pts[~up, 1] + (b - R)), R, atol=1e-9)
    # pear: the round end a circle of radius b about c = -a + b; the point an arc to (a, 0)
    pts, keys = ol._pear_dense(a, b)
    c = -a + b
    assert keys == [0, 4096, 8192, 12288]
    assert pts[keys] == pytest.approx(np.array([[a, 0], [c, b], [-a, 0], [c, -b]]), abs=1e-12)
    assert len(pts) == 4 * 4096
    back = pts[:, 0] <= c
    assert np.allclose(np.hypot(pts[back, 0] - c, pts[back, 1]), b, atol=1e-12)
    assert polygon_area(pts) > 0


def test_rounded_rectangle_dense():
    pts, keys = ol._rounded_rectangle_dense(5.0, 3.0, 0.0)
    assert pts.tolist() == [[5, 0], [5, 3], [0, 3], [-5, 3], [-5, 0], [-5, -3], [0, -3], [5, -3]]
    assert keys == list(range(8))
    pts, keys = ol._rounded_rectangle_dense(5.0, 3.0, 1.0)
    assert pts[keys] == pytest.approx(np.array([[5, 0], [0, 3], [-5, 0], [0, -3]]), abs=1e-12)
    # the straight side's ends and the corner arc of radius 1 about (4, 2)
    assert pts[1].tolist() == [5.0, 2.0]
    corner = (pts[:, 0] > 4) & (pts[:, 1] > 2)
    assert np.allclose(np.hypot(pts[corner, 0] - 4, pts[corner, 1] - 2), 1.0, atol=1e-12)
    assert [4.0, 3.0] in pts.tolist()
    # a square with the radius half its side: a circle, no point twice
    pts, keys = ol._rounded_rectangle_dense(5.0, 5.0, 5.0)
    assert np.allclose(np.hypot(pts[:, 0], pts[:, 1]), 5.0, atol=1e-12)
    assert np.all(np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-12)
    assert keys == [0, 4096, 8192, 12288]


# ------------------------------------------------------------------ make_outline, by name
def test_round_resampled_to_equal_angles():
    """A circle's measure is uniform (equal lengths, equal turns): 8 points at 45 degrees."""
    p = make_outline("round", 10, 10, n=8)
    want = [[5 * math.cos(k * math.pi / 4), 5 * math.sin(k * math.pi / 4)] for k in range(8)]
    assert p == pytest.approx(np.array(want), abs=1e-6)
    assert p[0].tolist() == [5.0, 0.0]


@pytest.mark.parametrize("name, W", [("round", 10.0), ("oval", 6.0), ("cushion", 6.0), ("pear", 6.0),
                                     ("marquise", 6.0), ("rectangle", 6.0)])
@pytest.mark.parametrize("n", [32, 64, 256])
def test_every_outline_is_ccw_simple_exact_and_about_n(name, W, n):
    p = make_outline(name, 10, W, n=n)
    ccw_simple(p)
    assert abs(len(p) - n) <= 4
    # the extreme points are vertices: the bounding box exact, centred
    assert p[:, 0].max() == pytest.approx(5.0, abs=1e-12) and p[:, 0].min() == pytest.approx(-5.0, abs=1e-12)
    assert p[:, 1].max() == pytest.approx(W / 2, abs=1e-12) and p[:, 1].min() == pytest.approx(-W / 2, abs=1e-12)
    assert p[0] == pytest.approx([5.0, 0.0], abs=1e-12)  # starts at +X


def test_each_name_is_its_curve():
    a, b = 8.0, 3.0
    p = make_outline("oval", 16, 6, n=64)
    assert np.allclose((p[:, 0] / a) ** 2 + (p[:, 1] / b) ** 2, 1.0, atol=1e-5)  # chords of the dense curve
    p = make_outline("cushion", 16, 6, n=64)
    assert np.allclose(np.abs(p[:, 0] / a) ** 3 + np.abs(p[:, 1] / b) ** 3, 1.0, atol=1e-5)
    p = make_outline("marquise", 16, 6, n=64)
    R = (a * a + b * b) / (2 * b)
    up = p[:, 1] >= 0
    assert np.allclose(np.hypot(p[up, 0], p[up, 1] - (b - R)), R, atol=1e-5)
    p = make_outline("pear", 16, 6, n=64)
    c = -a + b
    back = p[:, 0] <= c
    assert back.sum() >= 8
    assert np.allclose(np.hypot(p[back, 0] - c, p[back, 1]), b, atol=1e-5)
    # the default rectangle: straight sides, corners of 15 % of the smaller side (0.9 mm)
    p = make_outline("rectangle", 16, 6, n=64)
    r = 0.15 * 6
    on_side = np.isclose(np.abs(p[:, 0]), a) | np.isclose(np.abs(p[:, 1]), b)
    corner = ~on_side
    cx, cy = a - r, b - r
    assert np.allclose(np.hypot(np.abs(p[corner, 0]) - cx, np.abs(p[corner, 1]) - cy), r, atol=1e-5)
    assert np.isclose(np.abs(p[:, 1]), b).sum() >= 4 and np.isclose(np.abs(p[:, 0]), a).sum() >= 4
    # areas: pi a b, the superellipse's 4 a b Gamma(1 + 1/3)^2 / Gamma(1 + 2/3), the rounded rectangle's
    assert polygon_area(make_outline("oval", 16, 6, n=4096)) == pytest.approx(math.pi * a * b, rel=1e-5)
    cushion = 4 * a * b * math.gamma(1 + 1 / 3) ** 2 / math.gamma(1 + 2 / 3)
    assert polygon_area(make_outline("cushion", 16, 6, n=4096)) == pytest.approx(cushion, rel=1e-4)
    rect = 16 * 6 - (4 - math.pi) * r * r
    assert polygon_area(make_outline("rectangle", 16, 6, n=4096)) == pytest.approx(rect, rel=1e-5)


def test_names_in_any_case_and_n_as_float():
    assert np.array_equal(make_outline("OVAL", 16, 12, n=64), make_outline("oval", 16, 12, n=64))
    assert np.array_equal(make_outline("Round", 12, 12), make_outline("round", 12, 12))
    assert np.array_equal(make_outline("oval", 16, 12, n=64.9), make_outline("oval", 16, 12, n=64))
    assert abs(len(make_outline("oval", 16, 12)) - 256) <= 4  # the default n


def test_sharp_rectangle_is_its_eight_points():
    """corner_radius 0: the rectangle's corners and side midpoints, not resampled."""
    for r in (0, 0.0):
        p = make_outline("rectangle", 10, 6, n=256, corner_radius=r)
        assert p.tolist() == [[5, 0], [5, 3], [0, 3], [-5, 3], [-5, 0], [-5, -3], [0, -3], [5, -3]]


def test_rectangle_corner_radius_range():
    """Up to half the smaller side: 3 mm on a 10 x 6 (a stadium), its rounding tolerance 1e-12 above."""
    p = make_outline("rectangle", 10, 6, n=128, corner_radius=3)
    ccw_simple(p)
    assert p[:, 1].max() == pytest.approx(3.0, abs=1e-12)
    ends = np.abs(p[:, 0]) > 2
    assert np.allclose(np.hypot(np.abs(p[ends, 0]) - 2, p[ends, 1]), 3.0, atol=1e-5)
    make_outline("rectangle", 10, 6, corner_radius=3 * (1 + 1e-13))
    with pytest.raises(ParameterError) as info:
        make_outline("rectangle", 10, 6, corner_radius=3.001)
    assert str(info.value) == "corner_radius must lie in [0, 3] mm (up to half the smaller side), got 3.001"
    with pytest.raises(ParameterError) as info:
        make_outline("rectangle", 10, 6, corner_radius=-0.5)
    assert str(info.value) == "corner_radius must lie in [0, 3] mm (up to half the smaller side), got -0.5"


def test_unknown_outline_word_for_word():
    for bad in ("hexagon", "", 3, None, "ovals"):
        with pytest.raises(ParameterError) as info:
            make_outline(bad, 16, 12)
        assert str(info.value) == (f"unknown outline {bad!r}; use one of round, oval, cushion, pear, marquise, "
                                   "rectangle or an (N, 2) array of points")


def test_round_needs_equal_sides():
    make_outline("round", 10, 10 * (1 + 5e-10))  # within 1e-9 of the larger: the same diameter
    with pytest.raises(ParameterError) as info:
        make_outline("round", 16, 12)
    assert str(info.value) == "a round outline has length == width (the diameter), got 16 x 12 mm"
    with pytest.raises(ParameterError) as info:
        make_outline("round", 10, 10.0001)
    assert str(info.value) == "a round outline has length == width (the diameter), got 10 x 10.0001 mm"


@pytest.mark.parametrize("name", ["pear", "marquise"])
def test_pointed_outlines_need_length_at_least_width(name):
    ccw_simple(make_outline(name, 12, 12, n=64))  # equal: allowed
    ccw_simple(make_outline(name, 12 * (1 - 1e-13), 12, n=64))
    with pytest.raises(ParameterError) as info:
        make_outline(name, 8, 12)
    assert str(info.value) == f"a {name} outline needs length >= width (it points along the length), got 8 x 12 mm"
    with pytest.raises(ParameterError) as info:
        make_outline(name, 11.99, 12)
    assert str(info.value) == f"a {name} outline needs length >= width (it points along the length), got 11.99 x 12 mm"


def test_sizes_checked_word_for_word():
    with pytest.raises(ParameterError) as info:
        make_outline("oval", 0.05, 12)
    assert str(info.value) == "length must lie in [0.1, 1000] mm (a stone's size), got 0.05"
    with pytest.raises(ParameterError) as info:
        make_outline("oval", 16, 2000)
    assert str(info.value) == "width must lie in [0.1, 1000] mm (a stone's size), got 2000"
    ccw_simple(make_outline("oval", 0.1, 0.1, n=32))
    ccw_simple(make_outline("oval", 1000, 1000, n=32))


# ------------------------------------------------------------------ resample
def test_resample_keeps_a_short_curve_as_it_is():
    dense = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    out = resample(dense, [0], 4)
    assert out.tolist() == dense.tolist() and out is not dense
    out = resample(dense, [0], 2, keep_all_vertices=True)
    assert out.tolist() == dense.tolist() and out is not dense


def test_resample_keys_exact_and_counts():
    """Keys are kept exactly (here given out of order, repeated and past the end); each segment
    between keys gets its share of n, at least one point."""
    dense, keys = ol._ellipse_dense(8.0, 3.0)
    out = resample(dense, [4096 + 16384, 0, 12288, 8192, 0, 4096], 40)
    for k in (0, 4096, 8192, 12288):
        assert dense[k].tolist() in out.tolist()
    assert len(out) == 40
    # one tiny segment next to a long one: the tiny one still gets its key
    out = resample(dense, [0, 1, 8192], 10)
    assert dense[1].tolist() in out.tolist() and dense[0].tolist() in out.tolist()


def test_resample_half_length_half_turning():
    """A 10 x 2 rectangle traced densely (with corners as keys): the long sides hold most of the
    length, the corners all the turning; each point's measure is half its length share, half its
    turning share."""
    side = lambda p, q, k: [np.array(p) + t * (np.array(q) - np.array(p)) for t in np.arange(k) / k]  # noqa: E731
    dense = np.array(side((5, -1), (5, 1), 200) + side((5, 1), (-5, 1), 1000) + side((-5, 1), (-5, -1), 200)
                     + side((-5, -1), (5, -1), 1000), dtype=float)
    keys = [0, 200, 1200, 1400]
    out = resample(dense, keys, 40)
    # per side: length share 2/24 or 10/24, turning share 1/4 each (the corners at both ends, halved)
    # -> 40 * (0.5 * 2/24 + 0.5 * 1/4) = 6.67 -> 7 points on a short side, 40 * (0.5 * 10/24 + 0.125) = 13.3 -> 13
    xs = out[:, 0]
    short = np.sum(np.isclose(xs, 5.0) & (out[:, 1] < 1 - 1e-9))  # from (5, -1) up to (5, 1), not its end
    assert short == 7
    assert len(out) == 7 + 13 + 7 + 13


def test_resample_drops_points_closer_than_1e_9():
    """Keys 1e-10 apart give one point, and a last point within 1e-9 of the first is dropped."""
    dense = np.array([[1.0, 0.0], [1.0, 1e-10], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, -1e-10]])
    out = resample(dense, [0, 1, 2, 3, 4, 5], 5)
    assert out.tolist() == [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]]


# ------------------------------------------------------------------ polygon helpers
def test_polygon_area_by_hand():
    assert polygon_area(SQUARE) == 4.0
    assert polygon_area(SQUARE[::-1]) == -4.0
    assert polygon_area([[0, 0], [4, 0], [0, 3]]) == 6.0
    assert polygon_area(DART) == 10.0
    assert polygon_area([[1, 1], [3, 1], [3, 2], [1, 2]]) == 2.0  # off the origin


def test_segments_intersect_by_hand():
    assert segments_intersect(SQUARE) is None
    assert segments_intersect(BOWTIE) == (0, 2)  # (0,0)-(10,10) crosses (10,0)-(0,10)
    assert segments_intersect(DART) is None
    assert segments_intersect(C_SHAPE) is None
    # a vertex on another edge: (5, 0) touches edge 0 (0,0)-(10,0)
    assert segments_intersect(np.array([[0, 0], [10, 0], [10, 10], [5, 0], [0, 10]], dtype=float)) == (0, 2)
    # collinear overlap: edge 2 runs back along edge 0
    assert segments_intersect(np.array([[0, 0], [10, 0], [4, 0], [2, 5]], dtype=float)) is not None
    # adjacent edges share an end: not a crossing; a triangle never crosses
    assert segments_intersect(np.array([[0, 0], [4, 0], [0, 3]], dtype=float)) is None
    # edges that nearly touch (1e-6 apart on a 10 mm polygon) do not
    assert segments_intersect(np.array([[0, 0], [10, 0], [10, 10], [5, 1e-6], [0, 10]], dtype=float)) is None


def test_segments_intersect_past_the_first_chunk():
    """Edges are tested 256 at a time: a crossing between edges 300 and 302 of a 600-gon is found,
    the first crossing pair in order."""
    t = np.linspace(0, 2 * math.pi, 600, endpoint=False)
    p = np.column_stack([np.cos(t), np.sin(t)]) * 10
    p[[301, 302]] = p[[302, 301]]
    assert segments_intersect(p) == (300, 302)
    q = np.column_stack([np.cos(t), np.sin(t)]) * 10
    q[[3, 4]] = q[[4, 3]]
    q[[501, 502]] = q[[502, 501]]
    assert segments_intersect(q) == (2, 4)


def test_centroid_by_hand():
    assert ol._centroid(SQUARE).tolist() == [1.0, 1.0]
    assert ol._centroid(np.array([[0.0, 0.0], [6.0, 0.0], [0.0, 3.0]])) == pytest.approx([2.0, 1.0], abs=1e-12)
    assert ol._centroid(DART) == pytest.approx([6.0, 5.0], abs=1e-12)
    # no area: the mean of the points
    assert ol._centroid(np.array([[0.0, 0.0], [1.0, 1.0], [5.0, 5.0]])).tolist() == [2.0, 2.0]


def test_star_centre_is_the_centroid_when_inside():
    assert star_centre(SQUARE).tolist() == [1.0, 1.0]
    p = make_outline("pear", 16, 10, n=128)
    assert star_centre(p) == pytest.approx(ol._centroid(p), abs=0)


def test_star_centre_is_the_kernels_centroid():
    """The dart's centroid (6, 5) sees not all of it; its kernel is the kite (8, 5), (80/9, 40/9),
    (10, 5), (80/9, 50/9), whose centroid is (242/27, 5)."""
    assert star_centre(DART) == pytest.approx([242 / 27, 5.0], abs=1e-9)
    assert star_centre(DART[::-1].copy()) is None  # clockwise: no inner side


def test_star_centre_none_when_nothing_sees_it_all():
    assert star_centre(C_SHAPE) is None
    # a kernel of area 1e-8 mm^2 (under 1e-6 x size^2): too small to scale a dome from
    thin = np.array([[0.0, 0.0], [10.0, 5.0 - 1e-5], [10.0, 5.0 + 1e-5], [0.0, 10.0], [9.999, 5.0]])
    assert star_centre(thin) is None


# ------------------------------------------------------------------ validate_outline
def test_validate_returns_ccw_float64():
    p = validate_outline([[0, 0], [0, 2], [2, 2], [2, 0]])  # clockwise, ints
    assert p.dtype == np.float64
    assert p.tolist() == [[2, 0], [2, 2], [0, 2], [0, 0]]
    assert validate_outline(SQUARE).tolist() == SQUARE.tolist()
    assert validate_outline([[0, 0], [4, 0], [0, 3]]).tolist() == [[0, 0], [4, 0], [0, 3]]


def test_validate_drops_closing_and_repeated_points():
    p = validate_outline([[0, 0], [2, 0], [2, 0], [2, 2], [0, 2], [0, 0]])
    assert p.tolist() == SQUARE.tolist()
    p = validate_outline([[0, 0], [2, 0], [2, 2 + 1e-13], [2, 2], [0, 2], [1e-13, 0]])
    assert len(p) == 4
    p = validate_outline([[0, 0], [2, 0], [2, 2], [2, 2 + 1e-11], [0, 2]])  # 1e-11 apart: two points
    assert len(p) == 5


def test_validate_errors_word_for_word():
    def msg(points, name="outline"):
        with pytest.raises(ParameterError) as info:
            validate_outline(points, name)
        return str(info.value)

    assert msg("abc") == "outline must be a name or an (N, 2) array of points in mm"
    assert msg([[0, 0], [1]]) == "outline must be a name or an (N, 2) array of points in mm"
    assert msg(np.zeros((4, 3)), "girdle") == "girdle must be an (N, 2) array of x, y points in mm, got shape (4, 3)"
    assert msg([1, 2, 3]) == "outline must be an (N, 2) array of x, y points in mm, got shape (3,)"
    assert msg([[0, 0], [1, 0], [np.nan, 1]]) == "outline has non-finite points (NaN or inf)"
    assert msg([[0, 0], [1, 0], [np.inf, 1]]) == "outline has non-finite points (NaN or inf)"
    assert msg([[0, 0], [1, 0]]) == "outline needs at least 3 distinct points, got 2"
    assert msg([[0, 0], [1, 0], [0, 0]]) == "outline needs at least 3 distinct points, got 2"
    assert msg([[1, 1], [1, 1], [1, 1], [1, 1]]) == "outline needs at least 3 distinct points, got 1"
    assert msg(np.zeros((0, 2))) == "outline needs at least 3 distinct points, got 0"
    assert msg([[0, 0], [1, 1], [2, 2]]) == "outline encloses no area (its points are collinear)"
    assert msg([[0, 0], [1, 1], [3, 3], [2, 2]]) == "outline is self-intersecting (edges 1 and 3 cross or touch)"  # overlap
    assert msg(BOWTIE) == "outline is self-intersecting (edges 0 and 2 cross or touch)"


def test_validate_area_threshold():
    """Collinear means an area at most 1e-9 x size^2: a 10 mm triangle 1e-9 mm high has none, one
    1e-6 mm high is kept."""
    with pytest.raises(ParameterError, match="collinear"):
        validate_outline([[0, 0], [10, 0], [5, 1e-9]])
    assert len(validate_outline([[0, 0], [10, 0], [5, 1e-6]])) == 3


# ------------------------------------------------------------------ densify and convexity
def test_densify_by_hand():
    """A 4 x 1 rectangle to 10 points: 6 new ones, by length 2.4, 0.6, 2.4, 0.6; whole parts 2, 0,
    2, 0, the two left over to the largest remainders (the short sides): 2, 1, 2, 1."""
    p = np.array([[0, 0], [4, 0], [4, 1], [0, 1]], dtype=float)
    out = densify(p, 10)
    want = [[0, 0], [4 / 3, 0], [8 / 3, 0], [4, 0], [4, 0.5], [4, 1], [8 / 3, 1], [4 / 3, 1], [0, 1], [0, 0.5]]
    assert out == pytest.approx(np.array(want), abs=1e-12)
    assert densify(p, 4).tolist() == p.tolist() and densify(p, 3).tolist() == p.tolist()
    out = densify(p, 14)  # 10 new: 4, 1, 4, 1 exactly
    assert len(out) == 14 and out[:6] == pytest.approx(np.array([[0, 0], [0.8, 0], [1.6, 0], [2.4, 0], [3.2, 0], [4, 0]]))
    assert out[6].tolist() == [4.0, 0.5]


def test_is_convex_polygon():
    assert is_convex_polygon(SQUARE)
    assert is_convex_polygon([[0, 0], [1, 0], [2, 0], [2, 2], [0, 2]])  # a collinear vertex
    assert not is_convex_polygon(DART)
    assert not is_convex_polygon(C_SHAPE)
    assert not is_convex_polygon(SQUARE[::-1])  # clockwise: every vertex turns right
    # a dent of 1e-10 over 1 mm edges is within the default rtol 1e-9 x the edges' lengths; 1e-8 is not
    assert is_convex_polygon([[0, 0], [1, 1e-10], [2, 0], [2, 2], [0, 2]])
    assert not is_convex_polygon([[0, 0], [1, 1e-8], [2, 0], [2, 2], [0, 2]])
    assert is_convex_polygon([[0, 0], [1, 1e-8], [2, 0], [2, 2], [0, 2]], rtol=1e-7)


# ------------------------------------------------------------------ second round: what the first run left
def test_dense_lengths_and_the_rectangles_tangent_points():
    """Each dense curve has 4 x 4096 points (a marquise too); the rounded rectangle's quarter is
    (a, 0), (a, b - r), the corner's 4095 inner points, (a - r, b), (0, b), whatever the length of
    the straight runs (0.5 mm here: still a vertex)."""
    assert len(ol._marquise_dense(8.0, 3.0)[0]) == 4 * 4096
    pts, keys = ol._rounded_rectangle_dense(5.0, 3.0, 1.0)
    assert len(pts) == 4 * 4098 and keys == [0, 4098, 8196, 12294]
    assert pts[1].tolist() == [5.0, 2.0] and pts[4097].tolist() == [4.0, 3.0]
    pts, keys = ol._rounded_rectangle_dense(5.0, 3.0, 2.5)  # straight runs of 0.5 (up) and 2.5 (across)
    assert pts[1].tolist() == [5.0, 0.5] and [2.5, 3.0] in pts.tolist()
    pts, keys = ol._rounded_rectangle_dense(5.0, 4.5, 4.5)  # no run up the side, 0.5 across the top
    assert [0.5, 4.5] in pts.tolist() and len(pts) == 4 * 4097


def test_resample_exactly_n_points_is_kept():
    """A curve of exactly n points is returned as it is (not moved by the resampling)."""
    dense = np.array([[5, 0], [5, 3], [0, 3], [-5, 3], [-5, 0], [-5, -3], [0, -3], [5, -3]], dtype=float)
    assert resample(dense, [0], 8).tolist() == dense.tolist()


def test_resample_drops_only_near_duplicates():
    """A repeated first point is dropped without dropping the last; a last point within 1e-9 of
    the first (a closed curve) is dropped."""
    dense = np.array([[1.0, 0.0], [1.0, 1e-10], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    assert resample(dense, [0, 1, 2, 3, 4], 4).tolist() == [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]]
    dense = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, -1e-10]])
    assert resample(dense, [0, 1, 2, 3, 4], 4).tolist() == [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]]


def test_default_n_is_256_and_rounded_rectangles_are_resampled():
    assert np.array_equal(make_outline("oval", 16, 12), make_outline("oval", 16, 12, n=256))
    for r in (1, 1.0, 0.5, 3):
        assert abs(len(make_outline("rectangle", 10, 6, n=64, corner_radius=r)) - 64) <= 4


def test_segments_intersect_touching_a_vertical_or_horizontal_edge():
    """A vertex exactly on a vertical edge (its x the edge's x): the bounding-box test includes its
    ends; the lower-numbered edge's own vertex on the other edge is found as well."""
    p = np.array([[0, 0], [10, 0], [10, 10], [0, 10], [10, 5]], dtype=float)
    assert segments_intersect(p) == (1, 3)
    assert segments_intersect(p[:, ::-1][::-1].copy()) is not None  # the same on a horizontal edge
    q = np.array([[10, 5], [0, 0], [10, 0], [10, 10], [0, 10]], dtype=float)
    assert segments_intersect(q) == (0, 2)
    # a vertex 1e-12 mm off an edge of a 10 mm polygon touches it (tolerance 1e-12 x size^2 on the cross product)
    assert segments_intersect(np.array([[0, 0], [10, 0], [10, 10], [5, 1e-12], [0, 10]])) == (0, 2)


def test_segments_intersect_every_chunk():
    """Edges 256 and 600 of a 700-gon: a crossing in each chunk is found."""
    t = np.linspace(0, 2 * math.pi, 700, endpoint=False)
    for k in (256, 257, 600):
        p = np.column_stack([np.cos(t), np.sin(t)]) * 10
        p[[k, k + 1]] = p[[k + 1, k]]
        assert segments_intersect(p) == (k - 1, k + 1)


def test_star_centre_anywhere_any_size():
    """The dart's kernel centroid moved with the dart (1000 mm along X or Y) and scaled with it
    (0.01: clipping must not depend on the size of the cross products)."""
    want = np.array([242 / 27, 5.0])
    for shift in ([1000.0, 0.0], [0.0, 1000.0], [-1000.0, 500.0]):
        assert star_centre(DART + shift) == pytest.approx(want + shift, abs=1e-7)
    assert star_centre(DART * 0.01) == pytest.approx(want * 0.01, abs=1e-11)
    # an edge split in two collinear halves clips nothing more: the same kernel
    split = np.array([[0.0, 0.0], [5.0, 2.5], [10.0, 5.0], [0.0, 10.0], [8.0, 5.0]])
    assert star_centre(split) == pytest.approx(want, abs=1e-9)


def test_centroid_of_a_small_polygon():
    """Under 1 mm^2 the centroid is still the area centroid, not the vertex mean."""
    assert ol._centroid(DART * 0.1) == pytest.approx([0.6, 0.5], abs=1e-12)


def test_validate_default_name_and_closing_point_tolerance():
    with pytest.raises(ParameterError) as info:
        validate_outline([[0, 0], [1, 0]])
    assert str(info.value) == "outline needs at least 3 distinct points, got 2"
    # a last point 1e-9 from the first is a point of its own (only 1e-12 closes the outline), as
    # is one 0.001 from the first of a 2000 mm outline (no relative tolerance)
    assert len(validate_outline([[0, 0], [2, 0], [2, 2], [0, 2], [0, 1e-9]])) == 5
    assert len(validate_outline([[1000, 1000], [2000, 1000], [2000, 2000], [1000, 2000], [1000, 1000.001]])) == 5


def test_validate_small_outlines():
    """A 0.5 mm triangle is an outline, kept counter-clockwise as given."""
    tri = [[0, 0], [0.5, 0], [0, 0.4]]
    assert validate_outline(tri).tolist() == tri
    assert validate_outline(tri[::-1]).tolist() == [[0, 0.4], [0.5, 0], [0, 0]][::-1]


def test_densify_remainders_by_hand():
    """Edges 3, 1, sqrt(10), 2 to 10 points: 6 new by length 1.96, 0.65, 2.07, 1.31: whole parts
    1, 0, 2, 1, the 2 left over to the largest remainders (edges 0 and 1): 2, 1, 2, 1."""
    p = np.array([[0, 0], [3, 0], [3, 1], [0, 2]], dtype=float)
    want = [[0, 0], [1, 0], [2, 0], [3, 0], [3, 0.5], [3, 1], [2, 4 / 3], [1, 5 / 3], [0, 2], [0, 1]]
    assert densify(p, 10) == pytest.approx(np.array(want), abs=1e-12)
    r = np.array([[0, 0], [4, 0], [4, 1], [0, 1]], dtype=float)
    assert len(densify(r, 9)) == 9  # one left over
    r3 = np.array([[0, 0], [3, 0], [3, 1], [0, 1]], dtype=float)
    assert len(densify(r3, 11)) == 11  # 2.625, 0.875, 2.625, 0.875: three left over
    assert densify([[0, 0], [2, 0], [2, 2], [0, 2]], 4).dtype == np.float64


def test_is_convex_polygon_more():
    for name, W in (("round", 10), ("oval", 6), ("cushion", 6), ("pear", 6), ("marquise", 6), ("rectangle", 6)):
        assert is_convex_polygon(make_outline(name, 10, W, n=64))
    assert is_convex_polygon([[0, 0], [2, 0], [2, 0], [2, 2], [0, 2]])  # a repeated vertex
    assert not is_convex_polygon([[0, 0], [10, 0], [10, 10], [5, 4], [0, 10]])
    assert not is_convex_polygon([[0, 0], [4, 0], [4, 1], [1, 1], [1, 4], [0, 4]])  # an L
    # the tolerance is relative to the edges' lengths: a 1e-8 dent over 100 mm edges is convex
    assert is_convex_polygon([[0, 0], [100, 1e-8], [200, 0], [200, 200], [0, 200]])
    assert not is_convex_polygon([[0, 0], [100, 1e-4], [200, 0], [200, 200], [0, 200]])
