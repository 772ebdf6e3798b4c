"""labcut.rendering.exposure pinned to hand-computed cases (issue 37: mutation testing).

How bright a render's PNG is: the reference exposure every scene shares, ``auto`` and given
multipliers, the captions a picture carries. Each case is small enough to work out by hand:
lamps of known irradiance and direction, a uniform environment map (a card facing anywhere gets
``pi`` times its radiance), the incident-light meter's ``pi / E`` times ``2**offset``. Fast (no
render): the module's own tests in tests/test_exposure.py render through Mitsuba.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from labcut.errors import ParameterError
from labcut.rendering import exposure as ex
from labcut.rendering.scene import CameraView
from labcut.rendering.studio import Studio
from labcut.scene import Lights, Views, resolve_scene
from labcut.scene.envmap import Environment
from labcut.scene.scenario import Setting

ROOM = math.pi * 0.02  # the diagram look's dim room: pi x its radiance 0.02


@pytest.fixture(autouse=True)
def _fresh_reference():
    """The reference exposure is cached per look; a cached value from another test (or from the
    mutation tool's first run) would hide a change in how it is computed."""
    ex.reference_exposure.cache_clear()
    yield
    ex.reference_exposure.cache_clear()


def _lamps(directions, weights) -> Setting:
    return Setting(Lights(directions, weights), Views([[0.0, 0.0, 1.0]]))


def _grey_map(radiance: float = 2.0) -> Setting:
    env = Environment(np.full((32, 64, 3), radiance, np.float32), np.eye(3), "grey")
    return Setting(Lights.from_envmap(env, n=64), Views([[0.0, 0.0, 1.0]]))


# ---------------------------------------------------------------------- the constants
def test_the_reference_scene_and_modes():
    assert ex.REFERENCE_SCENARIO == "bench"
    assert ex.MODES == ("reference", "auto")
    assert ex.DIAGRAM_EV == -1.0


# ---------------------------------------------------------------------- check_mode
@pytest.mark.parametrize("asked, parsed", [(None, "reference"), ("reference", "reference"), (" Reference ", "reference"),
                                           ("auto", "auto"), ("AUTO", "auto"), ("\tAuto\n", "auto")])
def test_the_named_modes_parse(asked, parsed):
    assert ex.check_mode(asked) == parsed


@pytest.mark.parametrize("asked", [2, 0.5, 1e-6, np.float64(3.25)])
def test_a_multiplier_is_kept_as_a_float(asked):
    out = ex.check_mode(asked)
    assert out == float(asked) and type(out) is float


@pytest.mark.parametrize("asked", ["bright", "", "given", "referenc", "auto-exposure"])
def test_an_unknown_word_is_refused_with_the_choices(asked):
    with pytest.raises(ParameterError) as err:
        ex.check_mode(asked)
    assert str(err.value) == f"exposure must be reference, auto or a multiplier > 0, got {asked!r}"
    assert err.value.parameter == "exposure"


@pytest.mark.parametrize("asked", [0, 0.0, -1.0, float("nan"), float("inf"), True])
def test_a_bad_multiplier_is_refused(asked):
    with pytest.raises(ParameterError, match="exposure must be a finite number > 0"):
        ex.check_mode(asked)


# ---------------------------------------------------------------------- the diagram look's meter
def test_the_diagram_meter_adds_the_lamps_facing_the_card_and_the_dim_room():
    # weights 4 + 2 = 6 scaled to the render's 3: x 0.5; the card faces +Z (the camera given unnormalised)
    s = _lamps([[0, 0, 1], [1, 0, 0]], [4.0, 2.0])
    assert ex.diagram_irradiance_at_camera(s, [0, 0, 5]) == pytest.approx(4.0 * 0.5 + ROOM, rel=1e-12)
    # the card turned 45 deg towards +X sees both lamps at cos 45
    assert ex.diagram_irradiance_at_camera(s, [2, 0, 2]) == pytest.approx(6.0 * 0.5 * math.sqrt(0.5) + ROOM, rel=1e-12)
    # facing +X: the overhead lamp grazes (cos 0), the side lamp faces it
    assert ex.diagram_irradiance_at_camera(s, [1, 0, 0]) == pytest.approx(2.0 * 0.5 + ROOM, rel=1e-12)


def test_a_lamp_behind_the_card_adds_nothing():
    s = _lamps([[0, 0, 1], [0, 0, -1]], [1.0, 2.0])
    # scale 3 / 3 = 1; the lamp below lights the card's back, not its face
    assert ex.diagram_irradiance_at_camera(s, [0, 0, 1]) == pytest.approx(1.0 + ROOM, rel=1e-12)
    assert ex.diagram_irradiance_at_camera(s, [0, 0, -1]) == pytest.approx(2.0 + ROOM, rel=1e-12)


def test_the_diagram_meter_under_a_map_is_pi_times_its_scaled_radiance():
    # a uniform map of radiance 2: its samples carry 4 pi x 2 in all, scaled to 3, so the map's
    # radiance becomes 3 / (4 pi) and a card facing anywhere gets pi times that, 0.75; no dim room
    s = _grey_map(2.0)
    for v in ([0, 0, 1], [1, 0, 0], [0, 1, 1]):
        assert ex.diagram_irradiance_at_camera(s, v) == pytest.approx(0.75, rel=2e-3)


def test_a_map_and_lamps_together_are_scaled_as_one():
    env = Environment(np.full((32, 64, 3), 1.0, np.float32), np.eye(3), "grey")
    map_part = Lights.from_envmap(env, n=64)
    lights = Lights.combine([(Lights([[0.0, 0.0, 1.0]], [1.0]), 1.0), (map_part, 2.0)], "both")
    s = Setting(lights, Views([[0.0, 0.0, 1.0]]))
    # shares 1 : 2 of the render's 3: the lamp 1 on a face-up card, the map (4 pi L = 2 -> L = 1 / (2 pi)) pi L = 0.5
    assert ex.diagram_irradiance_at_camera(s, [0, 0, 1]) == pytest.approx(1.0 + 0.5, rel=2e-3)


# ---------------------------------------------------------------------- metering
def test_the_diagram_look_meters_a_stop_below_grey():
    s = _lamps([[0, 0, 1], [1, 0, 0]], [4.0, 2.0])
    e = 2.0 + ROOM
    assert ex.metered(s, None, [0, 0, 1]) == pytest.approx(math.pi / e * 0.5, rel=1e-12)


def test_the_studio_look_meters_its_lamps_and_its_tent():
    # no tent: the lamps alone (two lamps of unequal weight stay two point lamps): 4 x 0.5 facing up
    s = _lamps([[0, 0, 1], [1, 0, 0]], [4.0, 2.0])
    assert ex.studio_irradiance_at_camera(s, Studio(tent_share=0.0), [0, 0, 1]) == pytest.approx(2.0, rel=1e-9)
    assert ex.studio_irradiance_at_camera(s, Studio(tent_share=0.0), [1, 0, 0]) == pytest.approx(1.0, rel=1e-9)
    # the tent adds its share of the lights' total on a face-up card: 0.35 x 3
    studio = Studio()
    assert ex.studio_irradiance_at_camera(s, studio, [0, 0, 1]) == pytest.approx(2.0 + 0.35 * 3.0, rel=1e-5)
    assert ex.metered(s, studio, [0, 0, 1]) == pytest.approx(math.pi / 3.05 * 2.0 ** -1.75, rel=1e-5)
    assert ex.metered(s, Studio(tent_share=0.0), [0, 0, 1]) == pytest.approx(math.pi / 2.0 * 2.0 ** -1.75, rel=1e-9)


def test_the_studio_meter_takes_the_looks_point_lamp_size():
    # a point lamp is drawn as a disc of the look's point_lamp_deg: its irradiance does not change
    s = _lamps([[0, 0, 1]], [1.0])
    for deg in (0.1, 1.5, 10.0):
        assert ex.studio_irradiance_at_camera(s, Studio(tent_share=0.0, point_lamp_deg=deg), [0, 0, 1]) == pytest.approx(3.0)


def test_the_reference_is_the_bench_rest_pose_metered_towards_its_viewer():
    bench = resolve_scene("bench").main_setting()
    v = np.asarray(bench.views.main) / np.linalg.norm(bench.views.main)
    d = np.asarray(bench.lights.lamp_directions)
    w = np.asarray(bench.lights.lamp_weights) * 3.0 / float(np.sum(bench.lights.weights))
    by_hand = float(np.sum(w * np.clip(d @ v, 0.0, None))) + ROOM
    assert ex.reference_exposure(None) == pytest.approx(math.pi / by_hand * 0.5, rel=1e-12)
    # the figures every render's PNG is exposed at (a changed reference scene, offset or meter moves them)
    assert ex.reference_exposure(None) == pytest.approx(0.5232272475005948, rel=1e-9)
    assert ex.reference_exposure(Studio()) == pytest.approx(0.23508967760750618, rel=1e-6)


def test_the_reference_depends_on_the_look_only():
    assert ex.reference_exposure(Studio(tent_share=0.0)) != pytest.approx(ex.reference_exposure(Studio()), rel=1e-3)
    bench = resolve_scene("bench").main_setting()
    assert ex.reference_exposure(Studio(tent_share=0.0)) == pytest.approx(
        ex.metered(bench, Studio(tent_share=0.0), bench.views.main), rel=1e-12)


# ---------------------------------------------------------------------- captions and stops
class _Picture(ex.Exposed):
    def __init__(self, exposure, mode, reference):
        self.exposure, self.exposure_mode, self.exposure_reference = exposure, mode, reference


def test_stops_are_log2_of_the_multiplier_and_of_its_ratio_to_the_reference():
    p = _Picture(8.0, "auto", 2.0)
    assert p.exposure_ev == 3.0 and p.exposure_vs_reference_ev == 2.0
    assert _Picture(0.25, "given", 1.0).exposure_ev == -2.0
    assert _Picture(0.25, "given", 1.0).exposure_vs_reference_ev == -2.0
    assert p.exposure_caption == "+2.0 EV over the bench reference (auto: brightened to this scene)"


def test_the_reference_caption_says_a_dimmer_scene_looks_dimmer():
    text = "bench reference exposure (one for every scene: a dimmer scene looks dimmer)"
    assert ex.exposure_caption("reference", 0.0) == text
    assert ex.exposure_caption("reference", 1.7) == text  # the mode decides, not the stops
    assert _Picture(1.0, "reference", 1.0).exposure_caption == text


@pytest.mark.parametrize("mode, ev, caption", [
    ("auto", 0.0, "bench reference exposure (auto: brightened to this scene)"),
    ("auto", 0.0499, "bench reference exposure (auto: brightened to this scene)"),
    ("auto", -0.0499, "bench reference exposure (auto: brightened to this scene)"),
    ("auto", 0.05, "+0.1 EV over the bench reference (auto: brightened to this scene)"),
    ("auto", 1.64, "+1.6 EV over the bench reference (auto: brightened to this scene)"),
    ("given", 0.0, "bench reference exposure (given)"),
    ("given", -0.05, "-0.1 EV over the bench reference (given)"),
    ("given", -2.26, "-2.3 EV over the bench reference (given)"),
])
def test_other_captions_say_how_many_stops_over_the_reference_and_why(mode, ev, caption):
    assert ex.exposure_caption(mode, ev) == caption


# ---------------------------------------------------------------------- choose_exposure
VIEWS = [CameraView("front", (0.0, 0.0, 1.0)), CameraView("side", (1.0, 0.0, 0.0))]


def test_reference_is_the_looks_reference():
    s = _lamps([[0, 0, 1]], [1.0])
    for studio in (None, Studio()):
        ref = ex.reference_exposure(studio)
        assert ex.choose_exposure("reference", studio, s, VIEWS, np.zeros((2, 2, 3))) == ex.ExposureChoice(
            ref, "reference", ref, "reference")


def test_auto_in_the_diagram_look_meters_the_image_reading_nan_as_black():
    # lit pixels' brightest channel: 0.5 everywhere but one pixel whose red is NaN and green 4:
    # read as (0, 4, 0), its 4 lifts the 99.5th percentile of the 4 lit peaks to 3.955
    image = np.array([[[0.5, 0.1, 0.0], [0.2, 0.5, 0.3]],
                      [[float("nan"), 4.0, 0.0], [0.0, 0.0, 0.5]]])
    out = ex.choose_exposure("auto", None, _lamps([[0, 0, 1]], [1.0]), VIEWS, image)
    assert out.mode == "auto" and out.metering == "image" and out.reference == ex.reference_exposure(None)
    assert out.value == pytest.approx(2.0 / np.percentile([0.5, 0.5, 4.0, 0.5], 99.5), rel=1e-12)


def test_auto_in_the_diagram_look_of_a_black_image_is_one():
    out = ex.choose_exposure("auto", None, _lamps([[0, 0, 1]], [1.0]), VIEWS, np.full((2, 2, 3), -1.0))
    assert out.value == 1.0 and out.metering == "image"


def test_auto_in_the_studio_meters_the_lights_towards_the_first_camera():
    s = _lamps([[0, 0, 1], [1, 0, 0]], [4.0, 2.0])
    studio = Studio(tent_share=0.0)
    out = ex.choose_exposure("auto", studio, s, VIEWS, np.zeros((2, 2, 3)))
    # the first camera faces +Z: the overhead lamp's 2 (not the side camera's 1)
    assert out == ex.ExposureChoice(pytest.approx(math.pi / 2.0 * 2.0 ** -1.75, rel=1e-9), "auto",
                                    ex.reference_exposure(studio), "incident")
    # an irradiance the caller already has is used as it is
    given = ex.choose_exposure("auto", studio, s, VIEWS, np.zeros((2, 2, 3)), irradiance=8.0)
    assert given.value == pytest.approx(math.pi / 8.0 * 2.0 ** -1.75, rel=1e-12) and given.metering == "incident"


def test_a_given_multiplier_is_used_and_checked():
    s = _lamps([[0, 0, 1]], [1.0])
    out = ex.choose_exposure(2.5, Studio(), s, VIEWS, np.zeros((2, 2, 3)))
    assert out == ex.ExposureChoice(2.5, "given", ex.reference_exposure(Studio()), "given")
    with pytest.raises(ParameterError, match="exposure must be a finite number > 0"):
        ex.choose_exposure(-2.0, None, s, VIEWS, np.zeros((2, 2, 3)))


def test_a_studio_without_its_tent_has_no_environment_under_lamps_alone():
    from labcut.rendering.studio import irradiance_at_camera, lamps_of, studio_environment

    s = _lamps([[0, 0, 1]], [1.0])
    # tent_share 0 is a legal studio (its range is [0, 10]): lamps in a dark room, not a black map refused
    assert studio_environment(s, Studio(tent_share=0.0), 1.0) is None
    assert irradiance_at_camera(lamps_of(s.lights), None, [0, 0, 1], 3.0) == pytest.approx(3.0, rel=1e-12)
    # a scenario's own map stays, without the tent
    env = studio_environment(_grey_map(), Studio(tent_share=0.0), 1.0)
    assert env is not None and env.name == "grey" and np.allclose(env.radiance, 2.0)
