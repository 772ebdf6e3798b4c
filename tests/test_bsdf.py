"""The labradorite BSDF: sampling vs pdf (chi²), reciprocity, energy, variants, bad input."""

from __future__ import annotations

import math

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from mitsuba_helpers import launched, surface_interaction


_si = surface_interaction


def _opaque(x: float, y: float, z: float):
    """A direction as a value, not a literal: the next angle runs the same compiled kernel."""
    return mi.Vector3f(*(dr.opaque(mi.Float, float(c)) for c in (x, y, z)))


def _bsdf(**params):
    return mi.load_dict({"type": "labradorite", **params})


def adapter(params: dict, wi, ctx):
    """mitsuba.chi2.BSDFAdapter, plus the shading frame the lamella normal is expressed in."""

    def sample_func(sample):
        bsdf = _bsdf(**params)
        bs, weight = bsdf.sample(ctx, _si(dr.width(sample), wi), sample[0], mi.Point2f(sample[1], sample[2]))
        w = dr.full(mi.Float, 1.0, dr.width(weight))
        w[dr.all(mi.unpolarized_spectrum(weight) == 0)] = 0
        return bs.wo, w

    def pdf_func(wo):
        return _bsdf(**params).pdf(ctx, _si(dr.width(wo), wi), wo)

    return sample_func, pdf_func


CHI2_CASES = [
    # component, lamella normal, spread (deg), incident direction (local)
    ("glossy", [0.0, 0.0, 1.0], 3.0, [0.0, 0.0, 1.0]),
    ("glossy", [0.0, 0.0, 1.0], 3.0, [0.3, 0.0, 0.954]),
    ("glossy", [0.0, 0.0, 1.0], 8.0, [0.7, 0.1, 0.7]),
    ("glossy", [0.25, 0.1, 1.0], 5.0, [-0.5, 0.2, 0.84]),
    ("glossy", [-0.4, 0.3, 1.0], 12.0, [0.2, -0.3, 0.93]),
    ("glossy", [0.0, 0.0, 1.0], 1.0, [0.5, 0.0, 0.866]),
    ("diffuse", [0.0, 0.0, 1.0], 3.0, [0.6, 0.0, 0.8]),
    ("diffuse", [0.3, 0.0, 1.0], 3.0, [0.05, 0.0, 0.999]),
    ("both", [0.2, 0.0, 1.0], 8.0, [0.4, 0.1, 0.91]),
    ("both", [0.0, 0.3, 1.0], 4.0, [0.0, -0.6, 0.8]),
]


@pytest.mark.parametrize("component, normal, spread, wi", CHI2_CASES)
def test_chi2_sampling_matches_pdf(component, normal, spread, wi, variant):
    from mitsuba.chi2 import ChiSquareTest, SphericalDomain

    variant("rgb")
    ctx = mi.BSDFContext()
    if component == "glossy":
        ctx.component = 1
    elif component == "diffuse":
        ctx.component = 2
    else:
        ctx.type_mask = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection
    sample_func, pdf_func = adapter({"normal": normal, "spread_deg": spread}, dr.normalize(mi.ScalarVector3f(wi)), ctx)
    chi2 = ChiSquareTest(
        domain=SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func, sample_dim=3,
        res=201, ires=32, sample_count=1_000_000,
    )
    assert chi2.run(), chi2.messages
    assert float(np.sum(chi2.pdf)) > 0.05  # the lobe has mass: the test was not vacuous


@pytest.mark.parametrize("mode, polarized", [("spectral", False), ("mono", False), ("spectral", True)])
def test_chi2_in_other_variants(mode, polarized, variant):
    from mitsuba.chi2 import ChiSquareTest, SphericalDomain

    variant(mode, polarized)
    ctx = mi.BSDFContext()
    ctx.type_mask = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection
    sf, pf = adapter({"normal": [0.2, 0.0, 1.0], "spread_deg": 6.0}, dr.normalize(mi.ScalarVector3f(0.3, 0.1, 0.95)), ctx)
    chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sf, pdf_func=pf, sample_dim=3, res=151, ires=32)
    assert chi2.run(), chi2.messages


def _directions(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    u = rng.random((n, 2))
    z = 0.02 + 0.98 * u[:, 0]
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(2 * np.pi * u[:, 1]), r * np.sin(2 * np.pi * u[:, 1]), z], axis=1)


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
@pytest.mark.parametrize("normal, spread", [([0, 0, 1], 3.0), ([0.3, -0.2, 1.0], 6.0), ([1.0, 0.0, 0.2], 15.0)])
def test_reciprocity(mode, normal, spread, variant):
    variant(mode)
    bsdf = _bsdf(normal=normal, spread_deg=spread)
    ctx = mi.BSDFContext()
    a, b = _directions(4000, 1), _directions(4000, 2)
    # concentrate pairs near the schiller lobe too: b = a mirrored about the lamella normal
    m = np.asarray(normal, float) / np.linalg.norm(normal)
    mirrored = 2 * (a @ m)[:, None] * m - a
    b = np.where((mirrored[:, 2] > 0.05)[:, None], mirrored * 0.999 + 0.001 * b, b)
    b /= np.linalg.norm(b, axis=1)[:, None]
    va, vb = mi.Vector3f(a.T), mi.Vector3f(b.T)
    f_ab = np.array(mi.unpolarized_spectrum(bsdf.eval(ctx, _si(len(a), va), vb))) / b[:, 2][None, :]
    f_ba = np.array(mi.unpolarized_spectrum(bsdf.eval(ctx, _si(len(a), vb), va))) / a[:, 2][None, :]
    assert np.all(np.isfinite(f_ab))
    assert np.allclose(f_ab, f_ba, rtol=2e-3, atol=1e-6)


@pytest.mark.parametrize(
    "params",
    [
        {"normal": [0, 0, 1], "spread_deg": 3.0},
        {"normal": [0.5, 0.0, 1.0], "spread_deg": 2.0},
        {"normal": [1.0, 0.0, 0.0], "spread_deg": 20.0},
        # a perfect, thick stack: R = 1 at its Bragg peak
        {"normal": [0, 0, 1], "spread_deg": 1.0, "sigma_a": 0.0, "sigma_b": 0.0, "pairs": 100000, "body_albedo": 1.0},
    ],
)
@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_albedo_at_most_one_for_every_incident_direction(params, mode, variant):
    variant(mode)
    bsdf = _bsdf(**params)
    ctx = mi.BSDFContext()
    n = 1 << 17
    rng = np.random.default_rng(3)
    for theta in np.radians([0.0, 20.0, 45.0, 70.0, 85.0, 89.0]):
        for phi in (0.0, 2.0):
            wi = mi.Vector3f(math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))
            si = _si(n, wi)
            s = rng.random((3, n)).astype(np.float32)
            _, w = bsdf.sample(ctx, si, mi.Float(s[0]), mi.Point2f(s[1], s[2]))
            w = np.array(mi.unpolarized_spectrum(w))
            assert np.all(np.isfinite(w)) and np.all(w >= 0)
            albedo = w.mean(axis=1)
            err = 4 * w.std(axis=1) / math.sqrt(n)
            assert np.all(albedo <= 1.0 + err + 1e-3), (theta, albedo)


@pytest.mark.parametrize("theta_deg", [0.0, 20.0, 40.0, 60.0])
def test_polarized_schiller_is_the_stacks_s_and_p(theta_deg, variant):
    """Lamellae parallel to the surface, mirror geometry in the x-z plane: the schiller's Mueller
    matrix is a diattenuator of the stack's R_s and R_p at the internal angle (labcut.physics),
    handedness flipped like a mirror's below the phases' Brewster angle; its M00 is the
    unpolarised schiller of the spectral variant."""
    from labcut import Labradorite

    lab = Labradorite.preset("blue", spread_deg=4.0)
    params = {k: v for k, v in lab.to_dict().items() if k != "name"}
    t = math.radians(theta_deg)
    cos_l = math.sqrt(1.0 - (math.sin(t) / lab.n_surface) ** 2)
    wl = np.array([450.0, 500.0, 550.0, 600.0])
    r_s, r_p = lab.reflectance(wl, cos_l, "s"), lab.reflectance(wl, cos_l, "p")

    variant("spectral", polarized=True)
    wi, wo = _opaque(math.sin(t), 0.0, math.cos(t)), _opaque(-math.sin(t), 0.0, math.cos(t))
    value = _bsdf(normal=[0, 0, 1], surface=False, body=False, **params).eval(mi.BSDFContext(), _si(1, wi), wo)
    m = np.array([[np.array(value[i, j]).ravel() for j in range(4)] for i in range(4)])  # (4, 4, wavelengths)
    assert np.allclose(np.abs(m[0, 1]) / m[0, 0], np.abs(r_s - r_p) / (r_s + r_p), rtol=2e-3, atol=3e-4)  # float32 r_s, r_p
    assert np.allclose(np.hypot(m[2, 2], m[2, 3]) / m[0, 0], 2 * np.sqrt(r_s * r_p) / (r_s + r_p), rtol=2e-3, atol=1e-4)
    if theta_deg == 0.0:
        assert np.allclose(m[2, 2], -m[0, 0], rtol=1e-4)  # a mirror at normal incidence
    variant("spectral")
    wi, wo = _opaque(math.sin(t), 0.0, math.cos(t)), _opaque(-math.sin(t), 0.0, math.cos(t))
    unpolarised = np.array(_bsdf(normal=[0, 0, 1], surface=False, body=False, **params).eval(mi.BSDFContext(), _si(1, wi), wo))
    assert np.allclose(m[0, 0], unpolarised.ravel(), rtol=1e-4)


@pytest.mark.parametrize("polarized", [False, True])
def test_another_material_runs_the_spectral_kernels_already_made(polarized, variant):
    """The spectral and polarised schiller read the stack as opaque values: another material
    launches the very kernels the first one did (its fields as literals would make new kernels,
    compiled for every material a render meets)."""
    from labcut import Labradorite

    variant("spectral", polarized=polarized)
    wi, wo = _opaque(0.3, 0.0, 0.954), _opaque(-0.3, 0.0, 0.954)

    def schiller(peak):
        params = {k: v for k, v in Labradorite.from_peak_wavelength(peak, spread_deg=4.0).to_dict().items() if k != "name"}
        bsdf = _bsdf(normal=[0, 0, 1], surface=False, body=False, **params)
        return lambda: np.array(mi.unpolarized_spectrum(bsdf.eval(mi.BSDFContext(), _si(16, wi), wo)))

    first, second = schiller(470.0), schiller(563.7)
    assert not np.allclose(first(), second())  # two materials indeed
    assert {k["hash"] for k in launched(second)[1]} <= {k["hash"] for k in launched(first)[1]}


def test_polarized_surface_is_a_mueller_matrix_and_body_is_depolarised(variant):
    variant("spectral", polarized=True)
    ctx = mi.BSDFContext()
    wi = dr.normalize(mi.Vector3f(0.8, 0.0, 0.5))
    wo = dr.normalize(mi.Vector3f(-0.3, 0.4, 0.6))
    value = _bsdf(normal=[0, 0, 1], surface=False, schiller=False).eval(ctx, _si(1, wi), wo)
    m = np.array([[np.array(value[i, j])[0, 0] for j in range(4)] for i in range(4)])
    assert m[0, 0] > 0 and np.allclose(m.ravel()[1:], 0.0)  # depolariser: only M00
    bs, w = _bsdf(normal=[0, 0, 1]).sample(ctx, _si(1, wi), mi.Float(0.0), mi.Point2f(0.5, 0.5))  # picks the surface
    assert int(bs.sampled_component[0]) == 0
    assert abs(float(np.array(w[0, 1])[0, 0])) > 1e-4  # Fresnel reflection polarises


@pytest.mark.parametrize("normal", [[0, 0, 0], [float("nan"), 0, 1], [0, 0, float("inf")]])
def test_bad_normal_is_a_clear_error(normal, variant):
    variant("rgb")
    with pytest.raises(Exception, match="lamella normal"):
        _bsdf(normal=normal)


def test_bad_material_is_a_clear_error(variant):
    variant("rgb")
    with pytest.raises(Exception, match="d_a"):
        _bsdf(d_a=-10.0)


def test_traverse_exposes_a_differentiable_normal(variant):
    variant("rgb")
    params = mi.traverse(_bsdf(normal=[0, 0.2, 1]))
    assert "normal" in params.keys()
    assert not params.flags("normal") & int(mi.ParamFlags.NonDifferentiable)


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
@pytest.mark.parametrize(
    "params",
    [
        {"normal": [1.0, 0.0, 0.0], "spread_deg": 3.0},  # lamellae perpendicular to the surface
        {"normal": [0.0, 0.0, 1.0], "spread_deg": 0.1},  # nearly a mirror
        {"normal": [0.3, 0.2, 1.0], "spread_deg": 45.0},  # the widest spread allowed
        {"normal": [0.0, 0.0, 1.0], "spread_deg": 2.0, "sigma_a": 0.0, "sigma_b": 0.0, "pairs": 100000},
    ],
)
def test_hard_cases_stay_finite_with_finite_gradients(mode, params, variant):
    variant(mode)
    bsdf = _bsdf(**params)
    ctx = mi.BSDFContext()
    rng = np.random.default_rng(5)
    n = 20000
    # incident and outgoing directions crowded at the pole and at grazing incidence
    z = np.concatenate([np.full(n // 4, 1.0), np.full(n // 4, 1e-7), np.full(n // 4, 1e-3), rng.uniform(0, 1, n // 4)])
    phi = rng.uniform(0, 2 * np.pi, n)
    r = np.sqrt(1 - z * z)
    wi = mi.Vector3f(r * np.cos(phi), r * np.sin(phi), z)
    wo_np = _directions(n, 9)
    wo_np[: n // 8, 2] = 1e-7
    wo_np /= np.linalg.norm(wo_np, axis=1)[:, None]
    wo = mi.Vector3f(wo_np.T)
    si = _si(n, wi)
    value, pdf = bsdf.eval_pdf(ctx, si, wo)
    assert np.all(np.isfinite(np.array(mi.unpolarized_spectrum(value)))) and np.all(np.isfinite(np.array(pdf)))
    s = rng.random((3, n)).astype(np.float32)
    bs, w = bsdf.sample(ctx, si, mi.Float(s[0]), mi.Point2f(s[1], s[2]))
    assert np.all(np.isfinite(np.array(mi.unpolarized_spectrum(w)))) and np.all(np.isfinite(np.array(bs.pdf)))
    params_ = mi.traverse(bsdf)
    dr.enable_grad(params_["normal"])
    params_.update()
    value = bsdf.eval(ctx, _si(n, wi), wo)
    dr.backward(dr.sum(mi.unpolarized_spectrum(value), axis=None))
    assert np.all(np.isfinite(np.array(dr.grad(params_["normal"]))))


@pytest.mark.parametrize("spread", [1.0, 2.0])
def test_schiller_albedo_of_parallel_lamellae_is_exact(spread, variant):
    """Lamellae parallel to the surface, light at normal incidence, a narrow lobe: all schiller
    light leaves near the normal, so its albedo tends to T(0)² R(1) (energy balance through both
    surfaces and the stack; wider lobes lose some to oblique exits, by design).
    Integrated by an independent quadrature (uniform grid in solid angle), not by the BSDF's sampling."""
    from labcut import Labradorite
    from labcut.colour import luminance_table

    variant("mono")
    lab = Labradorite.preset("green", spread_deg=spread)
    params = {k: v for k, v in lab.to_dict().items() if k != "name"}
    bsdf = _bsdf(normal=[0.0, 0.0, 1.0], surface=False, body=False, **params)
    cap = math.radians(10.0 * spread)  # the lobe, refracted out, lies well inside this cap
    n_mu, n_phi = 1500, 256
    mu = 1.0 - (np.arange(n_mu) + 0.5) / n_mu * (1.0 - math.cos(cap))
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2.0 * math.pi
    mu_g, phi_g = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - mu_g**2)
    wo = mi.Vector3f((s * np.cos(phi_g)).ravel(), (s * np.sin(phi_g)).ravel(), mu_g.ravel())
    value = np.array(bsdf.eval(mi.BSDFContext(), _si(n_mu * n_phi, mi.Vector3f(0.0, 0.0, 1.0)), wo)).ravel()
    albedo = float(value.sum()) * (2.0 * math.pi * (1.0 - math.cos(cap))) / (n_mu * n_phi)
    t0 = 1.0 - ((lab.n_surface - 1.0) / (lab.n_surface + 1.0)) ** 2
    expected = t0 * t0 * float(luminance_table(lab)[1][-1])
    assert albedo == pytest.approx(expected, rel=0.02)


@pytest.mark.parametrize("mode", ["rgb", "mono", "spectral"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sample_weight_is_eval_over_pdf_and_eval_pdf_is_consistent(mode, seed, variant):
    """The standard consistency check over random incident directions and lamella tilts up to
    60°: for every non-delta sample, weight == eval / pdf and pdf == pdf(wo); eval_pdf returns
    eval and pdf. (Changing max(a_z, b_z) to min in eval alone breaks this.)"""
    variant(mode)
    rng = np.random.default_rng(seed)
    tilt = math.radians(rng.uniform(0.0, 60.0))
    phi = rng.uniform(0, 2 * math.pi)
    normal = [math.sin(tilt) * math.cos(phi), math.sin(tilt) * math.sin(phi), math.cos(tilt)]
    bsdf = _bsdf(normal=normal, spread_deg=float(rng.uniform(2.0, 12.0)))
    n = 4096
    z = rng.uniform(0.05, 1.0, n)
    az = rng.uniform(0.0, 2 * math.pi, n)
    r = np.sqrt(1 - z * z)
    wi = mi.Vector3f(r * np.cos(az), r * np.sin(az), z)
    si = _si(n, wi)
    ctx = mi.BSDFContext()
    s1 = mi.Float(rng.uniform(0, 1, n))
    s2 = mi.Point2f(rng.uniform(0, 1, n), rng.uniform(0, 1, n))
    bs, weight = bsdf.sample(ctx, si, s1, s2)
    value = bsdf.eval(ctx, si, bs.wo)
    pdf = bsdf.pdf(ctx, si, bs.wo)
    ev, pv = bsdf.eval_pdf(ctx, si, bs.wo)
    w = np.array(mi.unpolarized_spectrum(weight)).reshape(-1, n)
    v = np.array(mi.unpolarized_spectrum(value)).reshape(-1, n)
    p = np.array(pdf).ravel()
    delta = np.array(bs.sampled_component).ravel() == 0
    ok = (~delta) & (np.array(bs.pdf).ravel() > 1e-6) & np.any(w > 0, axis=0)
    assert ok.sum() > n // 4
    assert np.allclose(np.array(bs.pdf).ravel()[ok], p[ok], rtol=1e-3, atol=1e-6)
    assert np.allclose(w[:, ok], v[:, ok] / p[ok], rtol=2e-3, atol=1e-5)
    assert np.allclose(np.array(mi.unpolarized_spectrum(ev)).reshape(-1, n), v, rtol=1e-5, atol=1e-7)
    assert np.allclose(np.array(pv).ravel(), p, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("tilt_deg, incidence_deg", [(0.0, 0.0), (25.0, 30.0), (20.0, 10.0), (15.0, 45.0)])
def test_schiller_albedo_of_a_narrow_lobe_matches_the_mirror_energy_balance(tilt_deg, incidence_deg, variant):
    """Independent of the lobe code: for a narrow lobe (1°) the schiller albedo is that of one
    tilted mirror, T_i T_o R(|a·m|) b_z / max(a_z, b_z) (docs/rendering.md), computed here from
    Snell's law, Fresnel and the mirror reflection alone, and integrated by quadrature over a
    cap around the exit direction. It pins the max(a_z, b_z) of f_s (min would change these
    numbers by a_z/b_z) and the whole normalisation."""
    from labcut import Labradorite
    from labcut.colour import luminance_table

    variant("mono")
    lab = Labradorite.preset("green", spread_deg=1.0)
    eta = lab.n_surface
    t, i = math.radians(tilt_deg), math.radians(incidence_deg)
    m = np.array([math.sin(t), 0.0, math.cos(t)])
    wi = np.array([math.sin(i), 0.0, math.cos(i)])
    a = np.array([wi[0] / eta, 0.0, math.sqrt(1.0 - (wi[0] / eta) ** 2)])  # refracted in (pointing up)
    b = 2.0 * (a @ m) * m - a
    assert b[2] > 0 and abs(b[0] * eta) < 1
    wo = np.array([b[0] * eta, 0.0, math.sqrt(1.0 - (b[0] * eta) ** 2)])  # refracted out

    def fresnel_t(c: float) -> float:
        ct = math.sqrt(1.0 - (1.0 - c * c) / eta**2)
        rs = (c - eta * ct) / (c + eta * ct)
        rp = (eta * c - ct) / (eta * c + ct)
        return 1.0 - 0.5 * (rs * rs + rp * rp)

    table_c, table_r = luminance_table(lab)
    r = float(np.interp(abs(a @ m), table_c, table_r))
    expected = fresnel_t(wi[2]) * fresnel_t(wo[2]) * r * b[2] / max(a[2], b[2])

    cap = math.radians(25.0)  # the exit lobe (σ ≈ 2° inside, up to ~5° outside) lies well inside
    n_mu, n_phi = 1200, 256
    mu = 1.0 - (np.arange(n_mu) + 0.5) / n_mu * (1.0 - math.cos(cap))
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2.0 * math.pi
    mu_g, phi_g = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - mu_g**2)
    e1 = np.cross(wo, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(wo, e1)
    d = (s * np.cos(phi_g))[..., None] * e1 + (s * np.sin(phi_g))[..., None] * e2 + mu_g[..., None] * wo
    d = d.reshape(-1, 3)
    bsdf = _bsdf(normal=m.tolist(), surface=False, body=False, **{k: v for k, v in lab.to_dict().items() if k != "name"})
    value = np.array(bsdf.eval(mi.BSDFContext(), _si(len(d), mi.Vector3f(*wi.tolist())),
                               mi.Vector3f(d[:, 0], d[:, 1], d[:, 2]))).ravel()
    albedo = float(value.sum()) * (2.0 * math.pi * (1.0 - math.cos(cap))) / len(d)
    assert albedo == pytest.approx(expected, rel=0.02)


def test_plugin_parameter_table_is_complete_and_documented():
    """Every property the plugin reads is in PLUGIN_PARAMETERS and nothing else is; docs/plugin.md
    is generated from that table and up to date."""
    import re
    import subprocess
    import sys
    from pathlib import Path

    from labcut.rendering import bsdf as plugin

    root = Path(__file__).resolve().parents[1]
    source = "".join((root / "labcut" / "rendering" / f).read_text() for f in ("bsdf.py", "zoning_kernel.py"))
    read = set(re.findall(r'props\[\s*"(\w+)"\s*\]', source)) | set(re.findall(r'props\.get\(\s*"(\w+)"', source))
    read |= set(re.findall(r'"(\w+)" (?:not )?in props', source)) | set(plugin._MATERIAL_KEYS)
    table = {name for name, *_ in plugin.PLUGIN_PARAMETERS}
    assert read == table, (read ^ table)
    assert "Plugin parameters" in plugin.__doc__ and "`zoning_hi`" in plugin.__doc__
    proc = subprocess.run([sys.executable, str(root / "tools" / "plugin_docs.py"), "--check"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
