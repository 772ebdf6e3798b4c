"""labcut.geometry.profiles pinned by mutation testing (issue 37; docs/testing.md, "labcut/geometry/profiles.py").

The dome profiles worked by hand from the module docstring: each profile's height at chosen
radii (elliptic, spherical cap, tallow-top superellipse), a buff-top's virtual dome and flat
table, the closed-form and numerical volume factors, the rings' arc-length spacing, every
parameter at both ends of its range with its error word for word, and the spherical dome's
height limit (a hemisphere; with a buff-top table ``a sqrt(1 - t^2)``). No mesh: a few seconds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

from labcut.errors import ParameterError
from labcut.geometry import profiles as prof_mod
from labcut.geometry.profiles import MAX_TABLE, PROFILES, TALLOW_EXPONENT, Profile, dome_limit


def approx(x, rel=1e-12, abs=1e-12):
    return pytest.approx(x, rel=rel, abs=abs)


# ------------------------------------------------------------------ constants
def test_constants():
    assert PROFILES == ("elliptic", "spherical", "tallow")
    assert TALLOW_EXPONENT == 3.0
    assert MAX_TABLE == 0.95


# ------------------------------------------------------------------ the shape each name means
@pytest.mark.parametrize("s, z", [(0.0, 3.0), (0.6, 2.4), (0.8, 1.8), (1.0, 0.0), (-0.5, 3.0), (1.5, 0.0)])
def test_elliptic_by_hand(s, z):
    # z = H sqrt(1 - s^2), H = 3; s clipped to [0, 1]
    p = Profile("elliptic", 3.0, 7.0)
    assert float(p.z(s)) == approx(z)
    assert p.virtual_height == 3.0


@pytest.mark.parametrize("s, z", [(0.0, 2.0), (0.5, math.sqrt(21.0) - 3.0), (0.75, 1.0), (1.0, 0.0),
                                  (-1.0, 2.0), (2.0, 0.0)])
def test_spherical_cap_by_hand(s, z):
    # a = 4, H = 2: the sphere through (4, 0) and (0, 2) has R = (16 + 4) / 4 = 5, centre 3 mm below the foot
    p = Profile("spherical", 2.0, 4.0)
    assert float(p.z(s)) == approx(z)
    # every point lies on that sphere
    if 0.0 <= s <= 1.0:
        assert (4.0 * s) ** 2 + (z + 3.0) ** 2 == approx(25.0)


def test_spherical_hemisphere_by_hand():
    # H = a: a hemisphere, z = sqrt(a^2 - (a s)^2)
    p = Profile("spherical", 5.0, 5.0)
    s = np.array([0.0, 0.6, 0.8, 1.0])
    assert p.z(s) == approx([5.0, 4.0, 3.0, 0.0])


def test_spherical_depends_on_half_width_not_elliptic():
    # the cap's curvature comes from a; the elliptic and tallow domes ignore it
    assert float(Profile("spherical", 2.0, 4.0).z(0.5)) != approx(float(Profile("spherical", 2.0, 8.0).z(0.5)))
    assert float(Profile("spherical", 2.0, 8.0).z(0.5)) == approx(math.sqrt(17.0 ** 2 - 16.0) - 15.0)
    for kind in ("elliptic", "tallow"):
        assert float(Profile(kind, 2.0, 4.0).z(0.5)) == float(Profile(kind, 2.0, 9.0).z(0.5))


@pytest.mark.parametrize("s, z", [(0.0, 2.0), (0.5, 2.0 * 0.875 ** (1 / 3)), (2 ** (-1 / 3), 2.0 * 0.5 ** (1 / 3)),
                                  (1.0, 0.0), (-0.2, 2.0), (1.2, 0.0)])
def test_tallow_by_hand(s, z):
    # (z/H)^3 + s^3 = 1, H = 2
    p = Profile("tallow", 2.0, 5.0)
    assert float(p.z(s)) == approx(z)


def test_tallow_flatter_on_top_than_elliptic():
    s = np.linspace(0.01, 0.99, 50)
    assert np.all(Profile("tallow", 2.0, 5.0).z(s) > Profile("elliptic", 2.0, 5.0).z(s))


def test_z_keeps_shape_of_array():
    p = Profile("elliptic", 3.0, 7.0)
    out = p.z(np.array([[0.0, 0.6], [0.8, 1.0]]))
    assert out.shape == (2, 2)
    assert out == approx(np.array([[3.0, 2.4], [1.8, 0.0]]))


@pytest.mark.parametrize("kind", PROFILES)
def test_z_in_float64_from_any_numbers(kind):
    # float32, integer and list inputs are read as float64 radii: the heights are float64
    p = Profile(kind, 2.0, 4.0)
    want = p.z(np.array([0.0, 0.6, 1.0]))
    for s in (np.array([0.0, 0.6, 1.0], dtype=np.float32), [0.0, 0.6, 1.0]):
        out = p.z(s)
        assert out.dtype == np.float64
    assert p.z(np.array([0.0, 0.6], dtype=np.float32))[1] == approx(float(p.z(float(np.float32(0.6)))))
    assert p.z(np.array([0, 1, 2])) == approx([want[0], want[2], want[2]])
    assert p.z(np.array([0, 1, 2])).dtype == np.float64


@settings(max_examples=60, deadline=None)
@given(kind=st.sampled_from(PROFILES), a=st.floats(0.5, 30.0), frac=st.floats(0.05, 1.0),
       table=st.one_of(st.just(0.0), st.floats(0.05, MAX_TABLE)))
def test_any_profile_foot_apex_monotone(kind, a, frac, table):
    H = frac * dome_limit(kind, a, table)
    p = Profile(kind, H, a, table)
    s = np.linspace(0.0, 1.0, 101)
    z = p.z(s)
    assert z[0] == approx(H, rel=1e-9)
    assert z[-1] == approx(0.0, abs=1e-9 * H)
    assert np.all(np.diff(z) <= 1e-12 * H)
    assert np.all(z <= H * (1 + 1e-12)) and np.all(z >= 0.0)
    # a buff-top's table is flat at H out to s = t, its virtual dome passes through (t, H)
    if table:
        assert np.all(p.z(np.linspace(0.0, table, 11)[:-1]) == H)
        assert float(p.z(table)) == approx(H, rel=1e-9)
        assert float(prof_mod._virtual(kind, p.virtual_height, a, np.array(table))) == approx(H, rel=1e-9)
        assert p.virtual_height > H


# ------------------------------------------------------------------ buff-tops by hand
def test_buff_top_elliptic_by_hand():
    # t = 0.6, H = 2.4: z_v(0.6) = hv * 0.8 = 2.4 gives hv = 3
    p = Profile("elliptic", 2.4, 10.0, 0.6)
    assert p.virtual_height == approx(3.0)
    s = np.array([0.0, 0.3, 0.6, 0.8, 1.0])
    assert p.z(s) == approx([2.4, 2.4, 2.4, 1.8, 0.0])


def test_buff_top_tallow_by_hand():
    # t = 0.5: hv = H / (1 - 0.125)^(1/3)
    p = Profile("tallow", 2.0, 10.0, 0.5)
    hv = 2.0 / 0.875 ** (1 / 3)
    assert p.virtual_height == approx(hv)
    assert float(p.z(0.25)) == 2.0
    assert float(p.z(0.75)) == approx(hv * (1 - 0.75 ** 3) ** (1 / 3))


def test_buff_top_spherical_by_hand():
    # a = 4, t = 0.75, H = 1: the sphere R = 5 centred 3 mm below (hv = 2) passes through (3, 1)
    p = Profile("spherical", 1.0, 4.0, 0.75)
    assert p.virtual_height == approx(2.0, rel=1e-10)
    assert float(p.z(0.5)) == 1.0
    assert float(p.z(0.875)) == approx(math.sqrt(25.0 - 3.5 ** 2) - 3.0, rel=1e-10)


def test_buff_top_spherical_at_its_limit_is_a_cut_hemisphere():
    # a = 5, t = 0.6: the limit a sqrt(1 - t^2) = 4 is the hemisphere (hv = a = 5) cut at z = 4
    p = Profile("spherical", 4.0, 5.0, 0.6)
    assert p.virtual_height == approx(5.0, rel=1e-10)
    assert float(p.z(0.8)) == approx(3.0, rel=1e-10)
    assert float(p.z(0.3)) == 4.0


def test_buff_top_spherical_low_and_high_domes():
    # the bisection finds hv for a dome much lower and just below the limit
    for H, t in ((0.05, 0.5), (3.0, 0.5), (4.3, 0.5), (0.5, 0.9)):
        p = Profile("spherical", H, 5.0, t)
        hv = p.virtual_height
        R = (25.0 + hv * hv) / (2 * hv)
        assert math.sqrt(R * R - (5.0 * t) ** 2) - (R - hv) == approx(H, rel=1e-10)
        assert H < hv <= 5.0 * (1 + 1e-12)


# ------------------------------------------------------------------ volume factors
def quad_factor(p: Profile) -> float:
    val, _ = integrate.quad(lambda s: 2.0 * s * float(p.z(s)), 0.0, 1.0, limit=400, epsabs=1e-13, epsrel=1e-12,
                            points=[p.table] if p.table else None)
    return val


def test_volume_factor_closed_forms_by_hand():
    # elliptic: half-spheroid, 2/3 H
    assert Profile("elliptic", 3.0, 5.0).volume_factor() == approx(2.0)
    # spherical cap a = 4, H = 2: V / A = pi H (3a^2 + H^2) / 6 / (pi a^2) = 52/48
    assert Profile("spherical", 2.0, 4.0).volume_factor() == approx(52.0 / 48.0)
    # hemisphere: 2/3 a
    assert Profile("spherical", 5.0, 5.0).volume_factor() == approx(10.0 / 3.0)
    # tallow: H (2/n) B(2/n, 1 + 1/n), n = 3
    beta = math.gamma(2 / 3) * math.gamma(4 / 3) / math.gamma(2.0)
    assert Profile("tallow", 2.0, 5.0).volume_factor() == approx(2.0 * (2 / 3) * beta)


def test_volume_factor_buff_tops_by_hand():
    # elliptic t = 0.6, H = 2.4, hv = 3: H t^2 + hv (2/3) (1 - t^2)^1.5 = 0.864 + 1.024
    assert Profile("elliptic", 2.4, 10.0, 0.6).volume_factor() == approx(1.888)
    # spherical a = 5, t = 0.6, H = 4 (hemisphere cut): 4 * 0.36 + (2/75) * 16^1.5
    assert Profile("spherical", 4.0, 5.0, 0.6).volume_factor() == approx(1.44 + 128.0 / 75.0, rel=1e-9)


@pytest.mark.parametrize("kind, H, a, t", [("elliptic", 3.0, 5.0, 0.0), ("spherical", 2.0, 4.0, 0.0),
                                           ("tallow", 2.0, 5.0, 0.0), ("elliptic", 2.0, 5.0, 0.3),
                                           ("spherical", 1.0, 4.0, 0.75), ("spherical", 3.0, 6.0, 0.4),
                                           ("tallow", 2.0, 10.0, 0.5), ("tallow", 1.0, 3.0, 0.9)])
def test_volume_factor_is_the_integral(kind, H, a, t):
    p = Profile(kind, H, a, t)
    assert p.volume_factor() == approx(quad_factor(p), rel=1e-9, abs=0)


# ------------------------------------------------------------------ rings
def test_rings_full_elliptic_by_arc_length():
    # the normalised curve (s, z / H) of an elliptic dome is a quarter circle: equal arcs are equal angles
    p = Profile("elliptic", 2.0, 5.0)
    s, z = p.rings(4)
    angles = np.arange(5) * (math.pi / 8)
    assert s == approx(np.cos(angles), rel=0, abs=2e-7)
    assert s[0] == 1.0 and s[-1] == 0.0
    assert z[0] == 0.0 and z[-1] == 2.0
    assert z == approx(2.0 * np.sin(angles), rel=0, abs=2e-7)


def test_rings_buff_top_edge_is_a_ring():
    # elliptic t = 0.6, hv = 3: arc acos(0.6) on the circle, then the table's 0.6; 4 intervals,
    # the target nearest the edge (the second) moved onto it
    p = Profile("elliptic", 2.4, 10.0, 0.6)
    s, z = p.rings(4)
    edge = math.acos(0.6)
    total = edge + 0.6
    want_s = [1.0, math.cos(total / 4), 0.6, 0.6 - (3 * total / 4 - edge), 0.0]
    assert s == approx(want_s, rel=0, abs=2e-7)
    assert z[0] == 0.0
    assert z[1] == approx(3.0 * math.sin(total / 4), rel=0, abs=2e-7)
    assert list(z[2:]) == [2.4, 2.4, 2.4]


def test_rings_count_and_order():
    for kind, H, a, t in (("elliptic", 2.0, 5.0, 0.0), ("spherical", 2.0, 4.0, 0.0), ("tallow", 2.0, 5.0, 0.0),
                          ("spherical", 1.0, 4.0, 0.75), ("tallow", 2.0, 10.0, 0.5)):
        p = Profile(kind, H, a, t)
        for count in (2, 7, 40):
            s, z = p.rings(count)
            assert len(s) == len(z) == count + 1
            assert s[0] == 1.0 and s[-1] == 0.0 and z[0] == 0.0 and z[-1] == H
            assert np.all(np.diff(s) < 0) and np.all(np.diff(z) >= 0)
            assert z[1:-1] == approx(p.z(s[1:-1]))
            if t:
                assert np.any(s == t) or np.any(np.abs(s - t) < 1e-12)
                assert np.all(z[s <= t] == H)
    # fewer than 2 intervals are 2; a float count is truncated
    p = Profile("elliptic", 2.0, 5.0)
    for count in (-3, 0, 1, 2):
        assert len(p.rings(count)[0]) == 3
    assert len(p.rings(5.9)[0]) == 6


def test_rings_tallow_evenly_spaced_in_normalised_arc():
    # spacing by arc length of (s, z / hv): every segment about the same length
    p = Profile("tallow", 0.5, 20.0)
    s, z = p.rings(16)
    seg = np.hypot(np.diff(s), np.diff(z) / 0.5)
    assert seg == approx(np.full(16, seg.mean()), rel=1e-3)
    # the same rings for any dome height
    assert Profile("tallow", 7.0, 20.0).rings(16)[0] == approx(s)


# ------------------------------------------------------------------ dome_limit
def test_dome_limit_by_hand():
    assert dome_limit("spherical", 5.0) == 5.0
    assert dome_limit("spherical", 5.0, 0.6) == approx(4.0)
    assert dome_limit("spherical", 5.0, 0.0) == 5.0
    assert dome_limit("spherical", 5.0, 1.0) == 0.0
    assert dome_limit("spherical", 5.0, 1.5) == 0.0  # never the root of a negative
    assert dome_limit("elliptic", 5.0) == 10.0
    assert dome_limit("elliptic", 5.0, 0.6) == 10.0
    assert dome_limit("tallow", 3.0, 0.9) == 6.0


# ------------------------------------------------------------------ parameters at both ends, errors word for word
def error(**kw) -> str:
    args = dict(kind="elliptic", height=2.0, ref_half_width=5.0, table=0.0)
    args.update(kw)
    with pytest.raises(ParameterError) as info:
        Profile(**args)
    return str(info.value)


def test_unknown_profile():
    assert error(kind="gothic") == "unknown profile 'gothic'; use one of elliptic, spherical, tallow"
    assert error(kind="Elliptic") == "unknown profile 'Elliptic'; use one of elliptic, spherical, tallow"


@pytest.mark.parametrize("name", ["height", "ref_half_width"])
@pytest.mark.parametrize("value, shown", [(0.0, "0.0"), (0, "0"), (-1.0, "-1.0"), (float("nan"), "nan"),
                                          (float("inf"), "inf"), ("2", "'2'"), (None, "None")])
def test_lengths_positive_finite(name, value, shown):
    assert error(**{name: value}) == f"profile {name} must be a positive finite number of mm, got {shown}"


@pytest.mark.parametrize("name", ["height", "ref_half_width"])
def test_lengths_small_and_large_accepted(name):
    for v in (1e-9, 3, 1e6):
        kw = dict(kind="elliptic", height=2.0, ref_half_width=5.0)
        kw[name] = v
        assert getattr(Profile(**kw), name) == v


@pytest.mark.parametrize("t", [0.0, 0.05, 0.5, MAX_TABLE])
def test_table_range_accepted(t):
    p = Profile("elliptic", 2.0, 5.0, t)
    assert p.table == t


@pytest.mark.parametrize("t, shown", [(-1e-9, "-1e-09"), (-0.1, "-0.1"), (0.9500001, "0.9500001"), (1.0, "1.0"),
                                      (float("nan"), "nan"), (float("inf"), "inf"), (float("-inf"), "-inf")])
def test_table_range_refused(t, shown):
    assert error(table=t) == f"buff-top table fraction must be in [0, 0.95], got {shown}"


def test_spherical_height_limit_is_a_hemisphere():
    assert Profile("spherical", 5.0, 5.0).height == 5.0
    assert Profile("spherical", 5.0 * (1 + 5e-13), 5.0).virtual_height == 5.0 * (1 + 5e-13)
    for H in (5.0 * (1 + 1e-11), 5.001, 6.0):
        assert error(kind="spherical", height=H, ref_half_width=5.0) == (
            f"a spherical dome on this outline can be at most 5 mm high (a hemisphere over half-width 5 mm), "
            f"got {H:g} mm")
    assert error(kind="spherical", height=2.5, ref_half_width=2.25) == (
        "a spherical dome on this outline can be at most 2.25 mm high (a hemisphere over half-width 2.25 mm), "
        "got 2.5 mm")
    # the elliptic and tallow domes have no such limit here (dome_limit's 2a is cabochon's check)
    assert Profile("elliptic", 12.0, 5.0).height == 12.0
    assert Profile("tallow", 12.0, 5.0).height == 12.0


def test_spherical_buff_top_height_limit():
    # a = 5, t = 0.6: at most a sqrt(1 - t^2) = 4 mm
    assert Profile("spherical", 4.0, 5.0, 0.6).height == 4.0
    for H in (4.0 * (1 + 1e-11), 4.01, 5.0):
        assert error(kind="spherical", height=H, ref_half_width=5.0, table=0.6) == (
            f"a spherical dome with a 0.6 buff-top table on this outline can be at most 4 mm high "
            f"(a hemisphere over half-width 5 mm), got {H:g} mm")
    # the limit shown to four significant digits: 5 sqrt(1 - 0.25) = 4.3301...
    assert Profile("spherical", 5.0 * math.sqrt(0.75), 5.0, 0.5).height == 5.0 * math.sqrt(0.75)
    assert error(kind="spherical", height=4.34, ref_half_width=5.0, table=0.5) == (
        "a spherical dome with a 0.5 buff-top table on this outline can be at most 4.33 mm high "
        "(a hemisphere over half-width 5 mm), got 4.34 mm")
    # the largest table: a = 10, t = 0.95, limit 10 sqrt(0.0975) = 3.1225
    assert Profile("spherical", 3.12, 10.0, MAX_TABLE).height == 3.12
    assert error(kind="spherical", height=3.13, ref_half_width=10.0, table=MAX_TABLE) == (
        "a spherical dome with a 0.95 buff-top table on this outline can be at most 3.122 mm high "
        "(a hemisphere over half-width 10 mm), got 3.13 mm")


def test_profile_is_frozen():
    p = Profile("elliptic", 2.0, 5.0)
    with pytest.raises(AttributeError):
        p.height = 3.0  # type: ignore[misc]


# ------------------------------------------------------------------ found by the mutation run (docs/testing.md)
@pytest.mark.parametrize("n", [2.0, 4.0])
def test_tallow_closed_form_holds_for_its_exponent(monkeypatch, n):
    # the closed form A H (2/n) B(2/n, 1 + 1/n) for any superellipse exponent; n = 2 is the elliptic 2/3 H
    monkeypatch.setattr(prof_mod, "TALLOW_EXPONENT", n)
    p = Profile("tallow", 2.0, 5.0)
    assert p.volume_factor() == approx(quad_factor(p), rel=1e-9, abs=0)
    if n == 2.0:
        assert p.volume_factor() == approx(4.0 / 3.0)
        assert float(p.z(0.6)) == approx(1.6)


def test_rings_edge_nearest_the_first_target():
    # elliptic t = 0.9: arc acos(0.9) = 0.451 then the table's 0.9; of the targets 0, 0.338, 0.675, ... the
    # second is the nearest to the edge: it moves there, the others stay
    p = Profile("elliptic", 1.0, 5.0, 0.9)
    s, z = p.rings(4)
    edge = math.acos(0.9)
    targets = np.linspace(0.0, edge + 0.9, 5)
    want = [1.0, 0.9, 0.9 - (targets[2] - edge), 0.9 - (targets[3] - edge), 0.0]
    assert s == approx(want, rel=0, abs=2e-7)
    assert list(z[1:]) == [1.0] * 4


@pytest.mark.parametrize("count", [2, 4])
def test_rings_small_table_edge_is_still_a_ring(count):
    # t = 0.05: the edge lies nearest the apex's target; the target before the apex moves there
    p = Profile("elliptic", 1.0, 5.0, 0.05)
    s, z = p.rings(count)
    edge = math.acos(0.05)
    targets = np.linspace(0.0, edge + 0.05, count + 1)
    want = [math.cos(x) for x in targets[:-2]] + [0.05, 0.0]
    assert s == approx(want, rel=0, abs=2e-7)
    assert list(z[-2:]) == [1.0, 1.0]


def test_spherical_buff_top_within_the_rounding_tolerance():
    # a height over the limit a sqrt(1 - t^2) by less than 1e-12 (rounding) is accepted: its virtual dome
    # is the hemisphere (hv = a), the bisection's upper end
    for H, a, t in ((4.0 * (1 + 5e-13), 5.0, 0.6), (5.0 * math.sqrt(0.75) * (1 + 9e-13), 5.0, 0.5)):
        p = Profile("spherical", H, a, t)
        assert p.virtual_height == approx(a, rel=1e-9)
        assert float(p.z(0.0)) == H
