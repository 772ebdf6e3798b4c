"""The scene layer: one vocabulary of lights, views and wear scenarios for every command."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import labcut
from labcut import Labradorite, Lights, ParameterError, Scenario, Views
from labcut.orientation.problem import build_problem
from labcut.orientation.radiance import reference_radiance, schiller_weights
from labcut.orientation.render_estimator import render_metrics
from labcut.rendering.scene import camera_views
from labcut.scene import LIGHTING, SCENARIOS, VIEWING, Environment, direction, resolve_scene
from labcut.scene.directions import rotation
from labcut.scene.envmap import MAP_TO_WORLD, pixel_directions


#: the CLI in this process (conftest's ``cli``): nothing here depends on a fresh interpreter
CLI_IN_PROCESS = True


MESHES = Path(__file__).resolve().parents[1] / "meshes"
OVAL = MESHES / "oval-16x12-low.ply"
LAB = Labradorite.preset("blue")


def angle_deg(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return math.degrees(math.acos(min(1.0, abs(a @ b) / np.linalg.norm(a) / np.linalg.norm(b))))


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh(OVAL)


# ---------------------------------------------------------------------- registries
def test_one_registry_per_kind_names_the_same_choices_everywhere(cli):
    assert SCENARIOS.names() == ("bench", "ring", "pendant", "brooch", "display", "outdoor", "ring-diffuse", "pendant-diffuse",
                                 "brooch-diffuse", "outdoor-still")
    for registry, make in ((SCENARIOS, Scenario.preset), (LIGHTING, Lights.preset), (VIEWING, Views.preset)):
        with pytest.raises(ParameterError) as err:
            make("nonsense")
        assert all(name in str(err.value) for name in registry.names())
        for name in registry.names():
            make(name, "draft")  # every registered preset builds
    helps = {cmd: cli(cmd, "--help").stdout for cmd in ("render", "recommend-orientation", "evaluate-orientation")}
    for text in helps.values():
        flat = " ".join(text.split())
        for name in SCENARIOS.names() + LIGHTING.names() + VIEWING.names():
            assert name in flat
    listing = json.loads(cli("scenarios", "--json", "-").stdout)
    assert [s["name"] for s in listing["scenarios"]] == list(SCENARIOS.names())
    assert [s["name"] for s in listing["lighting"]] == list(LIGHTING.names())


def test_lighting_presets_have_unit_irradiance_and_lamps_are_discs():
    for name in LIGHTING.names():
        lights = Lights.preset(name, "draft")
        assert lights.total_irradiance == pytest.approx(1.0, rel=1e-9), name
    lamp = Lights.lamp([0, 0, 1], 8.0, 2.0, 13)
    assert len(lamp) == 13 and lamp.total_irradiance == pytest.approx(2.0)
    assert max(angle_deg(d, [0, 0, 1]) for d in lamp.directions) < 8.0
    assert len(Lights.lamp([0, 0, 1], 0.0, 1.0, 13)) == 1  # a point lamp is one direction
    office = Lights.preset("office", "draft")
    assert office.environment is not None and 0 < office.n_lamps < len(office)
    assert office.lamp_weights.sum() == pytest.approx(0.25) and office.weights[office.n_lamps :].sum() == pytest.approx(0.75)


# ---------------------------------------------------------------------- environment maps
def _spot_map(target: np.ndarray, radius_deg: float = 1.5, width: int = 512, height: int = 256) -> Environment:
    def radiance(d):
        inside = d @ target > math.cos(math.radians(radius_deg))
        return np.repeat(np.where(inside, 200.0, 0.0)[:, None], 3, axis=1)

    return Environment.from_function(radiance, width, height, "spot")


@pytest.mark.parametrize("pose", [np.eye(3), rotation([1.0, 0.0, 0.0], 90.0), rotation([0.3, -0.2, 1.0], 37.0)])
def test_envmap_convention_matches_mitsuba(pose, variant):
    """The direction labcut samples from a map is the direction Mitsuba's envmap emitter shines from."""
    variant("rgb")
    target = direction(50.0, 200.0)
    env = _spot_map(target).rotated(pose)
    d, w = env.sample(64)
    centroid = (d * w[:, None]).sum(0)
    expected = pose @ target
    assert angle_deg(centroid, expected) < 0.3
    emitter = mi.load_dict(env.emitter())
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(*(-expected).tolist())  # a ray travelling away from the light's direction
    assert float(np.array(emitter.eval(si)).ravel()[0]) == pytest.approx(200.0, rel=0.05)
    si.wi = mi.Vector3f(*expected.tolist())
    assert float(np.array(emitter.eval(si)).ravel()[0]) == 0.0
    # and the documented layout: top row up, centre column the front (-Y)
    pix = pixel_directions(4, 2)
    assert pix[0, 0, 2] > 0 and pix[1, 0, 2] < 0
    assert np.allclose(MAP_TO_WORLD @ np.array([0.0, 1.0, 0.0]), [0, 0, 1])
    centre = pixel_directions(64, 32)[16, 32]
    assert centre[1] < -0.99


def test_envmap_sampling_is_importance_sampling():
    sky = Environment.from_function(lambda d: np.repeat(np.clip(d[:, 2], 0, None)[:, None], 3, axis=1), 128, 64, "c")
    d, w = sky.sample(400)
    assert w.sum() == pytest.approx(sky.power) and sky.power == pytest.approx(math.pi, rel=2e-3)  # ∫ cos θ dω
    assert np.all(d[:, 2] > 0)  # nothing sampled where the map is black
    # cosine-weighted: the mean z of samples (by weight) is 2/3
    assert float((d[:, 2] * w).sum() / w.sum()) == pytest.approx(2.0 / 3.0, abs=0.01)


def test_black_or_broken_maps_are_clear_errors(tmp_path):
    with pytest.raises(ParameterError, match="black"):
        Environment.from_function(lambda d: np.zeros((len(d), 3)), 16, 8, "black")
    with pytest.raises(ParameterError, match="non-finite"):
        Environment.from_function(lambda d: np.full((len(d), 3), np.nan), 16, 8, "nan")
    (tmp_path / "broken.exr").write_bytes(b"not an exr")
    with pytest.raises(ParameterError, match="environment map"):
        Lights.from_envmap(tmp_path / "broken.exr")
    with pytest.raises(ParameterError, match="does not exist"):
        Lights.from_envmap(tmp_path / "missing.hdr")


def test_envmap_with_one_bright_spot_recommends_like_that_single_light(oval, tmp_path):
    target = direction(25.0, 250.0)
    path = tmp_path / "spot.exr"
    _spot_map(target, 1.0).write(path)
    from_map = labcut.recommend_orientation(oval, LAB, lighting=str(path), viewing="face-up", quality="draft")
    single = labcut.recommend_orientation(oval, LAB, lighting=Lights([target]), viewing="face-up", quality="draft")
    assert angle_deg(from_map.normal, single.normal) < 1.0
    assert from_map.tilt_deg > 5.0  # the spot is off-axis: the answer really follows it


# ---------------------------------------------------------------------- one schiller lobe
@settings(max_examples=25, suppress_health_check=[HealthCheck.function_scoped_fixture])  # the fixture only sets the variant
@given(seed=st.integers(0, 10_000))
def test_bsdf_schiller_equals_the_estimators_c_times_q(variant, seed):
    """Pointwise: the BSDF's f_s (n·l) at random (light, view, lamella) triples equals the
    estimator's weight times the lobe, through the one lobe implementation."""
    from labcut.colour import luminance_table
    from labcut.physics.schiller import lobe_density
    from mitsuba_helpers import surface_interaction

    variant("mono")
    rng = np.random.default_rng(seed)
    lab = Labradorite.preset("green", spread_deg=float(rng.uniform(2.0, 15.0)))
    k = 64
    z = rng.uniform(0.05, 1.0, (2, k))
    phi = rng.uniform(0, 2 * np.pi, (2, k))
    r = np.sqrt(1 - z**2)
    light = np.stack([r[0] * np.cos(phi[0]), r[0] * np.sin(phi[0]), z[0]], 1)
    view = np.stack([r[1] * np.cos(phi[1]), r[1] * np.sin(phi[1]), z[1]], 1)
    n = np.tile([0.0, 0.0, 1.0], (k, 1))
    h, w = schiller_weights(n, light, view, np.ones(k), lab.n_surface, luminance_table(lab))
    m = h[rng.integers(0, k)] + rng.normal(0, 0.05, 3)  # a lamella normal near some triples' mirror direction
    m /= np.linalg.norm(m)
    expected = w * lobe_density(h @ m, lab.lobe_kappa, lab.lobe_norm)
    bsdf = mi.load_dict({"type": "labradorite", "normal": m.tolist(), "surface": False, "body": False,
                         **{key: v for key, v in lab.to_dict().items() if key != "name"}})
    si = surface_interaction(k, mi.Vector3f(view[:, 0], view[:, 1], view[:, 2]))
    got = np.array(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(light[:, 0], light[:, 1], light[:, 2]))).ravel()
    scale = max(float(expected.max()), 1e-12)
    assert np.allclose(got, expected, rtol=2e-3, atol=1e-5 * scale), np.max(np.abs(got - expected)) / scale


def test_estimators_agree_under_scenarios(oval):
    """Surface samples and rendered images, pose by pose, for a still, a posed and a rocked scenario."""
    for name in ("pendant", "bench"):
        settings = Scenario.preset(name, "draft").settings()
        normal = [0.0, 0.12, 1.0]
        problem = build_problem(oval, LAB, quality="standard", settings=settings)
        from labcut.orientation.scoring import Scorer

        samples = Scorer(problem).metrics(np.asarray(normal) / np.linalg.norm(normal))
        images = render_metrics(oval, LAB, normal, settings=settings, resolution=128, spp=16)
        assert abs(samples.flash_energy - images.flash_energy) <= 0.05 * images.flash_energy, (name, samples, images)


def test_reference_radiance_is_per_unit_irradiance():
    assert reference_radiance(LAB, 2.0) == pytest.approx(2.0 * reference_radiance(LAB, 1.0))


# ---------------------------------------------------------------------- scenarios
def test_poses_put_the_world_into_the_mesh_frame():
    pendant = Scenario.preset("pendant", "draft")
    rest = pendant.main_setting()
    assert np.allclose(rest.up(), [0, 1, 0])  # the bail end (+Y) is up
    assert np.allclose(rest.views.main, [0, 0, 1])  # the viewer in front looks at the face
    lamp = Lights([[0.0, 0.0, 1.0]])  # a lamp straight above in the world ...
    assert np.allclose(pendant.with_lights(lamp).main_setting().lights.directions[0], [0, 1, 0])  # ... is above the top edge
    cam = camera_views("main", rest)[0]
    assert np.allclose(cam.direction, [0, 0, 1]) and np.allclose(cam.up, [0, 1, 0])
    bench = Scenario.preset("bench", "standard")
    poses = bench.poses()
    assert np.allclose(poses[0][0], np.eye(3)) and sum(w for _, w in poses) == pytest.approx(1.0)
    tilts = sorted({round(angle_deg(p @ [0, 0, 1], [0, 0, 1]), 6) for p, _ in poses})
    assert tilts[0] == 0.0 and tilts[-1] == pytest.approx(30.0)
    for p, _ in poses:
        assert np.allclose(p @ p.T, np.eye(3))


def test_pendant_tilts_the_lamellae_towards_the_top_edge(oval):
    rec = labcut.recommend_orientation(oval, LAB, scenario="pendant", quality="standard")
    assert 5.0 <= rec.tilt_deg <= 30.0, rec.tilt_deg
    assert rec.normal[1] > 0 and abs(rec.azimuth_deg - 90.0) < 30.0, rec.azimuth_deg  # towards +Y
    assert rec.settings["scenario"]["name"] == "pendant"
    assert "towards the top (+Y, the bail end)" in rec.description  # named as the pendant is worn


@pytest.mark.parametrize("scenario", ["ring", "bench"])
def test_ring_and_bench_keep_a_round_cabochon_near_face_up(scenario):
    cab = labcut.load_mesh(MESHES / "round-12-low.ply")
    rec = labcut.recommend_orientation(cab, LAB, scenario=scenario, quality="standard")
    assert rec.tilt_deg <= 10.0, rec.tilt_deg


def test_lighting_and_viewing_override_a_scenario():
    ring = resolve_scene("ring", lighting="spot", quality="draft")
    assert ring.lights.name == "spot" and ring.views.name == "above"
    still = resolve_scene(lighting="spot", quality="draft")
    assert still.name == "custom" and still.views.name == "face-up" and still.poses()[0][1] == 1.0
    assert resolve_scene(quality="draft").name == "bench"


BAD_SCENARIOS = [
    ({"pose": [[1, 0, 0], [0, 1, 0], [0, 0, 2]], "lighting": "overhead", "viewing": "face-up"}, "not a rotation"),
    ({"pose": [[1, 0, 0], [0, 1, 0]], "lighting": "overhead", "viewing": "face-up"}, "3 x 3"),
    ({"pose": [[float("nan"), 0, 0], [0, 1, 0], [0, 0, 1]], "lighting": "overhead", "viewing": "face-up"}, "finite"),
    ({"pose": [[1, 0, 0], [0, 1, 0], [0, 0, -1]], "lighting": "overhead", "viewing": "face-up"}, "not a rotation"),
    ({"lighting": {"directions": []}, "viewing": "face-up"}, "no directions"),
    ({"lighting": "overhead", "viewing": {"directions": []}}, "no directions"),
    ({"lighting": "overhead", "viewing": "face-up", "rock_deg": float("inf")}, "finite"),
    ({"lighting": "overhead", "viewing": "face-up", "colour": "red"}, "unknown key"),
    ({"lighting": "overhead"}, "missing 'viewing'"),
    ({"lighting": "disco", "viewing": "face-up"}, "unknown lighting"),
    ({"pose": "face-down", "lighting": "overhead", "viewing": "face-up"}, "pose must be"),
    ({"pose": "face-front", "lighting": "overhead", "viewing": "face-up"}, "does not see the face"),
]


@pytest.mark.parametrize("data, message", BAD_SCENARIOS)
def test_bad_scenario_json_is_a_typed_error(tmp_path, data, message):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data).replace("NaN", "NaN").replace("Infinity", "1e999"))
    with pytest.raises(ParameterError, match=message):
        Scenario.from_json(path)


@pytest.mark.parametrize("data", [BAD_SCENARIOS[0][0], BAD_SCENARIOS[2][0], BAD_SCENARIOS[4][0], BAD_SCENARIOS[5][0]])
@pytest.mark.parametrize("command", ["recommend-orientation", "render"])
def test_bad_scenario_on_the_cli_exits_2_with_one_line_and_no_output(cli, tmp_path, data, command):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    out = tmp_path / "out.png"
    args = ["--render", str(out), "--json", str(tmp_path / "r.json")] if command != "render" else ["-o", str(out)]
    proc = cli(command, str(OVAL), "--scenario", str(path), *args)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().count("\n") == 0 and proc.stderr.startswith("error:")
    assert "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == [path]


def test_custom_scenario_file_round_trip(oval, tmp_path):
    path = tmp_path / "counter.json"
    path.write_text(json.dumps({
        "name": "counter", "description": "a jeweller's counter", "pose": "face-up",
        "lighting": [{"preset": "ceiling", "share": 0.6}, {"lamp": [0, -0.5, 1], "radius_deg": 5, "share": 0.4}],
        "viewing": {"directions": [[0, -0.3, 1], [0.3, -0.3, 1]], "main": [0, -0.3, 1]},
        "rock_deg": 10,
    }))
    sc = Scenario.from_json(path, "draft")
    assert sc.name == "counter" and len(sc.poses()) > 1 and sc.lights.n_lamps == 7
    rec = labcut.recommend_orientation(oval, LAB, scenario=str(path), quality="draft")
    assert rec.settings["scenario"]["name"] == "counter" and rec.scenario is not None


# ---------------------------------------------------------------------- every scenario on every command
@pytest.mark.parametrize("scenario", list(SCENARIOS.names()))
def test_every_scenario_works_on_every_command(cli_main, tmp_path, scenario):
    cli = cli_main  # in process: 18 calls, each a new interpreter's start-up saved (conftest's cli_main)
    png, js = tmp_path / "r.png", tmp_path / "r.json"
    proc = cli("render", str(OVAL), "--scenario", scenario, "--spp", "1", "--resolution", "16", "-o", str(png), "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    assert json.loads(js.read_text())["scenario"]["name"] == scenario
    proc = cli("recommend-orientation", str(OVAL), "--scenario", scenario, "--quality", "draft", "--json", "-")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["settings"]["scenario"]["name"] == scenario
    proc = cli("evaluate-orientation", str(OVAL), "--scenario", scenario, "--quality", "draft", "--json", "-")
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert data["scenario"]["name"] == scenario and data["metrics"]["flash_energy"] > 0


def test_recommended_render_is_the_scenarios_main_view(cli, tmp_path):
    js = tmp_path / "p.json"
    proc = cli("recommend-orientation", str(OVAL), "--scenario", "pendant-diffuse", "--quality", "draft", "--render",
               str(tmp_path / "p.png"), "--spp", "2", "--json", str(js))
    assert proc.returncode == 0, proc.stderr
    data = json.loads(js.read_text())
    assert data["render"]["scenario"]["name"] == "pendant-diffuse"
    assert "eye-level" in data["render"]["views"][0]


# ---------------------------------------------------------------------- plugin package
@pytest.mark.parametrize("order", ["labcut-first", "variant-first"])
def test_import_labcut_registers_the_plugin_in_either_order(order):
    code = {
        "labcut-first": "import labcut, mitsuba as mi\nfor v in ('llvm_ad_rgb', 'llvm_ad_mono', 'llvm_ad_spectral'):\n"
                        "    mi.set_variant(v); mi.load_dict({'type': 'labradorite'})\nprint('ok')",
        "variant-first": "import mitsuba as mi\nmi.set_variant('llvm_ad_spectral_polarized')\nimport labcut\n"
                         "mi.load_dict({'type': 'labradorite'})\nmi.set_variant('llvm_ad_rgb')\nmi.load_dict({'type': 'labradorite'})\nprint('ok')",
    }[order]
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr


def test_a_scenarios_settings_are_made_once():
    """settings() makes the poses' rotated lights and views once per scenario (a recommendation asks
    for them several times); another scenario (a new quality, other lights) makes its own."""
    import dataclasses

    import labcut

    sc = labcut.Scenario.preset("bench", "draft")
    first, second = sc.settings(), sc.settings()
    assert first is not second and all(a is b for a, b in zip(first, second))
    finer = labcut.Scenario.preset("bench", "standard")
    assert len(finer.settings()) > len(first)  # more rocking poses, its own settings
    moved = dataclasses.replace(sc, rock_deg=0.0, sway_deg=0.0)
    assert len(moved.settings()) == 1 and len(sc.settings()) == len(first)


def test_tilt_azimuth_takes_a_unit_vector_as_it_is():
    """One home for tilt and azimuth: a unit normal's angles come from its own components (the
    recommendation's map in JSON is the same to the last digit as before the home moved); any other
    length is normalised first."""
    import math

    from labcut.scene.directions import tilt_azimuth

    rng = np.random.default_rng(7)
    for _ in range(50):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        n[2] = abs(n[2])
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(n[2])))))
        az = math.degrees(math.atan2(float(n[1]), float(n[0]))) % 360.0
        assert tilt_azimuth(n) == (tilt, az)
        assert tilt_azimuth(3.0 * n) == pytest.approx((tilt, az), abs=1e-12)
    assert tilt_azimuth([0.0, 0.0, 2.0]) == (0.0, 0.0)


def test_lights_drawn_again_from_their_map_keep_the_lamps_and_the_maps_share():
    """``with_env_samples``: the map drawn through more directions, the lamps as they were, the map's
    share of the irradiance as it was (a scene's parts keep their weights)."""
    sc = labcut.Scenario.preset("pendant-diffuse", "draft")
    lights = sc.lights
    k = lights.n_lamps
    more = lights.with_env_samples(128)
    assert more.n_lamps == k and more.environment is lights.environment and more.name == lights.name
    assert np.array_equal(more.directions[:k], lights.directions[:k]) and np.array_equal(more.weights[:k], lights.weights[:k])
    assert 64 < len(more) - k <= 128 and len(lights) - k == 32
    assert more.weights[k:].sum() == pytest.approx(lights.weights[k:].sum(), rel=1e-12)
    assert more.total_irradiance == pytest.approx(lights.total_irradiance, rel=1e-12)
    lamp = labcut.Lights.lamp([0, 0, 1], 5.0, 1.0, 7)
    assert lamp.with_env_samples(128) is lamp
    assert sc.with_env_samples(None) is sc and labcut.Scenario.preset("bench", "draft").with_env_samples(128).lights.environment is None
    denser = sc.with_env_samples(128)
    assert all(len(st.lights) == len(more) for st in denser.settings())


@pytest.mark.parametrize("n_map, poses, want", [(32, 1, 256), (64, 1, 256), (128, 1, 256), (16, 1, 256), (32, 2, 256),
                                                (48, 1, 384), (32, 3, 32), (32, 7, 32), (1, 1, 256), (96, 1, 384),
                                                (256, 1, 256), (512, 1, 512), (96, 2, 96), (47, 2, 376)])
def test_a_map_seen_past_the_parts_is_drawn_densely_where_the_poses_see_too_few(n_map, poses, want):
    from labcut.planner import ENV_DIRECTIONS_ENOUGH, ENV_SAMPLES_PAST_PARTS, env_samples_enough

    assert (ENV_DIRECTIONS_ENOUGH, ENV_SAMPLES_PAST_PARTS) == (96, 256)
    assert env_samples_enough(n_map, poses) == want
