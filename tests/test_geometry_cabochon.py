"""labcut.cabochon: analytic volumes, exact dimensions, watertightness, sweeps, errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import labcut
from labcut.errors import ParameterError
from labcut.geometry import outlines as ol
from labcut.geometry.cabochon import DOME_RATIOS, cabochon
from labcut.geometry.profiles import TALLOW_EXPONENT

VOLUME_RTOL = 0.005  # the 0.5 %
DIM_ATOL = 0.01  # mm


def check_solid(mesh, length, width, height):
    """Watertight, outward, base on z = 0, bounding box as asked."""
    assert mesh.is_watertight
    assert mesh.is_winding_consistent
    assert mesh.volume > 0  # consistent winding + positive volume: normals point outward
    lo, hi = mesh.bounds
    assert abs(lo[2]) < 1e-9
    ext = hi - lo
    assert abs(ext[0] - length) < DIM_ATOL, ext
    assert abs(ext[1] - width) < DIM_ATOL, ext
    assert abs(ext[2] - height) < DIM_ATOL, ext
    # outward, face by face: a ray a hair outside each face centroid along its normal
    # is outside the solid (checked on a sample of faces, winding-number test)
    rng = np.random.default_rng(0)
    idx = rng.choice(len(mesh.faces), size=min(12, len(mesh.faces)), replace=False)
    step = 1e-3 * min(ext) * mesh.face_normals[idx]
    assert not np.any(_winding_inside(mesh, mesh.triangles_center[idx] + step))
    assert np.all(_winding_inside(mesh, mesh.center_mass[None, :]))  # the test can see "inside"
    return ext


def _winding_inside(mesh, points):
    """Generalised winding number > 1/2 (inside), numpy only."""
    tri = mesh.triangles[None, :, :, :] - points[:, None, None, :]
    a, b, c = tri[..., 0, :], tri[..., 1, :], tri[..., 2, :]
    la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
    det = np.einsum("...i,...i->...", a, np.cross(b, c))
    den = la * lb * lc + np.einsum("...i,...i->...", a, b) * lc + np.einsum("...i,...i->...", b, c) * la + np.einsum("...i,...i->...", c, a) * lb
    w = np.arctan2(det, den).sum(axis=1) / (2 * np.pi)
    return w > 0.5


def rel_err(mesh, exact):
    return abs(mesh.volume / exact - 1.0)


# ----------------------------------------------------------------------------- analytic volumes
def test_public_api_names():
    assert labcut.cabochon is cabochon
    m = labcut.cabochon(outline="oval", length=16, width=12, dome="low")
    check_solid(m, 16, 12, 0.2 * 12)


def test_spherical_cap_volume():
    a, H = 5.0, 2.0
    m = cabochon("round", 2 * a, dome=H, profile="spherical")
    check_solid(m, 2 * a, 2 * a, H)
    exact = math.pi * H * (3 * a * a + H * H) / 6
    assert rel_err(m, exact) < VOLUME_RTOL


def test_hemisphere_volume():
    a = 4.0
    m = cabochon("round", 2 * a, dome="high", profile="spherical")
    check_solid(m, 2 * a, 2 * a, a)
    assert rel_err(m, 2 / 3 * math.pi * a**3) < VOLUME_RTOL


@pytest.mark.parametrize("L,W,H", [(16, 12, 2.4), (10, 10, 3.0), (30, 8, 6.0)])
def test_half_ellipsoid_volume(L, W, H):
    m = cabochon("oval" if L != W else "round", L, W, dome=H, profile="elliptic")
    check_solid(m, L, W, H)
    assert rel_err(m, 2 / 3 * math.pi * (L / 2) * (W / 2) * H) < VOLUME_RTOL


def test_girdle_cylinder_volume():
    L, W, H, g = 14.0, 10.0, 3.0, 1.5
    m = cabochon("oval", L, W, dome=H, girdle=g)
    check_solid(m, L, W, H + g)
    a, b = L / 2, W / 2
    assert rel_err(m, math.pi * a * b * (g + 2 / 3 * H)) < VOLUME_RTOL


def test_double_cabochon_volume():
    L, W, H, Hb, g = 18.0, 13.0, 4.0, 1.5, 0.8
    m = cabochon("oval", L, W, dome=H, base=Hb, girdle=g)
    check_solid(m, L, W, Hb + g + H)
    a, b = L / 2, W / 2
    assert rel_err(m, math.pi * a * b * (g + 2 / 3 * (H + Hb))) < VOLUME_RTOL
    # the base dome touches z = 0 in one point only: the lowest ring is above it
    z = m.vertices[:, 2]
    assert (np.abs(z) < 1e-9).sum() == 1


def test_double_spherical_cabochon_volume():
    a, H, Hb = 6.0, 3.0, 1.0
    m = cabochon("round", 2 * a, dome=H, base=Hb, profile="spherical")
    cap = lambda h: math.pi * h * (3 * a * a + h * h) / 6  # noqa: E731
    assert rel_err(m, cap(H) + cap(Hb)) < VOLUME_RTOL


def test_tallow_volume():
    a, H = 5.0, 2.5
    n = TALLOW_EXPONENT
    m = cabochon("round", 2 * a, dome=H, profile="tallow")
    check_solid(m, 2 * a, 2 * a, H)
    # V = pi a^2 H * integral_0^1 2 s (1 - s^n)^(1/n) ds, the integral by Beta functions
    integral = (2 / n) * math.gamma(2 / n) * math.gamma(1 + 1 / n) / math.gamma(2 / n + 1 + 1 / n)
    assert rel_err(m, math.pi * a * a * H * integral) < VOLUME_RTOL
    # flatter top than the elliptic dome of the same height: more volume
    e = cabochon("round", 2 * a, dome=H, profile="elliptic")
    assert m.volume > 1.05 * e.volume


def test_buff_top_elliptic_volume():
    a, H, t = 5.0, 3.0, 0.5
    m = cabochon("round", 2 * a, dome=H, buff_top=t)
    check_solid(m, 2 * a, 2 * a, H)
    hv = H / math.sqrt(1 - t * t)
    # disc area pi a^2 (1 - (z/hv)^2) integrated from 0 to H
    assert rel_err(m, math.pi * a * a * (H - H**3 / (3 * hv * hv))) < VOLUME_RTOL
    # the table is flat and spans t of the width
    top = m.vertices[np.abs(m.vertices[:, 2] - H) < 1e-9]
    assert abs(np.ptp(top[:, 0]) - 2 * a * t) < DIM_ATOL


def test_buff_top_spherical_volume():
    a, H, t = 6.0, 2.0, 0.4
    m = cabochon("round", 2 * a, dome=H, buff_top=t, profile="spherical")
    check_solid(m, 2 * a, 2 * a, H)
    zc = (t * t * a * a + H * H - a * a) / (2 * H)  # sphere through (a, 0) and (t a, H)
    R = math.hypot(a, zc)
    hv = R + zc
    cap = lambda h: math.pi * h * h * (3 * R - h) / 3  # noqa: E731
    assert rel_err(m, cap(hv) - cap(hv - H)) < VOLUME_RTOL


def test_rectangle_volume():
    L, W, r, H = 20.0, 15.0, 2.0, 3.0
    m = cabochon("rectangle", L, W, dome=H, corner_radius=r)
    check_solid(m, L, W, H)
    assert rel_err(m, (L * W - (4 - math.pi) * r * r) * 2 / 3 * H) < VOLUME_RTOL


def test_sharp_rectangle_and_custom_square():
    m = cabochon("rectangle", 10, 10, dome=2, corner_radius=0)
    assert rel_err(m, 100 * 2 / 3 * 2) < VOLUME_RTOL
    sq = [[0, 0], [10, 0], [10, 10], [0, 10]]
    c = cabochon(sq, dome=2)
    check_solid(c, 10, 10, 2)
    assert rel_err(c, 100 * 2 / 3 * 2) < VOLUME_RTOL
    # a user outline can be scaled to a length (and width)
    c2 = cabochon(sq, length=5, dome=1)
    check_solid(c2, 5, 5, 1)


def test_cushion_volume():
    L, W, H = 12.0, 10.0, 3.0
    n = 3.0
    a, b = L / 2, W / 2
    area = 4 * a * b * math.gamma(1 + 1 / n) ** 2 / math.gamma(1 + 2 / n)
    m = cabochon("cushion", L, W, dome=H)
    check_solid(m, L, W, H)
    assert rel_err(m, area * 2 / 3 * H) < VOLUME_RTOL


def _lens_area(half_len, half_w):
    """Area of a marquise: two circular segments of sagitta half_w and half-chord half_len."""
    R = (half_len**2 + half_w**2) / (2 * half_w)
    seg = R * R * math.acos((R - half_w) / R) - (R - half_w) * half_len
    return 2 * seg


def test_marquise_and_pear_volume():
    L, W, H = 20.0, 8.0, 3.0
    m = cabochon("marquise", L, W, dome=H)
    check_solid(m, L, W, H)
    assert rel_err(m, _lens_area(L / 2, W / 2) * 2 / 3 * H) < VOLUME_RTOL
    p = cabochon("pear", L, W, dome=H)
    check_solid(p, L, W, H)
    b = W / 2
    area = math.pi * b * b / 2 + _lens_area(L - b, b) / 2
    assert rel_err(p, area * 2 / 3 * H) < VOLUME_RTOL
    assert cabochon("navette", L, W, dome=H).volume == pytest.approx(m.volume)


def test_default_resolution_triangle_budget_and_benchmark_oval():
    m = cabochon("oval", 16, 12, dome="low")
    assert 20_000 <= len(m.faces) <= 50_000
    for kw in (dict(base=1.0, girdle=0.5), dict(buff_top=0.6), dict(profile="tallow")):
        n = len(cabochon("oval", 16, 12, dome="low", **kw).faces)
        assert 20_000 <= n <= 50_000, (kw, n)
    # higher resolution: more triangles and a smaller volume error
    exact = 2 / 3 * math.pi * 8 * 6 * 2.4
    fine = cabochon("oval", 16, 12, dome="low", resolution=512)
    assert rel_err(fine, exact) < rel_err(m, exact) < VOLUME_RTOL


def test_dome_ratios_documented_values():
    assert DOME_RATIOS == {"low": 0.20, "medium": 0.33, "high": 0.50}
    for name, ratio in DOME_RATIOS.items():
        m = cabochon("oval", 20, 10, dome=name)
        assert m.bounds[1][2] == pytest.approx(ratio * 10, abs=1e-9)
    # the ratio is of the smaller side whatever the orientation
    m = cabochon("oval", 10, 20, dome="low")
    assert m.bounds[1][2] == pytest.approx(2.0)


def test_convex_flag_and_metadata():
    m = cabochon("pear", 14, 9, dome="medium")
    meta = m.metadata["labcut"]
    assert meta["convex"] is True
    assert meta["kind"] == "cabochon" and meta["outline"] == "pear"
    assert meta["nominal_volume_mm3"] == pytest.approx(m.volume, rel=VOLUME_RTOL)
    t = np.linspace(0, 2 * math.pi, 60, endpoint=False)
    r = 5 + 1.5 * np.cos(5 * t)
    star = np.column_stack([r * np.cos(t), r * np.sin(t)])
    s = cabochon(star, dome=2.0)
    assert s.is_watertight and s.volume > 0
    assert s.metadata["labcut"]["convex"] is False
    assert s.metadata["labcut"]["outline"] == "custom"


def test_clockwise_and_closed_user_outline_accepted():
    sq_cw = [[0, 0], [0, 10], [10, 10], [10, 0], [0, 0]]
    m = cabochon(sq_cw, dome=2)
    assert rel_err(m, 100 * 2 / 3 * 2) < VOLUME_RTOL


def test_outlines_are_ccw_simple_and_exact():
    for name in ol.OUTLINES:
        W = 10.0 if name == "round" else 7.0
        p = ol.make_outline(name, 10.0, W, n=200)
        assert ol.polygon_area(p) > 0
        assert ol.segments_intersect(p) is None
        assert np.ptp(p[:, 0]) == pytest.approx(10.0, abs=1e-9)
        assert np.ptp(p[:, 1]) == pytest.approx(W, abs=1e-9)
        assert ol.star_centre(p) is not None
        assert ol.is_convex_polygon(p)


# ----------------------------------------------------------------------------- sweeps
sweep = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@sweep
@given(
    outline=st.sampled_from(ol.OUTLINES),
    profile=st.sampled_from(["elliptic", "spherical", "tallow"]),
    length=st.floats(1.0, 60.0),
    aspect=st.floats(1.0, 8.0),
    dome_ratio=st.floats(0.005, 1.0),
    girdle=st.sampled_from([0.0, 0.05, 0.7]),
    base_ratio=st.one_of(st.none(), st.floats(0.005, 0.5)),
    buff=st.one_of(st.just(False), st.floats(0.05, 0.95)),
)
def test_sweep_every_outline_and_profile(outline, profile, length, aspect, dome_ratio, girdle, base_ratio, buff):
    width = length if outline == "round" else length / aspect
    limit = (width / 2) * (math.sqrt(1 - buff * buff) if buff else 1.0) if profile == "spherical" else width
    H = dome_ratio * limit
    base = "flat" if base_ratio is None else base_ratio * (width / 2 if profile == "spherical" else width)
    m = cabochon(outline, length, width, dome=H, profile=profile, girdle=girdle, base=base, buff_top=buff, resolution=64)
    total = H + girdle + (0.0 if base_ratio is None else base)
    check_solid(m, length, width, total)
    nominal = m.metadata["labcut"]["nominal_volume_mm3"]
    assert m.volume == pytest.approx(nominal, rel=0.03)
    assert m.metadata["labcut"]["convex"] is True


def test_extremes():
    # very low dome
    m = cabochon("oval", 16, 12, dome=0.01)
    check_solid(m, 16, 12, 0.01)
    assert rel_err(m, 2 / 3 * math.pi * 8 * 6 * 0.01) < VOLUME_RTOL
    # very elongated marquise
    m = cabochon("marquise", 60, 3, dome="high", profile="tallow")
    check_solid(m, 60, 3, 1.5)
    # tiny and large stones, minimum resolution
    check_solid(cabochon("round", 0.5, dome="low", resolution=16), 0.5, 0.5, 0.1)
    check_solid(cabochon("pear", 200, 120, dome="medium", resolution=16), 200, 120, 0.33 * 120)
    # hemisphere with a girdle and a maximal buff-top table
    check_solid(cabochon("round", 8, dome=2, buff_top=0.95, girdle=0.2), 8, 8, 2.2)


@sweep
@given(
    pts=st.lists(st.tuples(st.floats(-20, 20), st.floats(-20, 20)), min_size=3, max_size=12),
)
def test_sweep_user_polygons_build_or_refuse_clearly(pts):
    """Any random polygon either builds a valid solid or raises a one-line ParameterError."""
    try:
        m = cabochon(np.array(pts), dome=1.0, resolution=32)
    except ParameterError as exc:
        assert "\n" not in str(exc)
        return
    assert m.is_watertight and m.is_winding_consistent and m.volume > 0
    assert abs(m.bounds[0][2]) < 1e-9


# ----------------------------------------------------------------------------- errors
BOWTIE = [[0, 0], [10, 10], [10, 0], [0, 10]]
C_SHAPE = [[0, 0], [10, 0], [10, 2], [2, 2], [2, 8], [10, 8], [10, 10], [0, 10], [0, 9.9], [1, 9.9], [1, 0.1], [0, 0.1]]


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(outline="oval", length=-16, width=12), "length"),
        (dict(outline="oval", length=16, width=0), "width"),
        (dict(outline="oval", length=float("nan"), width=12), "length"),
        (dict(outline="oval", length=float("inf"), width=12), "length"),
        (dict(outline="oval", length=16), "width"),
        (dict(outline="oval", width=12), "length"),
        (dict(outline="hexagon", length=16, width=12), "unknown outline"),
        (dict(outline="oval", length=16, width=12, profile="gothic"), "unknown profile"),
        (dict(outline="oval", length=16, width=12, dome=13.0), "higher than allowed"),
        (dict(outline="oval", length=16, width=12, dome=6.5, profile="spherical"), "higher than allowed"),
        (dict(outline="oval", length=16, width=12, dome=-1.0), "dome"),
        (dict(outline="oval", length=16, width=12, dome="towering"), "dome"),
        (dict(outline="oval", length=16, width=12, base=-2.0), "base"),
        (dict(outline="oval", length=16, width=12, base=20.0), "higher than allowed"),
        (dict(outline="oval", length=16, width=12, girdle=-0.5), "girdle"),
        (dict(outline="oval", length=16, width=12, girdle=100.0), "girdle"),
        (dict(outline="oval", length=16, width=12, buff_top=1.2), "buff_top"),
        (dict(outline="oval", length=16, width=12, buff_top=-0.1), "buff_top"),
        (dict(outline="oval", length=16, width=12, dome=5.9, profile="spherical", buff_top=0.5), "buff-top"),
        (dict(outline="round", length=16, width=12), "round"),
        (dict(outline="marquise", length=8, width=12), "length >= width"),
        (dict(outline="pear", length=8, width=12), "length >= width"),
        (dict(outline="rectangle", length=16, width=12, corner_radius=7), "corner_radius"),
        (dict(outline="oval", length=16, width=12, corner_radius=1), "corner_radius"),
        (dict(outline="oval", length=16, width=12, resolution=5), "resolution"),
        (dict(outline="oval", length=16, width=12, resolution="fine"), "resolution"),
        (dict(outline=BOWTIE), "self-intersecting"),
        (dict(outline=[[0, 0], [10, 10], [10, 0], [0, 12]]), "self-intersecting"),
        (dict(outline=[[0, 0], [10, 0], [10, 10], [5, 0], [0, 10]]), "self-intersecting"),
        (dict(outline=C_SHAPE, dome=1.0), "star-shaped"),
        (dict(outline=[[0, 0], [1, 1], [2, 2]]), "no area"),
        (dict(outline=[[0, 0], [1, 0]]), "at least 3"),
        (dict(outline=[[0, 0], [1, 0], [np.nan, 1]]), "non-finite"),
        (dict(outline=np.zeros((4, 3))), "shape"),
    ],
)
def test_impossible_parameters_are_clear_errors(kwargs, match):
    with pytest.raises(ParameterError, match=match) as info:
        cabochon(**kwargs)
    assert "\n" not in str(info.value)
    assert isinstance(info.value, labcut.LabcutError)


def test_long_traced_outline_is_resampled_keeping_corners():
    edges = [((0, 0), (10, 0)), ((10, 0), (10, 10)), ((10, 10), (0, 10)), ((0, 10), (0, 0))]
    t = np.linspace(0, 1, 1500, endpoint=False)[:, None]
    traced = np.vstack([np.array(a) + t * (np.array(b) - np.array(a)) for a, b in edges])  # 6000 points
    m = cabochon(traced, dome=2)
    assert len(m.faces) < 50_000
    check_solid(m, 10, 10, 2)
    assert rel_err(m, 100 * 2 / 3 * 2) < VOLUME_RTOL  # corners kept: the square is exact
