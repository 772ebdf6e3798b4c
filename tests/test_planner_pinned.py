"""``labcut.planner`` pinned by hand (issue 37, mutation testing): every decision rule at its
threshold's edges (the inter-reflection tolerance on the bound and on the pilots' measurement, the
depth's thin share, the polarisation bias, the map's directions past a carving's parts), forced
effects, each reason the plan gives word for word, the estimator it picks, the seconds it predicts
against their formulas on stand-in calibrations, the hemispherical Fresnel reflectance, the return
albedo and the polarisation bias against independent references, the pilot cache and the linear
fits on hand data.

Nothing is rendered, calibrated or ray-cast: the self-view fraction, the depth exposure, the
polarisation biases, the pilot renders and the timing calibrations are stand-ins (monkeypatched),
and every user cache file lies in the test's own folder. The file runs in a few seconds.
"""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

import labcut
from labcut import planner as P
from labcut.errors import LabcutWarning, ParameterError
from labcut.scene import Lights, Views, resolve_scene


#: the module's own pilot cache path (each test below replaces it with a file of its own)
PILOT_CACHE_PATH = P._pilot_cache_path


@pytest.fixture(autouse=True)
def own_caches(monkeypatch, tmp_path):
    """Every user cache file in this test's folder, nothing kept in this process."""
    from labcut import fileio

    folder = tmp_path / "user-cache"
    monkeypatch.setattr(fileio, "cache_path", lambda name: folder / name)
    monkeypatch.setattr(fileio, "_CALIBRATIONS", {})
    monkeypatch.setattr(fileio, "_STORES", {})
    monkeypatch.setattr(fileio, "_CACHE_WARNED", set())
    monkeypatch.setattr(P, "_PILOT_CACHE", {})
    monkeypatch.setattr(P, "_pilot_cache_path", lambda: folder / "planner-pilot.json")
    return folder


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh("meshes/oval-16x12-low.ply")


@pytest.fixture(scope="module")
def biplane():
    return labcut.load_mesh("meshes/carving-biplane.ply")


class Stand:
    """Stand-ins for what a plan measures: the self-view fraction ``f``, the return albedo ``rho``,
    the depth exposure (thin share ``thin``), the polarisation biases ``bias`` (one per pose), the
    pilot renders (``measured``, or ``skip`` seconds predicted over the budget) and the predicted
    seconds; each call recorded."""

    def __init__(self, mp):
        from labcut.orientation import volume
        from labcut.rendering import rays

        self.f, self.rho, self.thin, self.bias = 0.0, 0.5, 0.1, None
        self.measured, self.skip = 0.0, None
        self.pilots, self.pairs, self.seconds, self.renders, self.materials = [], [], [], [], []
        mp.setattr(rays, "self_view_fraction", lambda mesh: self._mesh(mesh) and self.f)
        mp.setattr(P, "return_albedo", lambda material: self._material(material) and self.rho)
        mp.setattr(volume, "depth_exposure", lambda mesh, material: self._mesh(mesh) and self._material(material) and {
            "thin_share": self.thin, "turn_deg": 11.24, "flash_depth_mm": 0.4336, "stack_depth_mm": 0.93})
        mp.setattr(P, "polarisation_biases", self._biases)
        mp.setattr(P, "measured_interreflection", self._pilot)
        mp.setattr(P, "estimator_seconds", self._seconds)
        mp.setattr(P, "_predicted_render_seconds", self._render)

    @staticmethod
    def _mesh(mesh):
        assert len(mesh.faces) in (4798, 22016) and len(mesh.vertices) > 2000, mesh  # the biplane or the oval
        return True

    def _material(self, material):
        assert isinstance(material, labcut.Labradorite), material
        self.materials.append(material)
        return True

    def _biases(self, material, pairs):
        self.pairs.append((material, pairs))
        return list(self.bias) if self.bias is not None else [0.001] * len(pairs)

    def _pilot(self, mesh, material, scene, timing=None, max_seconds=None):
        self.pilots.append(SimpleNamespace(mesh=mesh, material=material, scene=scene, max_seconds=max_seconds))
        if self.skip is not None:
            timing["pilot_seconds_skipped"] = self.skip
            return None
        timing["pilot_seconds"] = 1.25
        return self.measured

    def _seconds(self, scene, command, occlusion, inter_reflection, convex, zoned=False, *, env_samples=None):
        self.seconds.append((scene, command, occlusion, inter_reflection, convex, zoned, env_samples))
        return {"samples": 1.0, "volume": 2.0, "render": 30.0}

    def _render(self, *args):
        self.renders.append(args)
        return {"render": 4.5}


@pytest.fixture
def stand(monkeypatch):
    return Stand(monkeypatch)


def plan(mesh, **kw):
    kw.setdefault("scenario", "bench")
    kw.setdefault("quality", "draft")
    kw.setdefault("predict", False)
    return P.plan_effects(mesh, **kw)


EFFECTS = ("occlusion", "inter_reflection", "depth", "environment", "polarisation", "colour", "zoning")
THIN_10 = ("10% of the surface lies over less stone than the stack's 0.93 mm and the normal turns 11.2° across "
           "twice the flash depth (0.43 mm)")
DEPTH_OFF_10 = THIN_10 + (": below 20%; on the bundled cuts this leaves the energy within 4 % and the answer "
                          "within 0.6° (1.3° along a worn ring's flat top; docs/planner.md)")
DEPTH_HOW = ("the volume estimator: light refracted in, mirrored at a depth drawn from the stack's depth law, "
             "traced to where it leaves")
COLOUR_WHY = ("flash metrics are luminance ratios: a luminance table integrates the spectrum exactly at every angle "
              "(no colour channels needed)")
POL_01 = ("unpolarised light and eye: s/p-averaged Fresnel and stack terms, 0.10% off the exact unpolarised product "
          "for this scene's light and view pairs")
OCC_HOW = "shadow rays from every surface sample to every light and view direction"
OCC_ON = "non-convex stone: parts of it hide lights and viewers from other parts"
IR_HOW = "the render estimator's path tracer (the surface samples cannot carry it)"


# ---------------------------------------------------------------------- a convex stone
def test_a_convex_stone_under_lamps_every_decision_word_for_word(oval, stand):
    p = plan(oval)
    assert p.command == "recommend" and p.convex is True and p.pilot_seconds == 0.0 and p.env_samples is None
    assert [d.effect for d in p.decisions] == list(EFFECTS)
    assert [d.to_dict() for d in p.decisions] == [
        {"effect": "occlusion", "on": False, "how": "",
         "why": "convex stone: a ray leaving the surface never meets it again (exact)", "forced": False, "bound": 0.0},
        {"effect": "inter_reflection", "on": False, "how": IR_HOW,
         "why": "convex stone: no light path leaves it and comes back (exact)", "forced": False, "bound": 0.0},
        {"effect": "depth", "on": False, "how": DEPTH_HOW, "why": DEPTH_OFF_10, "forced": False, "bound": None},
        {"effect": "environment", "on": False, "how": "", "why": "the lights are lamps only", "forced": False,
         "bound": 0.0},
        {"effect": "polarisation", "on": False, "how": "", "why": POL_01, "forced": False, "bound": 0.001},
        {"effect": "colour", "on": False, "how": "luminance", "why": COLOUR_WHY, "forced": False, "bound": 0.0},
        {"effect": "zoning", "on": False, "how": "", "why": "a uniform material (--zoning asks for colour zones)",
         "forced": False, "bound": None},
    ]
    assert p.estimator == "samples" and p.estimator_why == "every effect on is one the surface samples carry"
    assert p.facts == {"convex": True, "scenario": "bench", "lighting": "overhead", "viewing": "cutter", "poses": 7,
                       "thin_share": 0.1, "normal_turn_deg": 11.24, "flash_depth_mm": 0.4336, "stack_depth_mm": 0.93,
                       "polarisation_bias": 0.001}
    assert p.predicted_seconds == {} and stand.seconds == [] and stand.pilots == []
    # the polarisation bias asked once, for each pose's lights and views, of the material asked for
    (material, pairs), = stand.pairs
    scene = resolve_scene("bench", quality="draft")
    assert material == labcut.Labradorite.coerce(None) and len(pairs) == 7
    assert all(lv[0].name == "overhead" and lv[1].name == "cutter" for lv in pairs)
    assert [np.asarray(lv[0].directions).tolist() for lv in pairs] == [
        np.asarray(st.lights.directions).tolist() for st in scene.settings()]


def test_the_polarisation_bias_is_the_largest_pose_s_and_said_above_the_tolerance(oval, stand):
    stand.bias = [0.001, 0.0345, 0.002, 0.0, 0.01, 0.003, 0.004]
    p = plan(oval)
    d = p["polarisation"]
    assert d.bound == 0.0345 and p.facts["polarisation_bias"] == 0.0345 and d.on is False
    assert d.why == ("unpolarised light and eye: s/p-averaged Fresnel and stack terms, 3.45% off the exact unpolarised "
                     "product for this scene's light and view pairs, above the 2% the answer can miss: the flash "
                     "estimators carry unpolarised terms only (grazing light on the face; a render with --polarizer "
                     "shows the polarised flash)")
    stand.bias = [0.02]  # exactly the tolerance: not above it
    assert plan(oval)["polarisation"].why.endswith("for this scene's light and view pairs")
    stand.bias = [0.0200001]
    assert "above the 2%" in plan(oval)["polarisation"].why
    stand.bias = [0.123456789]
    assert plan(oval).facts["polarisation_bias"] == 0.12346


def test_forcing_an_effect_on_in_a_convex_stone_is_refused(oval, stand):
    with pytest.raises(ParameterError) as info:
        plan(oval, effects={"occlusion": True})
    assert str(info.value) == "occlusion cannot be switched on for a convex stone: no part of it can hide another"
    with pytest.raises(ParameterError) as info:
        plan(oval, effects={"inter_reflection": True})
    assert str(info.value) == ("inter-reflection cannot be switched on for a convex stone: no light path leaves it "
                               "and comes back")
    # switched off: as it is (exact), and said so
    p = plan(oval, effects={"occlusion": False, "inter_reflection": False})
    assert p["occlusion"].on is False and p["inter_reflection"].on is False and p["inter_reflection"].forced is True
    assert p["inter_reflection"].why == "convex stone: no light path leaves it and comes back (exact)"


# ---------------------------------------------------------------------- a carving: inter-reflection
SHARE = "25% of the sky above the surface is the stone itself, which sends back at most 40%"


def test_a_carving_s_bound_above_the_tolerance_is_measured_by_pilots(biplane, stand):
    stand.f, stand.rho, stand.measured = 0.25, 0.4, 0.03  # a bound of 10 %, measured 3 %
    p = plan(biplane, pilot_seconds_max=7.5)
    ir = p["inter_reflection"]
    assert ir.on is True and ir.bound == 0.03 and ir.forced is False and ir.how == IR_HOW
    assert ir.why == ("pilot renders with and without light between its parts (64² px, 16 spp, 5 normals) differ by "
                      f"3.0% of the best flash ({SHARE}: a bound of 10.0%), above the 2% the answer can miss")
    assert p.facts["self_view_fraction"] == 0.25 and p.facts["return_albedo"] == 0.4
    assert p.facts["interreflection_bound"] == 0.1 and p.facts["interreflection_measured"] == 0.03
    assert "interreflection_pilots_skipped_seconds" not in p.facts
    assert p.pilot_seconds == 1.25
    (call,) = stand.pilots
    assert call.mesh is biplane or call.mesh is labcut.geometry.stone.mesh_of(biplane)
    assert call.material == labcut.Labradorite.coerce(None) and call.max_seconds == 7.5
    # the pilots' own scene: the scenario drawn at the standard quality (13 poses), not the plan's draft
    assert call.scene.name == "bench" and str(call.scene.quality) == "standard" and len(call.scene.poses()) == 13
    assert p.estimator == "render" and p.estimator_why == "inter-reflection is on and only renders carry it"
    # the occlusion of a carving
    occ = p["occlusion"]
    assert (occ.on, occ.how, occ.why, occ.forced, occ.bound) == (True, OCC_HOW, OCC_ON, False, None)


def test_the_measured_share_at_the_tolerance_is_below_it(biplane, stand):
    stand.f, stand.rho, stand.measured = 0.25, 0.4, 0.02
    ir = plan(biplane)["inter_reflection"]
    assert ir.on is False and ir.bound == 0.02
    assert ir.why == ("pilot renders with and without light between its parts (64² px, 16 spp, 5 normals) differ by "
                      f"2.0% of the best flash ({SHARE}: a bound of 10.0%), below the 2% the answer can miss")
    stand.measured = 0.02000001
    assert plan(biplane)["inter_reflection"].on is True
    stand.measured = 0.0
    p = plan(biplane)
    assert p["inter_reflection"].on is False and p.facts["interreflection_measured"] == 0.0
    assert p.estimator == "samples"  # thin share 10 %, lamps only


def test_the_facts_are_rounded_as_documented(biplane, stand):
    stand.f, stand.rho, stand.measured = 0.123456, 0.456789, 0.0312345678
    p = plan(biplane)
    assert p.facts["self_view_fraction"] == 0.1235 and p.facts["return_albedo"] == 0.4568
    assert p.facts["interreflection_bound"] == 0.0564 and p.facts["interreflection_measured"] == 0.03123


def test_a_bound_at_the_tolerance_needs_no_pilots(biplane, stand):
    stand.f, stand.rho = 0.04, 0.5  # exactly 0.02
    p = plan(biplane)
    ir = p["inter_reflection"]
    assert stand.pilots == [] and ir.on is False and ir.bound == 0.02 and p.pilot_seconds == 0.0
    assert ir.why == ("4% of the sky above the surface is the stone itself, which sends back at most 50%: at most 2.0% "
                      "of the flash energy, below the 2% the answer can miss")
    assert "interreflection_measured" not in p.facts and p.facts["interreflection_bound"] == 0.02
    stand.f = 0.0400001
    plan(biplane)
    assert len(stand.pilots) == 1


def test_pilots_only_for_recommend_and_evaluate_and_not_when_forced(biplane, stand):
    stand.f, stand.rho, stand.measured = 0.25, 0.4, 0.01
    assert plan(biplane, command="evaluate")["inter_reflection"].bound == 0.01 and len(stand.pilots) == 1
    c = plan(biplane, command="compare")
    assert len(stand.pilots) == 1 and c["inter_reflection"].bound == 0.1  # the bound, not measured
    plan(biplane, command="render")
    assert len(stand.pilots) == 1
    p = plan(biplane, effects={"inter-reflection": "off"})
    assert len(stand.pilots) == 1
    ir = p["inter_reflection"]
    assert ir.on is False and ir.forced is True and ir.bound == 0.1
    assert ir.why == f"switched off ({SHARE}: at most 10.0% of the flash energy)"
    p = plan(biplane, effects={"inter_reflection": True})
    assert p["inter_reflection"].on is True and p["inter_reflection"].why.startswith("switched on (")
    assert p.estimator == "render"


def test_a_pilot_scene_given_is_the_one_measured(biplane, stand):
    stand.f, stand.rho, stand.measured = 0.25, 0.4, 0.01
    scene = resolve_scene("ring", quality="draft")
    plan(biplane, pilot_scene=scene)
    assert stand.pilots[0].scene is scene and stand.pilots[0].max_seconds is None
    with pytest.raises(ParameterError) as info:
        plan(biplane, pilot_scene="bench")
    assert str(info.value) == "pilot_scene must be a labcut.Scenario (planner.pilot_scene(setup)), got str"


def test_pilots_over_the_budget_leave_inter_reflection_off_and_say_why(biplane, stand):
    stand.f, stand.rho, stand.skip = 0.25, 0.4, 2.3456
    p = plan(biplane, pilot_seconds_max=0.5)
    ir = p["inter_reflection"]
    assert ir.on is False and ir.bound == 0.1 and p.pilot_seconds == 0.0
    assert p.facts["interreflection_pilots_skipped_seconds"] == 2.346 and "interreflection_measured" not in p.facts
    assert ir.why == ("not measured: the time budget leaves 0.5 s for pilot renders predicted to take 2.3 s, so the "
                      f"surface samples answer ({SHARE}: at most 10.0% of the flash energy; a larger budget, or none, "
                      "measures it)")
    assert p.estimator == "samples"


def test_pilots_of_a_clustered_copy_say_so(biplane, stand, monkeypatch):
    stand.f, stand.rho, stand.measured = 0.25, 0.4, 0.05
    monkeypatch.setattr(P, "pilots_on_copy", lambda mesh: True)
    assert plan(biplane)["inter_reflection"].why.startswith(
        "pilot renders with and without light between its parts (64² px, 16 spp, 5 normals, of a copy clustered to "
        "256 cells along its diagonal) differ by 5.0%")


def test_occlusion_switched_off_in_a_carving(biplane, stand):
    p = plan(biplane, effects={"occlusion": "off"}, scenario="ring-diffuse")
    occ = p["occlusion"]
    assert (occ.on, occ.how, occ.forced, occ.bound) == (False, OCC_HOW, True, None)
    assert occ.why == "switched off: lights and viewers treated as seen from every surface point (approximate)"
    # no occlusion: the map is not seen past the parts, no more directions drawn
    assert p.env_samples is None and "map_directions" not in p.facts and p.estimator == "samples"
    assert p.estimator_why == "every effect on is one the surface samples carry"
    p = plan(biplane, effects={"occlusion": True})
    assert p["occlusion"].forced is True and p["occlusion"].why == OCC_ON


# ---------------------------------------------------------------------- depth
def test_the_thin_share_at_its_threshold_turns_the_volume_estimator_on(oval, stand):
    stand.thin = 0.2
    p = plan(oval)
    d = p["depth"]
    thin = THIN_10.replace("10%", "20%")
    assert d.on is True and d.forced is False and d.how == DEPTH_HOW
    assert d.why == thin + ": at or above 20%, thin parts would mirror a whole stack's flash in the surface model"
    assert p.estimator == "volume"
    assert p.estimator_why == "the stack's depth matters here and the volume estimator carries it"
    stand.thin = 0.19999
    p = plan(oval)
    assert p["depth"].on is False and p.estimator == "samples"
    assert p["depth"].why == thin + (": below 20%; on the bundled cuts this leaves the energy within 4 % and the "
                                     "answer within 0.6° (1.3° along a worn ring's flat top; docs/planner.md)")


def test_depth_forced_either_way(oval, stand):
    stand.thin = 0.5
    d = plan(oval, effects={"depth": False})["depth"]
    assert d.on is False and d.forced is True and d.why == "switched off (" + THIN_10.replace("10%", "50%") + ")"
    stand.thin = 0.0
    p = plan(oval, effects={"depth": "on"})
    assert p["depth"].on is True and p["depth"].why == "switched on (" + THIN_10.replace("10%", "0%") + ")"
    assert p.estimator == "volume"


def test_the_estimator_asked_for_and_what_it_leaves_out(biplane, stand):
    stand.f, stand.rho, stand.measured, stand.thin = 0.25, 0.4, 0.05, 0.5
    p = plan(biplane, estimator="render")
    assert p.estimator == "render"
    assert p.estimator_why == "asked for; renders mirror the light where it enters (the stack's depth is left out)"
    p = plan(biplane, estimator="volume")
    assert p.estimator == "volume"
    assert p.estimator_why == "asked for; it cannot carry inter-reflection (up to 5.0% of the energy is left out)"
    p = plan(biplane, estimator="samples")
    assert p.estimator == "samples"
    assert p.estimator_why == ("asked for; it mirrors the light where it enters (the stack's depth is left out); it "
                               "cannot carry inter-reflection (up to 5.0% of the energy is left out)")
    # auto: the render estimator, which leaves the depth out
    p = plan(biplane)
    assert p.estimator == "render" and p.estimator_why == (
        "inter-reflection is on and only renders carry it; renders mirror the light where it enters (the stack's "
        "depth is left out)")
    stand.thin, stand.measured = 0.0, 0.0
    for est in ("render", "volume", "samples"):
        assert plan(biplane, estimator=est).estimator_why == "asked for", est


def test_asked_estimators_past_a_still_map(biplane, stand):
    stand.f, stand.rho, stand.measured = 0.25, 0.4, 0.05
    seen = ("the environment map is seen past the stone's parts through 256 sampled directions instead of the "
            "quality's 32 (fewer miss the light the parts let through from the rest of the map, docs/planner.md)")
    p = plan(biplane, scenario="ring-diffuse", estimator="volume")
    assert p.estimator_why == ("asked for; it cannot carry inter-reflection (up to 5.0% of the energy is left out); "
                               + seen) and p.env_samples == 256
    assert p.facts["map_directions_sampled"] == 256 and p["environment"].how.startswith("256 directions")
    p = plan(biplane, scenario="ring-diffuse", estimator="samples")
    assert p.estimator_why == ("asked for; it cannot carry inter-reflection (up to 5.0% of the energy is left out); "
                               + seen) and p.env_samples == 256
    p = plan(biplane, scenario="ring-diffuse", estimator="render")
    assert p.estimator_why == "asked for" and p.env_samples is None
    assert "map_directions_sampled" not in p.facts and p["environment"].how == "32 directions importance-sampled from the map"
    assert p.facts["map_directions"] == 32 and p.facts["map_directions_over_poses"] == 32


# ---------------------------------------------------------------------- environment maps
def test_a_still_map_past_a_carving_s_parts_is_drawn_through_more_directions(biplane, stand):
    p = plan(biplane, scenario="ring-diffuse")
    assert p.estimator == "samples" and p.env_samples == 256
    assert p.estimator_why == ("the environment map is seen past the stone's parts through 256 sampled directions "
                               "instead of the quality's 32 (fewer miss the light the parts let through from the rest "
                               "of the map, docs/planner.md)")
    env = p["environment"]
    assert env.on is True and env.forced is False and env.bound is None
    assert env.how == "256 directions importance-sampled from the map (the quality's 32, more where the map is seen past the stone's parts)"
    assert env.why == "the lights include the map 'ceiling'"
    assert p["occlusion"].how == OCC_HOW and p["depth"].how == DEPTH_HOW and p["colour"].how == "luminance"
    assert p.facts["map_directions"] == 32 and p.facts["map_directions_over_poses"] == 32
    assert p.facts["map_directions_sampled"] == 256
    # with depth on: the volume estimator, both reasons
    stand.thin = 0.3
    p = plan(biplane, scenario="ring-diffuse")
    assert p.estimator == "volume" and p.env_samples == 256
    assert p.estimator_why.startswith("the stack's depth matters here and the volume estimator carries it; the "
                                      "environment map is seen past the stone's parts through 256")


def test_a_moving_map_past_a_carving_s_parts_is_enough(biplane, stand):
    p = plan(biplane, scenario="ring")  # 32 map directions x 7 poses = 224
    assert p.estimator == "samples" and p.env_samples is None
    assert p.estimator_why == ("an environment map seen past the parts of a non-convex stone, but the moving stone sees "
                               "32 map directions in each of 7 poses, 224 in its own frame (at least 96): the samples "
                               "follow the map as the renders do (docs/planner.md)")
    assert p["environment"].how == "32 directions importance-sampled from the map"
    assert p.facts["map_directions"] == 32 and p.facts["map_directions_over_poses"] == 224
    assert "map_directions_sampled" not in p.facts
    stand.thin = 0.3
    assert plan(biplane, scenario="ring").estimator_why == (
        "the stack's depth matters here and the volume estimator carries it; an environment map seen past the parts "
        "of a non-convex stone, but the moving stone sees 32 map directions in each of 7 poses, 224 in its own frame "
        "(at least 96): the samples follow the map as the renders do (docs/planner.md)")


def test_a_map_on_a_convex_stone_is_sampled_as_the_quality_says(oval, stand):
    p = plan(oval, scenario="outdoor-still")
    env = p["environment"]
    assert env.on is True and env.how == "32 directions importance-sampled from the map"
    assert env.why == "the lights include the map 'sky'" and p.env_samples is None
    assert p.estimator_why == "every effect on is one the surface samples carry" and "map_directions" not in p.facts
    r = plan(oval, scenario="outdoor-still", command="render")
    assert r["environment"].how == "an envmap emitter"
    r = plan(oval, command="render")
    assert r["environment"].why == "the lights are lamps only (a dim constant room shows the body in renders)"


# ---------------------------------------------------------------------- compare
def test_compare_ranks_with_the_samples_and_says_what_it_leaves_out(biplane, stand):
    stand.f, stand.rho, stand.thin = 0.25, 0.4, 0.5
    p = plan(biplane, command="compare")
    assert p.estimator == "samples" and stand.pilots == []
    assert p.estimator_why == ("compare ranks many cuts with the sample estimator; inter-reflection (up to 10.0% of the "
                               "flash energy) and the stack's depth (thin parts mirroring less) are left out: "
                               "recommend-orientation --estimator render or --estimator volume per cut carries it")
    ir, depth = p["inter_reflection"], p["depth"]
    assert ir.on is False and ir.how == "" and ir.bound == 0.1 and ir.forced is False
    assert ir.why == ("left out: compare ranks with the sample estimator (" + SHARE + ": at most 10.0% of the flash "
                      "energy, above the 2% the answer can miss)")
    assert depth.on is False and depth.why.startswith("left out: compare ranks with the sample estimator (50% of")
    assert p["occlusion"].on is True and p["occlusion"].how == OCC_HOW  # kept
    assert p["zoning"].why == "a uniform material"
    stand.thin = 0.0
    p = plan(biplane, command="compare")
    assert p.estimator_why == ("compare ranks many cuts with the sample estimator; inter-reflection (up to 10.0% of the "
                               "flash energy) is left out: recommend-orientation --estimator render per cut carries it")
    assert p["depth"].on is False and p["depth"].why.startswith("0% of")
    stand.f, stand.thin = 0.0, 0.5
    p = plan(biplane, command="compare", scenario="ring-diffuse")
    assert p.estimator_why == (
        "compare ranks many cuts with the sample estimator; the stack's depth (thin parts mirroring less) is left out: "
        "recommend-orientation --estimator volume per cut carries it; the environment map is seen past the stone's "
        "parts through 256 sampled directions instead of the quality's 32 (fewer miss the light the parts let through "
        "from the rest of the map, docs/planner.md)")
    assert p["inter_reflection"].why.endswith("below the 2% the answer can miss")
    assert p.env_samples == 256


def test_compare_leaves_a_forced_inter_reflection_out_and_says_it_was_forced(biplane, stand):
    stand.f, stand.rho = 0.01, 0.4
    p = plan(biplane, command="compare", effects={"inter_reflection": True})
    ir = p["inter_reflection"]
    assert ir.on is False and ir.forced is True and ir.bound == pytest.approx(0.004)
    assert ir.why == ("left out: compare ranks with the sample estimator (switched on (1% of the sky above the surface is "
                      "the stone itself, which sends back at most 40%: at most 0.4% of the flash energy))")
    assert p.estimator_why.endswith("is left out: recommend-orientation --estimator render per cut carries it")


def test_compare_refuses_the_render_and_volume_estimators(biplane, stand):
    for est in ("render", "volume"):
        with pytest.raises(ParameterError) as info:
            plan(biplane, command="compare", estimator=est)
        assert str(info.value) == ("compare runs the sample estimator (many cuts and curves); use --estimator samples, "
                                   f"or recommend-orientation --estimator {est} per cut")
        with pytest.raises(ParameterError):
            P.check_compare_estimator(est)
    for est in ("samples", "auto"):
        assert P.check_compare_estimator(est) is None
    assert plan(biplane, command="compare", estimator="samples").estimator == "samples"


# ---------------------------------------------------------------------- zoning
def test_a_zoned_stone_is_answered_by_renders(oval, stand):
    p = plan(oval, zoning="natural")
    z = p["zoning"]
    assert z.on is True and z.how == ("lamella parameters blended by a baked noise field: the render estimator weighs "
                                      "each zone's flash as the viewers see it")
    assert z.why == "colour zones asked for (natural)"
    assert p.estimator == "render"
    assert p.estimator_why == "a zoned stone: each point flashes with its own lamella stack, which only renders carry"
    assert plan(oval, zoning=SimpleNamespace(name="marbled"))["zoning"].why == "colour zones asked for (marbled)"
    assert plan(oval, zoning=SimpleNamespace(name=None))["zoning"].why == "colour zones asked for (custom)"
    assert plan(oval, zoning=SimpleNamespace())["zoning"].why == "colour zones asked for (custom)"
    r = plan(oval, zoning="natural", command="render", look="studio")["zoning"]
    assert r.how == "lamella parameters blended by a baked noise field"
    assert r.why == ("a studio picture shows a real stone's zones by default (natural; --zoning none for the clean "
                     "model)")
    assert plan(oval, zoning="natural", command="render")["zoning"].why == "colour zones asked for (natural)"
    assert plan(oval, zoning="smooth", command="render", look="studio")["zoning"].why == "colour zones asked for (smooth)"
    assert plan(oval, zoning="natural", look="studio")["zoning"].why == "colour zones asked for (natural)"
    stand.thin = 0.5
    assert plan(oval, zoning="natural").estimator_why == (
        "a zoned stone: each point flashes with its own lamella stack, which only renders carry; renders mirror the "
        "light where it enters (the stack's depth is left out)")


# ---------------------------------------------------------------------- renders
def test_a_render_s_plan(biplane, oval, stand):
    p = plan(biplane, command="render")
    occ, ir, depth = p["occlusion"], p["inter_reflection"], p["depth"]
    assert (occ.on, occ.how, occ.why, occ.forced, occ.bound) == (
        True, "ray tracing", "a renderer traces every ray; it costs nothing extra", False, None)
    assert ir.on is True and ir.how == "path tracing, 3 bounces" and p.estimator is None and p.estimator_why == ""
    assert depth.on is False and depth.why == ("renders mirror the schiller where the light meets the surface (the BSDF); "
                                               "recommend --estimator volume carries the depth")
    assert p["polarisation"].why == "no polariser: the eye and the camera see unpolarised light"
    assert p["polarisation"].on is False and p["polarisation"].how == "" and stand.pairs == []
    assert p["colour"].to_dict() == {"effect": "colour", "on": True, "how": "rgb", "forced": False, "bound": None,
                                     "why": "RGB: the BSDF's colour table integrates the spectrum at every angle"}
    assert p.facts["mode"] == "rgb"
    assert p["zoning"].why == "a uniform material (--zoning asks for colour zones)"
    c = plan(oval, command="render", effects={"occlusion": False})
    assert c["occlusion"].bound == 0.0 and c["occlusion"].on is True and c["occlusion"].forced is True
    assert c["inter_reflection"].on is False and c["inter_reflection"].how == "path tracing, 3 bounces"
    stand.thin = 0.9
    assert plan(oval, command="render")["depth"].on is False


def test_a_render_s_depth_asked_for(biplane, oval, stand):
    for mesh, depth, on in ((biplane, 2, False), (biplane, 3, True), (oval, 3, True), (oval, 2.9, False)):
        ir = plan(mesh, command="render", max_depth=depth)["inter_reflection"]
        assert ir.on is on and ir.how == f"path tracing to depth {int(depth)} (as asked)", (depth, ir)


def test_a_render_s_polariser_and_colour(oval, stand):
    p = plan(oval, command="render", polarizer_deg=30.0)
    assert p["polarisation"].on is True
    assert p["polarisation"].how == "Stokes vectors through Mueller matrices (polarised variant)"
    assert p["polarisation"].why == "a polariser at 30° is in front of the camera"
    assert p["colour"].how == "spectral" and p["colour"].why == "a polariser: Mitsuba has no polarised RGB, so spectral"
    assert plan(oval, command="render", polarizer_deg=22.5)["polarisation"].why == "a polariser at 22.5° is in front of the camera"
    s = plan(oval, command="render", polarizer_deg=30.0, mode="spectral")["colour"]
    assert s.how == "spectral" and s.why == "spectral as asked"
    m = plan(oval, command="render", mode="mono")
    assert m["colour"].how == "mono" and m["colour"].why == "mono as asked" and m.facts["mode"] == "mono"
    r = plan(oval, command="render", mode="rgb")["colour"]
    assert r.how == "rgb" and r.why == "rgb as asked"
    with pytest.raises(ParameterError) as info:
        plan(oval, command="render", polarizer_deg=30.0, mode="mono")
    assert str(info.value) == ("a polariser view needs colour (the polarised schiller changes hue): use --mode spectral "
                               "or leave --mode out, not mono")


def test_a_render_s_predicted_seconds(oval, biplane, stand):
    p = plan(oval, command="render", predict=True)
    assert p.predicted_seconds == {"render": 4.5}
    assert stand.renders[-1] == ("rgb", False, "direct", 512, 64, 1, "diagram")
    assert p.facts["predicted_for"] == "512² px, 64 spp, 1 view, diagram look"
    p = plan(biplane, command="render", predict=True, resolution=96, spp=8, views=3, look="studio", polarizer_deg=10.0)
    assert stand.renders[-1] == ("spectral", True, "path", 96, 8, 3, "studio")
    assert p.facts["predicted_for"] == "96² px, 8 spp, 3 views, studio look"
    plan(oval, command="render", predict=True, max_depth=2, mode="mono")
    assert stand.renders[-1] == ("mono", False, "path", 512, 64, 1, "diagram")
    assert stand.seconds == []


def test_the_predicted_seconds_of_the_estimators_are_asked_with_the_plan_s_choices(biplane, oval, stand):
    p = plan(oval, predict=True)
    assert p.predicted_seconds == {"samples": 1.0, "volume": 2.0, "render": 30.0} and stand.renders == []
    scene, *rest = stand.seconds[-1]
    assert scene.name == "bench" and str(scene.quality) == "draft"
    assert rest == ["recommend", False, False, True, False, None]
    plan(oval, predict=True, zoning="smooth", command="evaluate")
    assert stand.seconds[-1][1:] == ("evaluate", False, False, True, True, None)
    stand.f, stand.rho, stand.measured = 0.25, 0.4, 0.05
    plan(biplane, predict=True, scenario="ring-diffuse")
    assert stand.seconds[-1][1:] == ("recommend", True, True, False, False, 256)
    plan(biplane, predict=True, scenario="ring-diffuse", effects={"occlusion": False})
    assert stand.seconds[-1][1:] == ("recommend", False, True, False, False, None)


def test_the_material_and_the_lights_and_views_asked_for(biplane, stand):
    stand.f, stand.rho, stand.measured = 0.25, 0.4, 0.05
    blue = labcut.Labradorite.preset("blue")
    p = plan(biplane, material="blue", scenario="bench", lighting="office", viewing="front")
    assert (p.facts["scenario"], p.facts["lighting"], p.facts["viewing"], p.facts["poses"]) == ("bench", "office", "front", 7)
    assert stand.pairs[-1][0] == blue and stand.pilots[-1].material == blue and blue != labcut.Labradorite()
    assert stand.materials == [blue, blue]  # the return albedo's and the depth exposure's
    assert stand.pilots[-1].scene.lights.name == "office" and stand.pilots[-1].scene.views.name == "front"
    plan(biplane, scenario="display")  # the pilots' scene: the scenario's, at the standard quality
    assert stand.pilots[-1].scene.name == "display" and stand.pilots[-1].scene.lights.name == "shop"
    assert str(stand.pilots[-1].scene.quality) == "standard"
    p = plan(biplane, scenario=None, lighting="room", viewing="above")
    assert (p.facts["scenario"], p.facts["lighting"], p.facts["viewing"]) == ("custom", "room", "above")


def test_a_render_of_a_carving_traces_occlusion_even_switched_off(biplane, stand):
    """A renderer traces every ray: occlusion on (forced off or not), so the map is seen past the parts."""
    p = plan(biplane, command="render", scenario="ring-diffuse", effects={"occlusion": False})
    assert p["occlusion"].on is True and p["occlusion"].forced is True and p.estimator is None
    assert p.facts["map_directions"] == 32 and p.facts["map_directions_over_poses"] == 32
    assert "map_directions_sampled" not in p.facts and p.env_samples is None
    assert p["environment"].how == "an envmap emitter"


def test_the_defaults_a_standard_recommendation_with_its_seconds(oval, stand):
    p = P.plan_effects(oval, scenario="bench")
    assert p.command == "recommend" and p.facts["poses"] == 13 and str(stand.seconds[-1][0].quality) == "standard"
    assert p.predicted_seconds == {"samples": 1.0, "volume": 2.0, "render": 30.0} and p.estimator == "samples"
    r = P.plan_effects(oval, command="render")
    assert stand.renders[-1] == ("rgb", False, "direct", 512, 64, 1, "diagram") and r.predicted_seconds == {"render": 4.5}


def test_bad_requests_are_one_line_errors(oval, stand):
    cases = [
        (dict(command="explain"), "command must be one of render, recommend, evaluate, compare, got 'explain'"),
        (dict(estimator="paths"), "estimator must be one of auto, samples, volume, render, got 'paths'"),
        (dict(look="photo", command="render"), "look must be diagram or studio, got 'photo'"),
        (dict(polarizer_deg=30.0), "recommend scores luminance flash: colour mode and polariser apply to renders only"),
        (dict(mode="rgb", command="evaluate"),
         "evaluate scores luminance flash: colour mode and polariser apply to renders only"),
        (dict(zoning="natural", command="compare"),
         "compare scores uniform materials with the sample estimator: zoning applies to render, "
         "recommend-orientation and evaluate-orientation"),
        (dict(zoning="natural", estimator="samples"),
         "the sample estimator scores a uniform material: a zoned stone needs --estimator render (or auto, which "
         "picks it)"),
        (dict(command="render", estimator="samples"), "estimator applies to recommend, evaluate and compare, not to render"),
    ]
    for kw, message in cases:
        with pytest.raises(ParameterError) as info:
            plan(oval, **kw)
        assert str(info.value) == message, kw
    # the image size and views: their ranges, ends included
    plan(oval, command="render", resolution=8, spp=1, views=1)
    plan(oval, command="render", resolution=8192, spp=1 << 30, views=10_000)
    for kw, message in ((dict(resolution=7), "resolution must lie in [8, 8192], got 7"),
                        (dict(resolution=8193), "resolution must lie in [8, 8192], got 8193"),
                        (dict(spp=0), "spp (samples per pixel) must lie in [1, 1073741824], got 0"),
                        (dict(spp=(1 << 30) + 1), "spp (samples per pixel) must lie in [1, 1073741824], got 1073741825"),
                        (dict(views=0), "views must lie in [1, 10000], got 0"),
                        (dict(views=10_001), "views must lie in [1, 10000], got 10001"),
                        (dict(resolution=64.5), "resolution")):
        with pytest.raises(ParameterError) as info:
            plan(oval, command="render", **kw)
        assert str(info.value).startswith(message), kw
    # a zoned stone with the render or volume estimator, and any estimator under compare, are fine
    assert plan(oval, zoning="natural", estimator="render").estimator == "render"
    assert plan(oval, zoning="natural", estimator="auto").estimator == "render"
    assert plan(oval, command="render", mode="spectral", polarizer_deg=5.0)["colour"].how == "spectral"


# ---------------------------------------------------------------------- the plan as text and data
def test_the_plan_s_lines_repr_and_dict(biplane, stand):
    stand.f, stand.rho, stand.measured = 0.25, 0.4, 0.05
    p = plan(biplane, predict=True, effects={"occlusion": True})
    lines = p.lines()
    assert lines[0] == f"occlusion         ON   {OCC_HOW} — {OCC_ON} (forced)"
    assert lines[1] == (f"inter-reflection  ON   {IR_HOW} — pilot renders with and without light between its parts (64² "
                        f"px, 16 spp, 5 normals) differ by 5.0% of the best flash ({SHARE}: a bound of 10.0%), above "
                        "the 2% the answer can miss")
    assert lines[2] == "depth             off  " + DEPTH_OFF_10
    assert lines[3] == "environment       off  the lights are lamps only"
    assert lines[-1] == ("estimator         render  — inter-reflection is on and only renders carry it (predicted 30.0 "
                         "s; samples ~1.0 s, volume ~2.0 s, render ~30.0 s)")
    assert len(lines) == 8
    assert repr(p) == "EffectPlan(recommend: on=['occlusion', 'inter_reflection'], estimator='render')"
    d = p.to_dict()
    assert list(d) == ["command", "estimator", "estimator_why", "predicted_seconds", "env_samples", "convex", "facts",
                       "effects"]
    assert d["command"] == "recommend" and d["estimator"] == "render" and d["convex"] is False
    assert d["env_samples"] is None and d["facts"] is p.facts
    assert d["estimator_why"] == "inter-reflection is on and only renders carry it"
    assert list(d["effects"]) == list(EFFECTS) and d["effects"]["occlusion"]["forced"] is True
    assert p.on("inter_reflection") is True and p.on("depth") is False
    with pytest.raises(KeyError) as info:
        p["shadows"]
    assert info.value.args == ("shadows",)
    html = p._repr_html_()
    assert html.startswith("<table><thead><tr><th>effect</th><th></th><th>why</th></tr></thead><tbody>")
    assert "<tr><td>occlusion</td><td>on</td><td>" + OCC_ON + "</td></tr>" in html
    assert "<tr><td>depth</td><td>off</td><td>" + DEPTH_OFF_10.replace("'", "&#x27;") + "</td></tr>" in html
    assert html.endswith("<tr><td>estimator</td><td>render</td><td>inter-reflection is on and only renders carry "
                         "it</td></tr></tbody></table>")


def test_lines_without_an_estimator_or_a_prediction():
    d = P.Decision("zoning", False, "x", "none <asked>")
    assert d.to_dict() == {"effect": "zoning", "on": False, "how": "x", "why": "none <asked>", "forced": False,
                           "bound": None}
    p = P.EffectPlan("render", (d,), None, "", {"render": 12.3456}, facts={"predicted_for": "64² px"})
    assert p.lines() == ["zoning            off  none <asked>", "predicted         render ~12.3 s (64² px)"]
    assert p.to_dict()["predicted_seconds"] == {"render": 12.346} and p.to_dict()["convex"] is True
    assert repr(p) == "EffectPlan(render: on=[])"
    assert p._repr_html_() == ("<table><thead><tr><th>effect</th><th></th><th>why</th></tr></thead><tbody><tr><td>zoning"
                               "</td><td>off</td><td>none &lt;asked&gt;</td></tr></tbody></table>")
    q = P.EffectPlan("render", (d,), None, "", {"render": 2.0, "volume": 0.25})
    assert q.lines()[-1] == "predicted         render ~2.0 s, volume ~0.2 s"
    two = P.EffectPlan("x", (d, P.Decision("depth", True, "h", "w")), "samples", "a & b")
    assert two._repr_html_() == (
        "<table><thead><tr><th>effect</th><th></th><th>why</th></tr></thead><tbody><tr><td>zoning</td><td>off</td><td>"
        "none &lt;asked&gt;</td></tr><tr><td>depth</td><td>on</td><td>w</td></tr><tr><td>estimator</td><td>samples</td>"
        "<td>a &amp; b</td></tr></tbody></table>")
    assert two.lines() == ["zoning            off  none <asked>", "depth             ON   h — w",
                           "estimator         samples  — a & b"]
    assert P.EffectPlan("render", (d,), None, "").lines() == ["zoning            off  none <asked>"]
    e = P.EffectPlan("compare", (P.Decision("depth", True, "volume", "thin", True, 0.5),), "samples", "why",
                     {"volume": 3.0})
    assert e.lines() == ["depth             ON   volume — thin (forced)", "estimator         samples  — why"]
    assert repr(e) == "EffectPlan(compare: on=['depth'], estimator='samples')"
    assert P.EffectPlan("x", (), None, "").pilot_seconds == 0.0 and P.EffectPlan("x", (), None, "").env_samples is None


# ---------------------------------------------------------------------- the physics of the bounds
def textbook_fresnel_sp(c, eta):
    """Fresnel power reflectances (R_s, R_p) from air into ``eta`` at the external cosine ``c``."""
    c = min(max(c, 0.0), 1.0)
    ct = math.sqrt(1.0 - (1.0 - c * c) / (eta * eta))
    rs = ((c - eta * ct) / (c + eta * ct)) ** 2
    rp = ((ct - eta * c) / (ct + eta * c)) ** 2
    return rs, rp


def test_the_occlusion_rule():
    assert P.occlusion_on(True, {}) is False and P.occlusion_on(False, {}) is True
    assert P.occlusion_on(False, {"occlusion": False}) is False
    assert P.occlusion_on(True, {"occlusion": np.bool_(True)}) is True
    assert P.occlusion_on(False, {"inter_reflection": False}) is True


def test_the_hemispherical_fresnel_reflectance_by_the_midpoint_rule_and_by_quadrature():
    from scipy.integrate import quad

    def midpoint(eta, n):
        return 2.0 / n * sum(0.5 * sum(textbook_fresnel_sp((i + 0.5) / n, eta)) * (i + 0.5) / n for i in range(n))

    assert P.hemispherical_fresnel(1.5) == pytest.approx(midpoint(1.5, 512), rel=1e-12)
    assert P.hemispherical_fresnel(1.56, 64) == pytest.approx(midpoint(1.56, 64), rel=1e-12)
    assert P.hemispherical_fresnel(1.5, 1) == pytest.approx(0.5 * sum(textbook_fresnel_sp(0.5, 1.5)), rel=1e-12)
    exact = quad(lambda c: 2.0 * c * 0.5 * sum(textbook_fresnel_sp(c, 1.5)), 0.0, 1.0, limit=200)[0]
    assert exact == pytest.approx(0.0918, abs=5e-4)  # Walter et al.'s value for n = 1.5
    assert P.hemispherical_fresnel(1.5, 4096) == pytest.approx(exact, abs=2e-6)
    assert P.hemispherical_fresnel(1.0) == pytest.approx(0.0, abs=1e-15)


def test_the_return_albedo_is_polish_plus_body_plus_the_brightest_schiller(monkeypatch):
    from labcut import colour

    seen = []
    material = SimpleNamespace(n_surface=1.56, body_albedo=0.05)
    monkeypatch.setattr(colour, "luminance_table",
                        lambda m: seen.append(m) or (np.linspace(0, 1, 5), np.array([0.1, 0.3, 0.25, 0.0, 0.2])))
    assert P.return_albedo(material) == pytest.approx(P.hemispherical_fresnel(1.56) + 0.05 + 0.3, rel=1e-14)
    assert seen == [material]
    assert P.hemispherical_fresnel(1.56) == pytest.approx(0.1005, abs=5e-4)


def test_the_s_and_p_transmissions():
    cos = np.array([1.0, 0.8, 0.5, 0.1, 0.0, 1.3, -0.2])
    ts, tp = P._fresnel_sp(cos, 1.56)
    for c, s, p in zip(cos, ts, tp):
        rs, rp = textbook_fresnel_sp(c, 1.56)
        assert s == pytest.approx(1.0 - rs, abs=1e-12) and p == pytest.approx(1.0 - rp, abs=1e-12), c
    assert ts[0] == pytest.approx(1 - (0.56 / 2.56) ** 2, abs=1e-12) and ts[4] == pytest.approx(0.0, abs=1e-12)
    for eta, c in ((1.2, 0.1), (1.2, 0.6), (1.05, 0.3)):  # below sqrt(2): eta² - sin² under 1
        ts_, tp_ = P._fresnel_sp(np.array([c]), eta)
        rs, rp = textbook_fresnel_sp(c, eta)
        assert ts_[0] == pytest.approx(1.0 - rs, abs=1e-12) and tp_[0] == pytest.approx(1.0 - rp, abs=1e-12), (eta, c)
    ts32, _ = P._fresnel_sp(np.float32(0.5), 1.56)
    assert float(ts32) == pytest.approx(ts[2], abs=1e-15)  # float32 read in float64
    assert P._fresnel_sp([0.5], 1.56)[0][0] == pytest.approx(ts[2], abs=1e-15)


def stack_table(m):
    assert m.n_surface == 1.56, m  # the material's own table
    grid = np.linspace(0.0, 1.0, 2049)
    return grid, 0.2 * grid ** 2 + 0.01, 0.05 + 0.1 * grid


def reference_bias(L, wl, V, wv, eta):
    """The exact unpolarised flash against the s/p-averaged one, pair by pair (Snell by angles)."""
    def inside(d):
        d = np.asarray(d, float)
        sin = math.hypot(d[0], d[1]) / np.linalg.norm(d)
        sin_t = sin / eta
        az = d[:2] / max(math.hypot(d[0], d[1]), 1e-300)
        return np.array([az[0] * sin_t, az[1] * sin_t, math.sqrt(1 - sin_t ** 2)])

    num = den = 0.0
    for l, a in zip(L, wl):
        for v, b in zip(V, wv):
            if l[2] <= 1e-3 or v[2] <= 1e-3:
                continue
            ti, to = inside(l), inside(v)
            h = ti + to
            ch = float(ti @ h / np.linalg.norm(h))
            rs, rp = 0.2 * ch ** 2 + 0.01, 0.05 + 0.1 * ch
            (rsl, rpl), (rsv, rpv) = textbook_fresnel_sp(l[2], eta), textbook_fresnel_sp(v[2], eta)
            tsl, tpl, tsv, tpv = 1 - rsl, 1 - rpl, 1 - rsv, 1 - rpv
            exact = 0.5 * (tsl * rs * tsv + tpl * rp * tpv)
            approx = 0.5 * (tsl + tpl) * 0.5 * (rs + rp) * 0.5 * (tsv + tpv)
            num += a * b * (approx - exact)
            den += a * b * exact
    return abs(num) / den if den > 0 else 0.0


def unit(*v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def test_the_polarisation_bias_against_a_pair_by_pair_reference(monkeypatch):
    from labcut import colour

    monkeypatch.setattr(colour, "luminance_sp_table", stack_table)
    eta = 1.56
    mat = SimpleNamespace(n_surface=eta)
    grazing = np.array([math.sqrt(1 - 1e-6), 0.0, 1e-3])  # exactly at the face's cut-off: skipped
    L1 = np.array([unit(0.6, 0.0, 0.8), unit(-0.3, 0.5, 0.8), grazing, unit(0.2, 0.1, -0.5)])
    wl1 = np.array([0.5, 0.3, 5.0, 3.0])
    V1 = np.array([unit(-0.7, 0.1, 0.7), unit(0.0, 0.0, 1.0), unit(0.05, -0.9, 0.4), -grazing * [1, 1, -1]])
    wv1 = np.array([0.2, 0.5, 0.3, 4.0])
    L2, wl2 = np.array([unit(0.95, 0.0, 0.3)]), np.array([1.0])
    V2, wv2 = np.array([unit(-0.95, 0.0, 0.3)]), np.array([2.0])
    below = (np.array([unit(0.3, 0.0, -0.9)]), np.array([1.0]), V2, wv2)
    weightless = (L2, np.array([0.0]), V2, wv2)
    L3, wl3 = np.array([unit(0.0, 0.5, 0.85)]), np.array([1.0])
    V3, wv3 = np.array([unit(0.1, -0.2, 0.97)]), np.array([1.0])
    got = P._polarisation_bias(mat, [(L1, wl1, V1, wv1), (L2, wl2, V2, wv2), below, weightless, (L3, wl3, V3, wv3)])
    assert got[0] == pytest.approx(reference_bias(L1, wl1, V1, wv1, eta), rel=1e-6)
    assert got[1] == pytest.approx(reference_bias(L2, wl2, V2, wv2, eta), rel=1e-6)
    assert got[4] == pytest.approx(reference_bias(L3, wl3, V3, wv3, eta), rel=1e-6)
    assert got[2] == 0.0 and got[3] == 0.0 and len(got) == 5
    assert got[0] > 1e-3 and got[1] > 1e-3 and got[0] != pytest.approx(got[1], rel=1e-3)
    # each set alone as in a batch; no set, no bias
    assert P._polarisation_bias(mat, [(L2, wl2, V2, wv2)]) == [pytest.approx(got[1], rel=1e-12)]
    assert P._polarisation_bias(mat, []) == []
    # the weights: a pair's share of the flash, not a count
    only_first = P._polarisation_bias(mat, [(L1[:1], wl1[:1], V1[:1], wv1[:1])])[0]
    assert only_first == pytest.approx(reference_bias(L1[:1], wl1[:1], V1[:1], wv1[:1], eta), rel=1e-6)


def test_polarisation_biases_are_kept_in_the_user_cache_under_a_documented_key(monkeypatch, own_caches):
    import hashlib

    from labcut.colour import material_key
    from labcut.fileio import code_hash
    from pathlib import Path

    calls, sets_seen = [], []

    def measure(m, sets):
        assert m == blue
        sets_seen.append(sets)
        calls.append(len(sets))
        return [0.01 * (i + 1) for i in range(len(sets))]

    monkeypatch.setattr(P, "_polarisation_bias", measure)
    blue = labcut.Labradorite.preset("blue")
    L = Lights([[0.3, 0.0, 0.95], [0.0, 0.2, 0.98]], weights=[0.7, 0.3])
    V = Views([[-0.2, 0.0, 0.98]])
    V2 = Views([[-0.3, 0.1, 0.95]])
    assert P.polarisation_biases(blue, [(L, V), (L, V2), (L, V)]) == [0.01, 0.02, 0.01] and calls == [2]
    (Ls, wls, Vs, wvs), (_, _, V2s, _) = sets_seen[0]
    assert np.array_equal(Ls, L.directions) and np.array_equal(wls, [0.7, 0.3]) and np.array_equal(Vs, V.directions)
    assert np.array_equal(wvs, V.weights) and np.array_equal(V2s, V2.directions)
    assert P.polarisation_bias(blue, L, V2) == 0.02 and calls == [2]
    stored = json.loads((own_caches / "planner-polarisation.json").read_text())

    def key(lights, views):
        digest = hashlib.blake2b(digest_size=16)
        for x in (lights.directions, lights.weights, views.directions, views.weights):
            x = np.asarray(x, dtype=np.float64)
            digest.update(str(x.shape).encode())
            digest.update(np.ascontiguousarray(x).tobytes())
        return f"planner {code_hash(Path(P.__file__))} directions {digest.hexdigest()} {material_key(blue)}"

    assert stored == {key(L, V): {"bias": 0.01}, key(L, V2): {"bias": 0.02}}
    assert P._planner_code() == code_hash(Path(P.__file__))
    # a later process reads them back, as kept (no warning, nothing computed)
    from labcut import fileio
    import warnings

    monkeypatch.setattr(fileio, "_CALIBRATIONS", {})
    monkeypatch.setattr(fileio, "_STORES", {})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert P.polarisation_biases(blue, [(L, V2), (L, V)]) == [0.02, 0.01] and calls == [2]
    # the same directions and weights in float32 are the same key
    def rounded(x, dtype):
        return np.asarray(x, dtype=np.float32).astype(dtype)

    wide = [(SimpleNamespace(directions=rounded(d.directions, np.float64), weights=rounded(d.weights, np.float64)),
             SimpleNamespace(directions=rounded(V.directions, np.float64), weights=rounded(V.weights, np.float64)))
            for d in (L,)]
    narrow = [(SimpleNamespace(directions=rounded(d.directions, np.float32), weights=rounded(d.weights, np.float32)),
               SimpleNamespace(directions=rounded(V.directions, np.float32), weights=rounded(V.weights, np.float32)))
              for d in (L,)]
    assert P.polarisation_biases(blue, wide) == [0.01] and calls == [2, 1]
    assert P.polarisation_biases(blue, narrow) == [0.01] and calls == [2, 1]
    # another material measures again; the file keeps the latest 256
    monkeypatch.setattr(fileio, "_CALIBRATIONS", {})
    monkeypatch.setattr(fileio, "_STORES", {})
    (own_caches / "planner-polarisation.json").write_text(json.dumps({f"old {i}": {"bias": 0.5} for i in range(300)}
                                                                      | {key(L, V): {"bias": "damaged"}}))
    with pytest.warns(LabcutWarning, match="is not what labcut keeps there"):
        assert P.polarisation_bias(blue, L, V) == 0.01 and calls == [2, 1, 1]
    stored = json.loads((own_caches / "planner-polarisation.json").read_text())
    assert len(stored) == 256 and list(stored)[-1] == key(L, V) and "old 44" not in stored and "old 45" in stored
    monkeypatch.setattr(P, "_polarisation_bias", lambda m, sets: calls.append(m) or [0.07])
    red = labcut.Labradorite.from_peak_wavelength(620.0)
    assert P.polarisation_bias(red, L, V) == 0.07 and calls[-1] == red


# ---------------------------------------------------------------------- the pilot renders
class Clock:
    def __init__(self, *times):
        self.times = list(times)

    def perf_counter(self):
        return self.times.pop(0)


def pilot_key(mesh, material, settings, mark=" v1"):
    """measured_interreflection's cache key, as documented: the mesh, the material, the poses' lights,
    views, poses and weights, the pilots' size, the renders' kind, labcut's version and what renders
    (the backend with its libLLVM or CUDA version)."""
    import hashlib

    h = hashlib.sha256()
    h.update(np.asarray(mesh.vertices, dtype=np.float64).tobytes())
    h.update(np.asarray(mesh.faces, dtype=np.int64).tobytes())
    h.update(json.dumps(material.to_dict(), sort_keys=True, default=str).encode())
    for st in settings:
        for a in (st.lights.directions, st.lights.weights, st.views.directions, st.views.weights, st.pose):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        h.update(str(float(st.weight)).encode())
    h.update(f"pilot 64 16 5{mark} emitters hidden render frame".encode())
    h.update(f"labcut {labcut.__version__}".encode())
    from labcut.fileio import compute_platform

    h.update(compute_platform().encode())
    return h.hexdigest()[:32]


@pytest.fixture
def pilots(monkeypatch):
    """interreflection_share replaced: each call recorded, its answer 0.031 then 0.047 ..."""
    from labcut.orientation import render_objective

    calls = []

    def share(mesh, material, settings, resolution, spp):
        calls.append(SimpleNamespace(mesh=mesh, material=material, settings=list(settings), resolution=resolution, spp=spp))
        return [0.031, 0.047, 0.052][len(calls) - 1]

    monkeypatch.setattr(render_objective, "interreflection_share", share)
    return calls


def test_pilot_renders_are_measured_once_and_kept(oval, pilots, monkeypatch, own_caches):
    mat = labcut.Labradorite.preset("blue")
    scene = resolve_scene("bench", quality="draft")  # 7 poses: every second one, 4
    monkeypatch.setattr(P, "time", Clock(10.0, 12.0, 20.0, 21.0, 30.0, 31.0))
    timing = {}
    assert P.measured_interreflection(oval, mat, scene, timing=timing) == 0.031
    (call,) = pilots
    assert call.mesh is oval and call.material is mat and (call.resolution, call.spp) == (64, 16)
    settings = scene.settings()
    assert call.settings == [settings[0], settings[2], settings[4], settings[6]]
    assert timing == {"pilot_seconds": 2.0}
    path = own_caches / "planner-pilot.json"
    k = pilot_key(oval, mat, call.settings)
    assert json.loads(path.read_text()) == {k: 0.031, "seconds per pose": 0.5}
    # again: from this process, nothing rendered, no seconds
    timing = {}
    assert P.measured_interreflection(oval, mat, scene, timing=timing) == 0.031 and len(pilots) == 1 and timing == {}
    # a later process: from the file
    monkeypatch.setattr(P, "_PILOT_CACHE", {})
    assert P.measured_interreflection(oval, mat, scene, timing=timing, max_seconds=0.0) == 0.031 and len(pilots) == 1
    assert P._PILOT_CACHE == {k: 0.031}
    # another material: measured, the seconds per pose a running mean (0.5 and 0.25)
    red = labcut.Labradorite.from_peak_wavelength(620.0)
    assert P.measured_interreflection(oval, red, scene) == 0.047 and len(pilots) == 2
    stored = json.loads(path.read_text())
    assert list(stored) == [k, pilot_key(oval, red, call.settings), "seconds per pose"]
    assert stored["seconds per pose"] == 0.375
    assert P.pilot_seconds_predicted(4) == 1.5 and P.pilot_seconds_predicted(9) == 1.875
    # another backend (or libLLVM) renders other noise: measured again, not read
    from labcut import fileio

    monkeypatch.setattr(fileio, "compute_platform", lambda: "cuda 12.8 (9, 0)")
    assert P.measured_interreflection(oval, mat, scene) == 0.052 and len(pilots) == 3


def test_the_pilot_key_reads_the_mesh_in_float64_and_int64_and_names_a_copy(oval, pilots, monkeypatch, own_caches):
    mat = labcut.Labradorite.preset("blue")
    scene = resolve_scene("display", quality="draft")
    v32 = np.asarray(oval.vertices, dtype=np.float32)
    wide = SimpleNamespace(vertices=v32.astype(np.float64), faces=np.asarray(oval.faces, dtype=np.int64))
    narrow = SimpleNamespace(vertices=v32, faces=np.asarray(oval.faces, dtype=np.int32))
    assert P.measured_interreflection(wide, mat, scene) == 0.031
    assert P.measured_interreflection(narrow, mat, scene) == 0.031 and len(pilots) == 1
    assert list(json.loads((own_caches / "planner-pilot.json").read_text()))[0] == pilot_key(wide, mat, scene.settings())
    # a stone piloted on its clustered copy: the key says so (a copy's share is not the mesh's)
    monkeypatch.setattr(P, "pilots_on_copy", lambda mesh: True)
    monkeypatch.setattr(P, "pilot_mesh", lambda mesh: mesh)
    assert P.measured_interreflection(wide, mat, scene) == 0.047 and len(pilots) == 2
    assert pilot_key(wide, mat, scene.settings(), " copy 256 v2") in json.loads((own_caches / "planner-pilot.json").read_text())


def test_pilot_poses_are_at_most_five_evenly_spaced(oval, pilots, monkeypatch):
    mat = labcut.Labradorite.preset("blue")
    for quality, picked in (("standard", [0, 3, 6, 9, 12]), ("draft", [0, 2, 4, 6])):
        scene = resolve_scene("bench", quality=quality)
        P.measured_interreflection(oval, mat, scene)
        assert pilots[-1].settings == [scene.settings()[i] for i in picked]
    still = resolve_scene("display", quality="draft")
    P.measured_interreflection(oval, mat, still)
    assert pilots[-1].settings == still.settings()


def test_pilots_over_their_time_are_skipped(oval, pilots, monkeypatch, own_caches):
    mat = labcut.Labradorite.preset("blue")
    scene = resolve_scene("bench", quality="draft")
    path = own_caches / "planner-pilot.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"seconds per pose": 0.5}))  # 4 poses: 2 s
    timing = {}
    assert P.measured_interreflection(oval, mat, scene, timing=timing, max_seconds=1.999) is None
    assert timing == {"pilot_seconds_skipped": 2.0} and pilots == []
    assert P.measured_interreflection(oval, mat, scene, max_seconds=1.999) is None  # no timing dict: fine
    assert P.measured_interreflection(oval, mat, scene, timing=timing, max_seconds=2.0) == 0.031 and len(pilots) == 1


def test_the_pilot_file_keeps_the_latest_512_and_survives_damage(oval, pilots, monkeypatch, own_caches):
    mat = labcut.Labradorite.preset("blue")
    scene = resolve_scene("display", quality="draft")
    path = own_caches / "planner-pilot.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"seconds per pose": 0.1} | {f"k{i}": 0.01 for i in range(600)}))
    monkeypatch.setattr(P, "time", Clock(0.0, 0.3))
    assert P.measured_interreflection(oval, mat, scene) == 0.031
    stored = json.loads(path.read_text())
    assert len(stored) == 513 and "k88" not in stored and "k89" in stored and "k599" in stored
    assert list(stored)[-1] == "seconds per pose" and stored["seconds per pose"] == pytest.approx(0.2, abs=1e-12)
    path.write_text(json.dumps({"a": "x"}))
    monkeypatch.setattr(P, "_PILOT_CACHE", {})
    monkeypatch.setattr(P, "time", Clock(0.0, 0.8))
    with pytest.warns(LabcutWarning, match="is damaged \\(a value is not a number\\)"):
        assert P.measured_interreflection(oval, mat, scene) == 0.047
    assert json.loads(path.read_text()) == {pilot_key(oval, mat, scene.settings()): 0.047, "seconds per pose": 0.8}


def test_the_pilot_cache_file_is_named_as_documented(own_caches):
    assert PILOT_CACHE_PATH() == own_caches / "planner-pilot.json"


def test_the_pilots_predicted_seconds(own_caches):
    assert P.pilot_seconds_predicted(3) == pytest.approx(1.2) and P.pilot_seconds_predicted(7) == pytest.approx(2.0)
    assert P.pilot_seconds_predicted(5) == pytest.approx(2.0) and P.pilot_seconds_predicted(0) == 0.0
    path = own_caches / "planner-pilot.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    for stored, per_pose in (({"seconds per pose": 0.25}, 0.25), ({"seconds per pose": "0.5"}, 0.5),
                             ({"seconds per pose": "fast"}, 0.4), ({"seconds per pose": [1]}, 0.4), ({}, 0.4)):
        path.write_text(json.dumps(stored))
        assert P.pilot_seconds_predicted(3.7) == pytest.approx(3 * per_pose, rel=1e-12), stored


def test_which_meshes_are_piloted_on_a_clustered_copy(monkeypatch):
    import trimesh

    from labcut.geometry import meshio, proxy

    assert P.pilots_on_copy(SimpleNamespace(faces=range(200_000))) is False
    assert P.pilots_on_copy(SimpleNamespace(faces=range(200_001))) is True
    small = SimpleNamespace(faces=range(10))
    assert P.pilot_mesh(small) is small
    box = trimesh.creation.box(extents=(2.0, 3.0, 6.0))
    copy = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    made, marked = [], []
    monkeypatch.setattr(P, "pilots_on_copy", lambda mesh: True)
    monkeypatch.setattr(proxy, "clustered_proxy", lambda mesh, cell: made.append((mesh, cell)) or copy)
    monkeypatch.setattr(meshio, "mark_valid", lambda mesh: marked.append(mesh))
    assert P.pilot_mesh(box) is copy and P.pilot_mesh(box) is copy
    assert len(made) == 1 and made[0][1] == pytest.approx(7.0 / 256, rel=1e-12) and marked == [copy]
    assert np.allclose(made[0][0].vertices, box.vertices)


def test_a_question_s_plan_and_its_pilots_scene(monkeypatch):
    from labcut.scene.quality import Quality

    got = []
    monkeypatch.setattr(P, "plan_effects", lambda mesh, material, **kw: got.append((mesh, material, kw)) or "plan")
    monkeypatch.setattr(P, "pilot_scene", lambda setup: f"pilots' scene of {setup.scenario}")
    setup = SimpleNamespace(material="m", scenario="s", quality="q", estimator="e", effect_overrides={"depth": True},
                            zoning="z")
    assert P.plan_question("mesh", setup, "evaluate", predict=False, pilot_seconds_max=3.0) == "plan"
    assert got[-1] == ("mesh", "m", dict(command="evaluate", scenario="s", quality="q", estimator="e",
                                         effects={"depth": True}, zoning="z", predict=False,
                                         pilot_scene="pilots' scene of s", pilot_seconds_max=3.0))
    P.plan_question("mesh", setup)
    assert got[-1][2]["command"] == "recommend" and got[-1][2]["predict"] is True
    assert got[-1][2]["pilot_seconds_max"] is None
    monkeypatch.undo()
    asked = []
    standard = SimpleNamespace(quality=Quality.coerce("standard"), scenario="own",
                               at_quality=lambda q: asked.append(q))
    assert P.pilot_scene(standard) == "own" and asked == []
    draft = SimpleNamespace(quality=Quality.coerce("draft"), scenario="own",
                            at_quality=lambda q: asked.append(q) or SimpleNamespace(scenario="standard's"))
    assert P.pilot_scene(draft) == "standard's" and asked == [Quality.coerce("standard")]


def test_how_many_map_directions_past_a_carving_s_parts():
    e = P.env_samples_enough
    assert e(32, 3) == 32 and e(32, 7) == 32 and e(1, 96) == 1  # 96 in the stone's frame: enough
    assert e(31, 3) == 496 and e(1, 95) == 256  # fewer: doubled until 256
    assert e(32, 1) == 256 and e(200, 1) == 400 and e(256, 1) == 256 and e(300, 1) == 300
    assert e(128, 1) == 256 and e(129, 1) == 258
    assert e(0, 1) == 256 and e(-5, 4) == 256 and e(96, 1) == 384 and e(96, 2) == 96
    assert e(48.9, 2.9) == 48 and e(47.9, 2.9) == 376 and e(32.5, "3") == 32


# ---------------------------------------------------------------------- predicted seconds
@pytest.fixture
def timing_stand(monkeypatch):
    """Stand-in calibrations: a sample recommendation 2 s, an evaluation 0.5 s, 1e6 volume paths, and a
    render estimator of ``1 + 0.1 it + 0.01 coarse + 0.001 depth + 0.5 convex + 1e-4 views + 1e-6 px +
    1e-7 spp`` seconds."""
    from labcut.orientation import render_estimator, timing, volume

    calls = SimpleNamespace(samples=[], evaluate=[], render=[], paths=[])
    monkeypatch.setattr(timing, "calibrating", lambda: False)
    monkeypatch.setattr(P, "predict_sample_seconds", lambda s, n, o: calls.samples.append((list(s), n, o)) or 2.0)
    monkeypatch.setattr(P, "predict_evaluate_seconds", lambda s, n, o: calls.evaluate.append((list(s), n, o)) or 0.5)
    monkeypatch.setattr(volume, "volume_paths", lambda s, n: calls.paths.append((list(s), n)) or 1e6)

    def render(n_views, res, spp, convex, iterations, coarse, depth):
        calls.render.append((n_views, res, spp, convex, iterations, coarse, depth))
        return 1 + 0.1 * iterations + 0.01 * coarse + 0.001 * depth + 0.5 * convex + 1e-4 * n_views + 1e-6 * res + 1e-7 * spp

    monkeypatch.setattr(render_estimator, "predict_render_seconds", render)
    calls.formula = render
    return calls


def test_each_estimator_s_seconds_against_its_formula(timing_stand, monkeypatch):
    from labcut.orientation import timing

    t, r = timing_stand, timing_stand.formula
    scene = resolve_scene("bench", quality="draft")  # 7 poses of one view; draft: 3000 points, renders 48 px 4 spp 15 its
    got = P.estimator_seconds(scene, "recommend", True, False, True)
    assert got == pytest.approx({"samples": 2.0, "volume": 2.0 + 2.5, "render": 2.0 + r(7, 48, 4, True, 15, 0, 2)},
                                rel=1e-12)
    assert t.samples[-1] == (scene.settings(), 3000, True) and t.paths[-1] == (scene.settings(), 3000)
    assert t.render[-1] == (7, 48, 4, True, 15, 0, 2)
    got = P.estimator_seconds(scene, "recommend", False, True, False, True)  # a zoned carving with inter-reflection
    assert t.render[-1] == (7, 48, 4, False, 15, 52, 4) and t.samples[-1][2] is False
    assert got["render"] == pytest.approx(2.0 + r(7, 48, 4, False, 15, 52, 4), rel=1e-12)
    got = P.estimator_seconds(scene, "evaluate", True, True, False)
    one, two = r(7, 48, 4, False, 1, 0, 4), r(7, 48, 4, False, 2, 0, 4)
    assert got == pytest.approx({"samples": 0.5, "volume": 3.0, "render": 0.5 + one - (two - one)}, rel=1e-12)
    assert t.evaluate[-1] == (scene.settings(), 3000, True) and t.paths[-1] == (scene.settings(), 3000)
    assert t.render[-2:] == [(7, 48, 4, False, 1, 0, 4),
                                                                                   (7, 48, 4, False, 2, 0, 4)]
    assert P.estimator_seconds(scene, "compare", True, False, False) == {"samples": 2.0}
    # the map's directions the samples draw; the renders see the map itself
    ring = resolve_scene("ring-diffuse", quality="draft")
    P.estimator_seconds(ring, "recommend", True, False, False, env_samples=256)
    assert [len(st.lights) for st in t.samples[-1][0]] == [256] and t.render[-1][0] == 12  # 12 views above
    P.estimator_seconds(ring, "recommend", True, False, False)
    assert [len(st.lights) for st in t.samples[-1][0]] == [32]
    # an evaluation whose second render costs more than twice the first: no negative seconds
    from labcut.orientation import render_estimator

    monkeypatch.setattr(render_estimator, "predict_render_seconds", lambda n, res, spp, c, it, coarse, d: 5.0 * it)
    assert P.estimator_seconds(scene, "evaluate", True, False, True)["render"] == 0.5
    # while a calibration runs, nothing is predicted
    monkeypatch.setattr(timing, "calibrating", lambda: True)
    assert P.estimator_seconds(scene, "recommend", True, False, True) == {}


def test_the_sample_calibrations_are_asked_of_the_right_runs(monkeypatch):
    import os

    from labcut.orientation import timing

    assert P._evaluate_key() == f"labcut {labcut.__version__} numpy {np.__version__} cpus {os.cpu_count()} evaluate v1"
    asked = []
    monkeypatch.setattr(timing, "sample_timing", lambda call, refresh=False: asked.append((call, refresh)) or "cal")
    assert P.sample_timing() == "cal" and P.sample_timing(refresh=True) == "cal"
    assert asked == [(P.recommend_run, False), (P.recommend_run, True)]
    monkeypatch.setattr(P, "sample_timing", lambda: SimpleNamespace(fixed=0.5, per_term=1e-6, per_ray=1e-5))
    settings = resolve_scene("bench", quality="draft").settings()  # 7 x 7 lamps x 1 view
    assert P.predict_sample_seconds(settings, 3000, True) == pytest.approx(0.5 + 0.147 + 1.68, rel=1e-12)
    assert P.predict_sample_seconds(settings, 1000, False) == pytest.approx(0.5 + 0.049, rel=1e-12)
    monkeypatch.setattr(P, "evaluate_timing", lambda: {"fixed": 0.25, "per_term": 2e-6, "per_ray": 3e-6})
    assert P.predict_evaluate_seconds(settings, 3000, True) == pytest.approx(0.25 + 0.294 + 0.504, rel=1e-12)
    assert P.predict_evaluate_seconds(settings, 3000, False) == pytest.approx(0.25 + 0.294, rel=1e-12)


def test_the_evaluation_calibration_file(monkeypatch):
    from labcut import fileio
    from labcut.orientation import timing

    seen, timed = [], []

    def calibration(name, key, measure, refresh=False, check=None, timed=False):
        assert timed  # a timing: not kept when measured under a profiler or tracer
        seen.append((name, key, refresh, check))
        return measure() | {"extra": 1}

    monkeypatch.setattr(fileio, "calibration", calibration)
    monkeypatch.setattr(timing, "time_three", lambda call, repeats=1: timed.append((call, repeats)) or (1, "2e-6", 3e-5))
    got = P.evaluate_timing(refresh=True)
    assert got == {"fixed": 1.0, "per_term": 2e-6, "per_ray": 3e-5} and all(type(v) is float for v in got.values())
    assert timed == [(P.evaluate_run, 2)]
    name, key, refresh, check = seen[0]
    assert (name, key, refresh) == ("planner-evaluate-timing.json", P._evaluate_key(), True)
    assert P.evaluate_timing()["fixed"] == 1.0 and seen[-1][2] is False
    check({"fixed": 1, "per_term": 2, "per_ray": 3})
    for bad in ({"fixed": 1, "per_term": 2}, {"per_term": 2, "per_ray": 3}, {"fixed": 1, "per_ray": 3},
                {"fixed": 1, "per_term": 2, "per_ray": "x"}):
        with pytest.raises((KeyError, ValueError)):
            check(bad)


def test_the_calibration_runs_use_the_commands_own_steps(monkeypatch):
    import contextlib

    from labcut import backend
    from labcut.orientation import recommend
    from labcut.scene.directions import normalize_normal

    log, blas = [], []

    @contextlib.contextmanager
    def serial():
        blas.append(True)
        yield
        blas.append(False)

    monkeypatch.setattr(backend, "serial_blas", serial)
    monkeypatch.setattr(recommend, "question", lambda s, quality: log.append(("question", s, quality)) or "ask")
    monkeypatch.setattr(P, "plan_question", lambda mesh, ask, command, **kw: log.append(("plan", mesh, ask, command, kw)) or "plan")
    monkeypatch.setattr(recommend, "build_scorer", lambda mesh, ask, plan: log.append(("scorer", mesh, ask, plan, list(blas))) or "scorer")
    monkeypatch.setattr(recommend, "answer_recommendation",
                        lambda mesh, ask, scorer, plan: log.append(("answer", mesh, ask, scorer, plan, list(blas))) or "answer")
    monkeypatch.setattr(recommend, "evaluation_metrics",
                        lambda mesh, ask, scorer, plan, normal: log.append(("metrics", mesh, ask, scorer, plan, normal)) or "m")
    assert P.recommend_run("mesh", "draft") == "answer"
    assert log == [("question", None, "draft"), ("plan", "mesh", "ask", "recommend", {}),
                   ("scorer", "mesh", "ask", "plan", [True]), ("answer", "mesh", "ask", "scorer", "plan", [True])]
    log.clear()
    assert P.evaluate_run("mesh", "standard") == "m"
    assert log[:3] == [("question", None, "standard"), ("plan", "mesh", "ask", "evaluate", {"predict": False}),
                       ("scorer", "mesh", "ask", "plan", [True, False, True])]
    assert log[3][:5] == ("metrics", "mesh", "ask", "scorer", "plan")
    assert np.array_equal(log[3][5], normalize_normal((0.05, 0.02, 1.0)))


def test_the_render_calibration_times_three_sizes_and_fits_them(monkeypatch):
    import os
    import time

    import mitsuba as mi

    from labcut import fileio
    from labcut.orientation.timing import calibrating

    clock = [100.0]
    rendered, seen = [], []

    def render_once(mesh, material, normal, res, n, kw):
        rendered.append((mesh, material, normal, res, n, dict(kw), calibrating()))
        clock[0] += 0.2 + 1e-6 * res * res + 2e-8 * res * res * n

    def calibration(name, key, measure, refresh=False, check=None, timed=False):
        assert timed  # a timing: not kept when measured under a profiler or tracer
        seen.append((name, key, refresh, check))
        return measure()

    monkeypatch.setattr(P, "render_once", render_once)
    monkeypatch.setattr(fileio, "calibration", calibration)
    monkeypatch.setattr(time, "perf_counter", lambda: clock[0])
    fixed, per_sample, per_pixel = P.render_command_timing("rgb", True, "path", "studio", refresh=True)
    assert (fixed, per_sample, per_pixel) == pytest.approx((0.2, 2e-8, 1e-6), rel=1e-6)
    assert [(r[3], r[4]) for r in rendered] == [(64, 4), (64, 4), (128, 4), (128, 4), (128, 16), (128, 16)]
    assert all(r[6] for r in rendered)
    mesh, material, normal, _, _, kw, _ = rendered[0]
    assert all(r[0] is mesh and r[1] is material and r[2] is normal and r[5] == kw for r in rendered)
    from labcut.geometry.stone import Stone

    assert Stone.of(mesh).convex is True
    assert kw == dict(scenario="bench", mode="rgb", polarizer_deg=30.0, max_depth=4, look="studio")
    assert np.allclose(np.linalg.norm(mesh.vertices, axis=1), 5.0) and len(mesh.faces) == 1280
    assert material == labcut.Labradorite()
    assert np.allclose(normal, np.array([0.05, 0.02, 1.0]) / np.linalg.norm([0.05, 0.02, 1.0]))
    name, key, refresh, check = seen[0]
    assert name == "planner-render-timing.json" and refresh is True
    assert key == (f"rgb polarised path studio | mitsuba {mi.__version__} labcut {labcut.__version__} "
                   f"cpus {os.cpu_count()} v4")
    check({"fixed": 1.0, "per_sample": 2.0, "per_pixel": "3"})
    for bad in ({"fixed": 1.0, "per_sample": 2.0}, {"per_sample": 2.0, "per_pixel": 3.0}, {"fixed": 1.0, "per_pixel": 3.0}):
        with pytest.raises(KeyError):
            check(bad)
    rendered.clear()
    P.render_command_timing("mono", False, "direct")
    assert rendered[0][5] == dict(scenario="bench", mode="mono", polarizer_deg=None, max_depth=None, look="diagram")
    assert seen[-1][1].startswith("mono plain direct diagram | mitsuba ") and seen[-1][2] is False


def test_one_calibration_render_by_the_render_command_s_steps(monkeypatch):
    from labcut.orientation import flash_check
    from labcut.rendering import api

    log = []
    ask = SimpleNamespace(material="M2", cameras="C", scenario=SimpleNamespace(main_setting=lambda: "S"))
    monkeypatch.setattr(api, "render_question", lambda **kw: log.append(kw) or ask)
    monkeypatch.setattr(api, "render_image", lambda mesh, a, normal, spp: log.append((mesh, a, normal, spp)) or SimpleNamespace())
    monkeypatch.setattr(flash_check, "flash_by_view", lambda *a: log.append(a) or ("F", "N"))
    out = P.render_once("mesh", "M", "n", 96, 8, {"scenario": "bench", "look": "diagram"})
    assert (out.flash, out.notes) == ("F", "N")
    assert log == [dict(material="M", resolution=96, spp=8, scenario="bench", look="diagram"), ("mesh", ask, "n", 8),
                   ("mesh", "M2", "n", "S", "C")]


def test_the_linear_fits_on_hand_data():
    assert P.linear_fit([(4, 1.0), (8, 2.5), (32, 4.5)]) == {"fixed": 0.5, "per_sample": 0.125}  # first and last
    assert P.linear_fit([(4, 2.0), (8, 1.0)]) == {"fixed": 2.0, "per_sample": 0.0}  # no negative slope
    assert P.linear_fit([(10, 1.0), (20, 3.0)]) == {"fixed": 0.0, "per_sample": 0.2}  # no negative intercept
    assert P.linear_fit([(5, 3.0), (5, 4.0)]) == {"fixed": 3.0, "per_sample": 0.0}
    got = P.pixel_sample_fit([(100, 4, 0.64), (400, 4, 1.06), (400, 32, 2.18)])
    assert got == pytest.approx({"fixed": 0.5, "per_sample": 1e-4, "per_pixel": 1e-3}, rel=1e-9)
    assert P.pixel_sample_fit([(100, 4, 0.64), (400, 4, 1.06), (400, 4, 2.18)]) == pytest.approx(
        {"fixed": 0.5, "per_sample": 0.0, "per_pixel": 0.0014}, rel=1e-9)  # no spp step: nothing per sample
    assert P.pixel_sample_fit([(400, 4, 1.0), (400, 4, 1.06), (400, 32, 2.18)]) == pytest.approx(
        {"fixed": 1.0 - 0.16, "per_sample": 1e-4, "per_pixel": 0.0}, rel=1e-9)  # no size step: nothing per pixel
    assert P.pixel_sample_fit([(100, 4, 2.0), (400, 4, 1.0), (400, 32, 0.5)]) == {
        "fixed": 2.0, "per_sample": 0.0, "per_pixel": 0.0}  # none below zero
    assert P.pixel_sample_fit([(100, 4, 0.0), (400, 4, 3.0), (400, 32, 3.0)]) == pytest.approx(
        {"fixed": 0.0, "per_sample": 0.0, "per_pixel": 0.01}, rel=1e-12)


def test_a_render_s_seconds_against_its_formula(monkeypatch):
    from labcut.orientation import timing

    asked = []
    monkeypatch.setattr(P, "render_command_timing", lambda *a: asked.append(a) or (0.5, 1e-7, 2e-6))
    assert P.render_seconds("rgb", False, "direct", 100, 16, 3) == pytest.approx(3 * (0.5 + 0.02 + 0.016), rel=1e-12)
    assert asked == [("rgb", False, "direct", "diagram")]
    assert P.render_seconds("spectral", True, "path", 10, 1, 1, "studio") == pytest.approx(0.5 + 2e-4 + 1e-5, rel=1e-12)
    assert asked[-1] == ("spectral", True, "path", "studio")
    monkeypatch.setattr(P, "render_seconds", lambda *a: asked.append(a) or 7.0)
    monkeypatch.setattr(timing, "calibrating", lambda: False)
    assert P._predicted_render_seconds("mono", True, "path", 64, 4, 2) == {"render": 7.0}
    assert asked[-1] == ("mono", True, "path", 64, 4, 2, "diagram")
    P._predicted_render_seconds("mono", True, "path", 64, 4, 2, "studio")
    assert asked[-1][-1] == "studio"
    monkeypatch.setattr(timing, "calibrating", lambda: True)
    assert P._predicted_render_seconds("mono", True, "path", 64, 4, 2) == {}


def test_the_module_s_constants_as_docs_planner_md_sets_them():
    """mutmut leaves module-level constants alone: each pinned here against docs/planner.md (the 2 %
    tolerance, the 20 % thin share, 96 directions over the poses, 256 past the parts, the pilots' 64² px,
    16 spp, at most 5 poses at standard, 200,000 triangles and 256 cells, 0.4 s a pose before any, the
    render calibration's 64² and 128² px at 4 and 16 spp) and docs/accuracy.md (2.5 µs per volume path)."""
    assert P.INTERREFLECTION_TOLERANCE == 0.02 and P.DEPTH_THIN_SHARE == 0.2
    assert P.ENV_DIRECTIONS_ENOUGH == 96 and P.ENV_SAMPLES_PAST_PARTS == 256
    assert (P.PILOT_RESOLUTION, P.PILOT_SPP, P.PILOT_POSES, P.PILOT_QUALITY) == (64, 16, 5, "standard")
    assert (P.PILOT_FACES, P.PILOT_CELLS, P.PILOT_SECONDS_PER_POSE) == (200_000, 256, 0.4)
    assert P.PILOT_BUDGET_SHARE == 0.25 and P.PILOT_TIMING_KEY == "seconds per pose"
    assert P.VOLUME_PATH_SECONDS == 2.5e-6 and P.POLARISATION_KEEP == 256
    assert P.COMMANDS == ("render", "recommend", "evaluate", "compare") and P.COMPARE_REFUSES == ("render", "volume")
    assert P._RENDER_CAL == ((64, 4), (128, 4), (128, 16))
