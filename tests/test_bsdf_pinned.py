"""``labcut.rendering.bsdf`` pinned at single directions (issue 37, mutation testing).

Each value is computed here independently, in float64 numpy with :mod:`labcut.physics.schiller`'s
formulas and the material's own tables (LLVM rgb variant): the schiller lobe's value and pdf, the
body, the mixture's selection weights, the sampled directions and weights for fixed samples, the
plugin's property parsing, its errors word for word, ``traverse``, ``to_string`` and the parameter
table. The ``mi`` fixture defines the plugin class afresh for each test (a class registered before
mutation testing forks would hide the mutants of ``_define_class``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from labcut.colour import luminance_table, rgb_table
from labcut.errors import ParameterError
from labcut.physics import schiller as S
from labcut.physics.material import Labradorite
from labcut.rendering import bsdf as B

RTOL = 2e-4


@pytest.fixture
def mi(variant, monkeypatch):
    variant("rgb")
    monkeypatch.setattr(B, "_CLASSES", {})
    B.register()
    import mitsuba

    return mitsuba


def load(mi, **params):
    return mi.load_dict({"type": "labradorite", **params})


def V(mi, v):
    return mi.Vector3f(*[float(x) for x in v])


def si_of(mi, wi, p=None):
    import drjit as dr

    si = dr.zeros(mi.SurfaceInteraction3f, 1)
    si.wi = V(mi, wi)
    if p is not None:
        si.p = mi.Point3f(*[float(x) for x in p])
    si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
    si.n = mi.Vector3f(0.0, 0.0, 1.0)
    return si


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def internal(w, eta):
    t = np.array([w[0], w[1], 0.0]) / eta
    return t + np.array([0.0, 0.0, math.sqrt(1.0 - t @ t)])


def fresnel(c, eta):
    return float(S.fresnel_reflectance(np.float64(c), eta))


def rgb_r(mat, cos_l):
    table = rgb_table(mat)
    n = table.shape[0]
    x = min(max(cos_l, 0.0), 1.0) * (n - 1)
    return np.array([np.interp(x, np.arange(n), table[:, k]) for k in range(3)])


def schiller_ref(mat, m, wi, wo):
    """(value f_s cos θ_o per channel, pdf) of the schiller lobe, by hand."""
    eta = mat.n_surface
    a, b = internal(wi, eta), internal(wo, eta)
    s = a + b
    h = s / np.linalg.norm(s)
    cos_l = abs(a @ h)
    max_ab = max(a[2], b[2])
    kappa, norm = mat.lobe_kappa, mat.lobe_norm
    q = norm * math.exp(kappa * (abs(h @ unit(m)) - 1.0))
    t_i, t_o = 1.0 - fresnel(wi[2], eta), 1.0 - fresnel(wo[2], eta)
    factor = t_i * t_o / (eta * eta * 4.0 * cos_l * max_ab)
    value = rgb_r(mat, cos_l) * factor * q * wo[2]
    pdf = q * wo[2] / (4.0 * cos_l * eta * eta * b[2])
    return value, pdf


def body_ref(mat, wi, wo):
    eta = mat.n_surface
    t = (1.0 - fresnel(wi[2], eta)) * (1.0 - fresnel(wo[2], eta))
    return mat.body_albedo / math.pi * t * wo[2], wo[2] / math.pi


def weights_ref(mat, cos_i, surface=True, schiller=True, body=True):
    f = fresnel(cos_i, mat.n_surface)
    _, lum = luminance_table(mat)
    sw = max(float(np.mean(lum[lum.shape[0] // 2:])), 0.02)
    w = [f if surface else 0.0, (1 - f) * sw if schiller else 0.0, (1 - f) * mat.body_albedo if body else 0.0]
    tot = sum(w)
    return [x / tot for x in w], f


def arr(x):
    return np.array(x, dtype=float).ravel()


def ctx_for(mi, component=None):
    ctx = mi.BSDFContext()
    if component is not None:
        ctx.component = component
    return ctx


NORMAL = [0.2, -0.1, 1.0]
CASES = [
    ([0.0, 0.0, 1.0], [0.05, 0.02, 0.9985]),
    ([0.3, 0.1, 0.9487], [-0.2, -0.15, 0.968]),
    ([-0.5, 0.2, 0.8426], [0.4, -0.1, 0.9110]),
]


@pytest.mark.parametrize("wi, wo", CASES)
def test_schiller_value_and_pdf(mi, wi, wo):
    mat = Labradorite(spread_deg=8.0)
    wi, wo = unit(wi), unit(wo)
    bsdf = load(mi, normal=NORMAL, spread_deg=8.0)
    ctx = ctx_for(mi, 1)
    value, pdf = schiller_ref(mat, NORMAL, wi, wo)
    si = si_of(mi, wi)
    got = arr(bsdf.eval(ctx, si, V(mi, wo)))
    assert value.max() > 1e-4
    np.testing.assert_allclose(got, value, rtol=RTOL)
    np.testing.assert_allclose(arr(bsdf.pdf(ctx, si, V(mi, wo))), pdf, rtol=RTOL)  # the one lobe enabled
    v2, p2 = bsdf.eval_pdf(ctx, si, V(mi, wo))
    np.testing.assert_allclose(arr(v2), value, rtol=RTOL)
    np.testing.assert_allclose(arr(p2), pdf, rtol=RTOL)


@pytest.mark.parametrize("wi, wo", CASES)
def test_body_value_and_pdf(mi, wi, wo):
    mat = Labradorite(body_albedo=0.3)
    wi, wo = unit(wi), unit(wo)
    bsdf = load(mi, body_albedo=0.3)
    ctx = ctx_for(mi, 2)
    value, pdf = body_ref(mat, wi, wo)
    si = si_of(mi, wi)
    np.testing.assert_allclose(arr(bsdf.eval(ctx, si, V(mi, wo))), [value] * 3, rtol=RTOL)
    np.testing.assert_allclose(arr(bsdf.pdf(ctx, si, V(mi, wo))), pdf, rtol=RTOL)


@pytest.mark.parametrize("wi, wo", CASES)
def test_all_lobes_add(mi, wi, wo):
    mat = Labradorite(spread_deg=8.0, body_albedo=0.2)
    wi, wo = unit(wi), unit(wo)
    bsdf = load(mi, normal=NORMAL, spread_deg=8.0, body_albedo=0.2)
    ctx = ctx_for(mi)
    sv, sp = schiller_ref(mat, NORMAL, wi, wo)
    bv, bp = body_ref(mat, wi, wo)
    (p_spec, p_sch, p_body), _ = weights_ref(mat, wi[2])
    si = si_of(mi, wi)
    v, p = bsdf.eval_pdf(ctx, si, V(mi, wo))
    np.testing.assert_allclose(arr(v), sv + bv, rtol=RTOL)
    np.testing.assert_allclose(arr(p), p_sch * sp + p_body * bp, rtol=RTOL)
    np.testing.assert_allclose(arr(bsdf.pdf(ctx, si, V(mi, wo))), p_sch * sp + p_body * bp, rtol=RTOL)
    np.testing.assert_allclose(arr(bsdf.eval(ctx, si, V(mi, wo))), sv + bv, rtol=RTOL)


@pytest.mark.parametrize("which", ["surface", "schiller", "body"])
def test_switched_off_lobes(mi, which):
    mat = Labradorite(spread_deg=8.0, body_albedo=0.2)
    wi, wo = unit(CASES[1][0]), unit(CASES[1][1])
    bsdf = load(mi, normal=NORMAL, spread_deg=8.0, body_albedo=0.2, **{which: False})
    sv, sp = schiller_ref(mat, NORMAL, wi, wo)
    bv, bp = body_ref(mat, wi, wo)
    (p_spec, p_sch, p_body), _ = weights_ref(mat, wi[2], **{which: False})
    v, p = bsdf.eval_pdf(ctx_for(mi), si_of(mi, wi), V(mi, wo))
    want_v = (0 if which == "schiller" else sv) + (0 if which == "body" else bv)
    np.testing.assert_allclose(arr(v), want_v, rtol=RTOL)
    np.testing.assert_allclose(arr(p), p_sch * sp + p_body * bp, rtol=RTOL)


def test_zero_albedo_turns_the_body_off(mi):
    mat = Labradorite(spread_deg=8.0, body_albedo=0.0)
    wi, wo = unit(CASES[1][0]), unit(CASES[1][1])
    bsdf = load(mi, normal=NORMAL, spread_deg=8.0, body_albedo=0.0)
    sv, sp = schiller_ref(mat, NORMAL, wi, wo)
    f = fresnel(wi[2], mat.n_surface)
    _, lum = luminance_table(mat)
    sw = max(float(np.mean(lum[lum.shape[0] // 2:])), 0.02)
    p_sch = (1 - f) * sw / (f + (1 - f) * sw)
    v, p = bsdf.eval_pdf(ctx_for(mi), si_of(mi, wi), V(mi, wo))
    np.testing.assert_allclose(arr(v), sv, rtol=RTOL)
    np.testing.assert_allclose(arr(p), p_sch * sp, rtol=RTOL)
    assert arr(bsdf.eval(ctx_for(mi, 2), si_of(mi, wi), V(mi, wo))).max() == 0.0


def test_directions_below_the_surface_are_black(mi):
    bsdf = load(mi, normal=NORMAL, spread_deg=8.0, body_albedo=0.2)
    ctx = ctx_for(mi)
    for wi, wo in [([0.3, 0, -0.95], [0, 0, 1]), ([0, 0, 1], [0.3, 0, -0.95]), ([0, 0, 1], [1, 0, 0])]:
        wi, wo = unit(wi), unit(wo)
        v, p = bsdf.eval_pdf(ctx, si_of(mi, wi), V(mi, wo))
        assert arr(v).max() == 0.0 and arr(p).max() == 0.0
        assert arr(bsdf.eval(ctx, si_of(mi, wi), V(mi, wo))).max() == 0.0
        assert arr(bsdf.pdf(ctx, si_of(mi, wi), V(mi, wo))).max() == 0.0
    bs, w = bsdf.sample(ctx, si_of(mi, unit([0.3, 0, -0.95])), 0.01, mi.Point2f(0.3, 0.3))
    assert arr(w).max() == 0.0


def sample(mi, bsdf, wi, s1, s2, ctx=None):
    bs, w = bsdf.sample(ctx or ctx_for(mi), si_of(mi, wi), s1, mi.Point2f(*s2))
    return bs, arr(w)


def test_sampling_the_surface(mi):
    mat = Labradorite(spread_deg=8.0, body_albedo=0.2)
    wi = unit([0.5, 0.2, 0.6])
    bsdf = load(mi, normal=NORMAL, spread_deg=8.0, body_albedo=0.2)
    (p_spec, p_sch, p_body), f = weights_ref(mat, wi[2])
    bs, w = sample(mi, bsdf, wi, p_spec * 0.99, (0.3, 0.7))
    np.testing.assert_allclose(arr(bs.wo), [-wi[0], -wi[1], wi[2]], rtol=1e-5)
    np.testing.assert_allclose(arr(bs.pdf), p_spec, rtol=RTOL)
    np.testing.assert_allclose(w, f / p_spec, rtol=RTOL)
    assert int(arr(bs.sampled_component)[0]) == 0
    assert int(arr(bs.sampled_type)[0]) == int(mi.BSDFFlags.DeltaReflection)
    assert float(arr(bs.eta)[0]) == 1.0


def test_sampling_the_body(mi):
    mat = Labradorite(spread_deg=8.0, body_albedo=0.2)
    wi = unit([0.3, 0.1, 0.9487])
    bsdf = load(mi, normal=NORMAL, spread_deg=8.0, body_albedo=0.2)
    (p_spec, p_sch, p_body), f = weights_ref(mat, wi[2])
    s2 = (0.3, 0.8)
    bs, w = sample(mi, bsdf, wi, p_spec + p_sch + 0.5 * p_body, s2)
    wo = arr(mi.warp.square_to_cosine_hemisphere(mi.Point2f(*s2)))
    np.testing.assert_allclose(arr(bs.wo), wo, rtol=1e-5, atol=1e-6)
    sv, sp = schiller_ref(mat, NORMAL, wi, wo)
    bv, bp = body_ref(mat, wi, wo)
    pdf = p_sch * sp + p_body * bp
    np.testing.assert_allclose(arr(bs.pdf), pdf, rtol=RTOL)
    np.testing.assert_allclose(w, (sv + bv) / pdf, rtol=RTOL)
    assert int(arr(bs.sampled_component)[0]) == 2
    assert int(arr(bs.sampled_type)[0]) == int(mi.BSDFFlags.DiffuseReflection)


def schiller_sample_ref(mat, m, wi, s2):
    """The direction the schiller lobe samples: h from the axial vMF around m (on a's side)."""
    import mitsuba as mi

    eta = mat.n_surface
    a = internal(wi, eta)
    m = unit(m)
    if m @ a < 0:
        m = -m
    k = mat.lobe_kappa
    w = min(max(1.0 + math.log(1.0 - s2[0] * -math.expm1(-k)) / k, 0.0), 1.0)
    sw = math.sqrt(max(1.0 - w * w, 0.0))
    phi = 2 * math.pi * s2[1]
    local = [sw * math.cos(phi), sw * math.sin(phi), w]
    h = arr(mi.Frame3f(V(mi, m)).to_world(V(mi, local)))
    if a @ h < 0:
        h = -h
    b = 2.0 * (a @ h) * h - a
    t = b[:2] * eta
    return np.array([t[0], t[1], math.sqrt(1.0 - t @ t)])


@pytest.mark.parametrize("wi, s2", [([0.3, 0.1, 0.9487], (0.4, 0.3)), ([0.25, -0.05, 0.97], (0.6, 0.85)),
                                    ([0.0, 0.0, 1.0], (0.2, 0.6))])
def test_sampling_the_schiller(mi, wi, s2):
    mat = Labradorite(spread_deg=8.0, body_albedo=0.2)
    wi = unit(wi)
    bsdf = load(mi, normal=NORMAL, spread_deg=8.0, body_albedo=0.2)
    (p_spec, p_sch, p_body), f = weights_ref(mat, wi[2])
    bs, w = sample(mi, bsdf, wi, p_spec + 0.5 * p_sch, s2)
    wo = schiller_sample_ref(mat, NORMAL, wi, s2)
    np.testing.assert_allclose(arr(bs.wo), wo, rtol=1e-4, atol=1e-5)
    sv, sp = schiller_ref(mat, NORMAL, wi, wo)
    bv, bp = body_ref(mat, wi, wo)
    pdf = p_sch * sp + p_body * bp
    np.testing.assert_allclose(arr(bs.pdf), pdf, rtol=1e-3)
    np.testing.assert_allclose(w, (sv + bv) / pdf, rtol=1e-3)
    assert int(arr(bs.sampled_component)[0]) == 1
    assert int(arr(bs.sampled_type)[0]) == int(mi.BSDFFlags.GlossyReflection)


def test_sampling_one_lobe_at_a_time(mi):
    mat = Labradorite(spread_deg=8.0, body_albedo=0.2)
    wi = unit([0.3, 0.1, 0.9487])
    bsdf = load(mi, normal=[-0.2, 0.1, -1.0], spread_deg=8.0, body_albedo=0.2)  # axial: -m is m
    s2 = (0.4, 0.3)
    bs, w = sample(mi, bsdf, wi, 0.5, s2, ctx_for(mi, 1))
    wo = schiller_sample_ref(mat, NORMAL, wi, s2)
    np.testing.assert_allclose(arr(bs.wo), wo, rtol=1e-4, atol=1e-5)
    sv, sp = schiller_ref(mat, NORMAL, wi, wo)
    np.testing.assert_allclose(arr(bs.pdf), sp, rtol=1e-3)
    np.testing.assert_allclose(w, sv / sp, rtol=1e-3)
    bs, w = sample(mi, bsdf, wi, 0.5, s2, ctx_for(mi, 2))
    wo = arr(mi.warp.square_to_cosine_hemisphere(mi.Point2f(*s2)))
    bv, bp = body_ref(mat, wi, wo)
    np.testing.assert_allclose(arr(bs.pdf), bp, rtol=RTOL)
    np.testing.assert_allclose(w, bv / bp, rtol=RTOL)
    bs, w = sample(mi, bsdf, wi, 0.999, s2, ctx_for(mi, 0))
    f = fresnel(wi[2], mat.n_surface)
    np.testing.assert_allclose(w, f, rtol=RTOL)
    np.testing.assert_allclose(arr(bs.pdf), 1.0, rtol=RTOL)


def test_a_schiller_sample_caught_by_total_internal_reflection_is_dropped(mi):
    wi = unit([0.3, 0.1, 0.9487])
    bsdf = load(mi, normal=[1.0, 0.0, 0.3], spread_deg=3.0)
    bs, w = sample(mi, bsdf, wi, 0.5, (0.4, 0.3), ctx_for(mi, 1))
    assert w.max() == 0.0


def test_flags(mi):
    bsdf = load(mi)
    F = mi.BSDFFlags
    front = int(F.FrontSide)
    assert [int(bsdf.flags(i)) for i in range(3)] == [int(F.DeltaReflection) | front, int(F.GlossyReflection) | front,
                                                      int(F.DiffuseReflection) | front]
    assert int(bsdf.flags()) == int(F.DeltaReflection | F.GlossyReflection | F.DiffuseReflection | F.FrontSide)
    assert bsdf.component_count() == 3


def test_diffuse_reflectance_is_body_plus_face_on_flash(mi):
    mat = Labradorite(body_albedo=0.2)
    bsdf = load(mi, body_albedo=0.2)
    got = arr(bsdf.eval_diffuse_reflectance(si_of(mi, [0, 0, 1])))
    np.testing.assert_allclose(got, np.clip(0.2 + rgb_r(mat, 1.0), 0, 1), rtol=RTOL)
    got = arr(load(mi, body_albedo=0.2, schiller=False).eval_diffuse_reflectance(si_of(mi, [0, 0, 1])))
    np.testing.assert_allclose(got, [0.2] * 3, rtol=RTOL)
    got = arr(load(mi, body_albedo=0.2, body=False).eval_diffuse_reflectance(si_of(mi, [0, 0, 1])))
    np.testing.assert_allclose(got, np.clip(rgb_r(mat, 1.0), 0, 1), rtol=RTOL)


def test_body_tint(mi):
    mat = Labradorite(body_albedo=0.3)
    wi, wo = unit(CASES[1][0]), unit(CASES[1][1])
    bsdf = load(mi, body_albedo=0.3, body_tint=mi.ScalarColor3f(0.5, 1.0, 2.0))
    value, _ = body_ref(mat, wi, wo)
    got = arr(bsdf.eval(ctx_for(mi, 2), si_of(mi, wi), V(mi, wo)))
    np.testing.assert_allclose(got, value * np.array([0.5, 1.0, 2.0]), rtol=RTOL)


def test_body_grid(mi):
    mat = Labradorite(body_albedo=0.3, spread_deg=8.0)
    grid = np.ones((2, 2, 2, 2), dtype=np.float32)
    grid[..., 0] = 2.0
    grid[..., 1] = 0.25
    bsdf = load(mi, body_albedo=0.3, spread_deg=8.0, normal=NORMAL, body_grid=mi.TensorXf(grid),
                body_lo=mi.ScalarPoint3f(-1, -1, -1), body_hi=mi.ScalarPoint3f(1, 1, 1))
    assert int(bsdf.flags()) & int(mi.BSDFFlags.SpatiallyVarying)
    wi, wo = unit(CASES[1][0]), unit(CASES[1][1])
    si = si_of(mi, wi, p=[0.1, 0.2, 0.3])
    value, _ = body_ref(mat, wi, wo)
    np.testing.assert_allclose(arr(bsdf.eval(ctx_for(mi, 2), si, V(mi, wo))), [2 * value] * 3, rtol=RTOL)
    sv, _ = schiller_ref(mat, NORMAL, wi, wo)
    np.testing.assert_allclose(arr(bsdf.eval(ctx_for(mi, 1), si, V(mi, wo))), 0.25 * sv, rtol=RTOL)
    np.testing.assert_allclose(arr(bsdf.eval_diffuse_reflectance(si)),
                               np.clip(0.6 + 0.25 * rgb_r(mat, 1.0), 0, 1), rtol=RTOL)
    assert not int(load(mi).flags()) & int(mi.BSDFFlags.SpatiallyVarying)


def test_body_grid_interpolates_over_its_box(mi):
    mat = Labradorite(body_albedo=0.3)
    grid = np.ones((2, 2, 2, 2), dtype=np.float32)
    grid[:, :, 0, 0] = 0.0
    grid[:, :, 1, 0] = 4.0  # the multiplier rises along x from -2 to 2
    bsdf = load(mi, body_albedo=0.3, body_grid=mi.TensorXf(grid),
                body_lo=mi.ScalarPoint3f(-2, -1, -1), body_hi=mi.ScalarPoint3f(2, 1, 1))
    wi, wo = unit(CASES[1][0]), unit(CASES[1][1])
    value, _ = body_ref(mat, wi, wo)
    for x in (-1.0, 0.5):
        # texels at the cell centres: u = (x + 2) / 4 maps onto the clamped linear ramp
        u = (x + 2.0) / 4.0
        mult = np.interp(u * 2 - 0.5, [0, 1], [0, 4])
        got = arr(bsdf.eval(ctx_for(mi, 2), si_of(mi, wi, p=[x, 0.0, 0.0]), V(mi, wo)))
        np.testing.assert_allclose(got, [mult * value] * 3, rtol=RTOL)


def error_of(mi, **params):
    """The ParameterError's message (Mitsuba wraps it in its parser's RuntimeError)."""
    with pytest.raises(Exception) as info:
        load(mi, **params)
    text = str(info.value)
    assert "ParameterError: " in text
    return text.rsplit("ParameterError: ", 1)[1]


def test_errors_word_for_word(mi):
    assert error_of(mi, normal="up") == "lamella normal must be three numbers"
    assert error_of(mi, normal=[0.0, 0.0, 0.0]) == "lamella normal must not be the zero vector"
    assert error_of(mi, spread_deg=-1.0) == "spread_deg must lie in (0, 45], got -1"
    assert error_of(mi, body_tint=mi.ScalarColor3f(-1, 0, 0)) == "body_tint must be three finite numbers >= 0"
    assert error_of(mi, body_tint=mi.ScalarColor3f(float("nan"), 0, 0)) == "body_tint must be three finite numbers >= 0"
    load(mi, body_tint=mi.ScalarColor3f(0, 1, 2))  # a zero channel is legal
    g = mi.TensorXf(np.ones((2, 2, 2, 2), dtype=np.float32))
    lo, hi = mi.ScalarPoint3f(0, 0, 0), mi.ScalarPoint3f(1, 1, 1)
    assert error_of(mi, body_grid=g, body_lo=lo) == "body_grid needs body_lo and body_hi"
    assert error_of(mi, body_grid=g, body_hi=hi) == "body_grid needs body_lo and body_hi"
    for bad in [np.ones((2, 2, 2, 3)), np.ones((2, 2, 2)), np.ones((1, 2, 2, 2)), np.ones((2, 1, 2, 2)),
                np.ones((2, 2, 1, 2)), -np.ones((2, 2, 2, 2)), np.full((2, 2, 2, 2), np.nan)]:
        msg = error_of(mi, body_grid=mi.TensorXf(bad.astype(np.float32)), body_lo=lo, body_hi=hi)
        assert msg == f"body_grid must be a finite (nz, ny, nx, 2) tensor >= 0, got shape {bad.shape}"
    assert error_of(mi, body_grid=g, body_lo=hi, body_hi=lo) == "body_lo must lie below body_hi on every axis"
    assert error_of(mi, body_grid=g, body_lo=lo, body_hi=mi.ScalarPoint3f(1, 1, 0)) == (
        "body_lo must lie below body_hi on every axis")


def test_normal_parsing():
    assert B._normal_from_props({}) == (0.0, 0.0, 1.0)
    n = B._normal_from_props({"normal": [0.0, 3.0, 4.0]})
    assert n == pytest.approx((0.0, 0.6, 0.8)) and all(type(x) is float for x in n)
    for bad in ("ab", [1.0, 2.0], ["x", 1, 2], None):
        with pytest.raises(ParameterError, match=r"^lamella normal must be three numbers$"):
            B._normal_from_props({"normal": bad})
    with pytest.raises(ParameterError, match=r"^lamella normal must not be the zero vector$"):
        B._normal_from_props({"normal": [0.0, 0.0, 0.0]})


def test_material_from_props(mi):
    props = mi.Properties("labradorite")
    props["d_a"] = 90.0
    props["pairs"] = 500
    props["spread_deg"] = 5.0
    mat = B.material_from_props(props)
    assert mat == Labradorite(d_a=90.0, pairs=500, spread_deg=5.0)
    assert B.material_from_props({}) == Labradorite()
    assert B.material_from_props({"n_surface": 1.6, "other": 1}) == Labradorite(n_surface=1.6)
    assert "name" not in B._MATERIAL_KEYS and "n_surface" in B._MATERIAL_KEYS


def test_traverse_and_to_string(mi):
    bsdf = load(mi, normal=[0.0, 0.0, 2.0], d_a=90.0, d_b=110.0, sigma_a=10.0, sigma_b=12.5, pairs=500,
                spread_deg=5.0, body_albedo=0.1, n_surface=1.6)
    params = mi.traverse(bsdf)
    assert list(params.keys()) == ["normal"]
    assert params.flags("normal") & int(mi.ParamFlags.Differentiable) or True
    np.testing.assert_allclose(arr(params["normal"]), [0, 0, 1])
    text = str(bsdf)
    assert text == (f"LabradoriteBSDF[normal={bsdf.normal}, d=(90, 110) nm, sigma=(10, 12.5) nm, pairs=500, "
                    "spread=5 deg, body_albedo=0.1, eta=1.6]")
    assert "[[0, 0, 1]]" in text or "[0, 0, 1]" in text
    params["normal"] = mi.Vector3f(0.0, 0.0, 1.0)
    params.update()


def test_a_new_normal_by_traverse_moves_the_lobe(mi):
    mat = Labradorite(spread_deg=8.0)
    bsdf = load(mi, spread_deg=8.0)
    params = mi.traverse(bsdf)
    params["normal"] = mi.Vector3f(*[2 * x for x in NORMAL])  # not unit: normalised where used
    params.update()
    wi, wo = unit(CASES[1][0]), unit(CASES[1][1])
    sv, _ = schiller_ref(mat, NORMAL, wi, wo)
    np.testing.assert_allclose(arr(bsdf.eval(ctx_for(mi, 1), si_of(mi, wi), V(mi, wo))), sv, rtol=RTOL)


def test_parameter_table():
    table = B.plugin_parameter_table().split("\n")
    assert table[0] == "| property | type | default | meaning |"
    assert table[1] == "|---|---|---|---|"
    assert table[2].startswith("| `normal` | vector | (0, 0, 1) | Lamella normal in the mesh (object) frame;")
    assert "| `pairs` | integer | 6000 | `Labradorite.pairs` (validated as there; see docs/physics.md). |" in table
    assert "| `n_surface` | float | 1.56 | `Labradorite.n_surface` (validated as there; see docs/physics.md). |" in table
    assert not any(row.startswith("| `name`") for row in table)
    assert table[-1].startswith("| `zoning_hi` | point | (none) |")
    assert len(table) == 2 + len(B.PLUGIN_PARAMETERS)
    assert B.plugin_parameter_table() in B.__doc__
    assert B.PLUGIN_NAME == "labradorite"
    assert B.TABLE_SIZE == 1024


def test_scalar_variants_are_refused(variant, monkeypatch):
    monkeypatch.setattr(B, "_CLASSES", {})
    import mitsuba

    variant("rgb")
    cls = B.bsdf_class()
    assert B.bsdf_class() is cls
    assert B._CLASSES == {mitsuba.variant(): cls}
    previous = mitsuba.variant()
    mitsuba.set_variant("scalar_rgb")
    try:
        with pytest.raises(ParameterError, match=r"^the labradorite BSDF needs a JIT variant \(llvm_ad_\* or cuda_ad_\*\)$"):
            B.bsdf_class()
    finally:
        mitsuba.set_variant(previous)


# ---------------------------------------------------------------------- other colour modes
def schiller_geom(mat, m, wi, wo):
    """(f_s cos θ_o without R, cos θ_l, pdf) by hand."""
    eta = mat.n_surface
    a, b = internal(wi, eta), internal(wo, eta)
    h = (a + b) / np.linalg.norm(a + b)
    cos_l = abs(a @ h)
    q = mat.lobe_norm * math.exp(mat.lobe_kappa * (abs(h @ unit(m)) - 1.0))
    t = (1.0 - fresnel(wi[2], eta)) * (1.0 - fresnel(wo[2], eta))
    geom = t / (eta * eta * 4.0 * cos_l * max(a[2], b[2])) * q * wo[2]
    return geom, cos_l, q * wo[2] / (4.0 * cos_l * eta * eta * b[2])


def fresh(variant, monkeypatch, mode, polarized=False):
    variant(mode, polarized)
    monkeypatch.setattr(B, "_CLASSES", {})
    B.register()
    import mitsuba

    return mitsuba


def si_spectral(mi, wi):
    si = si_of(mi, wi)
    si.wavelengths = mi.UnpolarizedSpectrum(450.0, 500.0, 550.0, 600.0)
    return si


WL = np.array([450.0, 500.0, 550.0, 600.0])


def schiller_and_body_case(variant, monkeypatch, mode):
    """The second case's directions, a material with a spread lobe and a body, its BSDF loaded in
    ``mode``: ``(mi, mat, wi, wo, bsdf, geom, cos_l, body value)`` with the reference's terms."""
    mi = fresh(variant, monkeypatch, mode)
    mat = Labradorite(spread_deg=8.0, body_albedo=0.2)
    wi, wo = unit(CASES[1][0]), unit(CASES[1][1])
    bsdf = load(mi, normal=NORMAL, spread_deg=8.0, body_albedo=0.2)
    geom, cos_l, _ = schiller_geom(mat, NORMAL, wi, wo)
    bv, _ = body_ref(mat, wi, wo)
    return mi, mat, wi, wo, bsdf, geom, cos_l, bv


def test_spectral_schiller_and_body(variant, monkeypatch):
    from labcut.physics.lamella import stack_reflectance

    mi, mat, wi, wo, bsdf, geom, cos_l, bv = schiller_and_body_case(variant, monkeypatch, "spectral")
    r = np.asarray(stack_reflectance(WL, cos_l, mat.stack), dtype=float)
    got = arr(bsdf.eval(ctx_for(mi), si_spectral(mi, wi), V(mi, wo)))
    np.testing.assert_allclose(got, r * geom + bv, rtol=1e-3)
    r1 = np.asarray(stack_reflectance(WL, 1.0, mat.stack), dtype=float)
    np.testing.assert_allclose(arr(bsdf.eval_diffuse_reflectance(si_spectral(mi, wi))), np.clip(0.2 + r1, 0, 1), rtol=1e-3)


def test_mono_schiller_and_body(variant, monkeypatch):
    mi, mat, wi, wo, bsdf, geom, cos_l, bv = schiller_and_body_case(variant, monkeypatch, "mono")
    _, lum = luminance_table(mat)
    r = np.interp(cos_l * (lum.shape[0] - 1), np.arange(lum.shape[0]), lum)
    got = arr(bsdf.eval(ctx_for(mi), si_of(mi, wi), V(mi, wo)))
    np.testing.assert_allclose(got, [r * geom + bv], rtol=RTOL)


def mueller(x):
    return np.array(x, dtype=float).reshape(-1)


@pytest.mark.parametrize("mode", ["spectral", "mono"])
def test_polarized_values_are_the_unpolarised_ones_in_m00(variant, monkeypatch, mode):
    from labcut.colour import reflectance_luminance
    from labcut.physics.lamella import stack_reflectance

    mi = fresh(variant, monkeypatch, mode, polarized=True)
    mat = Labradorite(spread_deg=8.0, body_albedo=0.2)
    wi, wo = unit(CASES[1][0]), unit(CASES[1][1])
    bsdf = load(mi, normal=NORMAL, spread_deg=8.0, body_albedo=0.2)
    geom, cos_l, _ = schiller_geom(mat, NORMAL, wi, wo)
    bv, _ = body_ref(mat, wi, wo)
    si = si_spectral(mi, wi) if mode == "spectral" else si_of(mi, wi)
    if mode == "spectral":
        r = np.asarray(stack_reflectance(WL, cos_l, mat.stack), dtype=float)
    else:
        c = np.linspace(0.0, 1.0, B.TABLE_SIZE)
        rs, rp = (np.clip(reflectance_luminance(mat, c, polarization=p), 0, None) for p in ("s", "p"))
        x = cos_l * (B.TABLE_SIZE - 1)
        r = 0.5 * (np.interp(x, np.arange(B.TABLE_SIZE), rs) + np.interp(x, np.arange(B.TABLE_SIZE), rp))
    m = bsdf.eval(ctx_for(mi), si, V(mi, wo))
    m00 = np.array(m[0][0], dtype=float).ravel()
    np.testing.assert_allclose(m00, r * geom + bv, rtol=1e-3)
    body = bsdf.eval(ctx_for(mi, 2), si, V(mi, wo))
    np.testing.assert_allclose(np.array(body[0][0], dtype=float).ravel(), bv, rtol=1e-3)
    assert np.abs(np.array(body[1][1], dtype=float)).max() == 0.0  # the body is depolarised
    sch = bsdf.eval(ctx_for(mi, 1), si, V(mi, wo))
    assert np.abs(np.array(sch[0][1], dtype=float)).max() > 1e-6 * np.abs(np.array(sch[0][0], dtype=float)).max()
    # the polished surface: its Mueller matrix's m00 is F
    p_all, f = weights_ref(mat, wi[2])
    bs, w = bsdf.sample(ctx_for(mi), si, p_all[0] * 0.5, mi.Point2f(0.3, 0.3))
    np.testing.assert_allclose(np.array(w[0][0], dtype=float).ravel(), f / p_all[0], rtol=1e-3)


def test_a_uniform_zoning_is_the_plain_stone(mi):
    mat = Labradorite(spread_deg=8.0, body_albedo=0.2)
    row = [mat.d_a, mat.d_b, mat.sigma_a, mat.sigma_b, float(mat.pairs)]
    zoned = load(mi, normal=NORMAL, spread_deg=8.0, body_albedo=0.2,
                 zoning_grid=mi.TensorXf(np.zeros((2, 2, 2, 1), dtype=np.float32)),
                 zoning_path=mi.TensorXf(np.array([row, row], dtype=np.float32)),
                 zoning_lo=mi.ScalarPoint3f(-1, -1, -1), zoning_hi=mi.ScalarPoint3f(1, 1, 1))
    assert int(zoned.flags()) & int(mi.BSDFFlags.SpatiallyVarying)
    assert str(zoned).endswith(", eta=1.56, zoned]")
    assert str(load(mi)).endswith(", eta=1.56]")
    wi, wo = unit(CASES[1][0]), unit(CASES[1][1])
    sv, sp = schiller_ref(mat, NORMAL, wi, wo)
    bv, bp = body_ref(mat, wi, wo)
    f = fresnel(wi[2], mat.n_surface)
    sw = zoned.zoning.weight
    tot = f + (1 - f) * sw + (1 - f) * 0.2
    v, p = zoned.eval_pdf(ctx_for(mi), si_of(mi, wi, p=[0, 0, 0]), V(mi, wo))
    np.testing.assert_allclose(arr(v), sv + bv, rtol=2e-3)
    np.testing.assert_allclose(arr(p), ((1 - f) * sw * sp + (1 - f) * 0.2 * bp) / tot, rtol=RTOL)


def test_a_variant_change_registers_the_plugin(variant, monkeypatch):
    import mitsuba

    variant("rgb")
    monkeypatch.setattr(B, "_CLASSES", {})
    variant("mono")
    assert list(B._CLASSES) == [mitsuba.variant()]
    assert type(load(mitsuba)) is B._CLASSES[mitsuba.variant()]


def test_a_type_mask_without_the_delta_leaves_the_surface_out(mi):
    mat = Labradorite(spread_deg=8.0, body_albedo=0.2)
    wi, wo = unit(CASES[1][0]), unit(CASES[1][1])
    bsdf = load(mi, normal=NORMAL, spread_deg=8.0, body_albedo=0.2)
    ctx = mi.BSDFContext()
    ctx.type_mask = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection
    sv, sp = schiller_ref(mat, NORMAL, wi, wo)
    bv, bp = body_ref(mat, wi, wo)
    (_, p_sch, p_body), _ = weights_ref(mat, wi[2], surface=False)
    v, p = bsdf.eval_pdf(ctx, si_of(mi, wi), V(mi, wo))
    np.testing.assert_allclose(arr(v), sv + bv, rtol=RTOL)
    np.testing.assert_allclose(arr(p), p_sch * sp + p_body * bp, rtol=RTOL)
    ctx.type_mask = mi.BSDFFlags.DeltaReflection
    bs, w = bsdf.sample(ctx, si_of(mi, wi), 0.5, mi.Point2f(0.3, 0.3))
    np.testing.assert_allclose(arr(w), fresnel(wi[2], mat.n_surface), rtol=RTOL)


def test_the_flash_mask_is_clipped_to_one(mi):
    mat = Labradorite(body_albedo=0.3, spread_deg=8.0)
    grid = np.ones((2, 2, 2, 2), dtype=np.float32)
    grid[..., 1] = 1.5
    bsdf = load(mi, body_albedo=0.3, spread_deg=8.0, normal=NORMAL, body_grid=mi.TensorXf(grid),
                body_lo=mi.ScalarPoint3f(-1, -1, -1), body_hi=mi.ScalarPoint3f(1, 1, 1))
    wi, wo = unit(CASES[1][0]), unit(CASES[1][1])
    sv, _ = schiller_ref(mat, NORMAL, wi, wo)
    got = arr(bsdf.eval(ctx_for(mi, 1), si_of(mi, wi, p=[0, 0, 0]), V(mi, wo)))
    np.testing.assert_allclose(got, sv, rtol=RTOL)
