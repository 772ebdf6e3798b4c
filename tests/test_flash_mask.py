"""Pictures that agree with the numbers (issue 33, items 1 and 2): the flash mask.

The share of a render's stone pixels whose schiller radiance reaches the flash threshold must be
the flash area the surface-sample estimator reports for that view (``RenderResult.flash``), in
the diagram look (orthographic) and in the studio look (perspective, each point judged from the
main view's direction); and the recommended biplane, which flashes over most of its face, must
show that flash in colour where the mask says it flashes.
"""

from __future__ import annotations

import colorsys
import json
from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.errors import ParameterError
from labcut.orientation import flash_mask as fm
from labcut.rendering.images import read_png_metadata

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT / "meshes"
OVAL = MESHES / "oval-16x12-low.ply"
#: the biplane's recommendation under the bench with the blue preset (recommend-orientation, standard)
BIPLANE_NORMAL = (-0.00402, -0.05484, 0.99849)

CASES = [  # mesh, scenario, lamella normal (flash areas from 4 % to 78 %, and none)
    ("oval-16x12-low.ply", "bench", (0.0, 0.0, 1.0)),
    ("round-12-medium.ply", "bench", (0.1, 0.0, 1.0)),
    ("carving-biplane.ply", "bench", BIPLANE_NORMAL),
    ("oval-16x12-low.ply", "pendant", (0.019, 0.159, 0.987)),
    ("oval-16x12-low.ply", "outdoor", (0.29, -0.28, 0.915)),
    ("oval-16x12-low.ply", "pendant", (0.0, 0.0, 1.0)),
]


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


@pytest.mark.parametrize("look", ["diagram", "studio"])
@pytest.mark.parametrize(("name", "scenario", "normal"), CASES)
def test_the_masks_share_is_the_views_flash_area(name, scenario, normal, look):
    mesh = labcut.load_mesh(MESHES / name)
    r = labcut.render(mesh, "blue", normal, scenario=scenario, look=look, resolution=96, spp=1, flash_mask=True)
    area = r.flash[0]["flash_area"]
    assert r.flash_mask.share == pytest.approx(area, abs=0.03), (r.flash_mask.share, area)
    assert r.flash_mask.mask.shape == (96, 96) and r.flash_mask.views == tuple(r.views)


def test_an_environment_of_many_lights_leaves_no_speckles():
    # 77 lights (the pendant's office: lamps and an environment map's samples): a sampled render
    # put faint pixels over the threshold at random; the mask sums the lights exactly, so its flash is
    # whole regions (no flashing pixel without a flashing neighbour) at the scene's own threshold
    from labcut.orientation.radiance import scene_peak
    from labcut.rendering.scene import camera_views

    mesh = labcut.load_mesh(OVAL)
    lab = labcut.Labradorite.preset("blue")
    setting = labcut.scene.resolve_scene("pendant").main_setting()
    assert len(setting.lights.weights) > 50
    mask = fm.flash_mask(mesh, lab, (0, 0, 1), setting, camera_views("main", setting), 64)
    assert mask.threshold == pytest.approx(0.1 * scene_peak(lab, setting.lights)) and mask.threshold < 0.02
    assert 0.0 < mask.share < 1.0 and mask.coverage.max() == 1.0 and 0.0 < mask.ratio.max() < 0.1
    on = mask.mask
    padded = np.pad(on, 1)
    neighbours = padded[:-2, 1:-1] | padded[2:, 1:-1] | padded[1:-1, :-2] | padded[1:-1, 2:]
    assert on.sum() > 20 and not (on & ~neighbours).any()


def test_the_ratio_is_the_schiller_radiance_over_the_reference():
    # a slab face-up under one lamp straight above, seen from straight above: the reference flash
    # itself (L_s = L_ref) wherever the face is seen; the threshold splits at tau
    mesh = labcut.load_mesh(MESHES / "slab-20x20x3.ply")
    lights = labcut.Lights.lamp((0, 0, 1))
    setting = labcut.scene.Setting(lights, labcut.Views([(0, 0, 1)]), 1.0, np.eye(3))
    from labcut.rendering.scene import CameraView

    mask = fm.flash_mask(mesh, labcut.Labradorite.preset("blue"), (0, 0, 1), setting, [CameraView("top", (0, 0, 1))], 32)
    face = mask.coverage == 1.0
    assert face.sum() > 300 and np.allclose(mask.ratio[face], 1.0, rtol=0.02)
    assert fm.FlashMask(mask.ratio, mask.coverage, 1.01, ("top",), (0.0,)).share == 0.0
    assert fm.FlashMask(mask.ratio, mask.coverage, 0.99, ("top",), (1.0,)).share == pytest.approx(1.0)


@pytest.mark.parametrize("azimuth", [0.0, 90.0])
def test_the_mask_agrees_with_the_render_estimator_where_the_carving_shades_itself(azimuth):
    # a low lamp (75° from the top): the biplane's fuselage and wings shade each other, and the
    # mask's shadow rays must leave those parts dark as Mitsuba's own sampled render does (without
    # them 75 % of the stone would flash instead of 65 %)
    import math

    from labcut.orientation.render_estimator import render_metrics
    from labcut.rendering.scene import CameraView
    from labcut.scene.directions import direction

    mesh = labcut.load_mesh(MESHES / "carving-biplane.ply")
    lab = labcut.Labradorite.preset("blue")
    lights, views = labcut.Lights.lamp(direction(75.0, azimuth)), labcut.Views([(0, 0, 1)])
    inside = math.degrees(math.asin(math.sin(math.radians(75.0)) / lab.n_surface))
    normal = direction(inside / 2.0, azimuth)  # mirrors the refracted lamp up to the viewer
    setting = labcut.scene.Setting(lights, views, 1.0, np.eye(3))
    mask = fm.flash_mask(mesh, lab, normal, setting, [CameraView("top", (0, 0, 1))], 128)
    sampled = render_metrics(mesh, lab, normal, lights, views, resolution=128, spp=16)
    energy = float((mask.coverage * mask.ratio).sum() / mask.coverage.sum())
    assert mask.share == pytest.approx(sampled.flash_area, abs=0.02)
    assert energy == pytest.approx(sampled.flash_energy, rel=0.03)


def test_the_overlay_marks_the_flash_and_dims_the_rest():
    ratio = np.array([[0.5, 0.05], [0.0, 0.2]])
    cover = np.array([[1.0, 1.0], [0.0, 0.5]])
    mask = fm.FlashMask(ratio, cover, 0.1, ("v",), (0.0,))
    assert mask.share == pytest.approx(1.5 / 2.5)
    picture = np.full((4, 4, 3), 200, dtype=np.uint8)  # twice the mask's size: each mask pixel covers 2 x 2
    out = mask.overlay(picture).astype(int)
    assert out.shape == (4, 4, 3)
    assert (out[:2, :2] == [228, 207, 100]).all()  # flashing: half the picture, half the mark colour
    assert (out[:2, 2:] == 70).all() and (out[2:, :2] == 70).all()  # not flashing or off the stone: dimmed
    assert (out[2:, 2:] == [149, 138, 85]).all()  # flashing, half covered: mixed by coverage
    with pytest.raises(ParameterError, match="frame"):
        mask.overlay(np.zeros((4, 6, 3), dtype=np.uint8))


def test_the_recommended_biplane_shows_its_flash_in_colour():
    # the demo's biplane recommended with --preset blue flashes over 78 % of its face: the studio
    # picture must show that flash as blue, not as grey wings
    from labcut.rendering.images import to_uint8

    mesh = labcut.load_mesh(MESHES / "carving-biplane.ply")
    for zoning, share_blue in (("none", 0.8), ("auto", 0.6)):  # the clean model; the natural zones (default)
        r = labcut.render(mesh, "blue", BIPLANE_NORMAL, look="studio", resolution=128, spp=4, flash_mask=True,
                          zoning=zoning)
        assert r.flash[0]["flash_area"] > 0.7 and r.flash_mask.share > 0.7
        picture = to_uint8(r.image, r.exposure, r.tonemap).astype(np.float64) / 255.0
        flashing = picture[r.flash_mask.mask & (r.flash_mask.coverage == 1.0)]
        hsv = np.array([colorsys.rgb_to_hsv(*p) for p in flashing])
        blue = (hsv[:, 0] > 0.5) & (hsv[:, 0] < 0.7) & (hsv[:, 1] > 0.2)
        assert blue.mean() > share_blue, (zoning, blue.mean(), np.median(hsv, axis=0))
        assert (hsv[:, 1] > 0.2).mean() > 0.9  # coloured, not the grey (152, 152, 152) the issue saw
        assert np.median(hsv[:, 1]) > 0.35


def test_cli_writes_the_flash_mask_beside_the_render(cli, tmp_path):
    png, mask, js = tmp_path / "r.png", tmp_path / "mask.png", tmp_path / "r.json"
    proc = cli("render", str(OVAL), "-o", str(png), "--flash-mask", str(mask), "--resolution", "32", "--spp", "1",
               "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    data = json.loads(js.read_text())
    share, area = data["flash_mask"]["share"], data["flash_by_view"][0]["flash_area"]
    assert data["flash_mask"]["path"] == str(mask) and share == pytest.approx(area, abs=0.05) and share > 0.2
    meta = read_png_metadata(mask)
    assert json.loads(meta["flash_mask"])["share"] == pytest.approx(share)
    assert f"{share:.0%} of the stone's pixels flash (the estimator's flash area: {area:.0%})" in " ".join(proc.stdout.split())


@pytest.mark.parametrize("args", [["--flash-mask", "m.jpg"], ["--flash-mask", "m.png", "--animate", "rock"]])
def test_cli_refuses_a_flash_mask_it_cannot_write(cli, tmp_path, args):
    out = tmp_path / ("a.webp" if "--animate" in args else "r.png")
    proc = cli("render", str(OVAL), "-o", str(out), *args, "--resolution", "16", "--spp", "1", cwd=tmp_path)
    assert proc.returncode == 2 and "--flash-mask" in proc.stderr and "Traceback" not in proc.stderr
    assert not out.exists() and not list(tmp_path.glob("m.*"))


def test_a_render_without_a_mask_says_so():
    mesh = labcut.load_mesh(OVAL)
    r = labcut.render(mesh, "blue", (0, 0, 1), resolution=16, spp=1, check_flash=False)
    with pytest.raises(ParameterError, match="flash_mask=True"):
        r.save_flash_mask("x.png")


def test_recommend_orientation_marks_the_flash_of_its_render(cli, tmp_path):
    js, mask = tmp_path / "r.json", tmp_path / "m.png"
    proc = cli("recommend-orientation", str(OVAL), "--quality", "draft", "--scenario", "pendant", "--render",
               str(tmp_path / "r.png"), "--flash-mask", str(mask), "--resolution", "48", "--spp", "1", "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    render = json.loads(js.read_text())["render"]
    share, area = render["flash_mask"]["share"], render["flash_by_view"][0]["flash_area"]
    # under the pendant's own threshold 60 % of the stone flashes (converged: the 128 px mask and the
    # high-quality estimator agree within a point); the draft estimator (3000 points) and a 48 px mask
    # each sit a couple of points off it, on either side
    assert mask.exists() and share == pytest.approx(area, abs=0.05) and area > 0.3
    assert render["exposure_mode"] == "reference" and render["exposure_vs_reference_ev"] == 0.0
    proc = cli("recommend-orientation", str(OVAL), "--flash-mask", str(tmp_path / "alone.png"))
    assert proc.returncode == 2 and "give --render too" in proc.stderr and not (tmp_path / "alone.png").exists()
