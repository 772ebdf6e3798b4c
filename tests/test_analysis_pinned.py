"""``labcut.reports.analysis`` pinned by hand (issue 37, mutation testing): the tilt axes, the tilt
curve's angles, poses, views and masking, the per-view flash of a toy flash problem, the compromise
of analytic energy maps (its tolerance, its tolerance by axis, "parallel to the base") and the
polishing cap. Every expected number is worked out from the definitions in the docstrings on toy
inputs small enough to do by hand; no mesh is built, so the file runs in about a second.
"""

from __future__ import annotations

import inspect
import math
from types import SimpleNamespace

import numpy as np
import pytest

from labcut.errors import ParameterError
from labcut.reports import analysis as A
from labcut.scene import Lights, Scenario, Views
from labcut.scene.quality import Quality

LN09 = math.log(0.9)


def rot(axis: str, deg: float) -> np.ndarray:
    """The right-handed rotation about a coordinate axis, written out (not labcut's ``rotation``)."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return {"x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
            "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


def scenario(main, pose=None, rock=0.0, sway=0.0, lights=((0.0, 0.0, 1.0),)) -> Scenario:
    """A scenario of one viewer (``main``, world frame) and the given lights."""
    return Scenario("toy", np.eye(3) if pose is None else pose, Lights(list(lights)), Views([main]), rock, sway)


# ---------------------------------------------------------------------- tilt axes
def test_tilt_axes_of_a_viewer_straight_above_are_x_and_y():
    """Straight above, the cross product with +Z vanishes: front-back is world +X and side-to-side
    ``v x X`` = +Y (the picture's up for a top view is the stone's far edge)."""
    axes = A.tilt_axes(scenario([0.0, 0.0, 1.0]))
    assert set(axes) == {"front_back", "side_to_side"}
    assert np.array_equal(axes["front_back"], [1.0, 0.0, 0.0])
    assert np.allclose(axes["side_to_side"], [0, 1, 0], atol=1e-15)


def test_tilt_axes_of_a_viewer_in_front_60_degrees_up():
    """v = (0, -0.6, 0.8): ``Z x v`` = (0.6, 0, 0), made unit: +X; ``v x X`` = (0, 0.8, 0.6), the
    picture's up (towards the stone's top, away from the viewer's feet)."""
    axes = A.tilt_axes(scenario([0.0, -0.6, 0.8]))
    assert np.allclose(axes["front_back"], [1.0, 0.0, 0.0], atol=1e-15)
    assert np.allclose(axes["side_to_side"], [0.0, 0.8, 0.6], atol=1e-15)


def test_tilt_axes_of_a_viewer_on_the_right():
    """v = (0.6, 0, 0.8) (from +X): ``Z x v`` = (0, 0.6, 0), unit +Y; ``v x Y`` = (-0.8, 0, 0.6)."""
    axes = A.tilt_axes(scenario([0.6, 0.0, 0.8]))
    assert np.allclose(axes["front_back"], [0.0, 1.0, 0.0], atol=1e-15)
    assert np.allclose(axes["side_to_side"], [-0.8, 0.0, 0.6], atol=1e-15)


@pytest.mark.parametrize("x, expected", [(5e-7, [1.0, 0.0, 0.0]), (8e-7, [1.0, 0.0, 0.0]), (2e-6, [0.0, 1.0, 0.0]),
                                         (0.5, [0.0, 1.0, 0.0])])
def test_a_viewer_within_1e_6_of_the_vertical_counts_as_straight_above(x, expected):
    """Only a horizontal part below 1e-6 falls back to +X; a viewer 2e-6 off the vertical towards +X
    already has its own axis ``Z x v`` = +Y."""
    v = np.array([x, 0.0, 1.0])
    axes = A.tilt_axes(scenario(v / np.linalg.norm(v)))
    assert np.allclose(axes["front_back"], expected, atol=1e-12)


def test_tilted_pose_turns_the_rest_pose_about_the_world_axis():
    """The tilted pose is R(world axis, angle) @ rest pose, not rest pose @ R: with the rest pose a
    quarter turn about Z and a top viewer (front-back = +X), 90 degrees front-back is Rx(90) Rz(90)."""
    sc = scenario([0.0, 0.0, 1.0], pose=rot("z", 90.0))
    assert np.allclose(A.tilted_pose(sc, "front_back", 90.0), rot("x", 90.0) @ rot("z", 90.0), atol=1e-12)
    assert np.allclose(A.tilted_pose(sc, "side_to_side", -30.0), rot("y", -30.0) @ rot("z", 90.0), atol=1e-12)
    assert not np.allclose(rot("x", 90.0) @ rot("z", 90.0), rot("z", 90.0) @ rot("x", 90.0))


# ---------------------------------------------------------------------- tilt settings
def test_tilt_angles_span_plus_minus_30_degrees_in_the_quality_step():
    """Draft steps 10 degrees, standard 7.5, high 5: -30 to +30 with both ends, by name or Quality."""
    sc = scenario([0.0, 0.0, 1.0])
    assert A.TILT_RANGE_DEG == 30.0
    for quality, count in (("draft", 7), ("standard", 9), (Quality.PRESETS["high"], 13)):
        angles, settings, seen = A.tilt_settings(sc, quality)
        step = 60.0 / (count - 1)
        assert np.allclose(angles, [-30.0 + step * i for i in range(count)], atol=1e-12)
        assert angles[0] == -30.0 and angles[-1] == pytest.approx(30.0, abs=1e-12)
        assert len(settings) == len(seen) == 2 * count
    angles, _, _ = A.tilt_settings(sc)  # default: standard
    assert len(angles) == 9
    assert A.TILT_POINTS == {"draft": 1000, "standard": 2000, "high": 5000}


@pytest.mark.parametrize("step, count, last", [(0.5, 121, 30.0), (7.0, 9, 28.0), (12.0, 5, 24.0), (25.0, 3, 25.0),
                                               (30.0, 3, 30.0)])
def test_tilt_angles_of_any_step_are_whole_steps_from_the_rest_pose(step, count, last):
    """A quality given as a dict may take any step: the angles are whole steps either side of 0
    (the rest pose, which :meth:`TiltCurve.at_rest` reads) and stay within +-30 degrees: step 7 gives
    -28 ... 28 (the range's arange gave -30 ... 33 without 0), 12 gives -24 ... 24 (not -30, -18,
    -6, 6, ...), 0.5 the 121 angles -30 ... 30."""
    q = Quality.PRESETS["draft"].to_dict()
    q["tilt_step_deg"] = step
    angles, settings, _ = A.tilt_settings(scenario([0.0, 0.0, 1.0]), q)
    assert len(angles) == count and len(settings) == 2 * count
    assert angles[-1] == last and angles[0] == -last and 0.0 in angles
    assert np.allclose(np.diff(angles), step, rtol=1e-12)


def test_tilt_settings_views_poses_and_lights_by_hand():
    """A viewer 60 degrees from the vertical, in front (v = (0, -sin 60, cos 60)), rest pose a turn of
    30 degrees about Z. Tilting front-back (about +X) by a moves the viewer, seen from the stone, to
    60 - a degrees from its face (``y = -sin(60 - a)``, ``z = cos(60 - a)``), then the rest pose's
    turn of -30 degrees about Z; side-to-side (about (0, cos 60, sin 60), across the line of sight)
    by a gives ``v cos a - X sin a``. At a = -30 front-back the viewer is at 90 degrees: edge-on, so
    unseen, with the placeholder view straight at the face. Each setting: the scenario's lights
    turned into the mesh frame (``pose.T @ light``), the one view named "main", weight 1, the pose."""
    s60, c60 = math.sin(math.radians(60)), 0.5
    pose0 = rot("z", 30.0)
    sc = scenario([0.0, -s60, c60], pose=pose0, lights=((0.0, 0.0, 1.0), (0.6, 0.0, 0.8)))
    angles, settings, seen = A.tilt_settings(sc, "draft")
    assert seen == [False] + [True] * 13
    lights_world = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    for i, a in enumerate(angles):
        for key, j in (("front_back", i), ("side_to_side", 7 + i)):
            st = settings[j]
            if key == "front_back":
                t = math.radians(60.0 - a)
                world_turn = rot("x", a)
                v = rot("z", -30.0) @ np.array([0.0, -math.sin(t), math.cos(t)])
            else:
                ar = math.radians(a)
                world_turn = None
                v = rot("z", -30.0) @ (np.array([0.0, -s60, c60]) * math.cos(ar) - np.array([1.0, 0.0, 0.0]) * math.sin(ar))
            if world_turn is not None:
                assert np.allclose(st.pose, world_turn @ pose0, atol=1e-12)
            if seen[j]:
                assert np.allclose(st.views.directions[0], v, atol=1e-12), (key, a)
            else:
                assert np.allclose(v, [v[0], v[1], 0.0], atol=1e-12)  # edge-on indeed
                assert np.array_equal(st.views.directions[0], [0.0, 0.0, 1.0])
            assert st.views.name == "main" and len(st.views) == 1 and st.weight == 1.0
            assert np.allclose(st.lights.directions, lights_world @ st.pose, atol=1e-12)


@pytest.mark.parametrize("theta, first_seen", [(59.97, False), (59.9, True)])
def test_a_face_seen_within_1e_3_of_edge_on_counts_as_edge_on(theta, first_seen):
    """At -30 degrees front-back a viewer ``theta`` from the vertical sits at ``theta + 30`` from the
    face: 89.97 degrees (cos = 5.2e-4, below the 1e-3 edge-on limit) is unseen, 89.9 (1.7e-3) seen."""
    t = math.radians(theta)
    _, settings, seen = A.tilt_settings(scenario([0.0, -math.sin(t), math.cos(t)]), "draft")
    assert seen[0] is first_seen and all(seen[1:])
    expected_z = 1.0 if not first_seen else math.cos(math.radians(theta + 30.0))
    assert settings[0].views.directions[0][2] == pytest.approx(expected_z, abs=1e-12)


# ---------------------------------------------------------------------- per-view flash of a toy problem
def toy_problem(dtype=np.float32) -> SimpleNamespace:
    """Three (light, view, point) terms in three pairs of two views plus an empty third view.
    kappa = ln 2 and q_norm = 2: the lobe density is 2 at |h.m| = 1 and 2 exp(-ln 2) = 1 at 0."""
    return SimpleNamespace(
        h=np.array([[0, 0, 1], [1, 0, 0], [0, 0, -1]], dtype=dtype), kappa=math.log(2.0), q_norm=2.0,
        c=np.array([1.0, 3.0, 0.5], dtype=dtype), pair=np.array([0, 0, 1]), pair_view=np.array([0, 1, 1]),
        pair_weight=np.array([0.5, 2.0, 4.0]), view_weight=np.array([0.2, 0.3, 0.5]), threshold=1.0)


def test_per_view_flash_of_a_toy_problem_by_hand():
    """q = (2, 1, 2) (the third term's h is -m: axial, full density); c q = (2, 3, 1); pair radiances
    (2 + 3, 1, 0) (the third pair has no term); energy per view = sum of pair weight x radiance:
    (0.5 x 5, 2 x 1 + 4 x 0, 0) = (2.5, 2, 0); area = the weights of the pairs at or above the
    threshold 1: (0.5, 2, 0) (the radiance exactly 1 counts). The normal (0, 0, 2) is made unit."""
    energy, area = A.per_view_flash(toy_problem(), np.array([0.0, 0.0, 2.0]))
    assert energy.dtype == np.float64 and energy.shape == (3,)
    assert np.allclose(energy, [2.5, 2.0, 0.0], rtol=1e-15, atol=0)
    assert np.allclose(area, [0.5, 2.0, 0.0], rtol=1e-15, atol=0)


def test_per_view_flash_in_float64_from_float32_terms():
    """A float32 problem is evaluated in float64: c = 0.1 in float32 is 0.10000000149..., and the
    energy of the first view is exactly 0.5 x 2 x float32(0.1) x 2... computed in float64."""
    p = toy_problem()
    p.c = np.array([0.1, 0.0, 0.0], dtype=np.float32)
    energy, _ = A.per_view_flash(p, np.array([0.0, 0.0, 1.0]))
    assert energy[0] == 0.5 * 2.0 * float(np.float32(0.1))


def test_per_view_flash_reads_a_float32_normal_in_float64():
    """A float32 normal is made unit in float64: the answer is the float64 one of the same numbers
    (normalised in float32 it differs in the eighth digit)."""
    p = np.array([0.3, 0.4, 0.866], dtype=np.float32)
    p32 = toy_problem()
    p32.h = np.array([[0.6, 0.0, 0.8], [0.0, 0.6, 0.8], [0.0, 0.0, 1.0]])
    e32, _ = A.per_view_flash(p32, p)
    e64, _ = A.per_view_flash(p32, p.astype(np.float64))
    assert np.allclose(e32, e64, rtol=1e-14, atol=0)


# ---------------------------------------------------------------------- TiltCurve
def curve(**kw) -> A.TiltCurve:
    base = dict(angles_deg=np.array([-10.0, 0.0, 10.0]),
                flash_energy={"front_back": np.array([1.0, 2.0, 3.0]), "side_to_side": np.array([7.0, 8.0, 9.0])},
                flash_area={"front_back": np.array([4.0, 5.0, np.nan]), "side_to_side": np.array([np.inf, 6.0, 0.5])},
                axes={"front_back": np.array([1.0, 0.0, 0.0]), "side_to_side": np.array([0.0, 1.0, 0.0])},
                surface_points=1000)
    base.update(kw)
    return A.TiltCurve(**base)


def test_at_rest_reads_the_front_back_value_at_angle_zero():
    c = curve()
    assert c.at_rest() == 2.0 and c.at_rest("flash_area") == 5.0
    assert curve(angles_deg=np.array([0.0, 10.0, 20.0])).at_rest() == 1.0
    assert c.rock_deg == 0.0 and c.sway_deg == 0.0 and c.notes == []


def test_tilt_curve_to_dict_whole():
    """Every key; NaN and infinity become None (JSON has neither), the rest plain floats."""
    c = curve(rock_deg=5.0, sway_deg=2.0, notes=["a note"])
    d = c.to_dict()
    assert d == {
        "angles_deg": [-10.0, 0.0, 10.0],
        "flash_energy": {"front_back": [1.0, 2.0, 3.0], "side_to_side": [7.0, 8.0, 9.0]},
        "flash_area": {"front_back": [4.0, 5.0, None], "side_to_side": [None, 6.0, 0.5]},
        "axes_world": {"front_back": [1.0, 0.0, 0.0], "side_to_side": [0.0, 1.0, 0.0]},
        "surface_points": 1000, "scenario_rock_deg": 5.0, "scenario_sway_deg": 2.0, "notes": ["a note"],
    }
    assert all(type(x) is float for x in d["flash_energy"]["front_back"])
    d["notes"].append("x")
    assert c.notes == ["a note"]


# ---------------------------------------------------------------------- tilt_curve's assembly
@pytest.fixture
def fake_problem(monkeypatch):
    """``build_problem`` and ``per_view_flash`` replaced: the calls recorded, the per-view values
    0, 1, 2, ... (energy) and 100, 101, ... (area), one per tilted pose."""
    calls = []

    def build(mesh, material, **kw):
        calls.append((mesh, material, kw))
        return kw["settings"]

    monkeypatch.setattr(A, "build_problem", build)
    def flash(settings, normal):
        calls.append(("normal", normal))
        return np.arange(len(settings), dtype=float), 100.0 + np.arange(len(settings))

    monkeypatch.setattr(A, "per_view_flash", flash)
    return calls


def test_tilt_curve_builds_one_problem_of_every_tilted_pose(fake_problem):
    """One problem: the quality's tilt_points samples, tau and seed passed on, the 2 x 7 settings of
    :func:`tilt_settings`; front-back the first 7 values, side-to-side the next 7; the edge-on pose
    (-30 front-back for a viewer 60 degrees out) NaN, with the note saying how many."""
    t = math.radians(60.0)
    sc = scenario([0.0, -math.sin(t), math.cos(t)], rock=4.0, sway=3.0)
    normal = np.array([0.0, 0.6, 0.8])
    tc = A.tilt_curve("mesh", "material", normal, sc, "draft", tau=0.2, seed=7)
    (mesh, material, kw), (_, given) = fake_problem
    assert given is normal
    assert (mesh, material) == ("mesh", "material")
    assert kw["quality"].name == "draft" and kw["tau"] == 0.2 and kw["seed"] == 7 and kw["n_points"] == 1000
    assert len(kw["settings"]) == 14
    assert np.array_equal(tc.angles_deg, np.arange(-30.0, 31.0, 10.0))
    assert np.array_equal(tc.flash_energy["front_back"], [np.nan, 1, 2, 3, 4, 5, 6], equal_nan=True)
    assert np.array_equal(tc.flash_energy["side_to_side"], np.arange(7.0, 14.0))
    assert np.array_equal(tc.flash_area["front_back"], [np.nan, 101, 102, 103, 104, 105, 106], equal_nan=True)
    assert np.array_equal(tc.flash_area["side_to_side"], 100.0 + np.arange(7.0, 14.0))
    assert tc.notes == ["at 1 tilt(s) the main viewer sees the face edge-on or from behind (no value)"]
    assert tc.surface_points == 1000 and (tc.rock_deg, tc.sway_deg) == (4.0, 3.0)
    assert np.allclose(tc.axes["front_back"], [1, 0, 0]) and set(tc.axes) == {"front_back", "side_to_side"}


def test_tilt_curve_defaults_and_a_curve_seen_everywhere(fake_problem):
    """Defaults: standard quality (2000 samples, 9 angles), tau 0.1, seed 0; no note when every pose
    is seen."""
    tc = A.tilt_curve("m", "x", np.array([0.0, 0.0, 1.0]), scenario([0.0, 0.0, 1.0]))
    (_, _, kw), _ = fake_problem
    assert kw["quality"].name == "standard" and kw["tau"] == 0.1 and kw["seed"] == 0 and kw["n_points"] == 2000
    assert tc.notes == [] and tc.surface_points == 2000
    assert np.array_equal(tc.flash_energy["front_back"], np.arange(9.0))


def test_tilt_curve_where_no_light_reaches_the_viewer(monkeypatch):
    """``build_problem`` refusing (no light reaches what the viewer sees): zeros, NaN where unseen,
    and both notes, word for word, in that order."""
    def refuse(*a, **k):
        raise ParameterError("no light")

    monkeypatch.setattr(A, "build_problem", refuse)
    t = math.radians(60.0)
    tc = A.tilt_curve("m", "x", np.array([0.0, 0.0, 1.0]), scenario([0.0, -math.sin(t), math.cos(t)]), "draft")
    assert np.array_equal(tc.flash_energy["front_back"], [np.nan] + [0.0] * 6, equal_nan=True)
    assert np.array_equal(tc.flash_energy["side_to_side"], [0.0] * 7)
    assert np.array_equal(tc.flash_area["side_to_side"], [0.0] * 7)
    assert tc.notes == ["no light of the scenario reaches what its main viewer sees at any of these tilts",
                        "at 1 tilt(s) the main viewer sees the face edge-on or from behind (no value)"]


# ---------------------------------------------------------------------- compromise of analytic maps
class Gauss:
    """A toy energy map ``amp exp(-(ax x^2 + ay y^2))`` of unit normals (x, y, z): its peak at the
    pole, falling ``ax`` fast towards the sides (X) and ``ay`` towards the front and back (Y)."""

    def __init__(self, ax, ay, amp=1.0):
        self.ax, self.ay, self.amp = ax, ay, amp

    def energy_map(self, normals):
        n = np.atleast_2d(normals)
        return self.amp * np.exp(-(self.ax * n[:, 0] ** 2 + self.ay * n[:, 1] ** 2))


class Lobe:
    """A toy energy map ``amp exp(k (n.p - 1))`` peaked at the unit axis ``p`` (isotropic)."""

    def __init__(self, p, k, amp=1.0):
        self.p, self.k, self.amp = np.asarray(p, float) / np.linalg.norm(p), k, amp

    def energy_map(self, normals):
        return self.amp * np.exp(self.k * (np.atleast_2d(normals) @ self.p - 1.0))


def tilted(deg, towards="x"):
    t = math.radians(deg)
    return np.array([math.sin(t), 0.0, math.cos(t)]) if towards == "x" else np.array([0.0, math.sin(t), math.cos(t)])


@pytest.mark.parametrize("args", [([], [], []), ([Gauss(1, 1)], ["a", "b"], [tilted(0)]),
                                  ([Gauss(1, 1), Gauss(1, 1)], ["a", "b"], [tilted(0)])])
def test_compromise_needs_one_scorer_name_and_optimum_per_scenario(args):
    with pytest.raises(ParameterError) as err:
        A.compromise(*args)
    assert str(err.value) == "compromise needs one scorer, name and optimum per scenario"


@pytest.mark.parametrize("amp", [0.0, -1.0])
def test_compromise_needs_a_positive_energy_at_each_optimum(amp):
    with pytest.raises(ParameterError) as err:
        A.compromise([Gauss(1, 1), Gauss(1, 1, amp)], ["a", "b"], [tilted(0), tilted(0)], "draft")
    assert str(err.value) == "compromise needs a positive energy at every scenario's optimum"


def test_compromise_of_one_scenario_is_its_optimum_with_tolerances_by_hand():
    """One scenario: the normal is its optimum (the lower sign of the axis given, -Z, read as +Z),
    score and relative 1. ``exp(-a sin^2 d) = 0.9`` gives the tolerance towards each side:
    ``asin(sqrt(-ln 0.9 / a))``: 5.892 degrees towards X (a = 10), 2.942 towards Y (a = 40); in any
    direction the smaller. At the pole, "parallel to the base" holds as far as the tolerance."""
    cp = A.compromise([Gauss(10.0, 40.0, amp=3.0)], ["only"], [np.array([0.0, 0.0, -2.0])], "draft")
    assert np.array_equal(cp.normal, [0.0, 0.0, 1.0])
    assert cp.score == 1.0 and cp.relative == {"only": 1.0}
    x = math.degrees(math.asin(math.sqrt(-LN09 / 10.0)))
    y = math.degrees(math.asin(math.sqrt(-LN09 / 40.0)))
    assert (x, y) == (pytest.approx(5.892, abs=1e-3), pytest.approx(2.942, abs=1e-3))
    assert set(cp.tolerance_by_axis) == {"front_back_deg", "left_right_deg"}
    assert cp.tolerance_by_axis["left_right_deg"] == pytest.approx(x, abs=0.05)
    assert cp.tolerance_by_axis["front_back_deg"] == pytest.approx(y, abs=0.05)
    assert cp.tolerance_deg == pytest.approx(y, abs=0.05)
    assert cp.parallel_within_deg == cp.tolerance_deg


class Local:
    """A toy energy map peaked at the unit normal ``p``: ``exp(-(a u^2 + b w^2))`` in the tangent
    coordinates u = n.tu, w = n.tw of two unit tangents at ``p``; ``a`` and ``b`` may be pairs
    (towards +tu, -tu), (towards +tw, -tw) for a lopsided peak."""

    def __init__(self, p, tu, tw, a, b):
        self.p, self.tu, self.tw = (np.asarray(x, float) for x in (p, tu, tw))
        self.a, self.b = (x if isinstance(x, tuple) else (x, x) for x in (a, b))

    def energy_map(self, normals):
        n = np.atleast_2d(normals)
        u, w = n @ self.tu, n @ self.tw
        a = np.where(u >= 0, self.a[0], self.a[1])
        b = np.where(w >= 0, self.b[0], self.b[1])
        return np.exp(-(a * u ** 2 + b * w ** 2))


def side_tol(alpha):
    """Degrees from the peak along a tangent where ``exp(-alpha sin^2 d)`` falls to 0.9."""
    return math.degrees(math.asin(math.sqrt(-LN09 / alpha)))


@pytest.mark.parametrize("towards", ["x", "y"])
def test_tolerance_by_axis_off_the_pole_is_along_the_world_axes(towards):
    """At a normal 30 degrees off the pole, "front/back" leans it towards world +-Y and "left/right"
    towards +-X, each along the tangent plane: at (sin 30, 0, cos 30) the tangents (0, 1, 0) and
    (cos 30, 0, -sin 30); at (0, sin 30, cos 30) the tangents (0, cos 30, -sin 30) and (1, 0, 0).
    The peak falls with a = 10 across X and b = 40 across Y: 5.892 and 2.942 degrees."""
    s, c = 0.5, math.sqrt(3.0) / 2.0
    if towards == "x":
        p, tx, ty = [s, 0.0, c], [c, 0.0, -s], [0.0, 1.0, 0.0]
    else:
        p, tx, ty = [0.0, s, c], [1.0, 0.0, 0.0], [0.0, c, -s]
    cp = A.compromise([Local(p, tx, ty, 10.0, 40.0)], ["a"], [np.array(p)], "draft")
    assert cp.tolerance_by_axis["left_right_deg"] == pytest.approx(side_tol(10.0), abs=0.05)
    assert cp.tolerance_by_axis["front_back_deg"] == pytest.approx(side_tol(40.0), abs=0.05)
    assert cp.parallel_within_deg is None  # the pole keeps exp(-10 x 0.25) or exp(-40 x 0.25): far below 90 %


def test_tolerance_by_axis_looks_both_ways():
    """A lopsided peak at the pole: towards +Y it keeps 90 % out to 5.892 degrees, towards -Y only to
    2.942; towards +X to 4.162 (a = 20), towards -X to 1.471 (a = 160). Each axis's tolerance is the
    nearer side's; in any direction the least of all."""
    cp = A.compromise([Local([0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0], (20.0, 160.0), (10.0, 40.0))], ["a"],
                      [np.array([0.0, 0.0, 1.0])], "draft")
    assert cp.tolerance_by_axis["front_back_deg"] == pytest.approx(side_tol(40.0), abs=0.05)
    assert cp.tolerance_by_axis["left_right_deg"] == pytest.approx(side_tol(160.0), abs=0.05)
    assert cp.tolerance_deg == pytest.approx(side_tol(160.0), abs=0.05)


def test_parallel_of_a_compromise_whose_score_is_below_95_percent():
    """Two lobes (k = 20) at 8 degrees towards +X and 4 towards -X: the best mean sits about 2 degrees
    towards +X (more than half a degree off the pole), where each keeps about exp(20 (cos 6 - 1)):
    score 0.896. The pole keeps 0.5 (exp(20 (cos 8 - 1)) + exp(20 (cos 4 - 1))) = 0.888, above
    90 % of the score (not of 1), so "parallel" holds as far from the pole as the mean keeps 0.9 x
    the score in the worst of the 16 directions: 4.668 degrees (bisection on the formula below)."""
    k = 20.0
    pa, pb = tilted(8.0), tilted(-4.0)
    cp = A.compromise([Lobe(pa, k), Lobe(pb, k)], ["a", "b"], [pa, pb], "draft")
    assert 1.5 < math.degrees(math.acos(cp.normal[2])) < 2.5 and cp.score == pytest.approx(0.896, abs=1e-3)

    def mean(n):
        return 0.5 * (math.exp(k * (n @ pa - 1)) + math.exp(k * (n @ pb - 1)))

    pole = np.array([0.0, 0.0, 1.0])
    assert mean(pole) == pytest.approx(0.888, abs=1e-3) and mean(pole) >= 0.9 * cp.score
    worst = 90.0
    for phi in np.linspace(0.0, 2.0 * math.pi, 16, endpoint=False):  # tolerance_deg's 16 directions from the pole
        lo, hi = 0.0, 30.0
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            t = math.radians(mid)
            n = np.array([math.sin(t) * math.cos(phi), math.sin(t) * math.sin(phi), math.cos(t)])
            lo, hi = (mid, hi) if mean(n) >= 0.9 * cp.score else (lo, mid)
        worst = min(worst, lo)
    assert worst == pytest.approx(4.668, abs=1e-3)
    assert cp.parallel_within_deg == pytest.approx(worst, abs=0.05)


@pytest.mark.parametrize("tilt, parallel", [(0.4, "tolerance"), (0.6, "around the pole")])
def test_parallel_to_the_base_within_half_a_degree_of_the_pole(tilt, parallel):
    """An isotropic lobe (k = 20: tolerance ``acos(1 + ln 0.9 / 20)`` = 5.884 degrees) peaked ``tilt``
    degrees from the pole. Within 0.5 degrees the normal counts as the pole and "parallel" is the
    tolerance; beyond, it is how far from the pole the normal may go and keep 90 %: the lobe's
    tolerance less the tilt in the worst direction (5.884 - 0.6)."""
    tol = math.degrees(math.acos(1.0 + LN09 / 20.0))
    cp = A.compromise([Lobe(tilted(tilt), 20.0)], ["a"], [tilted(tilt)], "draft")
    assert cp.tolerance_deg == pytest.approx(tol, abs=0.05)
    if parallel == "tolerance":
        assert cp.parallel_within_deg == cp.tolerance_deg
    else:
        assert cp.parallel_within_deg == pytest.approx(tol - tilt, abs=0.05)


@pytest.mark.parametrize("tilt, expected", [
    (6.0, None),   # the pole keeps exp(20 (cos 6 - 1)) = 0.896 < 90 %: not parallel
    (5.0, None),   # the pole keeps 0.927, but only as far as 5.884 - 5 = 0.884 degrees < 1
    (4.75, 1.134),  # just above the 1 degree minimum
    (3.0, 2.884),
])
def test_parallel_needs_90_percent_at_the_pole_and_at_least_one_degree(tilt, expected):
    """An isotropic lobe (k = 20) ``tilt`` degrees from the pole: the pole keeps
    ``exp(20 (cos tilt - 1))`` of the score; when that is at least 90 % the answer is "parallel" as
    far as the worst direction from the pole (straight away from the lobe) keeps 90 %,
    ``acos(1 + ln 0.9 / 20) - tilt``, provided that is at least :data:`PARALLEL_MIN_DEG` (1 degree);
    else None."""
    assert A.PARALLEL_MIN_DEG == 1.0
    within = math.degrees(math.acos(1.0 + LN09 / 20.0)) - tilt
    if expected is not None:
        assert within == pytest.approx(expected, abs=1e-3)
    cp = A.compromise([Lobe(tilted(tilt), 20.0)], ["a"], [tilted(tilt)], "draft")
    if expected is None:
        assert cp.parallel_within_deg is None
    else:
        assert cp.parallel_within_deg == pytest.approx(within, abs=0.05)


def test_compromise_of_two_mirror_scenarios_is_the_pole():
    """Two lobes (k = 20) 10 degrees either side of the pole towards +-X, with amplitudes 1 and 1000
    (each is divided by its own optimum's energy): by symmetry the best mean is the pole, where each
    keeps ``exp(20 (cos 10 - 1))`` = 0.738. Towards the front and back both fall alike:
    ``cos d = 1 + ln 0.9 / (20 cos 10)`` (5.930 degrees); towards the sides the mean of the two
    lobes, solved below by bisection on the formula."""
    k = 20.0
    a, b = Lobe(tilted(10.0), k), Lobe(tilted(-10.0), k, amp=1000.0)
    cp = A.compromise([a, b], ["right", "left"], [tilted(10.0), tilted(-10.0)], "draft")
    keep = math.exp(k * (math.cos(math.radians(10.0)) - 1.0))
    assert np.allclose(cp.normal, [0, 0, 1], atol=2e-3)  # the polish's last grid: 0.1 degrees
    assert cp.score == pytest.approx(keep, rel=1e-4)
    assert cp.relative["right"] == pytest.approx(keep, rel=1e-3) and cp.relative["left"] == pytest.approx(keep, rel=1e-3)
    assert list(cp.relative) == ["right", "left"]
    fb = math.degrees(math.acos(1.0 + LN09 / (k * math.cos(math.radians(10.0)))))

    def side(d):
        return 0.5 * (math.exp(k * (math.cos(math.radians(d - 10.0)) - 1)) + math.exp(k * (math.cos(math.radians(d + 10.0)) - 1)))

    lo, hi = 0.0, 30.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if side(mid) >= 0.9 * keep else (lo, mid)
    assert cp.tolerance_by_axis["front_back_deg"] == pytest.approx(fb, abs=0.15)
    assert cp.tolerance_by_axis["left_right_deg"] == pytest.approx(lo, abs=0.15)
    assert cp.tolerance_deg == pytest.approx(min(fb, lo), abs=0.15)
    assert cp.parallel_within_deg == cp.tolerance_deg


def test_compromise_between_two_scenarios_off_the_pole():
    """Two lobes at 30 degrees towards +X, 40 towards +Y... of which one matters more: scenario b is
    narrow (k = 200) and a broad (k = 5), so the best mean sits near b's own optimum, where b keeps
    nearly 1 and a keeps ``exp(5 (cos(angle to a) - 1))``. The compromise is better than or equal
    to both own optima and any point of a fine cap around it, and not parallel (the pole keeps far
    below 90 %)."""
    pa, pb = tilted(30.0), tilted(40.0, "y")
    a, b = Lobe(pa, 5.0), Lobe(pb, 200.0)

    def mean(n):
        n = np.atleast_2d(n)
        return 0.5 * (np.exp(5.0 * (n @ pa - 1)) + np.exp(200.0 * (n @ pb - 1)))

    cp = A.compromise([a, b], ["a", "b"], [pa, pb], "draft")
    assert cp.score == pytest.approx(float(mean(cp.normal)[0]), rel=1e-12)
    assert cp.score >= mean(np.array([pa, pb])).max()
    from labcut.orientation.misorientation import ring

    dense = np.concatenate([ring(cp.normal, r, 36) for r in np.arange(0.05, 2.0, 0.05)])
    assert mean(dense).max() <= cp.score * (1 + 1e-4)
    assert cp.relative["a"] == pytest.approx(float(np.exp(5.0 * (cp.normal @ pa - 1))), rel=1e-12)
    assert cp.relative["b"] == pytest.approx(float(np.exp(200.0 * (cp.normal @ pb - 1))), rel=1e-12)
    assert cp.parallel_within_deg is None
    assert cp.normal[2] > 0 and np.linalg.norm(cp.normal) == pytest.approx(1.0, abs=1e-12)


def test_compromise_reads_the_maps_when_they_share_their_normals():
    """``maps`` (one ``(normals, energies)`` per scenario on the same normals) stand for the grid:
    here they put all the energy at one normal 60 degrees towards -Y, far from the true best mean
    (the pole); the answer is then polished only locally (the quality's map spacing, 4 degrees for
    draft, then 1), so it stays near that normal. Maps on different normals, or not one per
    scenario, are not read: the hemisphere grid finds the pole."""
    a, b = Lobe(tilted(5.0), 10.0), Lobe(tilted(-5.0), 10.0)
    far = tilted(-60.0, "y")
    normals = np.array([[0.0, 0.0, 1.0], far, tilted(45.0)])
    fake = np.array([0.0, 1e9, 0.0])
    bests = [tilted(5.0), tilted(-5.0)]
    cp = A.compromise([a, b], ["a", "b"], bests, "draft", maps=[(normals, fake), (normals.copy(), fake)])
    assert math.degrees(math.acos(float(cp.normal @ far))) <= 5.0 + 1e-6
    for maps in ([(normals, fake), (normals[::-1], fake)], [(normals, fake)]):
        cp = A.compromise([a, b], ["a", "b"], bests, "draft", maps=maps)
        assert np.allclose(cp.normal, [0, 0, 1], atol=2e-3)


def test_compromise_normalises_the_maps_by_each_optimum():
    """Map values are divided by each scenario's energy at its optimum before they are averaged: two
    map normals, one where scenario a (best 1) has 10 and b (best 1000) nothing, one where a has
    nothing and b 8000. Normalised, the first wins (mean 5 against 4, and the own optima's 1); raw,
    the second would. Each scenario's true energy is flat (the polish keeps its centre)."""

    class Flat:
        def __init__(self, amp):
            self.amp = amp

        def energy_map(self, normals):
            return np.full(len(np.atleast_2d(normals)), self.amp)

    first, second = tilted(50.0), tilted(50.0, "y")
    normals = np.array([first, second])
    cp = A.compromise([Flat(1.0), Flat(1000.0)], ["a", "b"], [tilted(0.0), tilted(0.0)], "draft",
                      maps=[(normals, np.array([10.0, 0.0])), (normals, np.array([0.0, 8000.0]))])
    assert np.allclose(cp.normal, first, atol=1e-12)


def test_compromise_grid_is_the_quality_map_spacing():
    """The first polish searches a cap of the quality's map spacing (3 degrees standard, the default;
    1.5 high) in 0.5 degree steps, the second 1 degree in 0.1 steps: from a far normal the maps
    point to, the answer climbs towards the true best (the pole) by the spacing plus at most 1."""
    a, b = Lobe(tilted(5.0), 10.0), Lobe(tilted(-5.0), 10.0)
    far = tilted(-60.0, "y")
    normals = np.array([[0.0, 0.0, 1.0], far])
    fake = np.array([0.0, 1e9])
    for quality, spacing in (("draft", 4.0), ("standard", 3.0), ("high", 1.5), (None, 3.0)):
        kw = {} if quality is None else {"quality": quality}
        cp = A.compromise([a, b], ["a", "b"], [tilted(5.0), tilted(-5.0)], maps=[(normals, fake), (normals, fake)], **kw)
        moved = math.degrees(math.acos(min(1.0, float(cp.normal @ far))))
        assert moved == pytest.approx(spacing + 1.0, abs=1e-6), (quality, moved)


# ---------------------------------------------------------------------- the polishing cap
def test_cap_grid_by_hand():
    """Around the pole out to 1 degree in steps of 0.5: the centre, then ceil(2 pi x 0.5 / 0.5) = 7
    normals at 0.5 degrees and ceil(2 pi x 1 / 0.5) = 13 at 1 degree; the centre given with its lower
    sign comes back upper."""
    cap = A._cap_grid(np.array([0.0, 0.0, -1.0]), 1.0, 0.5)
    assert cap.shape == (21, 3)
    assert np.array_equal(cap[0], [0.0, 0.0, 1.0])
    angles = np.degrees(np.arccos(np.clip(cap[1:, 2], -1, 1)))
    assert np.allclose(angles[:7], 0.5, atol=1e-9) and np.allclose(angles[7:], 1.0, atol=1e-9)
    cap = A._cap_grid(tilted(20.0), 0.3, 0.1)  # rings at 0.1, 0.2, 0.3: 7, 13, 19 normals
    assert cap.shape == (1 + 7 + 13 + 19, 3)
    assert np.allclose(np.degrees(np.arccos(np.clip(cap[-19:] @ tilted(20.0), -1, 1))), 0.3, atol=1e-6)


# ---------------------------------------------------------------------- scorer_for
def test_scorer_for_builds_as_the_recommendation_does(monkeypatch):
    """The scenario's settings, the quality, tau, seed and occlusion passed on; an energy scorer;
    the defaults those of :func:`labcut.recommend_orientation` (tau 0.1, seed 0)."""
    from labcut.commands.recommend import recommend_orientation

    calls = []
    monkeypatch.setattr(A, "build_problem", lambda mesh, material, **kw: calls.append((mesh, material, kw)) or "problem")
    monkeypatch.setattr(A, "Scorer", lambda problem, objective: (problem, objective))
    sc = scenario([0.0, 0.0, 1.0])
    assert A.scorer_for("m", "x", sc, "draft") == ("problem", "energy")
    (mesh, material, kw), = calls
    assert (mesh, material) == ("m", "x") and kw["quality"] == "draft" and kw["occlusion"] is None
    assert kw["tau"] == 0.1 and kw["seed"] == 0 and len(kw["settings"]) == len(sc.settings())
    signature = inspect.signature(recommend_orientation).parameters
    assert (signature["tau"].default, signature["seed"].default) == (0.1, 0)
    A.scorer_for("m", "x", sc, "high", tau=0.3, seed=5, occlusion=False)
    assert calls[1][2]["tau"] == 0.3 and calls[1][2]["seed"] == 5 and calls[1][2]["occlusion"] is False
    assert calls[1][2]["quality"] == "high"
