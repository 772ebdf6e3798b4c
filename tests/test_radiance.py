"""The flash threshold relative to the scene (labcut/orientation/radiance.py, docs/orientation.md):
``L_ref`` the unit, ``P`` the brightest schiller the scene's own lights can give a flat face."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import labcut
from labcut.orientation.problem import build_problem
from labcut.orientation.radiance import (flash_threshold, flat_face_schiller, reference_radiance, scene_peak,
                                         sky_schiller)
from labcut.orientation.scoring import Scorer
from labcut.scene import Lights, Scenario, Views
from labcut.scene.directions import direction

LAB = labcut.Labradorite.preset("blue")


@settings(max_examples=25, deadline=None)
@given(st.floats(0.0, 85.0), st.floats(0.0, 360.0))
def test_one_point_light_gives_the_reference_flash_facing_it(tilt, azimuth):
    # L_ref's own definition: the face turned to the lamp, seen along its normal
    d = direction(tilt, azimuth)
    lamp = Lights.lamp(d, 0.0, 1.0, 1)
    assert flat_face_schiller(LAB, lamp, d[None])[0] == pytest.approx(1.0, rel=1e-9)
    assert scene_peak(LAB, lamp) == pytest.approx(1.0, rel=1e-9)
    # a face turned away sees the lamp further out in its lobe (σ 3° inside the stone: about 9°
    # outside, the light's internal direction turning twice the lamella's angle)
    away = [flat_face_schiller(LAB, lamp, direction(tilt + a if tilt < 50 else tilt - a, azimuth)[None])[0]
            for a in (5.0, 10.0, 30.0)]
    assert 0.8 < away[0] < 0.92 and 0.45 < away[1] < 0.65 and 0.0 < away[2] < 0.02


def test_the_irradiance_is_the_scenes_own_whatever_its_scale():
    d = direction(20.0, 40.0)
    assert scene_peak(LAB, Lights.lamp(d, 0.0, 7.5, 1)) == pytest.approx(1.0)
    assert flat_face_schiller(LAB, Lights.lamp(d, 3.0, 7.5, 9), d[None])[0] == pytest.approx(
        flat_face_schiller(LAB, Lights.lamp(d, 3.0, 1.0, 9), d[None])[0])


def test_a_wider_lamp_spreads_its_light_over_more_than_the_lobe():
    peaks = [scene_peak(LAB, Lights.lamp([0, 0, 1], r, 1.0, 400)) for r in (0.0, 2.0, 8.0, 20.0)]
    assert peaks[0] == pytest.approx(1.0) and all(a > b for a, b in zip(peaks, peaks[1:]))
    assert 0.6 < peaks[2] < 0.95 and peaks[3] < 0.5


def test_the_sky_term_is_the_lobe_summed_over_a_densely_sampled_sky():
    # an independent route: a uniform sky of unit radiance as 40,000 point lights (equal solid angle
    # over the upper hemisphere) summed on the face seen from straight above
    n = 40_000
    i = np.arange(n) + 0.5
    z = 1.0 - i / n
    r = np.sqrt(1.0 - z * z)
    phi = i * math.pi * (3.0 - math.sqrt(5.0))
    dirs = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    sky = Lights(dirs, np.full(n, 2.0 * math.pi / n))
    points = flat_face_schiller(LAB, sky, np.array([[0.0, 0.0, 1.0]]))[0] * sky.total_irradiance
    assert sky_schiller(LAB) == pytest.approx(points, rel=0.01)


def test_an_environment_counts_as_the_map_not_as_its_samples():
    ceiling = [scene_peak(LAB, Lights.preset("ceiling", q)) for q in ("draft", "standard", "high")]
    assert ceiling[0] == pytest.approx(ceiling[1], rel=1e-12) == ceiling[2]
    # the ceiling's brightest direction is the zenith (radiance ∝ cos θ): K Y(zenith) / E
    ceil = Lights.preset("ceiling", "standard")
    env = ceil.environment
    y_top = float(env.luminance()[0].mean())
    assert ceiling[0] == pytest.approx(sky_schiller(LAB) * y_top / ceil.total_irradiance, rel=0.03)
    assert ceiling[0] < 0.1  # a few hundredths: no direction gathers more than a lobe's worth of an even ceiling


def test_the_peak_does_not_depend_on_the_frame():
    office = Lights.preset("office", "draft")
    turn = labcut.scene.directions.rotation([1.0, 0.3, 0.0], 70.0)
    assert scene_peak(LAB, office.rotated(turn)) == pytest.approx(scene_peak(LAB, office), rel=2e-3)


def test_a_scenarios_poses_and_main_setting_find_the_peak_once(monkeypatch, fresh_user_cache):
    # P does not depend on the frame: the lights' turned copies share it (Lights.invariants)
    from labcut.orientation import radiance

    calls = []
    real = radiance._scene_peak
    monkeypatch.setattr(radiance, "_scene_peak", lambda m, l: calls.append(l) or real(m, l))
    sc = Scenario.preset("pendant", "draft")
    peaks = {scene_peak(LAB, st.lights) for st in sc.settings()} | {scene_peak(LAB, sc.main_setting().lights)}
    assert len(calls) == 1 and len(peaks) == 1
    assert scene_peak(LAB, Lights.preset("room", "draft")) == pytest.approx(peaks.pop(), rel=1e-6) and len(calls) == 2  # anew


def test_a_light_behind_the_face_gives_nothing():
    lights = Lights.lamp([0, 0, 1], 0.0, 1.0, 1)
    assert flat_face_schiller(LAB, lights, np.array([[0.0, 0.0, -1.0]]))[0] == 0.0
    assert reference_radiance(LAB, 2.0) == pytest.approx(2.0 * reference_radiance(LAB, 1.0))


def test_every_scenarios_threshold_lies_between_the_ceilings_and_one_lamps():
    peaks = {name: scene_peak(LAB, Scenario.preset(name, "draft").lights) for name in labcut.scene.SCENARIOS.names()}
    assert all(0.0 < p <= 1.0 for p in peaks.values()), peaks
    assert peaks["bench"] > peaks["display"] > peaks["ring"]


@pytest.fixture(scope="module")
def ring_problem():
    mesh = labcut.load_mesh("meshes/oval-16x12-low.ply")
    sc = Scenario.preset("ring", "draft")
    return build_problem(mesh, LAB, quality="draft", tau=0.1, settings=sc.settings()), sc


def test_the_problem_holds_the_scenes_threshold_and_its_area_uses_it(ring_problem):
    p, sc = ring_problem
    assert p.threshold == pytest.approx(flash_threshold(LAB, sc.lights, 0.1)) and p.threshold < 0.1 * 0.2
    scorer = Scorer(p)
    m = np.array([0.0, 0.0, 1.0])
    radiance = p.pair_radiance(m[None])[:, 0]
    w = p.pair_alpha
    by_hand = float((w * (radiance >= p.threshold)).sum())
    against_a_lamp = float((w * (radiance >= p.tau)).sum())
    metrics = scorer.metrics(m)
    assert metrics.flash_area == pytest.approx(by_hand, rel=1e-6) and by_hand > against_a_lamp + 0.05


def test_lights_built_again_find_their_peak_by_content(monkeypatch, fresh_user_cache):
    """The same lights made anew (a scenario resolved again, a rough plan's candidates) reuse the
    scene peak found for the first: one search per content and material, not per object; other
    lights or another material search again."""
    import labcut
    import labcut.orientation.radiance as rad

    calls = []
    real = rad._scene_peak
    monkeypatch.setattr(rad, "_scene_peak", lambda m, l: calls.append(l.name) or real(m, l))
    monkeypatch.setattr(rad, "_PEAKS", {})
    lab = labcut.Labradorite.preset("blue")
    first = rad.scene_peak(lab, labcut.Lights.preset("room", "draft"))
    again = rad.scene_peak(lab, labcut.Lights.preset("room", "draft"))
    assert again == first and calls == ["room"]
    rad.scene_peak(lab, labcut.Lights.preset("room", "standard"))  # more window directions: other content
    rad.scene_peak(labcut.Labradorite.preset("gold"), labcut.Lights.preset("room", "draft"))
    assert calls == ["room", "room", "room"]


def test_the_compass_search_finds_a_lobes_peak_from_nearby_starts_and_across_the_pole():
    from labcut.orientation.radiance import PEAK_TOL_DEG, polish_peak
    from labcut.scene.directions import direction

    for centre in (direction(0.0, 0.0), direction(37.0, 123.0), direction(179.0, 10.0)):
        f = lambda d, c=centre: np.exp(400.0 * (d @ c - 1.0))  # a lobe about 3° wide, peak 1 at c  # noqa: E731
        starts = np.array([direction(90.0, 0.0), direction(8.0, 45.0), direction(60.0, 200.0)])
        # rotate the starts so that the nearest lies 6° from the centre
        near = centre * math.cos(math.radians(6.0)) + np.cross(centre, [0.3, 0.4, 0.5]) / np.linalg.norm(np.cross(centre, [0.3, 0.4, 0.5])) * math.sin(math.radians(6.0))
        starts[1] = near / np.linalg.norm(near)
        got = polish_peak(f, starts, f(starts))
        # within the stopping step of the peak: 1 - exp(-400 (1 - cos tol)) of the value
        assert 1.0 - 400.0 * (1.0 - math.cos(math.radians(PEAK_TOL_DEG))) <= got <= 1.0
        assert got > f(starts).max() + 0.5  # it moved


def test_the_scene_peak_is_the_brightest_face_of_a_fine_sphere():
    """P against brute force: the largest flat-face schiller over 40,000 face directions (about 1°
    apart), near which P must lie and which it must not fall below by more than the grid's miss."""
    from labcut.orientation.radiance import _scene_peak
    from labcut.scene.directions import direction, spherical_cap

    faces = spherical_cap([0.0, 0.0, 1.0], 180.0, 40000)
    for lights in (Lights.lamp(direction(40.0, 30.0), 8.0, 1.0, 13), Lights.preset("room", "draft"),
                   Lights.lamp(direction(20.0, 250.0), 0.0, 1.0, 1)):
        brute = float(flat_face_schiller(LAB, lights, faces).max())
        peak = _scene_peak(LAB, lights)
        assert brute * (1 - 1e-9) <= peak <= brute * 1.01, (lights.name, peak, brute)
