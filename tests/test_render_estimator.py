"""The render estimator: the flash objective through Mitsuba renders, its AD gradient, the optimiser.

Small images and few samples (the objective is a deterministic function of the normal at a
fixed seed, so finite differences of it are exact enough at any spp); draft scenarios.
"""

from __future__ import annotations

import gc
import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import labcut
from labcut import Labradorite, ParameterError
from labcut.orientation import render_estimator as re_
from labcut.orientation.optimize import Constraint
from labcut.orientation.render_estimator import (
    RenderQuality, RenderObjective, optimize_render, predict_render_seconds, recommend_by_render, render_metrics,
)
from labcut.orientation.render_objective import combine_views, view_terms
from labcut.orientation.scoring import normal_to_stereo, stereo_jacobian, stereo_to_normal
from labcut.scene import resolve_scene

MESHES = Path(__file__).resolve().parents[1] / "meshes"
LAB = Labradorite()  # the default material, as recommend_orientation uses


def angle_deg(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return math.degrees(math.acos(min(1.0, abs(a @ b) / np.linalg.norm(a) / np.linalg.norm(b))))


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh(MESHES / "oval-16x12-low.ply")


@pytest.fixture(scope="module")
def still():
    """A still stone, face-up, under the overhead lamps, seen by the face-up viewers (7 views)."""
    return resolve_scene(lighting="overhead", viewing="face-up", quality="draft").settings()


@pytest.fixture(autouse=True)
def _let_go_of_the_tests_scenes():
    """Collect each test's render objectives when it ends: every live scene is traced into each
    later render's calls (a module-wide objective had made the pendant's pose test 3x slower)."""
    yield
    gc.collect()


@pytest.fixture
def energy(oval, still):
    return RenderObjective(oval, LAB, still, resolution=32, spp=4, seed=1)


def uv_gradient(objective, u, v, smooth=False, h=1e-3):
    """AD gradient in stereographic (u, v) and central finite differences of the same objective."""
    _, g = objective.value_and_grad(stereo_to_normal(u, v))
    ad = stereo_jacobian(u, v).T @ g
    f = lambda a, b: objective.value(stereo_to_normal(a, b), smooth=smooth)  # noqa: E731
    fd = np.array([(f(u + h, v) - f(u - h, v)) / (2 * h), (f(u, v + h) - f(u, v - h)) / (2 * h)])
    return ad, fd


# ------------------------------------------------------------------ image terms (numpy only)

def test_view_terms_by_hand():
    # four pixels: one empty, one half covered; L/L_ref = value / alpha / l_ref
    value = np.array([[0.0, 0.3], [0.05, 0.1]])
    alpha = np.array([[0.0, 1.0], [0.5, 1.0]])
    t = view_terms(value, alpha, tau=0.2, l_ref=1.0)
    # ratios 0.3, 0.1, 0.1 with weights 1, 0.5, 1: only the first flashes
    assert t.area == pytest.approx(1.0 / 2.5)
    assert t.intensity == pytest.approx(0.3)
    assert t.energy == pytest.approx((0.3 + 0.05 + 0.1) / 2.5)
    empty = view_terms(np.zeros((2, 2)), np.zeros((2, 2)), 0.2, 1.0)
    assert (empty.area, empty.intensity, empty.energy) == (0.0, 0.0, 0.0)


@given(
    seed=st.integers(0, 10_000),
    objective=st.sampled_from(["energy", "area", "intensity", "balanced"]),
    tau=st.floats(0.05, 1.0),
    width=st.floats(0.05, 0.5),
)
def test_image_gradient_matches_finite_differences(seed, objective, tau, width):
    """The derivative of the smoothed objective with respect to each pixel value (what seeds the
    adjoint renders) is the derivative of the value it reports."""
    rng = np.random.default_rng(seed)
    images = []
    for _ in range(2):
        alpha = np.where(rng.random((4, 4)) < 0.8, rng.uniform(0.2, 1.0, (4, 4)), 0.0)
        images.append((alpha * rng.uniform(0.0, 2.0 * tau, (4, 4)), alpha))
    weights = np.array([0.3, 0.7])

    def value(imgs):
        return combine_views([view_terms(y, a, tau, 0.8, width) for y, a in imgs], weights, objective)

    v0, grads = value(images)
    h = 1e-6 * tau
    for k, (y, a) in enumerate(images):
        for idx in zip(*np.nonzero(a > 1e-3)):
            plus = [(yy.copy(), aa) for yy, aa in images]
            minus = [(yy.copy(), aa) for yy, aa in images]
            plus[k][0][idx] += h
            minus[k][0][idx] -= h
            fd = (value(plus)[0] - value(minus)[0]) / (2 * h)
            assert grads[k][idx] == pytest.approx(fd, rel=1e-4, abs=1e-6 * (1.0 + abs(v0)) / h * 1e-6)


# ------------------------------------------------------------------ the rendered objective

def test_objective_equals_render_metrics(oval, still, energy):
    """The objective's images and weights are render_metrics' (the same renders, same seed)."""
    normal = stereo_to_normal(0.12, -0.08)
    value, _ = energy.value_and_grad(normal)
    reference = render_metrics(oval, LAB, normal, settings=still, resolution=32, spp=4, seed=1)
    assert value == pytest.approx(reference.flash_energy, rel=1e-9)
    mine = energy.metrics(normal)
    for key in ("flash_area", "flash_intensity", "flash_energy", "coverage"):
        assert getattr(mine, key) == pytest.approx(getattr(reference, key), rel=1e-9, abs=1e-12)
    assert mine.per_view["weight"] == pytest.approx(reference.per_view["weight"])
    assert value > 0.005  # the renders really see the flash (~5 % of the best energy, 11° off it)


def test_ad_gradient_matches_finite_differences(energy):
    u, v = 0.15, -0.10  # ~10° off the optimum: a steep flank
    ad, fd = uv_gradient(energy, u, v)
    value = energy.value(stereo_to_normal(u, v))
    assert np.linalg.norm(fd) > 0.5 * value  # not a tiny gradient
    assert np.linalg.norm(ad - fd) <= 0.05 * np.linalg.norm(fd), (ad, fd)
    # and the 3-vector gradient is tangent: the BSDF normalises the normal it is given
    _, g = energy.value_and_grad(stereo_to_normal(u, v))
    assert abs(g @ stereo_to_normal(u, v)) <= 1e-3 * np.linalg.norm(g)


def test_gradient_of_a_render_in_passes(oval, still, monkeypatch):
    """A large image is rendered and differentiated in passes (each its own seed): each adjoint
    pass carries its share of the derivative, so the gradient is still the objective's."""
    from labcut.orientation import render_objective

    monkeypatch.setattr(render_objective, "PASS_SAMPLES", 32 * 32 * 2)
    obj = RenderObjective(oval, LAB, still, resolution=32, spp=6, seed=1)
    assert len(obj._passes()) == 3
    ad, fd = uv_gradient(obj, 0.15, -0.10)
    assert np.linalg.norm(ad - fd) <= 0.05 * np.linalg.norm(fd), (ad, fd)


def test_smoothed_threshold_gradient_matches_finite_differences(oval, still):
    """The thresholded objectives are optimised through a logistic step: its AD gradient is the
    derivative of the smoothed value; the reported value keeps the hard threshold."""
    obj = RenderObjective(oval, LAB, still, resolution=32, spp=4, seed=1, objective="balanced", tau=0.1)
    u, v = 0.03, 0.02
    ad, fd = uv_gradient(obj, u, v, smooth=True)
    assert np.linalg.norm(fd) > 1e-3
    assert np.linalg.norm(ad - fd) <= 0.05 * np.linalg.norm(fd), (ad, fd)
    m = obj.metrics(stereo_to_normal(u, v))
    assert obj.value(stereo_to_normal(u, v)) == pytest.approx(math.sqrt(m.flash_area * m.flash_intensity))


# ------------------------------------------------------------------ the optimiser

@pytest.fixture
def display(oval):
    """The display scenario (8 viewers in front of a shop window): its best normal is tilted ~14°."""
    settings = resolve_scene("display", quality="draft").settings()
    return settings, RenderObjective(oval, LAB, settings, resolution=48, spp=4, seed=0)


def test_render_optimum_agrees_with_sample_estimator(oval, display):
    samples = labcut.recommend_orientation(oval, scenario="display", quality="draft")
    assert samples.tilt_deg > 8.0  # far from the start: the optimiser has to travel
    _, obj = display
    best = optimize_render(obj, (0.0, 0.0, 1.0), iterations=25)
    assert angle_deg(best.normal, samples.normal) < 1.0, (best.normal, samples.normal)
    assert best.score > 1.5 * best.start_score
    assert best.normal[2] > 0 and best.renders >= 2 * obj.n_views * best.evaluations
    assert best.score == pytest.approx(obj.value(best.normal), rel=1e-9)


def test_constraints_hold(oval, display):
    obj = RenderObjective(oval, LAB, display[0], resolution=32, spp=2, seed=0)  # cheaper: only where it ends matters
    capped = optimize_render(obj, (0.0, 0.0, 1.0), Constraint(max_tilt_deg=6.0), iterations=12)
    tilt = math.degrees(math.acos(capped.normal[2]))
    assert tilt <= 6.0 + 1e-6 and tilt > 5.0  # the optimum lies beyond: it ends on the cap's edge
    axis = Constraint(max_tilt_deg=30.0, tilt_axis=(1.0, 0.0, 0.0))
    about_x = optimize_render(obj, (0.0, 0.0, 1.0), axis, iterations=12)
    assert abs(about_x.normal[0]) < 1e-9  # rotated about x only
    assert about_x.score > about_x.start_score


def test_recommend_by_render(oval, still):
    steps = []
    rec = recommend_by_render(oval, LAB, still, start_normal=(0.1, 0.0, 1.0), quality="draft",
                              progress=lambda stage, f: steps.append(f))
    q = RenderQuality.of("draft")
    assert rec.stats["resolution"] == q.resolution and rec.stats["spp"] == q.spp and rec.stats["integrator"] == "direct"
    assert rec.stats["evaluations"] <= q.iterations + 1 and rec.stats["renders"] > 0 and rec.stats["seconds"] > 0
    assert rec.score == pytest.approx(rec.metrics.flash_energy)
    assert rec.score > rec.stats["start_score"]
    assert steps[-1] == 1.0 and steps == sorted(steps)
    json.dumps(rec.to_dict())  # plain JSON


# ------------------------------------------------------------------ bad input

def test_bad_input_is_a_parameter_error(oval, still, energy):
    for bad in ((0.0, 0.0, 0.0), (math.nan, 0.0, 1.0), (1.0, 2.0)):
        with pytest.raises(ParameterError):
            energy.value_and_grad(bad)
        with pytest.raises(ParameterError):
            recommend_by_render(oval, LAB, still, start_normal=bad, quality="draft")
    for kwargs in ({"spp": 0}, {"spp": 2.5}, {"resolution": 4}, {"objective": "sparkle"}, {"tau": math.nan},
                   {"seed": -1}, {"max_depth": 1}):
        with pytest.raises(ParameterError):
            RenderObjective(oval, LAB, still, **kwargs)
    with pytest.raises(ParameterError):
        RenderObjective(oval, LAB, [])
    with pytest.raises(ParameterError):
        recommend_by_render(oval, LAB, still, quality="ultra")
    with pytest.raises(ParameterError):
        predict_render_seconds(0, 64, 4, True)


# ------------------------------------------------------------------ cost model

def test_prediction_follows_the_calibration(monkeypatch, tmp_path):
    """The predicted time is built from the measured per-render costs (here a known calibration,
    stored and read back through the cache file), growing with views, pixels and samples."""
    timing = re_.RenderTiming({"direct": (0.01, 1e-7), "prb": (0.02, 4e-7)}, {"direct": (0.02, 2e-7), "prb": (0.05, 8e-7)},
                              {"direct": 1.0, "prb": 3.0}, 0.05, re_._timing_key())
    import labcut.fileio as fio

    monkeypatch.setattr(fio, "cache_path", lambda name: tmp_path / name)
    monkeypatch.setattr(fio, "_CALIBRATIONS", {})
    monkeypatch.setattr(fio, "_STORES", {})
    monkeypatch.setattr(re_, "measure_render_timing", lambda: timing)
    assert re_.render_timing() == timing and (tmp_path / re_._TIMING_FILE).exists()
    monkeypatch.setattr(re_, "measure_render_timing", lambda: pytest.fail("measured again instead of read from the cache"))
    monkeypatch.setattr(fio, "_CALIBRATIONS", {})  # a new process: read back from the file
    monkeypatch.setattr(fio, "_STORES", {})
    assert re_.render_timing() == timing
    p = predict_render_seconds(7, 48, 4, True, iterations=10)
    samples = 48 * 48 * 4
    expected = 0.05 * 7 + 1.0 + 7 * (10 * (0.01 + 1e-7 * samples + 0.02 + 2e-7 * samples) + (0.01 + 1e-7 * samples))
    assert p == pytest.approx(expected)
    assert predict_render_seconds(14, 48, 4, True, iterations=10) > p
    assert predict_render_seconds(7, 96, 4, True, iterations=10) > p
    assert predict_render_seconds(7, 48, 4, False, iterations=10) > p  # a carving: prb, deeper paths


def test_carving_gradient_with_light_between_its_parts_matches_finite_differences():
    """With deeper paths every lobe carries light between the biplane's parts (the delta polish
    included, which prb does not differentiate: only the schiller depends on the normal); the AD
    gradient of the flash (image less its no-schiller image) matches central differences."""
    biplane = labcut.load_mesh("meshes/carving-biplane.ply")
    settings = resolve_scene("display", quality="draft").settings()
    obj = RenderObjective(biplane, LAB, settings, resolution=48, spp=8, seed=0)
    assert obj.integrator == "prb" and obj.indirect
    n = np.array([0.2, -0.1, 1.0]) / np.linalg.norm([0.2, -0.1, 1.0])
    value, grad = obj.value_and_grad(n)
    assert value == pytest.approx(obj.value(n), rel=1e-9)
    for axis in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        u = axis - (axis @ n) * n
        u /= np.linalg.norm(u)
        h = 1e-3
        fd = (obj.value(n + h * u) - obj.value(n - h * u)) / (2 * h)
        assert grad @ u == pytest.approx(fd, rel=0.05), axis
    # the flash is the image less the no-schiller image: depth 2 with every lobe equals the schiller alone
    direct = RenderObjective(biplane, LAB, settings, resolution=48, spp=8, seed=0, max_depth=2)
    assert not direct.indirect
    assert obj.value(n) > direct.value(n) > 0.0
    assert obj.value(n) == pytest.approx(direct.value(n), rel=0.05)  # the glare and the body are not flash


@pytest.mark.parametrize("mesh_name, depth, scenario", [("oval-16x12-low.ply", None, "bench"), ("carving-biplane.ply", 4, "bench"),
                                                        ("carving-biplane.ply", 4, "pendant")])
def test_poses_in_one_scene_render_as_one_scene_per_pose(mesh_name, depth, scenario, monkeypatch):
    """A rocking stone's poses share one Mitsuba scene (one tree; each pose's lamps set through
    mi.traverse before its views render): its images, values and gradients are those of one
    scene per pose, bit for bit, direct lighting (the oval) and deeper paths with the no-schiller
    base images (the biplane); the gradients to float32 rounding. A worn pendant's poses turn an
    environment map as well as the lamps: its ``to_world`` is set per pose too."""
    from labcut.orientation import render_objective as ro

    mesh = labcut.load_mesh(MESHES / mesh_name)
    settings = resolve_scene(scenario, quality="draft").settings()[:3]
    assert len(settings) == 3
    kw = dict(resolution=24, spp=4, seed=2, max_depth=depth)
    n = np.array([0.25, -0.1, 1.0]) / np.linalg.norm([0.25, -0.1, 1.0])
    normals = (n, np.array([0.0, 0.0, 1.0]))  # the lamps go back to the first pose's

    def answers(obj):
        return obj.images(n), [obj.value_and_grad(normal) for normal in normals]

    shared = RenderObjective(mesh, LAB, settings, **kw)
    assert shared._pose_lamps is not None and len(shared._groups) == 1
    want = answers(shared)
    del shared
    gc.collect()  # one objective's scenes alive at a time: each render traces every live one
    with monkeypatch.context() as m:
        m.setattr(ro, "poses_share_a_scene", lambda lamp_sets: False)
        apart = RenderObjective(mesh, LAB, settings, **kw)
    assert apart._pose_lamps is None and len(apart._groups) == 3
    got = answers(apart)
    for a, b in zip(want[0], got[0]):
        assert np.array_equal(a, b)
    for (va, ga), (vb, gb) in zip(want[1], got[1]):
        # the values bit for bit; the adjoint passes accumulate with atomics (their order varies from
        # run to run, for one scene per pose too), so the gradients agree to float32 rounding
        assert va == vb and va > 0.0
        np.testing.assert_allclose(ga, gb, rtol=1e-5, atol=1e-9 * np.abs(gb).max())


@pytest.mark.parametrize("mesh_name, depth, scenario, shared", [("oval-16x12-low.ply", None, "bench", False),
                                                                ("carving-biplane.ply", 4, "pendant", False),
                                                                ("carving-biplane.ply", 4, "pendant", True)])
def test_values_render_one_scene_at_a_time_and_give_each_normals_value(mesh_name, depth, scenario, shared, monkeypatch):
    """``values`` (the planner's pilots) renders pose by pose: a pose's scene (and, with deeper
    paths, its no-schiller scene) is built, renders every normal's views and is let go before the
    next pose's, since every live scene slows each render's tracing; the values are ``value``'s,
    bit for bit, and nothing is left alive, the no-schiller shape neither. Poses that share a scene
    (their lamps set pose by pose) give ``value``'s too. (The scenes of the test above: its kernels.)"""
    from labcut.orientation import render_objective as ro

    if not shared:
        monkeypatch.setattr(ro, "poses_share_a_scene", lambda lamp_sets: False)  # as poses under other lamps
    mesh = labcut.load_mesh(MESHES / mesh_name)
    settings = resolve_scene(scenario, quality="draft").settings()[:2]
    kw = dict(resolution=24, spp=4, seed=2, max_depth=depth)
    normals = [(0.0, 0.0, 1.0), (0.3, -0.2, 1.0)]
    one_by_one = RenderObjective(mesh, LAB, settings, **kw)
    want = [one_by_one.value(n) for n in normals]
    del one_by_one
    obj = RenderObjective(mesh, LAB, settings, **kw)
    assert (obj._pose_lamps is None and len(obj._groups) == 2) if not shared else len(obj._groups) == 1
    alive, real = [], obj._render

    def counted(group, sensor, pose, base=False):
        alive.append(len(obj._built))
        return real(group, sensor, pose, base)

    monkeypatch.setattr(obj, "_render", counted)
    got = obj.values(normals)
    assert got == want and all(v > 0.0 for v in got)
    assert len(alive) == len(normals) * obj.n_views + (obj.n_views if obj.indirect else 0)
    assert max(alive) == (2 if obj.indirect else 1) and not obj._built and obj._base_shape is None


def test_the_pilots_objectives_are_alive_one_at_a_time(monkeypatch):
    """interreflection_share lets the direct-lighting objective go before the deeper one renders."""
    import weakref

    from labcut.orientation import render_objective as ro

    made: list[weakref.ref] = []
    seen: list[int] = []
    init, values = ro.RenderObjective.__init__, ro.RenderObjective.values

    def tracked_init(self, *a, **k):
        init(self, *a, **k)
        made.append(weakref.ref(self))

    def tracked_values(self, normals):
        seen.append(sum(r() is not None for r in made))
        return values(self, normals)

    monkeypatch.setattr(ro.RenderObjective, "__init__", tracked_init)
    monkeypatch.setattr(ro.RenderObjective, "values", tracked_values)
    mesh = labcut.load_mesh(MESHES / "carving-biplane.ply")
    share = ro.interreflection_share(mesh, LAB, resolve_scene("bench", quality="draft").settings()[:1],
                                     normals=[(0.0, 0.0, 1.0)], resolution=16, spp=2)
    assert share >= 0.0 and seen == [1, 1]


def test_which_poses_share_a_scene():
    from labcut.orientation.render_objective import poses_share_a_scene

    lamp = lambda d, e=1.0: {"type": "directional", "direction": d, "irradiance": {"type": "rgb", "value": [e] * 3},  # noqa: E731
                             "sampling_weight": e}
    one = {"light_0": lamp([0, 0, -1]), "light_1": lamp([0, 1, -1])}
    moved = {"light_0": lamp([0.1, 0, -1]), "light_1": lamp([0, 1.1, -1])}
    assert poses_share_a_scene([one, moved])
    assert not poses_share_a_scene([one])  # one pose: nothing to share
    assert not poses_share_a_scene([one, {"light_0": lamp([0, 0, -1])}])  # another lamp set
    assert not poses_share_a_scene([one, {**moved, "light_1": lamp([0, 1, -1], 2.0)}])  # another irradiance
    env = {"type": "envmap", "filename": "x.exr"}
    assert not poses_share_a_scene([{**one, "environment": env}, {**moved, "environment": env}])  # not a bitmap
    import mitsuba as mi

    from labcut.backend import set_variant

    set_variant("mono")
    sky = lambda v, w=0.3: {"type": "envmap", "bitmap": mi.Bitmap(np.full((4, 8, 3), v, dtype=np.float32)),  # noqa: E731
                            "to_world": mi.ScalarTransform4f(), "sampling_weight": w}
    assert poses_share_a_scene([{**one, "environment": sky(1.0)}, {**moved, "environment": sky(1.0)}])
    assert not poses_share_a_scene([{**one, "environment": sky(1.0)}, {**moved, "environment": sky(2.0)}])  # another map
    assert not poses_share_a_scene([{**one, "environment": sky(1.0)}, {**moved, "environment": sky(1.0, 0.4)}])


@pytest.mark.parametrize("depth", [None, 4])
def test_lights_seen_behind_the_stone_are_not_flash(depth):
    """A stone seen from the side (the pendant, at eye level) has the room's ceiling behind it: a
    pixel at the silhouette mixes stone and background, and the background must add nothing. Direct
    lighting and deeper paths then agree where the lamellae send no flash to the viewers (the
    planner's pilot renders compare the two: counting the background made 10.6 % of "light between
    the parts" of the biplane, and sent its pendant and brooch answers through the render
    estimator); the flash where they do is the same too."""
    mesh = labcut.load_mesh(MESHES / "carving-biplane.ply")
    settings = resolve_scene("pendant-diffuse", quality="draft").settings()
    direct = RenderObjective(mesh, LAB, settings, resolution=48, spp=8, seed=0, max_depth=2)
    other = direct if depth is None else RenderObjective(mesh, LAB, settings, resolution=48, spp=8, seed=0, max_depth=depth)
    away = np.array([1.0, 0.0, 0.3]) / np.linalg.norm([1.0, 0.0, 0.3])  # the lamellae face the side: no flash forward
    best = np.array([0.0, 0.0, 1.0])
    e_best = direct.value(best)
    assert e_best > 0.0
    assert direct.value(away) < 0.01 * e_best  # the ceiling behind the silhouette read 11 % of the best
    if depth is not None:
        assert other.value(best) == pytest.approx(e_best, rel=0.02)
