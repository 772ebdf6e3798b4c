"""One exposure for every scene by default (issue 33, item 1): a dimmer scene looks dimmer.

Every scenario's lights are scaled to the same total irradiance, so under the bench's reference
exposure a pendant (its face turned away from the overhead lamp) renders darker than the same
stone on the bench; ``exposure="auto"`` brightens it and says by how many stops.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.errors import ParameterError
from labcut.rendering import exposure as ex
from labcut.rendering.images import read_png_metadata
from labcut.rendering.studio import Studio
from labcut.rendering.tonemap import STUDIO_EV, metered_exposure

ROOT = Path(__file__).resolve().parents[1]
OVAL = ROOT / "meshes" / "oval-16x12-low.ply"
ROUND = ROOT / "meshes" / "round-12-medium.ply"
SCENARIOS = ("bench", "pendant", "ring", "outdoor")


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh(OVAL)


@pytest.mark.parametrize("look", ["diagram", "studio"])
def test_every_scenario_renders_under_the_bench_reference_by_default(oval, look):
    results = {s: labcut.render(oval, "blue", (0, 0, 1), scenario=s, look=look, resolution=16, spp=1, check_flash=False)
               for s in SCENARIOS}
    ref = ex.reference_exposure(None if look == "diagram" else Studio())
    for s, r in results.items():
        assert r.exposure == ref == r.exposure_reference, s
        assert r.exposure_mode == "reference" and r.exposure_vs_reference_ev == 0.0
        assert "bench reference exposure" in r.exposure_caption


def test_the_reference_is_the_bench_metered_towards_its_viewer():
    bench = labcut.scene.resolve_scene("bench").main_setting()
    e = ex.studio_irradiance_at_camera(bench, Studio(), bench.views.main)
    assert ex.reference_exposure(Studio()) == pytest.approx(metered_exposure(e, STUDIO_EV), rel=1e-12)
    # diagram: the lamps' irradiance on a card facing the cutter, plus pi x the dim room
    d = np.asarray(bench.lights.lamp_directions)
    w = np.asarray(bench.lights.lamp_weights) * 3.0 / float(np.sum(bench.lights.weights))
    v = np.asarray(bench.views.main) / np.linalg.norm(bench.views.main)
    e_diagram = float(np.sum(w * np.clip(d @ v, 0, None))) + math.pi * 0.02
    assert ex.reference_exposure(None) == pytest.approx(math.pi / e_diagram * 2.0 ** ex.DIAGRAM_EV, rel=1e-9)


@pytest.mark.parametrize("path", [OVAL, ROUND])
def test_the_diagram_reference_is_within_half_a_stop_of_a_flashing_cabochons_own(path):
    # the DIAGRAM_EV offset: a cabochon flashing face-up on the bench looks as it did when each
    # image was metered on its own
    mesh = labcut.load_mesh(path)
    r = labcut.render(mesh, "blue", (0, 0, 1), resolution=48, spp=4, exposure="auto", check_flash=False)
    assert r.exposure_mode == "auto" and abs(r.exposure_vs_reference_ev) < 0.5


def test_a_pendant_looks_dimmer_than_the_bench_and_auto_says_by_how_much(oval):
    bench = labcut.render(oval, "blue", (0, 0, 1), scenario="bench", look="studio", resolution=48, spp=4, check_flash=False)
    pendant = labcut.render(oval, "blue", (0, 0, 1), scenario="pendant", look="studio", resolution=48, spp=4, check_flash=False)
    lum = np.array([0.2126, 0.7152, 0.0722])
    # the same exposure, so the light that reaches the camera decides: the stone faces away from the lamp
    centre = slice(16, 32)
    assert (pendant.image[centre, centre] @ lum).mean() < 0.5 * (bench.image[centre, centre] @ lum).mean()
    auto = labcut.render(oval, "blue", (0, 0, 1), scenario="pendant", look="studio", resolution=48, spp=4,
                         exposure="auto", check_flash=False)
    assert auto.exposure_mode == "auto" and auto.exposure_metering == "incident"
    assert auto.exposure_vs_reference_ev == pytest.approx(math.log2(auto.exposure / bench.exposure))
    assert auto.exposure_vs_reference_ev > 1.0  # metering the pendant alone brightens it (+1.6 EV)
    assert auto.exposure_caption == f"{auto.exposure_vs_reference_ev:+.1f} EV over the bench reference (auto: brightened to this scene)"


def test_the_cli_says_the_exposure_against_the_reference(cli, tmp_path):
    png, js = tmp_path / "p.png", tmp_path / "p.json"
    proc = cli("render", str(OVAL), "--scenario", "pendant", "-o", str(png), "--resolution", "16", "--spp", "1",
               "--exposure", "auto", "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    data, meta = json.loads(js.read_text()), read_png_metadata(png)
    stops = data["exposure_vs_reference_ev"]
    assert data["exposure_mode"] == meta["exposure_mode"] == "auto" and stops > 1.0
    assert f"{stops:+.1f} EV over the bench reference" in data["exposure_caption"] == meta["exposure_caption"]
    assert f"{stops:+.1f} EV over the bench reference" in " ".join(proc.stdout.split())
    assert float(meta["exposure_vs_reference_ev"]) == pytest.approx(stops, abs=1e-3)
    proc = cli("render", str(OVAL), "--scenario", "pendant", "-o", str(png), "--resolution", "16", "--spp", "1", "--json", str(js))
    assert proc.returncode == 0 and json.loads(js.read_text())["exposure_mode"] == "reference"
    assert json.loads(js.read_text())["exposure"] == pytest.approx(ex.reference_exposure(Studio()))


def test_an_animation_keeps_the_reference_for_every_frame(oval):
    anim = labcut.animate(oval, "blue", (0, 0, 1), scenario="pendant", frames=2, spp=1, resolution=16)
    assert anim.exposure_mode == "reference" and anim.exposure == ex.reference_exposure(Studio())
    assert anim.exposure_vs_reference_ev == 0.0
    auto = labcut.animate(oval, "blue", (0, 0, 1), scenario="pendant", frames=2, spp=1, resolution=16, exposure="auto")
    assert auto.exposure_mode == "auto" and auto.exposure_vs_reference_ev > 1.0


@pytest.mark.parametrize("bad", ["bright", "", -1.0, 0.0, float("nan"), True])
def test_a_bad_exposure_is_a_parameter_error(bad):
    with pytest.raises(ParameterError, match="exposure"):
        ex.check_mode(bad)


def test_exposure_modes_parse():
    assert ex.check_mode(None) == ex.check_mode(" Reference ") == "reference"
    assert ex.check_mode("AUTO") == "auto" and ex.check_mode(2) == 2.0


def test_a_studio_without_its_tent_renders_under_its_lamps(oval):
    """``Studio(tent_share=0)`` is in the look's documented range: lamps in a dark room. It once
    failed with "environment map 'tent' is black" (a map of zeros refused) for every scene
    without a map of its own."""
    r = labcut.render(oval, "blue", (0, 0, 1), scenario="bench", look=Studio(tent_share=0.0), resolution=16, spp=1,
                      check_flash=False)
    assert r.exposure == ex.reference_exposure(Studio(tent_share=0.0)) and np.isfinite(r.image).all()
    assert r.image.max() > 0.0
