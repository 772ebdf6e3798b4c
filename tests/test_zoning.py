"""Colour zoning: noise, LUT, kernel lookup, renders with zones, chi², bad input."""

from __future__ import annotations

import json
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

import labcut
from labcut import Labradorite, ParameterError
from mitsuba_helpers import surface_interaction
from labcut.colour import dominant_wavelength, tables
from labcut.rendering.noise import equalise, fbm
from labcut.rendering.zoning import ZONED_KEYS, Zoning


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


ROOT = Path(__file__).resolve().parents[1]

MESHES = Path(__file__).resolve().parents[1] / "meshes"
BOX = [[-10.0, -10.0, 0.0], [10.0, 10.0, 3.0]]
BLUE, GOLD = Labradorite.preset("blue"), Labradorite.preset("gold")
FIG6 = ((0.0, 0.5, 0), (0.9, 1.0, 1))  # paper Fig. 6: A below 0.5, A->B blend, B above 0.9


def _params(m: Labradorite) -> np.ndarray:
    return np.array([float(getattr(m, k)) for k in ZONED_KEYS])


@pytest.fixture(scope="module")
def slab():
    return labcut.load_mesh(MESHES / "slab-20x20x3.ply")


# ---------------------------------------------------------------------- noise
def test_noise_is_deterministic_equalised_and_in_unit_interval():
    z = Zoning.preset("smooth")
    a, b = z.bake(BOX), Zoning.preset("smooth").bake(BOX)
    assert np.array_equal(a.grid, b.grid) and a.grid.dtype == np.float32
    assert a.grid.min() == 0.0 and a.grid.max() == 1.0
    hist = np.histogram(a.grid, bins=10, range=(0, 1))[0] / a.grid.size  # equalised: uniform
    assert np.allclose(hist, 0.1, atol=0.01)
    other = z.replace(seed=1).bake(BOX)
    assert np.mean(np.abs(other.grid - a.grid)) > 0.1
    pts = np.random.default_rng(0).uniform(-5, 5, (1000, 3))
    assert np.array_equal(fbm(pts, 4.0, 3, 7), fbm(pts, 4.0, 3, 7))
    # smooth in space: neighbouring grid values differ by far less than random ones
    assert np.mean(np.abs(np.diff(a.grid, axis=2))) < 0.1
    assert np.array_equal(equalise(np.array([3.0, -1.0, 2.0])), [1.0, 0.0, 0.5])


# ---------------------------------------------------------------------- LUT
def test_lut_unblended_ranges_are_exact_and_blends_are_linear():
    z = Zoning([BLUE, GOLD], ranges=FIG6)
    x = np.array([0.0, 0.2, 0.5, 0.9, 0.95, 1.0])
    p = z.parameters(x)
    for row in p[:3]:
        assert np.array_equal(row, _params(BLUE))
    for row in p[3:]:
        assert np.array_equal(row, _params(GOLD))
    xs = np.linspace(0.5, 0.9, 9)
    t = (xs - 0.5) / 0.4
    expected = (1 - t)[:, None] * _params(BLUE) + t[:, None] * _params(GOLD)
    assert np.allclose(z.parameters(xs), expected, rtol=1e-12)
    assert np.allclose(z.parameters(0.7), 0.5 * (_params(BLUE) + _params(GOLD)))


def test_sharp_mode_has_no_intermediate_values():
    z = Zoning([BLUE, GOLD, BLUE.replace(sigma_a=40.0)], ranges=((0, 0.3, 0), (0.5, 0.6, 1), (0.8, 1, 2)), mode="sharp")
    sets = {tuple(_params(m)) for m in z.materials}
    x = np.linspace(0.0, 1.0, 2001)
    rows = z.parameters(x)
    assert all(tuple(r) in sets for r in rows)
    i, j, t = z.blend(x)
    assert set(np.unique(t)) <= {0.0, 1.0}
    i = np.where(t > 0.5, j, i)  # the set in effect
    assert np.all(i[x < 0.4] == 0) and np.all(i[(x > 0.4) & (x < 0.7)] == 1) and np.all(i[x > 0.7] == 2)
    smooth = z.replace(mode="smooth").parameters(x)
    assert sum(tuple(r) not in sets for r in smooth) > 500  # the same LUT blended: intermediate values


def test_presets_dict_round_trip_and_json(tmp_path):
    base = Labradorite(spread_deg=5.0, sigma_a=12.0)
    for name in ("smooth", "sharp"):
        z = Zoning.preset(name, base)
        assert len(z.materials) == 3 and z.mode == name
        assert all(m.spread_deg == 5.0 and m.sigma_a == 12.0 for m in z.materials)
        assert Zoning.from_dict(json.loads(json.dumps(z.to_dict()))) == z
    peaks = [m.peak_wavelength() for m in Zoning.preset("smooth").materials]
    assert np.allclose(peaks, [470, 530, 580], atol=0.05)
    f = tmp_path / "z.json"
    f.write_text(json.dumps({"materials": ["blue", 600, {"an": 50}, {"sigma_a": 40}], "seed": 3, "mode": "sharp"}))
    z = Zoning.load(f, base)
    assert len(z.materials) == 4 and z.seed == 3 and z.materials[3].sigma_a == 40 and z.materials[3].d_a == base.d_a
    assert Zoning.from_dict({"preset": "sharp", "seed": 9}).seed == 9


# ---------------------------------------------------------------------- kernel
_si = surface_interaction


def _zoned(zoning: Zoning, **params):
    return mi.load_dict({"type": "labradorite", **params, **zoning.bake(BOX).props()})


@pytest.mark.parametrize("mode", ["spectral", "rgb"])
def test_kernel_looks_up_the_set_of_the_hit_point(mode, variant):
    variant(mode)
    z = Zoning([BLUE, GOLD], ranges=FIG6, scale_mm=4.0)
    baked = z.bake(BOX)
    rng = np.random.default_rng(1)
    pts = rng.uniform([-9, -9, 0.2], [9, 9, 2.8], (4000, 3))
    x = baked.values_at(pts)
    zoned = _zoned(z, spread_deg=8.0)
    ctx = mi.BSDFContext()
    wi, wo = dr.normalize(mi.Vector3f(0.3, 0.0, 0.95)), dr.normalize(mi.Vector3f(-0.25, 0.05, 0.97))
    # spectral: the same expression in float32. RGB: the zoned table (256 cos entries, looked up at
    # texel centres) and the plugin's own (1024 entries read half a texel off) differ by up to ~1 %
    tol = 1e-4 if mode == "spectral" else 1.5e-2
    for lo, hi, mat in ((0.0, 0.45, BLUE), (0.95, 1.0, GOLD)):  # unblended: exactly the set
        sel = pts[(x > lo) & (x < hi)][:50]
        assert len(sel) >= 10
        f = np.array(mi.unpolarized_spectrum(zoned.eval(ctx, _si(len(sel), wi, mi.Point3f(sel.T)), wo)))
        ref = mi.load_dict({"type": "labradorite", **{k: getattr(mat, k) for k in ZONED_KEYS}, "spread_deg": 8.0})
        g = np.array(mi.unpolarized_spectrum(ref.eval(ctx, _si(1, wi, mi.Point3f(0, 0, 0)), wo)))
        assert np.allclose(f, g, rtol=tol, atol=1e-7), (lo, hi)
    # blended: the parameters interpolated at that point's x
    sel = np.flatnonzero((x > 0.55) & (x < 0.85))[:6]
    assert len(sel) == 6
    f = np.array(mi.unpolarized_spectrum(zoned.eval(ctx, _si(len(sel), wi, mi.Point3f(pts[sel].T)), wo)))
    for col, k in enumerate(sel):
        params = dict(zip(ZONED_KEYS, (float(v) for v in z.parameters(x[k]))))
        ref = mi.load_dict({"type": "labradorite", **params, "pairs": 6000, "spread_deg": 8.0})
        g = np.array(mi.unpolarized_spectrum(ref.eval(ctx, _si(1, wi, mi.Point3f(0, 0, 0)), wo)))[:, 0]
        assert np.allclose(f[:, col], g, rtol=2e-3 if mode == "spectral" else 2e-2, atol=1e-6), (x[k], f[:, col], g)
    # flagged spatially varying only with zoning
    assert zoned.flags() & int(mi.BSDFFlags.SpatiallyVarying)
    assert not mi.load_dict({"type": "labradorite"}).flags() & int(mi.BSDFFlags.SpatiallyVarying)


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_chi2_with_zoning_at_a_fixed_point(mode, variant):
    from mitsuba.chi2 import ChiSquareTest, SphericalDomain

    variant(mode)
    z = Zoning.preset("smooth")
    props = {"normal": [0.2, 0.0, 1.0], "spread_deg": 6.0, **z.bake(BOX).props()}
    wi = dr.normalize(mi.ScalarVector3f(0.3, 0.1, 0.95))
    ctx = mi.BSDFContext()
    ctx.type_mask = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection
    p = mi.Point3f(2.5, -1.0, 1.5)
    bsdf = mi.load_dict({"type": "labradorite", **props})

    def sample_func(sample):
        bs, weight = bsdf.sample(ctx, _si(dr.width(sample), wi, p), sample[0], mi.Point2f(sample[1], sample[2]))
        w = dr.full(mi.Float, 1.0, dr.width(weight))
        w[dr.all(mi.unpolarized_spectrum(weight) == 0)] = 0
        return bs.wo, w

    def pdf_func(wo):
        return bsdf.pdf(ctx, _si(dr.width(wo), wi, p), wo)

    chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func, sample_dim=3, res=151, ires=32)
    assert chi2.run(), chi2.messages
    assert float(np.sum(chi2.pdf)) > 0.05


# ---------------------------------------------------------------------- renders
def _flash(img: np.ndarray, frac: float = 0.3) -> np.ndarray:
    lum = img @ np.array([0.2126, 0.7152, 0.0722])
    return lum >= frac * np.percentile(lum, 99)


def _render(slab, mode="rgb", zoning=None, lab=None, **kw):
    kw = {"resolution": 48, "spp": 32, "view": (12.0, 270.0), "lobes": ("schiller",), **kw}
    return labcut.render(slab, lab or Labradorite(), (0, 0, 1), mode=mode, zoning=zoning, **kw).image


def test_zoned_render_shows_several_hues_and_rgb_agrees_with_spectral(slab):
    rgb = _render(slab, "rgb", "smooth")
    spec = _render(slab, "spectral", "smooth")
    mask = _flash(rgb) & _flash(spec)
    assert mask.mean() > 0.3
    to_xyz = np.linalg.inv(tables().xyz_to_srgb)
    pix = rgb[mask][::3]
    dom = np.array([dominant_wavelength(to_xyz @ c)[0] for c in pix])
    dom = dom[np.isfinite(dom) & (dom > 0)]
    assert np.percentile(dom, 90) - np.percentile(dom, 10) > 30.0, np.percentile(dom, [10, 90])

    def chroma(img):  # 4 x 4 blocks to average the sampling noise
        b = img.reshape(12, 4, 12, 4, 3).mean(axis=(1, 3))
        c = np.clip(b, 0, None)
        return c / np.maximum(c.sum(axis=-1, keepdims=True), 1e-9)

    block = mask.reshape(12, 4, 12, 4).all(axis=(1, 3))
    diff = np.abs(chroma(rgb) - chroma(spec)).max(axis=-1)[block]
    assert block.sum() > 20 and np.median(diff) < 0.03 and np.percentile(diff, 90) < 0.06


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_single_set_zoning_equals_no_zoning(slab, mode):
    lab = Labradorite.preset("green")
    plain = _render(slab, mode, None, lab)
    zoned = _render(slab, mode, Zoning([lab]), lab)
    assert abs(zoned.mean() / plain.mean() - 1.0) < 0.01
    assert np.abs(zoned - plain).mean() < 0.01 * plain.mean() + 1e-6


# ---------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"materials": []}, "1 to 64"),
        ({"materials": BLUE}, "list"),
        ({"materials": [BLUE, "gold"]}, "set 1"),
        ({"materials": [BLUE, GOLD.replace(spread_deg=9.0)]}, "spread_deg"),
        ({"materials": [BLUE, GOLD], "ranges": ((0, 0.6, 0), (0.5, 1, 1))}, "overlap"),
        ({"materials": [BLUE, GOLD], "ranges": ((0, 0.6, 0), (0.7, 1, 2))}, "set index"),
        ({"materials": [BLUE, GOLD], "ranges": ((0, 0.6, 0),)}, "not used"),
        ({"materials": [BLUE, GOLD], "ranges": ((0.5, 0.2, 0), (0.7, 1, 1))}, "ends before"),
        ({"materials": [BLUE, GOLD], "ranges": ((0, 1.5, 0), (0.7, 1, 1))}, "range end"),
        ({"materials": [BLUE], "scale_mm": 0.0}, "scale_mm"),
        ({"materials": [BLUE], "scale_mm": float("nan")}, "scale_mm"),
        ({"materials": [BLUE], "octaves": 2.5}, "whole"),
        ({"materials": [BLUE], "octaves": 0}, "octaves"),
        ({"materials": [BLUE], "seed": -1}, "seed"),
        ({"materials": [BLUE], "mode": "fuzzy"}, "mode"),
        ({"materials": [BLUE], "resolution": 4}, "resolution"),
    ],
)
def test_bad_zoning_is_a_one_line_parameter_error(kwargs, match):
    with pytest.raises(ParameterError, match=match) as info:
        Zoning(**kwargs)
    assert "\n" not in str(info.value)


def test_bad_zoning_arguments(slab, tmp_path, cli):
    with pytest.raises(ParameterError, match="zoning preset"):
        labcut.render(slab, Labradorite(), zoning="tartan", resolution=16, spp=1)
    with pytest.raises(ParameterError, match="zoning must be"):
        labcut.render(slab, Labradorite(), zoning=42, resolution=16, spp=1)
    with pytest.raises(ParameterError, match="spread_deg"):
        labcut.render(slab, Labradorite(spread_deg=7.0), zoning=Zoning([BLUE]), resolution=16, spp=1)
    with pytest.raises(ParameterError, match="unknown zoning field"):
        Zoning.from_dict({"materials": ["blue"], "colour": "red"})
    with pytest.raises(ParameterError, match="unknown material parameter"):
        Zoning.from_dict({"materials": [{"peak_nm": 500, "hue": 3}]})
    bad = tmp_path / "z.json"
    bad.write_text("{not json")
    out = tmp_path / "x.png"
    for arg in ("tartan", str(bad), str(tmp_path / "missing.json")):
        proc = cli("render", str(MESHES / "cube-10.ply"), "-o", str(out), "--resolution", "16", "--zoning", arg)
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.strip().splitlines()[-1].startswith("error:") and "Traceback" not in proc.stderr
    assert not out.exists()


# ----------------------------------------------------------------------------- the natural default
def test_the_natural_preset_is_built_on_the_materials_own_colour():
    from labcut.rendering.zoning import NATURAL_DOMAINS, Zoning

    for preset in ("blue", "gold"):
        base = labcut.Labradorite.preset(preset)
        z = Zoning.preset("natural", base, seed=3)
        assert z.seed == 3 and z.name == "natural" and len(z.materials) == len(NATURAL_DOMAINS) == 4
        for m, (label, shift, share) in zip(z.materials, NATURAL_DOMAINS):
            assert m.name == label and m.peak_wavelength() == pytest.approx(base.peak_wavelength() + shift, abs=0.5)
            assert m.pairs == pytest.approx(base.pairs * share, abs=0.5)
            assert (m.n_a, m.spread_deg, m.body_albedo) == (base.n_a, base.spread_deg, base.body_albedo)


def test_the_natural_preset_takes_any_pair_count():
    from labcut.rendering.zoning import Zoning

    z = Zoning.preset("natural", labcut.Labradorite(pairs=1237))
    assert [m.pairs for m in z.materials] == [247, 990, 1237, 742]


def test_presentation_renders_show_natural_zones_by_default():
    from labcut.rendering.request import RenderRequest

    studio = RenderRequest.build("gold", look="studio", seed=5)
    assert studio.zoning.name == "natural" and studio.zoning.seed == 5
    assert studio.zoning.materials[2].peak_wavelength() == pytest.approx(580.0, abs=0.5)
    assert RenderRequest.build("gold").zoning is None  # the diagram look: the clean model
    assert RenderRequest.build("gold", look="studio", zoning="none").zoning is None
    assert RenderRequest.build("gold", look="studio", zoning=None).zoning is None
    assert RenderRequest.build("gold", look="studio", mode="mono").zoning is None
    assert RenderRequest.build("gold", look="studio", zoning="sharp").zoning.name == "sharp"


def test_natural_zones_vary_the_flash_colour_where_the_clean_model_is_one_colour():
    import colorsys

    mesh = labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")
    spread = {}
    for zoning in ("none", "auto"):
        r = labcut.render(mesh, "blue", (0, 0, 1), look="studio", resolution=96, spp=4, zoning=zoning, flash_mask=True)
        from labcut.rendering.images import to_uint8

        pic = to_uint8(r.image, r.exposure, r.tonemap).astype(float) / 255.0
        hue = np.array([colorsys.rgb_to_hsv(*p)[0] for p in pic[r.flash_mask.mask]])
        spread[zoning] = float(np.percentile(hue, 90) - np.percentile(hue, 10))
    assert spread["auto"] > 2.0 * spread["none"], spread


def test_cli_zoning_none_renders_the_clean_model(cli, tmp_path):
    js = tmp_path / "r.json"
    for arg, name in ((["--zoning", "none"], None), ([], "natural")):
        proc = cli("render", str(ROOT / "meshes" / "oval-16x12-low.ply"), "-o", str(tmp_path / "r.png"), "--resolution", "16",
                   "--spp", "1", "--json", str(js), *arg)
        assert proc.returncode == 0, proc.stderr
        data = json.loads(js.read_text())
        assert (data.get("zoning") or {}).get("name") == name
