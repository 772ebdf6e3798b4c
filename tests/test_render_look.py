"""The studio look (issue 15): what a client is shown.

Measured on the linear image (``RenderResult.image``) of the bundled oval at the orientation
``recommend_orientation`` picks (draft) under the ``bench`` scenario:

* the stone's pixels: a mask from tracing the same camera at a scene holding only the stone
  (white diffuse, albedo AOV: 1 on a hit, 0 on a miss), so the table never counts;
* the lamp's highlight: stone pixels whose display value is near white in every channel, and
  where the surface lobe alone (a ``lobes=("surface",)`` render) gives most of the light;
* the flash: stone pixels where the schiller lobe alone (``lobes=("schiller",)``) gives most
  of the light and is bright (a quarter of its 99th percentile on the stone or more);
* the body: stone pixels with no flash (schiller under a tenth of the flash's median) and no
  highlight, in the full render; and the body lobe alone (``lobes=("body",)``) on the stone.
"""

from __future__ import annotations

import colorsys
import json
from pathlib import Path

import numpy as np
import pytest

import labcut


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


ROOT = Path(__file__).resolve().parents[1]
MESH = ROOT / "meshes" / "oval-16x12-low.ply"
LUM = np.array([0.2126, 0.7152, 0.0722])


@pytest.fixture(scope="module")
def oval():
    mesh = labcut.load_mesh(MESH)
    material = labcut.Labradorite.preset("blue")
    rec = labcut.recommend_orientation(mesh, material, scenario="bench", quality="draft")
    return mesh, material, rec


def display(image: np.ndarray, exposure: float) -> np.ndarray:
    """What the PNG shows, in [0, 1] (the studio look's AgX curve after the exposure)."""
    from labcut.rendering.images import tonemap

    return tonemap(np.asarray(image, dtype=np.float64), exposure, "agx")


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


def stone_mask(mesh, rec, resolution: int) -> np.ndarray:
    """Pixels fully covered by the stone, from the studio camera (see the module docstring)."""
    import mitsuba as mi

    from labcut.rendering.api import build_scene
    from labcut.rendering.scene import to_mitsuba_mesh

    scene, _ = build_scene(mesh, labcut.Labradorite.preset("blue"), rec.normal, rec.scenario.main_setting(), "main",
                           resolution, look="studio", denoise=True)
    white = to_mitsuba_mesh(mesh, mi.load_dict({"type": "diffuse", "reflectance": {"type": "rgb", "value": 1.0}}))
    only = mi.load_dict({"type": "scene", "sensor": scene.sensors()[0], "stone": white,
                         "integrator": {"type": "aov", "aovs": "a:albedo"}})
    return np.array(mi.render(only, spp=16))[..., 0] > 0.999


def test_studio_render_shows_highlight_flash_and_a_dark_body(oval, tmp_path):
    mesh, material, rec = oval
    res = 128
    kw = dict(scenario=rec.scenario, resolution=res, look="studio", check_flash=False, spp=32)
    full = labcut.render(mesh, material, rec.normal, output=tmp_path / "oval.png", **kw)
    assert full.look == "studio" and full.tonemap == "agx" and full.plan.denoise
    parts = {lobe: labcut.render(mesh, material, rec.normal, lobes=(lobe,), denoise=False, **kw).image @ LUM
             for lobe in ("surface", "schiller", "body")}
    lum = full.image @ LUM
    stone = stone_mask(mesh, rec, res)
    assert 0.05 < stone.mean() < 0.5  # the stone sits on the table with a margin around it

    shown = display(full.image, full.exposure)
    highlight = stone & (shown.min(axis=-1) > 0.85)
    assert 1 <= highlight.sum() <= 0.03 * stone.sum(), "the lamp's mirror image: a small near-white spot"
    assert np.median(parts["surface"][highlight] / lum[highlight]) > 0.5, "the highlight is the polish mirroring the lamp"

    s = parts["schiller"]
    flash = stone & ~highlight & (s > 0.5 * lum) & (s > 0.25 * np.percentile(s[stone], 99))
    assert flash.sum() >= 0.2 * stone.sum(), "the recommended orientation flashes over much of the face"
    colour = shown[flash].mean(axis=0)
    assert colour[2] > colour[0] + 0.2, f"a blue flash, got display colour {colour}"

    flash_lum = lum[flash].mean()
    body = stone & ~highlight & (s < 0.1 * np.median(s[flash]))
    assert body.sum() >= 0.05 * stone.sum()
    assert lum[body].mean() * 5.0 <= flash_lum, f"body {lum[body].mean():.4g} vs flash {flash_lum:.4g}"
    assert parts["body"][stone & ~highlight].mean() * 5.0 <= flash_lum, "the body lobe is dark grey-green"

    from labcut.rendering.images import read_png_metadata

    assert read_png_metadata(tmp_path / "oval.png")["tonemap"] == "agx"


def test_denoised_low_spp_matches_raw_at_16x_the_samples(oval):
    """Denoised 4 spp against raw 64 spp, both against 1024 spp, on the denoised render's own
    scene (box pixel filter; the raw images are its colour, not denoised); display values."""
    from labcut.rendering.api import build_scene, render_pass

    mesh, material, rec = oval
    res = 64
    scene, plan = build_scene(mesh, material, rec.normal, rec.scenario.main_setting(), "main", res, look="studio", denoise=True)
    assert plan.denoise

    def raw(spp: int, seed: int) -> np.ndarray:
        n = min(spp, 16)
        return sum(np.array(render_pass(scene, n, seed + k), dtype=np.float64)[..., :3] for k in range(spp // n)) / (spp // n)

    dn = labcut.render(mesh, material, rec.normal, scenario=rec.scenario, spp=4, resolution=res, look="studio", check_flash=False)
    assert dn.plan.denoise
    e = dn.exposure
    ref = display(raw(1024, 1_000_000), e)
    err_dn = rmse(display(dn.image, e), ref)
    err_raw = rmse(display(raw(64, 5_000_000), e), ref)
    assert err_dn <= 2.0 * err_raw, f"denoised 4 spp: {err_dn:.4f}; raw 64 spp: {err_raw:.4f}"
    assert rmse(display(raw(4, 9_000_000), e), ref) > 2.0 * err_dn  # the same 4 spp, not denoised


def test_denoiser_auxiliaries_are_noise_free(oval):
    """The guide and normal a denoised render hands the denoiser come from passes of their own at
    many samples: two seeds agree far better than two 4 spp passes do; the guide is a linear
    radiance estimate close to the converged colour on the stone (it shows the flash, the
    highlight and the dark rim, which the albedo AOV does not)."""
    from labcut.rendering.api import build_scene, render_pass
    from labcut.rendering.denoise import AUX_SPP, GUIDE_SPP, trace_albedo_normal, trace_aux

    mesh, material, rec = oval
    res = 48
    scene, _ = build_scene(mesh, material, rec.normal, rec.scenario.main_setting(), "main", res, look="studio", denoise=True)
    a, b = trace_aux(scene, seed=0), trace_aux(scene, seed=1)
    assert a.shape == (res, res, 6) and AUX_SPP >= 64 and GUIDE_SPP >= 64
    assert np.all(np.isfinite(a)) and a[..., :3].min() >= 0.0
    length = np.linalg.norm(a[..., 3:], axis=-1)
    assert np.all(length <= 1.0 + 1e-4) and np.median(length) > 0.999  # unit normals (averaged at the silhouette)
    one = rmse(trace_aux(scene, spp=4, seed=0, guide_spp=4), trace_aux(scene, spp=4, seed=1, guide_spp=4))
    assert rmse(a, b) < 0.25 * one, (rmse(a, b), one)

    colour = sum(np.array(render_pass(scene, 16, 3_000_000 + k), dtype=np.float64)[..., :3] for k in range(32)) / 32
    stone = stone_mask(mesh, rec, res)
    albedo = trace_albedo_normal(scene, seed=0)[..., :3]

    def rel(x: np.ndarray) -> float:  # error of a per-pixel estimate of the colour's pattern on the stone (scale-free)
        x, c = x[stone] @ LUM, colour[stone] @ LUM
        return float(np.sqrt(np.mean((x / x.mean() - c / c.mean()) ** 2)))

    assert rel(a[..., :3]) < 0.2, rel(a[..., :3])
    assert rel(a[..., :3]) < 0.5 * rel(albedo), (rel(a[..., :3]), rel(albedo))


def test_rock_animation_one_exposure_webp_and_gif(oval, tmp_path, monkeypatch):
    from PIL import Image

    from labcut.commands import animate as anim_mod
    from labcut.commands import render as render_cmd

    mesh, material, rec = oval
    seen = []
    real = render_cmd.render_checked

    def spy(mesh, setup, *args, **kwargs):
        result = real(mesh, setup, *args, **kwargs)
        seen.append((setup.exposure, result.exposure))
        return result

    monkeypatch.setattr(render_cmd, "render_checked", spy)
    anim = anim_mod.animate(mesh, material, rec.normal, motion="rock", frames=4, scenario=rec.scenario, spp=2,
                            resolution=32, output=tmp_path / "rock.webp")
    assert len(anim.frames) == 4 and anim.angles_deg == pytest.approx([0.0, 30.0, 0.0, -30.0], abs=1e-9)
    assert anim.look == "studio" and anim.tonemap == "agx"
    # every frame is tonemapped with the rest pose's exposure: frames 2.. are rendered with it given
    assert len(seen) == 4 and all(given == anim.exposure for given, _ in seen[1:])
    assert {round(used, 12) for _, used in seen} == {round(anim.exposure, 12)}
    with Image.open(tmp_path / "rock.webp") as im:
        assert im.format == "WEBP" and im.n_frames == 4
    anim.save(tmp_path / "rock.gif")
    with Image.open(tmp_path / "rock.gif") as im:
        assert im.format == "GIF" and im.n_frames == 4

    # one exposure in the file too: a frame twice as bright stays brighter (no per-frame normalising)
    from labcut.commands.animate import write_animation

    dim = np.full((8, 8, 3), 0.05, dtype=np.float32)
    bright = 4.0 * dim
    bright[0, 0] = 0.0  # the frames differ in shape too (a GIF may merge identical frames)
    write_animation([dim, bright], tmp_path / "two.gif", exposure=1.0)
    with Image.open(tmp_path / "two.gif") as im:
        first = np.asarray(im.convert("RGB"), dtype=float).mean()
        im.seek(1)
        second = np.asarray(im.convert("RGB"), dtype=float).mean()
    assert second > first + 30


def test_cli_render_animate_rock(cli, tmp_path):
    from PIL import Image

    out, js = tmp_path / "rock.webp", tmp_path / "rock.json"
    proc = cli("render", str(MESH), "--animate", "rock", "--frames", "3", "--spp", "2", "--resolution", "24",
               "-o", str(out), "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    with Image.open(out) as im:
        assert im.n_frames == 3
    data = json.loads(js.read_text())
    assert data["animation"]["frames"] == 3 and data["look"] == "studio" and data["tonemap"] == "agx"
    bad = tmp_path / "rock.png"
    proc = cli("render", str(MESH), "--animate", "rock", "-o", str(bad), "--resolution", "16")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and not bad.exists()
    assert proc.stderr.strip().splitlines()[-1].startswith("error:")


def _hue_sat(rgb: np.ndarray) -> tuple[float, float]:
    h, s, _ = colorsys.rgb_to_hsv(*[float(x) for x in rgb])
    return h * 360.0, s


def _hue_gap(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def test_agx_keeps_a_bright_flash_blue_where_a_clip_turns_it_cyan():
    """A saturated blue flash 4x brighter than display white (after exposure): the studio PNG's
    curve keeps its hue and some saturation and grades it; clipping each channel turns it cyan."""
    from labcut.colour import encode_srgb
    from labcut.rendering.images import tonemap

    flash = np.array([0.02, 0.25, 1.0])
    hue_in, _ = _hue_sat(encode_srgb(flash))
    shown = tonemap(4.0 * flash[None, None], 1.0, "agx")[0, 0]
    hue, sat = _hue_sat(shown)
    assert _hue_gap(hue, hue_in) < 10.0 and sat > 0.25 and shown.max() < 0.99, (hue, sat, shown)
    clipped = encode_srgb(np.clip(4.0 * flash, 0.0, 1.0))
    assert _hue_gap(_hue_sat(clipped)[0], hue_in) > 25.0  # the clip is what this guards against
    # gradation: brighter flashes stay distinguishable (no flat blob)
    ramp = tonemap(np.array([k * flash for k in (1.0, 2.0, 4.0, 8.0)])[None], 1.0, "agx")[0]
    assert np.all(np.diff(ramp @ LUM) > 0.02)
    assert np.all(np.diff(ramp[:, 2]) > 0.0) and np.all(np.diff(ramp[:, 1]) > 0.02)


def test_recommend_render_uses_the_studio_look(cli, tmp_path):
    png, js = tmp_path / "rec.png", tmp_path / "rec.json"
    proc = cli("recommend-orientation", str(MESH), "--quality", "draft", "--render", str(png), "--spp", "2",
               "--resolution", "24", "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    plan = json.loads(js.read_text())["render"]["plan"]
    assert plan["look"] == "studio" and plan["denoise"]
    from labcut.rendering.images import read_png_metadata

    assert read_png_metadata(png)["tonemap"] == "agx"
    bad = tmp_path / "bad.png"
    proc = cli("recommend-orientation", str(MESH), "--quality", "draft", "--render", str(bad), "--look", "photo")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and not bad.exists()
    assert proc.stderr.strip().splitlines()[-1].startswith("error:") and "--look" in proc.stderr
