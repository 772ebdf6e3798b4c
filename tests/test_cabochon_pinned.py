"""labcut.geometry.cabochon pinned by mutation testing (issue 37; docs/testing.md, "labcut/geometry/cabochon.py").

The builder's definitions worked by hand from its docstring: the outline's size and centre, the dome
height as built (the named domes as fractions of the smaller side, the spherical dome's hemisphere
limit with and without a buff-top table), the base on z = 0, the girdle band and the double
cabochon's lower dome at their heights, the face-up frame, outward winding, the triangle counts the
rings give (``2 n rings``), the volume against the profile's closed-form volume factor x outline
area, the metadata, every parameter at both ends of its range with its error word for word, and
the defaults. Low resolutions: the whole file runs in a few seconds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from labcut.errors import ParameterError
from labcut.geometry import cabochon as cab_mod
from labcut.geometry import outlines as ol
from labcut.geometry.cabochon import (
    DEFAULT_RESOLUTION,
    DOME_RATIOS,
    MAX_RESOLUTION,
    MIN_RESOLUTION,
    _grid_mesh,
    _resolution,
    cabochon,
)
from labcut.geometry.profiles import Profile


def approx(x, rel=1e-12, abs=1e-12):
    return pytest.approx(x, rel=rel, abs=abs)


def refused(message, **kwargs):
    """The one-line ParameterError, word for word."""
    with pytest.raises(ParameterError) as info:
        cabochon(**kwargs)
    assert str(info.value) == message
    return info.value


def faces(n, rings):
    """Triangles of a stack of ``rings`` full rings between two apexes: two fans of n, 2n per band."""
    return 2 * n * rings


SQUARE = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]


# ------------------------------------------------------------------ constants and defaults
def test_constants():
    assert DOME_RATIOS == {"low": 0.20, "medium": 0.33, "high": 0.50}
    assert DEFAULT_RESOLUTION == 256
    assert (MIN_RESOLUTION, MAX_RESOLUTION) == (16, 4096)


def test_defaults_oval_medium_elliptic_flat_default_resolution():
    m = cabochon(length=16, width=12)
    meta = m.metadata["labcut"]
    assert meta == {
        "kind": "cabochon", "units": "mm", "outline": "oval", "length_mm": 16.0, "width_mm": 12.0,
        "dome_mm": approx(0.33 * 12), "profile": "elliptic", "girdle_mm": 0.0, "base": "flat",
        "base_dome_mm": 0.0, "buff_top": 0.0, "resolution": 256, "height_mm": approx(0.33 * 12),
        "outline_area_mm2": meta["outline_area_mm2"], "nominal_volume_mm3": meta["nominal_volume_mm3"],
        "convex": True, "watertight": True, "repairs": [],
    }
    # 256 points, 43 rings (256 / 6 rounded): 2 x 256 x 43 triangles, 43 full rings + 2 apexes
    assert len(m.faces) == faces(256, 43) == 22016
    assert len(m.vertices) == 256 * 43 + 2
    assert m.extents == approx([16.0, 12.0, 0.33 * 12], rel=0, abs=1e-12)


# ------------------------------------------------------------------ resolution
@pytest.mark.parametrize("given, n", [("default", 256), (16, 16), ("16", 16), (4096, 4096), (np.int64(40), 40),
                                      ("4096", 4096), (np.int32(17), 17)])
def test_resolution_accepted(given, n):
    assert _resolution(given) == n
    assert type(_resolution(given)) is int


@pytest.mark.parametrize("given, message", [
    (15, "resolution must be between 16 and 4096, got 15"),
    (4097, "resolution must be between 16 and 4096, got 4097"),
    ("15", "resolution must be between 16 and 4096, got 15"),
    (0, "resolution must be between 16 and 4096, got 0"),
    ("fine", "resolution must be an integer or 'default', got 'fine'"),
    ("Default", "resolution must be an integer or 'default', got 'Default'"),
    ("16.0", "resolution must be an integer or 'default', got '16.0'"),
    (True, "resolution must be an integer or 'default', got True"),
    (16.0, "resolution must be an integer or 'default', got 16.0"),
    (None, "resolution must be an integer or 'default', got None"),
])
def test_resolution_refused(given, message):
    with pytest.raises(ParameterError) as info:
        _resolution(given)
    assert str(info.value) == message
    assert info.value.parameter == "resolution"
    refused(message, outline="round", length=10, resolution=given)


@pytest.mark.parametrize("n, rings", [(16, 8), (48, 8), (54, 9), (57, 10), (60, 10), (64, 11), (75, 12), (81, 14)])
def test_ring_count_is_resolution_over_six_at_least_eight(n, rings):
    m = cabochon(SQUARE, dome=2, resolution=n)  # densified to exactly n points
    assert m.metadata["labcut"]["resolution"] == n
    assert len(m.faces) == faces(n, rings)
    assert len(m.vertices) == n * rings + 2


# ------------------------------------------------------------------ outline size, centre, frame
@pytest.mark.parametrize("outline, L, W", [("round", 10, 10), ("oval", 16, 12), ("cushion", 12, 9), ("pear", 14, 9),
                                           ("marquise", 20, 8), ("rectangle", 20, 15), ("OVAL", 16, 12)])
def test_named_outline_exact_size_centred_base_on_zero(outline, L, W):
    m = cabochon(outline, L, W, dome=2.0, resolution=32)
    lo, hi = m.bounds
    assert lo == approx([-L / 2, -W / 2, 0.0], rel=0, abs=1e-12)
    assert hi == approx([L / 2, W / 2, 2.0], rel=0, abs=1e-12)
    meta = m.metadata["labcut"]
    assert meta["outline"] == outline.lower()
    assert (meta["length_mm"], meta["width_mm"]) == (approx(L), approx(W))
    assert m.is_watertight and m.is_winding_consistent and m.volume > 0
    # the base: a flat face on z = 0, its normals down; exactly n + 1 vertices there (ring and centre)
    z = m.vertices[:, 2]
    assert (np.abs(z) < 1e-12).sum() == 33
    base = np.all(np.abs(m.triangles[:, :, 2]) < 1e-12, axis=1)
    assert base.sum() == 32
    assert m.face_normals[base] == approx(np.tile([0.0, 0.0, -1.0], (32, 1)), rel=0, abs=1e-9)
    # the top: the single apex vertex at the height, above the outline's centre
    top = m.vertices[np.argmax(z)]
    assert (np.abs(z - 2.0) < 1e-12).sum() == 1
    assert top[2] == 2.0
    fan = np.any(np.abs(m.triangles[:, :, 2] - 2.0) < 1e-12, axis=1)
    assert fan.sum() == 32 and np.all(m.face_normals[fan][:, 2] > 0)


def test_round_takes_either_size():
    for kw in (dict(length=10), dict(width=10), dict(length=10, width=10)):
        m = cabochon("round", dome=2, resolution=16, **kw)
        assert m.extents == approx([10.0, 10.0, 2.0], rel=0, abs=1e-12)


def test_navette_is_marquise():
    m = cabochon("Navette", 20, 8, dome=3, resolution=32)
    q = cabochon("marquise", 20, 8, dome=3, resolution=32)
    assert m.metadata["labcut"]["outline"] == "marquise"
    assert np.array_equal(m.vertices, q.vertices) and np.array_equal(m.faces, q.faces)


@pytest.mark.parametrize("kwargs, message", [
    (dict(outline="hexagon", length=16, width=12),
     "unknown outline 'hexagon'; use one of round, oval, cushion, pear, marquise, rectangle or an (N, 2) array of points in mm"),
    (dict(outline="round"), "a round cabochon needs its length in mm"),
    (dict(outline="oval", width=12), "an oval cabochon needs its length in mm"),
    (dict(outline="oval", length=16), "an oval cabochon needs its width in mm"),
    (dict(outline="pear", length=16), "a pear cabochon needs its width in mm"),
    (dict(outline="navette", length=16), "a marquise cabochon needs its width in mm"),
    (dict(outline="oval", length=16, width=12, corner_radius=1), "corner_radius applies only to the rectangle outline"),
    (dict(outline="oval", length=16, width=12, corner_radius=0), "corner_radius applies only to the rectangle outline"),
    (dict(outline=SQUARE, corner_radius=1), "corner_radius applies only to the rectangle outline"),
    (dict(outline=SQUARE, length=0), "length must be greater than 0 mm, got 0"),
    (dict(outline=SQUARE, length=-1), "length must be greater than 0 mm, got -1"),
    (dict(outline=SQUARE, width=0), "width must be greater than 0 mm, got 0"),
    (dict(outline=SQUARE, width=float("nan")), "width must be a finite number of mm, got nan"),
    (dict(outline=SQUARE, length="long"), "length must be a number of mm, got 'long'"),
])
def test_outline_errors_word_for_word(kwargs, message):
    refused(message, dome=1.0, **kwargs)


def test_sharp_rectangle_densified_below_half_the_resolution():
    # corner_radius=0: 8 points (corners and midpoints); fewer than n / 2 get points along the edges
    counts = {}
    for n in (16, 17, 18, 24, 32):
        m = cabochon("rectangle", 10, 10, dome=2, corner_radius=0, resolution=n)
        counts[n] = (len(m.faces), len(m.vertices))
        assert m.extents == approx([10.0, 10.0, 2.0], rel=0, abs=1e-12)
        assert m.volume == approx(cabochon("rectangle", 10, 10, dome=2, corner_radius=0, resolution=16).volume,
                                  rel=1e-12) if n % 8 == 0 else True
    assert counts[16] == (faces(8, 8), 8 * 8 + 2)
    assert counts[17] == (faces(8, 8), 8 * 8 + 2)
    assert counts[18] == (faces(18, 8), 18 * 8 + 2)
    assert counts[24] == (faces(24, 8), 24 * 8 + 2)
    assert counts[32] == (faces(32, 8), 32 * 8 + 2)


# ------------------------------------------------------------------ user outlines
def test_user_outline_scaled_and_centred():
    sq = np.array(SQUARE) + [3.0, -7.0]
    assert cabochon(sq, dome=1, resolution=16).bounds.ravel() == approx([-5, -5, 0, 5, 5, 1], rel=0, abs=1e-12)
    assert cabochon(sq, length=4, dome=1, resolution=16).bounds.ravel() == approx([-2, -2, 0, 2, 2, 1], rel=0, abs=1e-12)
    assert cabochon(sq, width=4, dome=1, resolution=16).bounds.ravel() == approx([-2, -2, 0, 2, 2, 1], rel=0, abs=1e-12)
    assert cabochon(sq, length=6, width=4, dome=1, resolution=16).bounds.ravel() == approx([-3, -2, 0, 3, 2, 1], rel=0, abs=1e-12)
    rect = [[0, 0], [20, 0], [20, 10], [0, 10]]
    assert cabochon(rect, length=4, dome=1, resolution=16).bounds.ravel() == approx([-2, -1, 0, 2, 1, 1], rel=0, abs=1e-12)
    assert cabochon(rect, width=4, dome=1, resolution=16).bounds.ravel() == approx([-4, -2, 0, 4, 2, 1], rel=0, abs=1e-12)
    m = cabochon(rect, dome=1, resolution=16)
    assert m.metadata["labcut"]["outline"] == "custom"
    assert (m.metadata["labcut"]["length_mm"], m.metadata["labcut"]["width_mm"]) == (20.0, 10.0)


def test_user_outline_densified_to_the_resolution():
    # 4 points -> n points along the edges; n points kept as they are
    for n in (16, 20):
        m = cabochon(SQUARE, dome=2, resolution=n)
        assert len(m.faces) == faces(n, 8)
        assert len(m.vertices) == n * 8 + 2
    sixteen = ol.densify(np.array(SQUARE), 16)
    m = cabochon(sixteen, dome=2, resolution=16)
    assert len(m.faces) == faces(16, 8)
    base = m.vertices[np.abs(m.vertices[:, 2]) < 1e-12]
    assert {tuple(p) for p in np.round(base[:, :2], 9)} >= {tuple(p) for p in np.round(sixteen - 5.0, 9)}


def _traced(corners, per_edge):
    t = np.linspace(0, 1, per_edge, endpoint=False)[:, None]
    c = np.asarray(corners, float)
    return np.vstack([a + t * (b - a) for a, b in zip(c, np.roll(c, -1, axis=0))])


def _base_ring(m):
    return m.vertices[(np.abs(m.vertices[:, 2]) < 1e-12)]


def _has_points(ring, points, tol=1e-9):
    d = np.linalg.norm(ring[None, :, :2] - np.asarray(points)[:, None, :], axis=2)
    return d.min(axis=1) < tol


def test_traced_outline_resampled_keeping_corners_and_extremes():
    # a square traced with 400 points at n = 16: resampled to 16 points, the 4 corners kept,
    # the same solid as the 4-point square
    traced = _traced(SQUARE, 100)
    m = cabochon(traced, dome=2, resolution=16)
    sq = cabochon(SQUARE, dome=2, resolution=16)
    assert len(m.faces) == faces(16, 8)
    assert m.volume == approx(sq.volume, rel=1e-9)
    assert m.extents == approx([10.0, 10.0, 2.0], rel=0, abs=1e-12)
    # a regular 23-gon (turns of 15.65 degrees) traced: every corner kept
    k = np.arange(23)
    poly = 5 * np.column_stack([np.cos(2 * np.pi * k / 23), np.sin(2 * np.pi * k / 23)])
    m = cabochon(_traced(poly, 20), dome=1, resolution=64)
    assert 60 * 22 <= len(m.faces) <= 70 * 22  # about 64 points, 11 rings
    assert np.all(_has_points(_base_ring(m) - 0.0, poly - (poly.min(axis=0) + poly.max(axis=0)) / 2))
    # a regular 25-gon (14.4 degrees) traced: its corners are not kept as such
    k = np.arange(25)
    poly = 5 * np.column_stack([np.cos(2 * np.pi * k / 25), np.sin(2 * np.pi * k / 25)])
    m = cabochon(_traced(poly, 20), dome=1, resolution=64)
    assert 60 * 22 <= len(m.faces) <= 70 * 22
    assert not np.all(_has_points(_base_ring(m), poly - (poly.min(axis=0) + poly.max(axis=0)) / 2))
    # a traced ellipse (no corner): resampled to n, the extreme points kept, so the size is exact
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    ell = np.column_stack([8 * np.cos(t), 5 * np.sin(t)])
    m = cabochon(ell, dome=2, resolution=20)
    assert len(m.faces) == faces(20, 8)
    assert m.extents == approx([16.0, 10.0, 2.0], rel=0, abs=1e-12)
    assert np.all(_has_points(_base_ring(m), [[8, 0], [-8, 0], [0, 5], [0, -5]]))


def test_traced_outline_with_more_corners_than_the_resolution_kept_whole():
    # a traced 16-gon (16 corners) at n = 16 is not resampled; at n = 17 it is, to about 17 points
    k = np.arange(16)
    poly = 5 * np.column_stack([np.cos(2 * np.pi * k / 16), np.sin(2 * np.pi * k / 16)])
    traced = _traced(poly, 5)  # 80 points
    assert len(cabochon(traced, dome=1, resolution=16).faces) == faces(80, 8)
    m = cabochon(traced, dome=1, resolution=17)
    assert len(m.faces) < faces(80, 8)
    assert np.all(_has_points(_base_ring(m), poly))


# ------------------------------------------------------------------ dome heights
@pytest.mark.parametrize("name", ["low", "medium", "high", "LOW", "Medium"])
def test_named_domes_fraction_of_the_smaller_side(name):
    r = DOME_RATIOS[name.lower()]
    for L, W in ((20, 10), (10, 20)):
        m = cabochon("oval", L, W, dome=name, resolution=16)
        assert m.bounds[1][2] == approx(r * 10)
        assert m.metadata["labcut"]["dome_mm"] == approx(r * 10)


def test_named_dome_spherical_capped_at_the_hemisphere():
    # round 10 mm: "high" is 5 mm, a hemisphere; with a 0.6 table the limit is 5 x 0.8 = 4 mm
    assert cabochon("round", 10, dome="high", profile="spherical", resolution=16).bounds[1][2] == approx(5.0)
    assert cabochon("round", 10, dome="high", profile="spherical", buff_top=0.6, resolution=16).bounds[1][2] == approx(4.0)
    assert cabochon("round", 10, dome="medium", profile="spherical", buff_top=0.6, resolution=16).bounds[1][2] == approx(3.3)
    # elliptic: no cap below the stone's width
    assert cabochon("round", 10, dome="high", buff_top=0.6, resolution=16).bounds[1][2] == approx(5.0)


def test_dome_in_mm_and_as_a_string():
    assert cabochon("oval", 16, 12, dome=2.5, resolution=16).bounds[1][2] == approx(2.5)
    assert cabochon("oval", 16, 12, dome="2.5", resolution=16).bounds[1][2] == approx(2.5)
    assert cabochon("oval", 16, 12, dome=3, resolution=16).bounds[1][2] == approx(3.0)
    assert cabochon("oval", 16, 12, dome=0.5, resolution=16).bounds[1][2] == approx(0.5)


def test_dome_limits_at_the_edge():
    # elliptic and tallow: the stone's width (12 mm); spherical: a hemisphere (6 mm)
    for profile, limit in (("elliptic", 12.0), ("tallow", 12.0), ("spherical", 6.0)):
        m = cabochon("oval", 16, 12, dome=limit, profile=profile, resolution=16)
        assert m.bounds[1][2] == approx(limit)
        # within the rounding tolerance: accepted, built at the limit
        m = cabochon("oval", 16, 12, dome=limit * (1 + 5e-10), profile=profile, resolution=16)
        assert m.bounds[1][2] == limit
    # spherical with a 0.5 table: 6 sqrt(0.75)
    lim = 6 * math.sqrt(0.75)
    m = cabochon("oval", 16, 12, dome=lim, profile="spherical", buff_top=0.5, resolution=16)
    assert m.bounds[1][2] == approx(lim)


@pytest.mark.parametrize("kwargs, message", [
    (dict(dome=12.01), "dome 12.01 mm is higher than allowed for an elliptic profile on this stone (12 mm: the stone's width)"),
    (dict(dome=12 * (1 + 2e-9)), "dome 12 mm is higher than allowed for an elliptic profile on this stone (12 mm: the stone's width)"),
    (dict(dome=13.0, profile="tallow"), "dome 13 mm is higher than allowed for a tallow profile on this stone (12 mm: the stone's width)"),
    (dict(dome=6.5, profile="spherical"), "dome 6.5 mm is higher than allowed for a spherical profile on this stone (6 mm: a hemisphere)"),
    (dict(dome=5.9, profile="spherical", buff_top=0.5),
     "dome 5.9 mm is higher than allowed for a spherical profile on this stone (5.196 mm: a hemisphere with this buff-top table)"),
    (dict(dome=13.0, buff_top=0.5),
     "dome 13 mm is higher than allowed for an elliptic profile on this stone (12 mm: the stone's width with this buff-top table)"),
    (dict(dome=0), "dome must be greater than 0 mm, got 0"),
    (dict(dome=-1.0), "dome must be greater than 0 mm, got -1"),
    (dict(dome="0"), "dome must be greater than 0 mm, got 0"),
    (dict(dome=float("inf")), "dome must be a finite number of mm, got inf"),
    (dict(dome=None), "dome must be a number of mm, got None"),
    (dict(dome=True), "dome must be a number of mm, got True"),
    (dict(dome="towering"), "dome must be low, medium, high or a height in mm, got 'towering'"),
    (dict(base="towering"), "base must be low, medium, high or a height in mm, got 'towering'"),
    (dict(base=0), "base must be greater than 0 mm, got 0"),
    (dict(base=-2.0), "base must be greater than 0 mm, got -2"),
    (dict(base=20.0), "base 20 mm is higher than allowed for an elliptic profile on this stone (12 mm: the stone's width)"),
    (dict(base=6.5, profile="spherical"), "base 6.5 mm is higher than allowed for a spherical profile on this stone (6 mm: a hemisphere)"),
    (dict(profile="gothic"), "unknown profile 'gothic'; use one of elliptic, spherical, tallow"),
    (dict(profile=None), "unknown profile None; use one of elliptic, spherical, tallow"),
    (dict(profile=3), "unknown profile 3; use one of elliptic, spherical, tallow"),
])
def test_dome_and_profile_errors_word_for_word(kwargs, message):
    refused(message, outline="oval", length=16, width=12, resolution=16, **kwargs)


def test_profile_name_any_case():
    m = cabochon("round", 10, dome=2, profile="Spherical", resolution=16)
    assert m.metadata["labcut"]["profile"] == "spherical"
    s = cabochon("round", 10, dome=2, profile="spherical", resolution=16)
    assert m.volume == approx(s.volume)


# ------------------------------------------------------------------ volumes: area x volume factor
@pytest.mark.parametrize("profile, kwargs", [("elliptic", {}), ("spherical", {}), ("tallow", {}),
                                             ("elliptic", dict(buff_top=0.5)), ("spherical", dict(buff_top=0.4)),
                                             ("elliptic", dict(girdle=1.5)), ("elliptic", dict(base=1.0, girdle=0.5)),
                                             ("spherical", dict(base=1.0))])
def test_nominal_volume_is_area_times_volume_factor(profile, kwargs):
    a, H = 6.0, 2.0
    m = cabochon("round", 2 * a, dome=H, profile=profile, resolution=128, **kwargs)
    meta = m.metadata["labcut"]
    area = ol.polygon_area(ol.make_outline("round", 2 * a, 2 * a, n=128))
    assert meta["outline_area_mm2"] == approx(area)
    assert area == approx(math.pi * a * a, rel=1e-3)  # the 128-gon
    table = {True: 0.5}.get(kwargs.get("buff_top"), kwargs.get("buff_top", 0.0))
    factor = Profile(profile, H, a, table).volume_factor() + kwargs.get("girdle", 0.0)
    if "base" in kwargs:
        factor += Profile(profile, kwargs["base"], a).volume_factor()
    assert meta["nominal_volume_mm3"] == approx(area * factor)
    # the mesh is that solid to the rings' accuracy
    assert m.volume == approx(meta["nominal_volume_mm3"], rel=0.01, abs=0)
    assert meta["height_mm"] == approx(H + kwargs.get("girdle", 0.0) + kwargs.get("base", 0.0))
    assert m.extents[2] == approx(meta["height_mm"])


def test_hemisphere_volume_and_half_ellipsoid_by_hand():
    m = cabochon("round", 8, dome="high", profile="spherical", resolution=128)
    assert m.metadata["labcut"]["nominal_volume_mm3"] == approx(m.metadata["labcut"]["outline_area_mm2"] * 2 / 3 * 4)
    assert m.volume == approx(2 / 3 * math.pi * 64, rel=0.005)
    m = cabochon("oval", 16, 12, dome=3, resolution=128)
    assert m.volume == approx(2 / 3 * math.pi * 8 * 6 * 3, rel=0.005)


# ------------------------------------------------------------------ girdle
def test_girdle_band_heights_and_count():
    # round 10 mm at n = 16: edge spacing 10 sin(pi/16) = 1.951 mm; a 5 mm girdle: 3 bands of 5/3 mm
    g = 5.0
    m = cabochon("round", 10, dome=2, girdle=g, resolution=16)
    assert len(m.faces) == faces(16, 8 + 3)
    rim = m.vertices[np.abs(np.hypot(m.vertices[:, 0], m.vertices[:, 1]) - 5.0) < 1e-9]
    assert sorted(set(np.round(rim[:, 2], 12))) == approx([0.0, 5 / 3, 10 / 3, 5.0])
    assert m.extents == approx([10.0, 10.0, 7.0], rel=0, abs=1e-12)
    meta = m.metadata["labcut"]
    assert meta["girdle_mm"] == 5.0 and meta["height_mm"] == approx(7.0)
    # a thin girdle: one band
    m = cabochon("round", 10, dome=2, girdle=0.5, resolution=16)
    assert len(m.faces) == faces(16, 9)
    # exactly one spacing: one band; a hair more: two
    spacing = 10 * math.sin(math.pi / 16)
    assert len(cabochon("round", 10, dome=2, girdle=spacing * (1 - 1e-9), resolution=16).faces) == faces(16, 9)
    assert len(cabochon("round", 10, dome=2, girdle=spacing * 1.01, resolution=16).faces) == faces(16, 10)
    # no girdle: no band
    assert len(cabochon("round", 10, dome=2, girdle=0, resolution=16).faces) == faces(16, 8)


def test_girdle_bands_at_most_64():
    # n = 256 on a 10 mm round: spacing 0.1227 mm; a 10 mm girdle would take 82 bands, capped at 64
    m = cabochon("round", 10, dome=2, girdle=10, resolution=256)
    assert len(m.faces) == faces(256, 43 + 64)
    # 7.8 mm: 64 bands exactly (63.6 rounded up)
    assert len(cabochon("round", 10, dome=2, girdle=7.8, resolution=256).faces) == faces(256, 43 + 64)
    assert len(cabochon("round", 10, dome=2, girdle=7.6, resolution=256).faces) == faces(256, 43 + 62)


def test_girdle_bounds():
    # up to the stone's length, 0 allowed
    m = cabochon("oval", 16, 12, dome=2, girdle=16, resolution=16)
    assert m.extents[2] == approx(18.0)
    refused("girdle 16.01 mm is taller than the stone is long (16 mm)", outline="oval", length=16, width=12,
            girdle=16.01, resolution=16)
    refused("girdle 12.5 mm is taller than the stone is long (12 mm)", outline=SQUARE, length=12, width=8,
            girdle=12.5, dome=1, resolution=16)
    refused("girdle must be at least 0 mm, got -0.5", outline="oval", length=16, width=12, girdle=-0.5, resolution=16)
    refused("girdle must be a finite number of mm, got nan", outline="oval", length=16, width=12, girdle=float("nan"),
            resolution=16)
    m = cabochon("oval", 16, 12, dome=2, girdle=0.0, resolution=16)
    assert m.metadata["labcut"]["girdle_mm"] == 0.0 and m.extents[2] == approx(2.0)


# ------------------------------------------------------------------ base
def test_flat_base_any_case():
    for base in ("flat", "FLAT", "Flat"):
        m = cabochon("round", 10, dome=2, base=base, resolution=16)
        assert m.metadata["labcut"]["base"] == "flat"
        assert m.metadata["labcut"]["base_dome_mm"] == 0.0
        assert len(m.faces) == faces(16, 8)


def test_double_cabochon_heights_and_rings():
    # round 10 mm, base dome 1 mm, girdle 0.5 mm (one band), crown 2 mm, n = 16 (8 rings each)
    m = cabochon("round", 10, dome=2, base=1.0, girdle=0.5, resolution=16)
    meta = m.metadata["labcut"]
    assert meta["base"] == "domed" and meta["base_dome_mm"] == 1.0
    assert meta["height_mm"] == approx(3.5)
    assert m.bounds.ravel() == approx([-5, -5, 0, 5, 5, 3.5], rel=0, abs=1e-12)
    z = m.vertices[:, 2]
    assert (np.abs(z) < 1e-12).sum() == 1  # the lower apex touches z = 0 in one point
    assert m.vertices[np.argmin(z)] == approx([0.0, 0.0, 0.0], rel=0, abs=1e-12)
    # the foot ring of the base dome at z = 1, the girdle's top at 1.5, both at the full outline
    rim = m.vertices[np.abs(np.hypot(m.vertices[:, 0], m.vertices[:, 1]) - 5.0) < 1e-9]
    assert sorted(set(np.round(rim[:, 2], 12))) == approx([1.0, 1.5])
    # 8 base intervals + 1 girdle band + 8 crown intervals: 16 full rings between the two apexes
    assert len(m.faces) == faces(16, 16)
    # the base dome is the crown's profile upside down: the lower half mirrors a 1 mm crown
    low = m.vertices[z < 1.0 - 1e-12]
    crown1 = cabochon("round", 10, dome=1.0, resolution=16).vertices
    up = crown1[crown1[:, 2] > 1e-12]
    assert sorted(np.round(1.0 - low[:, 2], 9)) == approx(sorted(np.round(up[:, 2], 9)), abs=1e-9)
    assert m.is_watertight and m.is_winding_consistent and m.volume > 0


def test_base_named_and_spherical_base_ignores_the_crown_table():
    m = cabochon("oval", 20, 10, dome=1.0, base="low", resolution=16)
    assert m.metadata["labcut"]["base_dome_mm"] == approx(2.0)
    assert m.extents[2] == approx(3.0)
    m = cabochon("oval", 20, 10, dome=1.0, base="2.5", resolution=16)
    assert m.metadata["labcut"]["base_dome_mm"] == approx(2.5)
    # a 0.6 table limits the crown to 4 mm on a 10 mm round, not the base (a hemisphere, 5 mm)
    m = cabochon("round", 10, dome=3, base=4.5, profile="spherical", buff_top=0.6, resolution=16)
    assert m.metadata["labcut"]["base_dome_mm"] == 4.5
    assert m.extents[2] == approx(7.5)


# ------------------------------------------------------------------ buff-top
@pytest.mark.parametrize("given, table", [(False, 0.0), (None, 0.0), (0, 0.0), (0.0, 0.0), (True, 0.5), (0.3, 0.3),
                                          ("0.3", 0.3), (0.95, 0.95), (np.float64(0.4), 0.4)])
def test_buff_top_accepted(given, table):
    m = cabochon("round", 10, dome=2, buff_top=given, resolution=16)
    assert m.metadata["labcut"]["buff_top"] == table
    assert m.extents[2] == approx(2.0)
    top = m.vertices[np.abs(m.vertices[:, 2] - 2.0) < 1e-12]
    if table:
        # the flat table spans the table fraction of the width
        assert np.ptp(top[:, 0]) == approx(10 * table, rel=0, abs=1e-9)
    else:
        assert len(top) == 1


@pytest.mark.parametrize("given", [1, 1.2, -0.1, 0.9500001, float("nan"), float("inf"), "lots", [0.5], "0", "0.0", -1e-9])
def test_buff_top_refused(given):
    refused(f"buff_top must be False or a table fraction in (0, 0.95], got {given!r}", outline="round", length=10,
            dome=2, buff_top=given, resolution=16)


# ------------------------------------------------------------------ not star-shaped
def test_not_star_shaped_message():
    c_shape = [[0, 0], [10, 0], [10, 2], [2, 2], [2, 8], [10, 8], [10, 10], [0, 10], [0, 9.9], [1, 9.9], [1, 0.1], [0, 0.1]]
    refused("the outline is not star-shaped (no point inside sees its whole boundary), so it cannot be domed",
            outline=c_shape, dome=1.0, resolution=16)


def test_star_outline_domed_about_its_kernel():
    # an L shape: the apex above the star centre, not the bounding box's centre
    L_shape = np.array([[0, 0], [10, 0], [10, 4], [4, 4], [4, 10], [0, 10]], float)
    m = cabochon(L_shape, dome=1.0, resolution=32)
    centre = ol.star_centre(ol.densify(L_shape - 5.0, 32))
    apex = m.vertices[np.argmax(m.vertices[:, 2])]
    assert apex[:2] == approx(centre, rel=0, abs=1e-9)
    assert m.is_watertight and m.volume > 0
    assert m.metadata["labcut"]["convex"] is False
    assert m.metadata["labcut"]["nominal_volume_mm3"] == approx(64.0 * 2 / 3)


# ------------------------------------------------------------------ the ring stack itself
def test_grid_mesh_by_hand():
    sq = np.array([[1.0, -1.0], [1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0]])  # CCW
    c = np.array([0.5, 0.0])
    V, F = _grid_mesh(sq, c, [(0.0, 0.0), (1.0, 0.0), (0.5, 2.0), (0.0, 3.0)])
    assert V.tolist() == [[0.5, 0.0, 0.0],
                          [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [-1.0, -1.0, 0.0],
                          [0.75, -0.5, 2.0], [0.75, 0.5, 2.0], [-0.25, 0.5, 2.0], [-0.25, -0.5, 2.0],
                          [0.5, 0.0, 3.0]]
    assert F.tolist() == [[0, 2, 1], [0, 3, 2], [0, 4, 3], [0, 1, 4],
                          [1, 2, 6], [2, 3, 7], [3, 4, 8], [4, 1, 5],
                          [1, 6, 5], [2, 7, 6], [3, 8, 7], [4, 5, 8],
                          [5, 6, 9], [6, 7, 9], [7, 8, 9], [8, 5, 9]]
    with pytest.raises(AssertionError, match="^two consecutive apex rings$"):
        _grid_mesh(sq, c, [(0.0, 0.0), (0.0, 1.0)])


def test_module_names():
    assert cab_mod._article("oval") == "an" and cab_mod._article("Elliptic") == "an"
    assert cab_mod._article("pear") == "a"


@pytest.mark.parametrize("outline, L, W", [("pear", 14, 9), ("oval", 16, 12), ("rectangle", 20, 15)])
def test_base_ring_is_the_named_outline_itself(outline, L, W):
    # the foot ring is make_outline's polygon, centred on its bounding box: not mirrored, not rotated
    # (the pear's point at +X, its round end at -X)
    p = ol.make_outline(outline, L, W, n=32)
    p = p - (p.min(axis=0) + p.max(axis=0)) / 2
    ring = _base_ring(cabochon(outline, L, W, dome=2, resolution=32))
    assert len(ring) == len(p) + 1  # and the centre
    assert np.all(_has_points(ring, p))
    if outline == "pear":
        tip = ring[np.argmax(ring[:, 0])]
        assert tip[:2] == approx([7.0, 0.0], rel=0, abs=1e-9)
        # the round end: a half circle of radius 4.5 about (-2.5, 0)
        back = ring[ring[:, 0] < -2.6]
        assert np.hypot(back[:, 0] + 2.5, back[:, 1]) == approx(np.full(len(back), 4.5), abs=1e-6)


def test_grid_mesh_cone_foot_ring_then_apex():
    # a foot ring straight into the top apex (s = 1 then s = 0): a pyramid, two fans
    sq = np.array([[1.0, -1.0], [1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0]])
    V, F = _grid_mesh(sq, np.zeros(2), [(0.0, 0.0), (1.0, 0.0), (0.0, 2.0)])
    assert len(V) == 6 and V[-1].tolist() == [0.0, 0.0, 2.0]
    assert F.tolist() == [[0, 2, 1], [0, 3, 2], [0, 4, 3], [0, 1, 4], [1, 2, 5], [2, 3, 5], [3, 4, 5], [4, 1, 5]]


@pytest.mark.parametrize("outline, L, W", [("marquise", 20, 8), ("pear", 13.7, 9.1), ("oval", 16.3, 12.7)])
def test_named_outline_bounding_box_exact_to_the_last_bit(outline, L, W):
    # the resampled outline is rescaled and recentred so the size is exactly what was asked
    # (make_outline's marquise is 3.6e-15 mm short, its 13.7 mm pear 4.4e-16 mm off centre)
    m = cabochon(outline, L, W, dome=2, resolution=32)
    assert m.bounds.tolist() == [[-L / 2, -W / 2, 0.0], [L / 2, W / 2, 2.0]]


def _egg(points=400, shift=37):
    """A traced outline with no symmetry: four quarter ellipses (8 and 5 mm to +X and -X, 4 and 3 mm
    to +Y and -Y); its extreme points are samples, none of them the first point."""
    t = np.linspace(0, 2 * np.pi, points, endpoint=False)
    c, s = np.cos(t), np.sin(t)
    egg = np.column_stack([np.where(c > 0, 8 * c, 5 * c), np.where(s > 0, 4 * s, 3 * s)])
    return np.roll(egg, shift, axis=0)


def test_traced_asymmetric_outline_keeps_its_four_extremes():
    # resampled to about 20 points: each of the four extreme points is kept, so the size is exact
    m = cabochon(_egg(), dome=2, resolution=20)
    assert m.extents.tolist() == approx([13.0, 7.0, 2.0], rel=0, abs=1e-12)
    ring = _base_ring(m)
    assert np.all(_has_points(ring, [[6.5, -0.5], [-6.5, -0.5], [-1.5, 3.5], [-1.5, -3.5]]))
    assert len(m.faces) < faces(40, 8)


def test_traced_smooth_polygon_turns_measured_vertex_by_vertex():
    # a 32-gon (turns of 11.25 degrees, under 15) at n = 20: no vertex is a corner, resampled to
    # about 20 points; measured over two edges its turns would be 22.5 degrees, all 32 kept
    k = np.arange(32)
    poly = 5 * np.column_stack([np.cos(2 * np.pi * k / 32), np.sin(2 * np.pi * k / 32)])
    m = cabochon(poly, dome=1, resolution=20)
    assert len(_base_ring(m)) - 1 < 26
    assert len(m.faces) < faces(26, 8)
