"""labcut.render: plans, gradients, colour modes, polarization, outputs, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

import labcut
from labcut import Labradorite, ParameterError
from labcut.rendering.api import build_scene, plan_render
from labcut.scene import Lights, resolve_scene

MESHES = Path(__file__).resolve().parents[1] / "meshes"


@pytest.fixture(scope="module")
def cab():
    return labcut.load_mesh(MESHES / "oval-16x12-low.ply")


@pytest.fixture(scope="module")
def slab():
    return labcut.load_mesh(MESHES / "slab-20x20x3.ply")


def test_plan_simulates_only_what_is_needed(cab):
    carving = labcut.load_mesh(MESHES / "carving-biplane.ply")
    light = Lights.preset("overhead")
    plan = plan_render(cab, light)
    assert plan.variant.endswith("_ad_rgb") and plan.integrator == "direct" and plan.convex
    assert plan_render(cab, light, mode="spectral").variant.endswith("_ad_spectral")
    assert plan_render(cab, light, polarizer_deg=0.0).variant.endswith("_ad_spectral_polarized")
    plan = plan_render(carving, light)
    assert not plan.convex and plan.integrator == "path" and plan.max_depth > 2
    assert any("non-convex" in r for r in plan.reasons)


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_gradient_wrt_lamella_normal_matches_finite_differences(cab, mode):
    lab = Labradorite.preset("green", spread_deg=6.0)
    # The delta surface lobe does not depend on the normal and is left out: prb's
    # relative_grad would credit radiance it sampled to the glossy lobe (see build_scene).
    scene, _ = build_scene(cab, lab, [0.12, -0.05, 1.0], resolve_scene(lighting="sky").main_setting(), "face-up", 48, mode, lobes=("schiller", "body"), integrator="prb")
    params = mi.traverse(scene)
    key = next(k for k in params.keys() if k.endswith("normal") and "bsdf" in k)
    m0 = np.array([params[key].x[0], params[key].y[0], params[key].z[0]], dtype=np.float64)

    def set_normal(m) -> None:
        params[key] = mi.Vector3f(*[float(x) for x in m])
        params.update()

    def mean_image() -> float:
        return float(np.array(mi.render(scene, params, spp=256, seed=7)).mean())

    set_normal(m0)
    dr.enable_grad(params[key])
    params.update()
    img = mi.render(scene, params, spp=256, seed=7)
    dr.backward(dr.mean(img, axis=None))
    ad = float(np.array(dr.grad(params[key]).x).ravel()[0])
    dr.disable_grad(params[key])

    h = 0.01
    set_normal(m0 + [h, 0, 0])
    plus = mean_image()
    set_normal(m0 - [h, 0, 0])
    minus = mean_image()
    fd = (plus - minus) / (2 * h)
    assert abs(fd) > 1e-4  # the image really depends on the normal
    assert abs(ad - fd) <= 0.05 * abs(fd), (ad, fd)


def test_modes_agree_on_where_the_flash_is(cab):
    lab = Labradorite.preset("blue")
    masks = {}
    for mode in ("mono", "rgb", "spectral"):
        img = labcut.render(cab, lab, (0.1, 0.0, 1.0), mode=mode, lobes=("schiller",), resolution=64, spp=64).image
        lum = img @ np.array([0.2126, 0.7152, 0.0722]) if mode != "mono" else img[..., 0]  # luminance Y
        masks[mode] = lum >= 0.25 * lum.max()
    for mode in ("mono", "spectral"):
        inter = np.logical_and(masks[mode], masks["rgb"]).sum()
        union = np.logical_or(masks[mode], masks["rgb"]).sum()
        assert union > 50 and inter / union > 0.9


def test_spectral_flash_colour_matches_material_colour(slab):
    lab = Labradorite.preset("green")
    # lamellae parallel to the face, overhead lamp: the flash sits at near-normal internal angles
    img = labcut.render(slab, lab, (0, 0, 1), mode="spectral", lobes=("schiller",), resolution=48, spp=64, view=(12.0, 270.0)).image
    lum = img.sum(axis=-1)
    flash = img[lum >= 0.5 * lum.max()].mean(axis=0)
    expected = np.asarray(lab.flash_colour(np.cos(np.radians(12.0 / 1.56))).linear_srgb)
    chroma = lambda c: np.clip(c, 0, None) / np.clip(c, 0, None).sum()  # noqa: E731
    assert np.max(np.abs(chroma(flash) - chroma(expected))) < 0.03


def polarised_schiller_ratio(lab: Labradorite, view_deg: float, samples: int = 200_000) -> float:
    """Y(R_p)/Y(R_s) of the schiller seen at ``view_deg`` from the normal of a slab with lamellae
    parallel to its face, averaged over lamella orientations drawn from the lobe (uniform sky)."""
    from labcut.colour import reflectance_luminance

    sb = math.sin(math.radians(view_deg)) / lab.n_surface
    b = np.array([0.0, -sb, math.sqrt(1.0 - sb * sb)])
    rng = np.random.default_rng(0)
    s = math.radians(lab.spread_deg)
    h = np.stack([rng.normal(0, s, samples), rng.normal(0, s, samples), np.ones(samples)], axis=1)
    cos_l = np.abs(h @ b) / np.linalg.norm(h, axis=1)
    grid = np.linspace(0.6, 1.0, 401)
    y = {pol: np.interp(cos_l, grid, reflectance_luminance(lab, grid, polarization=pol)).mean() for pol in "sp"}
    return float(y["p"] / y["s"])


def test_polarizer_removes_glare_and_shows_the_polarised_schiller(slab):
    """Viewed at Brewster's angle the glare is pure s and a crossed polarizer removes it; the schiller
    (lamellae parallel to the face, internal angle 32.6°) is polarised as the stack's R_s and R_p say:
    through the polarizer across s it keeps Y(R_p)/Y(R_s) of its brightness along s, averaged over the
    lamella lobe (an independent Monte Carlo over lamella orientations, not the renderer)."""

    lab = Labradorite.preset("gold")
    brewster = float(np.degrees(np.arctan(lab.n_surface)))

    def through(angle: float, lobe: str) -> float:
        r = labcut.render(slab, lab, (0, 0, 1), lighting="sky", view=(brewster, 270.0), resolution=24, spp=16, polarizer_deg=angle, lobes=(lobe,))
        return float(r.image[8:16, 8:16].mean())

    glare = [through(a, "surface") for a in (0.0, 90.0)]
    schiller = [through(a, "schiller") for a in (0.0, 90.0)]
    assert min(glare) < 0.02 * max(glare)
    expected = polarised_schiller_ratio(lab, brewster)
    assert expected < 0.7  # the flash really is polarised here
    assert schiller[1] / schiller[0] == pytest.approx(expected, rel=0.05), (schiller, expected)


@pytest.mark.parametrize("normal", [(0, 0, 0), (float("nan"), 0, 1), (1, 2), "up"])
def test_invalid_normal(cab, normal):
    with pytest.raises(ParameterError):
        labcut.render(cab, Labradorite(), normal, resolution=16, spp=1)


def test_invalid_arguments(cab, tmp_path):
    with pytest.raises(ParameterError, match="material must be"):
        labcut.render(cab, 42, resolution=16, spp=1)
    with pytest.raises(ParameterError, match="preset"):
        labcut.render(cab, "sparkly", resolution=16, spp=1)
    with pytest.raises(ParameterError):
        labcut.render(cab, Labradorite(), lighting="disco", resolution=16, spp=1)
    with pytest.raises(ParameterError):
        labcut.render(cab, Labradorite(), lighting=str(tmp_path / "missing.exr"), resolution=16, spp=1)
    with pytest.raises(ParameterError):
        labcut.render(cab, Labradorite(), view="upside-down", resolution=16, spp=1)
    with pytest.raises(ParameterError):
        labcut.render(cab, Labradorite(), spp=0, resolution=16)
    with pytest.raises(ParameterError):
        labcut.render(cab, Labradorite(), lobes=("sparkle",), resolution=16, spp=1)
    with pytest.raises(ParameterError):
        labcut.render(cab, Labradorite(), resolution=16, spp=1, output=tmp_path / "x.jpg")
    assert not list(tmp_path.iterdir())


def test_outputs_png_and_exr(cab, tmp_path):
    r = labcut.render(cab, Labradorite.preset("red"), (0, 0, 1), resolution=32, spp=4, output=tmp_path / "a.png")
    assert (tmp_path / "a.png").read_bytes()[:4] == b"\x89PNG"
    assert r.image.dtype == np.float32 and r.image.shape == (32, 32, 3) and np.all(np.isfinite(r.image))
    r.save(tmp_path / "a.exr")
    back = np.array(mi.Bitmap(str(tmp_path / "a.exr")))
    assert np.allclose(back, r.image, atol=1e-6)
    assert r.samples_per_second > 0 and r.plan.integrator == "direct"


def test_orbit_tiles_views(cab):
    r = labcut.render(cab, Labradorite(), (0, 0, 1), view="orbit", resolution=16, spp=1)
    assert r.image.shape == (32, 64, 3) and len(r.views) == 8


def test_progress_is_reported(cab):
    seen = []
    labcut.render(cab, Labradorite(), resolution=16, spp=40, progress=lambda done, total: seen.append((done, total)))
    assert seen[-1] == (40, 40) and len(seen) == 3


def test_carving_renders_without_nan():
    carving = labcut.load_mesh(MESHES / "carving-biplane.ply")
    r = labcut.render(carving, Labradorite.preset("blue"), (0.3, 0.2, 1.0), resolution=32, spp=4, view=(30.0, 270.0))
    assert np.all(np.isfinite(r.image)) and r.image.max() > 0


def test_environment_map_from_file(cab, tmp_path):
    # a small equirectangular sky: bright band near the zenith, dark below the horizon
    h, w = 32, 64
    theta = (np.arange(h) + 0.5) / h * np.pi
    sky = np.repeat(np.clip(np.cos(theta), 0.0, None)[:, None], w, axis=1)[..., None] * np.ones(3)
    path = tmp_path / "sky.exr"
    mi.Bitmap(sky.astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(str(path))
    r = labcut.render(cab, Labradorite.preset("green"), (0, 0, 1), lighting=str(path), resolution=32, spp=8)
    assert r.image.max() > 0 and np.all(np.isfinite(r.image))
    (tmp_path / "broken.exr").write_bytes(b"not an exr")
    with pytest.raises(ParameterError, match="environment map"):
        labcut.render(cab, Labradorite(), lighting=str(tmp_path / "broken.exr"), resolution=16, spp=1)
