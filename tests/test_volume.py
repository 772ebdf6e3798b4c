"""The volumetric flash problem (labcut.orientation.volume) and the planner's ``depth`` decision
(docs/physics.md "Depth", docs/planner.md "Depth"; issue 38). The stack's depth law is
tests/test_depth_law.py's.

References: the volume problem on a flat slab against the surface problem (exact there when the
slab is thicker than the stack) and on a slab thinner than the stack against the depth law's share;
the fixed point against more iterations; drawn lights against every light."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import trimesh

import labcut
from labcut.errors import ParameterError
from labcut.orientation.optimize import search_best
from labcut.orientation.problem import build_problem
from labcut.orientation.question import FlashQuestion
from labcut.orientation.scoring import Scorer
from labcut.orientation.volume import build_volume_problem, depth_exposure, depth_strata
from labcut.physics.depth import depth_law
from labcut.planner import DEPTH_THIN_SHARE, plan_effects


@pytest.fixture(scope="module")
def material():
    return labcut.Labradorite()


def angle_deg(a, b) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(np.dot(a, b))))))


def slab(tmp_path_factory, thickness: float, size: float = 40.0):
    box = trimesh.creation.box(extents=[size, size, thickness])
    box.apply_translation([0.0, 0.0, thickness / 2])
    path = tmp_path_factory.mktemp("slab") / f"slab-{thickness:g}.ply"
    box.export(path)
    return labcut.load_mesh(path)


# ---------------------------------------------------------------------- the volume problem
def test_depth_strata_fill_each_stratum_once():
    u = depth_strata(50, 4, 3)
    assert u.shape == (50, 4) and np.all((u >= 0) & (u < 1))
    assert np.all(np.floor(u * 4) == np.arange(4)[None, :])


def _answers(mesh, scene_lighting, **volume):
    q = FlashQuestion.build(None, None, scene_lighting, "face-up", quality="draft")
    settings_ = q.scenario.settings()
    surface = build_problem(mesh, q.material, quality=q.quality, settings=settings_)
    vol = build_volume_problem(mesh, q.material, quality=q.quality, settings=settings_, **volume)
    out = []
    for p in (surface, vol):
        found = search_best(Scorer(p, "energy"), q.constraint, q.quality, "nlopt")
        out.append((found.normal, found.score))
    return out, vol


def test_on_a_slab_thicker_than_the_stack_the_volume_is_the_surface(tmp_path_factory):
    """Flat faces, every depth inside the stone: the same flash but for the light that would enter
    within a millimetre of the slab's edge."""
    (surface, volume), vol = _answers(slab(tmp_path_factory, 3.0), "spot")
    assert angle_deg(surface[0], volume[0]) < 0.1
    assert volume[1] == pytest.approx(surface[1], rel=0.03)
    info = vol.info["volume"]
    assert info["kept"] > 0.8 * info["paths"] and info["unconverged"] < 0.03 * info["paths"]  # (at the edges)


def test_a_slab_thinner_than_the_stack_mirrors_only_its_depths_share(tmp_path_factory, material):
    """0.3 mm of stone under the face: only the top 0.3 mm of the 0.93 mm stack mirrors (the light
    leaves through the base before the rest), a third of the flash; the surface model mirrors the
    whole stack. The thick slab's ratio takes out what both lose at the slab's edges."""
    ratios, infos = [], []
    for thickness in (0.3, 3.0):
        (surface, volume), vol = _answers(slab(tmp_path_factory, thickness), "overhead")
        ratios.append(volume[1] / surface[1])
        infos.append(vol.info["volume"])
    want = float(depth_law(material).share_above(0.3, 1.0))  # lamellae parallel to the face: depth is depth
    assert 0.3 < want < 0.45
    assert ratios[0] / ratios[1] == pytest.approx(want, rel=0.08)
    # the paths dropped for want of stone: those whose depth lies below the base
    assert infos[0]["thin"] / infos[0]["paths"] == pytest.approx(1.0 - want, abs=0.05)
    assert infos[1]["thin"] < 0.05 * infos[1]["paths"]


def test_the_fixed_point_has_converged(material):
    """Four steps (the default) and eight give the same answer on the high dome; one step does not
    find the entry (most paths are dropped as unconverged)."""
    high = labcut.load_mesh("meshes/oval-16x12-high.ply")
    (_, three), v3 = _answers(high, "spot")  # the default: four steps
    (_, eight), _ = _answers(high, "spot", iterations=8)
    assert angle_deg(three[0], eight[0]) < 0.1 and three[1] == pytest.approx(eight[1], rel=0.01)
    _, v1 = _answers(high, "spot", iterations=1)
    assert v1.info["volume"]["unconverged"] > 20 * max(1, v3.info["volume"]["unconverged"])


def test_bad_volume_options_are_one_line_errors(material):
    oval = labcut.load_mesh("meshes/oval-16x12-low.ply")
    q = FlashQuestion.build(quality="draft")
    with pytest.raises(ParameterError, match="depths"):
        build_volume_problem(oval, material, "draft", settings=q.scenario.settings(), depths=0)
    with pytest.raises(ParameterError, match="iterations"):
        build_volume_problem(oval, material, "draft", settings=q.scenario.settings(), iterations=99)
    with pytest.raises(ParameterError, match="setting"):
        build_volume_problem(oval, material, "draft", settings=[])


# ---------------------------------------------------------------------- the planner's decision
def test_the_low_dome_leaves_the_depth_off_and_its_answer_stays_within_0_3_degrees():
    oval = labcut.load_mesh("meshes/oval-16x12-low.ply")
    plan = plan_effects(oval, scenario="bench", predict=False)
    assert not plan.on("depth") and plan.estimator == "samples"
    assert plan.facts["thin_share"] < DEPTH_THIN_SHARE and "below" in plan["depth"].why
    for lighting in ("spot", "overhead"):
        (surface, volume), _ = _answers(oval, lighting)
        assert angle_deg(surface[0], volume[0]) < 0.3, lighting


def test_thin_parts_turn_the_depth_and_the_volume_estimator_on():
    biplane = labcut.load_mesh("meshes/carving-biplane.ply")
    exposure = depth_exposure(biplane, labcut.Labradorite())
    assert exposure["thin_share"] > DEPTH_THIN_SHARE
    plan = plan_effects(biplane, scenario="bench", predict=False)
    assert plan.on("depth") and plan.estimator == "volume" and "thin parts" in plan["depth"].why
    off = plan_effects(biplane, scenario="bench", predict=False, effects={"depth": "off"})
    assert not off.on("depth") and off.estimator == "samples" and off["depth"].forced
    asked = plan_effects(biplane, scenario="bench", predict=False, estimator="samples")
    assert asked.estimator == "samples" and "depth is left out" in asked.estimator_why
    cmp = plan_effects(biplane, scenario="bench", predict=False, command="compare")
    assert cmp.estimator == "samples" and not cmp.on("depth") and "left out" in cmp["depth"].why
    with pytest.raises(ParameterError, match="compare"):
        plan_effects(biplane, scenario="bench", predict=False, command="compare", estimator="volume")
    render = plan_effects(biplane, scenario="bench", predict=False, command="render")
    assert not render.on("depth") and "BSDF" in render["depth"].why


def test_a_thick_cut_is_not_thin_and_a_thin_slab_is(tmp_path_factory, material):
    thick = depth_exposure(slab(tmp_path_factory, 3.0), material)
    thin = depth_exposure(slab(tmp_path_factory, 0.5), material)
    assert thick["thin_share"] == 0.0 and thick["turn_deg"] == 0.0
    assert thin["thin_share"] > 0.95  # all but the slab's sides (40 mm of stone behind them)
    assert plan_effects(slab(tmp_path_factory, 0.5), predict=False).estimator == "volume"


def test_recommend_with_the_volume_estimator_carries_it_through_the_answer():
    oval = labcut.load_mesh("meshes/oval-16x12-low.ply")
    rec = labcut.recommend_orientation(oval, lighting="spot", viewing="face-up", quality="draft", estimator="volume")
    assert rec.estimator == "volume" and rec.settings["estimator"] == "volume"
    assert rec.uncertainty is not None and rec.uncertainty.angle_deg > 0
    surface = labcut.recommend_orientation(oval, lighting="spot", viewing="face-up", quality="draft")
    assert surface.estimator == "samples"
    assert angle_deg(rec.normal, surface.normal) < 0.5
    assert rec.to_dict()["plan"]["effects"]["depth"]["forced"] is False


def test_the_cli_answers_through_the_volume_and_can_be_told_not_to(cli_main, tmp_path):
    out = tmp_path / "r.json"
    proc = cli_main("recommend-orientation", "meshes/carving-biplane.ply", "--quality", "draft", "--json", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "volume estimator:" in proc.stdout and "paths through the stone" in proc.stdout
    data = json.loads(out.read_text())
    assert data["estimator"] == "volume" and data["settings"]["depth"] is True
    assert data["settings"]["volume"]["kept"] > 0 and data["plan"]["effects"]["depth"]["on"]
    off = tmp_path / "off.json"
    proc = cli_main("recommend-orientation", "meshes/carving-biplane.ply", "--quality", "draft", "--effect", "depth=off",
                    "--json", str(off))
    assert proc.returncode == 0, proc.stderr
    data = json.loads(off.read_text())
    assert data["estimator"] == "samples" and data["settings"]["volume"] is None and "volume estimator:" not in proc.stdout
    proc = cli_main("compare", "meshes/oval-16x12-low.ply", "--estimator", "volume", "--quality", "draft")
    assert proc.returncode == 2 and "recommend-orientation --estimator volume" in proc.stderr


def test_over_the_path_budget_each_pair_draws_its_lights_without_bias(material):
    """A scene with more (pair, light) paths than the budget draws each pair's lights in proportion
    to their irradiance: the flash energy and the answer stay those of every light's paths."""
    oval = labcut.load_mesh("meshes/oval-16x12-low.ply")
    q = FlashQuestion.build(None, None, "overhead", "face-up", quality="draft")  # 7 lamp directions
    full = build_volume_problem(oval, material, "draft", settings=q.scenario.settings())
    drawn = build_volume_problem(oval, material, "draft", settings=q.scenario.settings(), path_budget=5_000)
    assert not full.info["volume"]["lights_drawn"] and drawn.info["volume"]["lights_drawn"]
    assert drawn.info["volume"]["paths"] < 0.5 * full.info["volume"]["paths"]
    best = []
    for p in (full, drawn):
        found = search_best(Scorer(p, "energy"), q.constraint, q.quality, "nlopt")
        best.append(found)
    assert best[1].score == pytest.approx(best[0].score, rel=0.03)
    assert angle_deg(best[0].normal, best[1].normal) < 1.0


def test_one_drawn_light_per_pair_keeps_the_carvings_flash(material):
    """The light each pair draws and the depth each path draws are independent: under a room's mixed
    lights (downlights, a window, the room's light) past the biplane's thin wings, one light drawn
    per pair keeps the flash energy of every light's paths within the draws' noise. (Drawn with the
    same golden-ratio sequence as the depths, the light decided the depth, and the energy fell by 29 %
    at one draw per pair; a high-quality answer, which draws a few, lost 33 %.)"""
    biplane = labcut.load_mesh("meshes/carving-biplane.ply")
    sc = labcut.Scenario.preset("pendant", "draft")
    n = np.array([-0.0136, 0.1725, 0.9849])
    full = build_volume_problem(biplane, material, "draft", settings=sc.settings())
    one = build_volume_problem(biplane, material, "draft", settings=sc.settings(), path_budget=5_000)
    assert not full.info["volume"]["lights_drawn"] and one.info["volume"]["lights_drawn"]
    assert one.info["volume"]["paths"] == one.info["pairs"] < 0.02 * full.info["volume"]["paths"]  # one light per pair
    e_full, e_one = (Scorer(p, "energy").metrics(n).flash_energy for p in (full, one))
    assert e_one == pytest.approx(e_full, rel=0.10), (e_one, e_full)


def test_the_drawn_lights_and_depths_of_successive_paths_fill_the_square():
    """The two sequences (:data:`DEPTH_ROTATION`, :data:`LIGHT_ROTATION`) of one index: every cell of
    a 4 x 4 grid of (depth quantile, light quantile) gets its share of 1,600 paths (within a fifth)."""
    from labcut.orientation.volume import LIGHT_ROTATION

    u = depth_strata(1600, 1, 3).ravel()
    slot = depth_strata(1600, 1, 3, LIGHT_ROTATION).ravel()
    counts, _, _ = np.histogram2d(u, slot, bins=4, range=[[0, 1], [0, 1]])
    assert counts.min() >= 0.8 * 100 and counts.max() <= 1.2 * 100, counts
    same, _, _ = np.histogram2d(u, depth_strata(1600, 1, 3 + 7919).ravel(), bins=4, range=[[0, 1], [0, 1]])
    assert same.min() == 0  # one rotation for both: a line through the square


def test_a_scan_too_big_to_copy_gets_the_same_exposure_from_rays_and_a_face_sample(monkeypatch, material):
    """A mesh over FAST_SMOOTH_FACES (a scan) is measured by ray casts and by the normal turn of
    faces drawn by area (a 1.4 M-triangle oval: 14 s as the small ones are measured, 1.5 s so);
    the low dome, taken for such a mesh, keeps its figures."""
    from labcut.orientation import volume

    small = depth_exposure(labcut.load_mesh("meshes/oval-16x12-low.ply"), material)
    monkeypatch.setattr(volume, "FAST_SMOOTH_FACES", 1000)
    monkeypatch.setattr(volume, "EXPOSURE_FACES", 4000)
    drawn = volume.depth_exposure(labcut.load_mesh("meshes/oval-16x12-low.ply"), material)
    assert drawn["thin_share"] == pytest.approx(small["thin_share"], abs=0.005)
    assert drawn["turn_deg"] == pytest.approx(small["turn_deg"], rel=0.05)
    assert drawn["turn_deg"] != small["turn_deg"]  # measured anew, from the drawn faces


def test_rays_that_miss_read_no_leftover_of_the_ray_tracer():
    """A ray that leaves the stone without meeting it (the two small cubes far apart of a user's file,
    a path out past a rim) has no face and no (u, v): the casts read face 0's corner for it, selected
    on the device, never what the ray tracer left in its slots (a signalling NaN there made numpy's
    conversion print a RuntimeWarning to the user, in about one run of four). The hits beside them
    are as before: the face and the shading normal of where they land."""
    import warnings

    from labcut.orientation.volume import VolumeRays

    import drjit as dr
    import mitsuba as mi

    cube = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
    rays = VolumeRays(cube)
    real = rays.scene

    class Leftovers:  # the ray tracer's scene, its misses' slots holding a signalling NaN and a wild face
        def ray_intersect_preliminary(self, ray):
            pi = real.ray_intersect_preliminary(ray)
            miss = ~np.asarray(pi.is_valid())
            uv = np.array(pi.prim_uv, dtype=np.float32)  # (2, N)
            uv.view(np.uint32)[:, miss] = 0x7FA00000  # a signalling NaN's bits (Dr.Jit's own ops would quiet it)
            pi.prim_uv = mi.Point2f(uv[0], uv[1])
            pi.prim_index = dr.select(mi.Bool(miss), mi.UInt32(0xFFFFFFF0), pi.prim_index)
            return pi

    rays.scene = Leftovers()
    n = 20_000
    origins = np.zeros((n, 3))
    dirs = np.tile([0.0, 0.0, 1.0], (n, 1))
    origins[1::2] = [0.0, 0.0, 5.0]  # every other ray starts above the cube, looking up: a miss
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")
        hits = rays.cast(origins, dirs)
    assert np.all(np.isinf(hits.t[1::2])) and np.allclose(hits.t[::2], 1.0)
    np.testing.assert_allclose(hits.n_geo[::2], np.tile([0.0, 0.0, 1.0], (n // 2, 1)), atol=1e-12)
    np.testing.assert_array_equal(hits.n_geo[1::2], np.tile(rays.face_normals[0], (n // 2, 1)))
    assert np.all(np.isfinite(hits.n_sh))
