"""``labcut.rendering.denoise`` pinned by hand (issue 37, mutation testing).

* The guide integrator on scenes small enough to integrate by hand (one or four pixels, Mitsuba's
  LLVM rgb variant): a diffuse plane under a sun, under a uniform sky (the fixed directions of the
  sky quadrature worked out through Mitsuba's uniform-sphere warp ``z = 1 - 2 v``), under a square
  lamp (its fixed points on the lamp, the inverse-square law), a mirror reflecting the sky, and
  what the camera sees directly.
* The auxiliary passes' plumbing (samples per pass, the guide's sample count by image size, the
  seeds, the averaging of passes, the camera copy, the scene of the auxiliaries).
* :func:`denoise`'s demodulation and what it hands OIDN, through a stand-in ``pyoidn`` that
  records its call; its errors word for word; one real OIDN call on a flat image.
"""

from __future__ import annotations

import math
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from labcut.errors import BackendError
from labcut.rendering import denoise as D

RHO = 0.5  # the diffuse plane's reflectance


@pytest.fixture
def mi(variant, monkeypatch):
    """Mitsuba in its rgb variant, with the guide integrator defined afresh for the test (a guide
    registered earlier in the process, e.g. before mutation testing forks, is not reused)."""
    variant("rgb")
    monkeypatch.setattr(D, "_GUIDES", {})
    import mitsuba

    return mitsuba


def look_down(mi, height=0.5, fov=0.01, res=1, **film):
    """A camera ``height`` above the origin looking straight down (a tiny field of view: the one
    pixel sees the origin)."""
    return {"type": "perspective", "fov": fov,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, height], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": res, "height": res, **film}}


def plane(mi, bsdf=None):
    bsdf = bsdf or {"type": "diffuse", "reflectance": {"type": "rgb", "value": RHO}}
    return {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale(10), "bsdf": bsdf}


def scene(mi, **parts):
    return mi.load_dict({"type": "scene", "sensor": parts.pop("sensor", look_down(mi)), **parts})


SKY = 2.0


def sky(mi):
    return {"type": "constant", "radiance": {"type": "rgb", "value": SKY}}


# ---------------------------------------------------------------------- the guide, by hand
def test_guide_of_a_diffuse_plane_under_the_sun(mi):
    """A sun straight above (irradiance 1, one direction: a delta emitter takes one node): the
    diffuse plane's radiance rho / pi, in every pixel and channel."""
    s = scene(mi, plane=plane(mi), sun={"type": "directional", "direction": [0, 0, -1], "irradiance": {"type": "rgb", "value": 1.0}},
              sensor=look_down(mi, height=5.0, fov=20.0, res=4))
    g = D.trace_guide(s, 4)
    assert g.shape == (4, 4, 3) and g.dtype == np.float32
    assert np.allclose(g, RHO / math.pi, rtol=1e-5)


def sky_quadrature(nodes: int) -> float:
    """The guide's uniform sky on a diffuse face-up plane: ``nodes`` fixed directions, the k-th at
    ``z = 1 - 2 v_k`` (Mitsuba's uniform sphere; v_k = k x 0.618... mod 1), each weighed by
    radiance / pdf = 4 pi L and the BSDF's rho / pi cos, averaged: ``4 rho L mean(max(z, 0))``."""
    v = [(k * 0.6180339887498949) % 1.0 for k in range(nodes)]
    return 4.0 * RHO * SKY * sum(max(1.0 - 2.0 * x, 0.0) for x in v) / nodes


def test_guide_of_a_diffuse_plane_under_a_uniform_sky(mi):
    """ENV_NODES = 4 directions: z = 1, -0.236, 0.528, -0.708: ``rho L (1 + 0.528)`` = 1.5279;
    with one direction (straight up) 4 rho L, with two the same over 2."""
    assert D.ENV_NODES == 4
    assert sky_quadrature(4) == pytest.approx(RHO * SKY * (2.0 - 2.0 * 0.2360679775), rel=1e-9)
    s = scene(mi, plane=plane(mi), env=sky(mi))
    assert D.trace_guide(s, 4)[0, 0, 0] == pytest.approx(sky_quadrature(4), rel=1e-4)
    for n in (1, 2, 3):
        assert D.trace_guide(s, 4, env_nodes=n)[0, 0, 0] == pytest.approx(sky_quadrature(n), rel=1e-4), n
    assert D.trace_guide(s, 4, env_nodes=0)[0, 0, 0] == 0.0  # no sky quadrature at all


def lamp_quadrature(nodes: int) -> float:
    """A 2 x 2 square lamp (radiance 1) facing down 1 above the origin: each fixed point (u, v) of
    :func:`_nodes` is the lamp's point (2u - 1, +-(2v - 1), 1); at distance r it adds
    ``rho / pi L cos cos' A / r^2`` = ``rho / pi 4 / r^4`` (both cosines 1 / r); averaged."""
    pts = [((i + 0.5) / nodes, (i * 0.6180339887498949) % 1.0) for i in range(nodes)]
    return sum(RHO / math.pi * 4.0 / ((2 * u - 1) ** 2 + (2 * v - 1) ** 2 + 1.0) ** 2 for u, v in pts) / nodes


def test_guide_of_a_diffuse_plane_under_a_square_lamp(mi):
    """LAMP_NODES = 2 fixed points (-0.5, 1) and (0.5, 0.236): 0.24958; one point (the middle of an
    edge, (0, 1): r^2 = 2): rho / pi = 0.15915; three: the formula."""
    T = mi.ScalarTransform4f
    s = scene(mi, plane=plane(mi), lamp={"type": "rectangle", "to_world": T().translate([0, 0, 1]) @ T().rotate([1, 0, 0], 180),
                                        "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 1.0}}})
    assert D.LAMP_NODES == 2
    assert lamp_quadrature(2) == pytest.approx(0.24958, abs=1e-5) and lamp_quadrature(1) == pytest.approx(RHO / math.pi)
    assert D.trace_guide(s, 4)[0, 0, 0] == pytest.approx(lamp_quadrature(2), rel=1e-4)
    for n in (1, 3):
        assert D.trace_guide(s, 4, lamp_nodes=n)[0, 0, 0] == pytest.approx(lamp_quadrature(n), rel=1e-4), n


def test_the_lamps_nodes_are_not_the_sky_s(mi):
    """A lamp and a sky together: each takes its own count of nodes (2 and 4 by default, and as
    given), and their light adds."""
    T = mi.ScalarTransform4f
    s = scene(mi, plane=plane(mi), env=sky(mi),
              lamp={"type": "rectangle", "to_world": T().translate([0, 0, 1]) @ T().rotate([1, 0, 0], 180),
                    "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 1.0}}})
    # the sky behind the lamp still counts: the guide casts no shadow rays
    assert D.trace_guide(s, 4)[0, 0, 0] == pytest.approx(lamp_quadrature(2) + sky_quadrature(4), rel=1e-4)
    assert D.trace_guide(s, 4, lamp_nodes=3, env_nodes=1)[0, 0, 0] == pytest.approx(lamp_quadrature(3) + sky_quadrature(1), rel=1e-4)


def test_the_sun_adds_to_the_lights_before_it(mi):
    """A square lamp and a sun (the auxiliary scene lists the lamp first), or a sky then a sun: the
    guide is the sum of each one's light, whatever the order."""
    T = mi.ScalarTransform4f
    sun = {"type": "directional", "direction": [0, 0, -1], "irradiance": {"type": "rgb", "value": 1.0}}
    lamp = {"type": "rectangle", "to_world": T().translate([0, 0, 1]) @ T().rotate([1, 0, 0], 180),
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 1.0}}}
    s = scene(mi, plane=plane(mi), lamp=lamp, sun=sun)
    assert D.trace_guide(s, 4)[0, 0, 0] == pytest.approx(lamp_quadrature(2) + RHO / math.pi, rel=1e-4)
    s = scene(mi, plane=plane(mi), env=sky(mi), sun=sun)
    assert D.trace_guide(s, 4)[0, 0, 0] == pytest.approx(sky_quadrature(4) + RHO / math.pi, rel=1e-4)


def test_guide_keeps_the_colour(mi):
    """A plane of reflectance (0.2, 0.4, 0.6) under a white sun: (0.2, 0.4, 0.6) / pi, channel by
    channel (an rgb film, not a luminance one repeated), for one pixel and for a row of two."""
    bsdf = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.2, 0.4, 0.6]}}
    sun = {"type": "directional", "direction": [0, 0, -1], "irradiance": {"type": "rgb", "value": 1.0}}
    for res in (1, 2):
        g = D.trace_guide(scene(mi, plane=plane(mi, bsdf), sun=sun, sensor=look_down(mi, res=res)), 4)
        assert g.shape == (res, res, 3)
        assert np.allclose(g, np.array([0.2, 0.4, 0.6]) / math.pi, rtol=1e-4), res


def test_guide_of_the_stone_s_polish_is_its_fresnel_mirror(mi):
    """labcut's own BSDF (the ``labradorite`` plugin) under the sky, its diffuse parts left out
    (``env_nodes=0``): the polish's mirror image alone, the sky times the Fresnel reflectance at
    normal incidence ``((n - 1) / (n + 1))^2`` of the stone's surface index (1.56: 0.0479)."""
    import labcut

    n = labcut.Labradorite().n_surface
    s = scene(mi, plane=plane(mi, {"type": "labradorite"}), env=sky(mi))
    assert D.trace_guide(s, 4, env_nodes=0)[0, 0, 0] == pytest.approx(SKY * ((n - 1) / (n + 1)) ** 2, rel=1e-4)


@pytest.mark.parametrize("reflectance", [1.0, 0.25])
def test_guide_of_a_mirror_is_the_sky_it_reflects(mi, reflectance):
    """A polished plane (a delta reflection of reflectance R) under the sky: no diffuse part for the
    sky's nodes, its one mirrored ray sees the sky: ``R L``."""
    bsdf = {"type": "conductor", "material": "none", "specular_reflectance": {"type": "rgb", "value": reflectance}}
    s = scene(mi, plane=plane(mi, bsdf), env=sky(mi))
    assert D.trace_guide(s, 4)[0, 0, 0] == pytest.approx(reflectance * SKY, rel=1e-4)


def test_guide_of_a_rough_mirror_has_no_mirror_image(mi):
    """A rough (not delta) conductor: no mirrored ray, no diffuse part for the sky's nodes: 0."""
    bsdf = {"type": "roughconductor", "material": "none", "alpha": 0.2}
    s = scene(mi, plane=plane(mi, bsdf), env=sky(mi))
    assert D.trace_guide(s, 4)[0, 0, 0] == 0.0


def test_guide_of_a_mirror_reflecting_a_lamp_and_the_sky_seen_directly(mi):
    """Looking straight down at a mirror under the square lamp (radiance 3, facing down), the
    mirrored ray meets the lamp: 3 (the lamp's nodes add nothing: a delta BSDF evaluates to 0).
    A camera looking up at the lamp sees its radiance 3; looking at the sky alone, the sky's 2."""
    T = mi.ScalarTransform4f
    lamp = {"type": "rectangle", "to_world": T().translate([0, 0, 1]) @ T().rotate([1, 0, 0], 180),
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 3.0}}}
    mirror = {"type": "conductor", "material": "none"}
    assert D.trace_guide(scene(mi, plane=plane(mi, mirror), lamp=lamp), 4)[0, 0, 0] == pytest.approx(3.0, rel=1e-4)
    up = {"type": "perspective", "fov": 0.01, "to_world": T().look_at(origin=[0, 0, 0.5], target=[0, 0, 1], up=[0, 1, 0]),
          "film": {"type": "hdrfilm", "width": 1, "height": 1}}
    assert D.trace_guide(scene(mi, lamp=lamp, sensor=up), 4)[0, 0, 0] == pytest.approx(3.0, rel=1e-4)
    g = D.trace_guide(scene(mi, env=sky(mi), sensor=look_down(mi, res=2)), 4)
    assert np.allclose(g, SKY, rtol=1e-6)


def test_guide_of_a_monochrome_render_has_three_equal_channels(mi, variant):
    """In the mono variant the one channel is repeated into three."""
    variant("mono")
    import mitsuba

    for res in (1, 2):
        s = scene(mitsuba, plane=plane(mitsuba, {"type": "diffuse", "reflectance": {"type": "spectrum", "value": RHO}}),
                  sun={"type": "directional", "direction": [0, 0, -1], "irradiance": {"type": "spectrum", "value": 1.0}},
                  sensor=look_down(mitsuba, res=res))
        g = D.trace_guide(s, 4)
        assert g.shape == (res, res, 3) and np.allclose(g, RHO / math.pi, rtol=1e-4), res


def test_register_guide_is_idempotent(mi):
    D.register_guide()
    cls = D._GUIDES[mi.variant()]
    D.register_guide()
    assert D._GUIDES[mi.variant()] is cls
    integrator = mi.load_dict({"type": "labcut_guide"})
    assert type(integrator) is cls  # registered under the name trace_guide asks for
    assert (integrator.lamp_nodes, integrator.env_nodes) == (2, 4) and integrator.aov_names() == []
    integrator = mi.load_dict({"type": "labcut_guide", "lamp_nodes": 5, "env_nodes": 0})
    assert (integrator.lamp_nodes, integrator.env_nodes) == (5, 0)


# ---------------------------------------------------------------------- small parts by hand
def test_nodes_are_a_fibonacci_lattice():
    """x: cell centres (i + 1/2) / n; y: i times the golden ratio's fraction 0.618..., mod 1."""
    assert np.allclose(D._nodes(4), [[0.125, 0.0], [0.375, 0.6180339887], [0.625, 0.2360679775], [0.875, 0.8541019662]],
                       atol=1e-10, rtol=0)
    assert D._nodes(1).tolist() == [[0.5, 0.0]] and D._nodes(2.0).shape == (2, 2)


@pytest.mark.parametrize("spp, per", [(0, 1), (1, 1), (2, 4), (4, 4), (5, 16), (16, 16), (17, 64), (64, 64), (1000, 64)])
def test_samples_per_pass_are_the_next_power_of_4_up_to_64(spp, per):
    assert D._per_pass(spp) == per


@pytest.mark.parametrize("pixels, spp", [(0, 64), (1, 64), (256 * 256, 64), (256 * 256 + 1, 16), (4 * 256 * 256, 16),
                                         (64 * 256 * 256, 16)])
def test_guide_samples_by_image_size(pixels, spp):
    """64 samples per pixel up to 256 x 256 pixels (as many samples in all as 256^2 x 64), then the
    next power of 4 down that keeps the total: 16 from one pixel more, never fewer than 16."""
    assert (D.GUIDE_SPP, D.GUIDE_SPP_MIN, D.AUX_SPP) == (64, 16, 64)
    assert D.guide_samples(pixels) == spp


def test_unit_normals():
    """Unit length; NaN read as 0; a vector of length 1e-6 or less is no direction (0); between
    1e-6 and 2e-6 it is still made unit; float32, C-contiguous."""
    n = np.array([[3.0, 0.0, 4.0], [np.nan, 0.0, 2.0], [1e-6, 0.0, 0.0], [1.5e-6, 0.0, 0.0], [0.0, 0.0, 0.0]])
    u = D._unit(np.asfortranarray(n))
    assert u.dtype == np.float32 and u.flags.c_contiguous
    assert np.allclose(u, [[0.6, 0.0, 0.8], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]], atol=1e-7)


def test_passes_average_one_render_per_pass(monkeypatch):
    """ceil(spp / per) passes (at least one), seeds seed, seed + 1, ..., each at ``per`` samples;
    their mean, in float64."""
    from labcut.rendering import passes

    calls = []

    def fake(scene, spp, seed):
        calls.append((scene, spp, seed))
        return np.full((1, 1, 1), float(seed), dtype=np.float32)

    monkeypatch.setattr(passes, "render_pass", fake)
    out = D._passes("s", 100, 16, 10)
    assert calls == [("s", 16, 10 + k) for k in range(7)]  # ceil(100 / 16) = 7
    assert out.dtype == np.float64 and out[0, 0, 0] == pytest.approx(13.0)
    calls.clear()
    assert D._passes("s", 0, 4, 5)[0, 0, 0] == 5.0 and calls == [("s", 4, 5)]
    calls.clear()
    D._passes("s", 64, 64, 0)
    assert len(calls) == 1


def fake_passes(monkeypatch, channels=7):
    """``aux_scene``, ``_camera`` and ``_passes`` replaced by recorders; the image an arange."""
    seen = {}
    monkeypatch.setattr(D, "aux_scene", lambda scene, integrator, sensor=None:
                        seen.update(scene=scene, integrator=integrator, sensor=sensor) or "aux")
    monkeypatch.setattr(D, "_camera", lambda sensor, sampler: seen.update(camera=(sensor, sampler)) or "camera")

    def passes(scene, spp, per, seed):
        seen.update(passes=(scene, spp, per, seed))
        return np.arange(2 * 2 * channels, dtype=np.float64).reshape(2, 2, channels) - 3.0

    monkeypatch.setattr(D, "_passes", passes)
    return seen


def test_aov_passes_take_their_own_low_discrepancy_camera(monkeypatch):
    """The AOV pass: the scene's first sensor copied with an ``ldsampler`` of ``per`` samples,
    Mitsuba's aov integrator with the AOVs asked, ``max(spp, per)`` samples in passes of ``per``,
    seed ``7919 seed + 1000003``; float32; the albedo and normal are the first six channels."""
    seen = fake_passes(monkeypatch)
    scene = SimpleNamespace(sensors=lambda: ["sensor0", "sensor1"])
    img = D.trace_albedo_normal(scene, 5, seed=2)
    assert seen["camera"] == ("sensor0", {"type": "ldsampler", "sample_count": 16})
    assert seen["integrator"] == {"type": "aov", "aovs": "albedo:albedo,nn:sh_normal"} and seen["sensor"] == "camera"
    assert seen["scene"] is scene
    assert seen["passes"] == ("aux", 16, 16, 2 * 7919 + 1_000_003)
    assert img.dtype == np.float32 and img.shape == (2, 2, 6) and img[0, 0].tolist() == [-3, -2, -1, 0, 1, 2]
    D.trace_albedo_normal(scene)
    assert seen["passes"] == ("aux", 64, 64, 1_000_003)


def test_guide_pass_seeds_and_clipping(monkeypatch):
    """The guide: the ``labcut_guide`` integrator with the node counts as integers, its own seeds
    (``7919 seed + 2000003``), NaN and negative radiance read as 0, the first three channels."""
    seen = fake_passes(monkeypatch, channels=4)
    monkeypatch.setattr(D, "register_guide", lambda: seen.update(registered=True))
    scene = SimpleNamespace(sensors=lambda: ["sensor0"])
    g = D.trace_guide(scene, 2, seed=3, lamp_nodes=3.0, env_nodes=1.0)
    assert seen["registered"]
    assert seen["integrator"] == {"type": "labcut_guide", "lamp_nodes": 3, "env_nodes": 1}
    assert type(seen["integrator"]["lamp_nodes"]) is int and type(seen["integrator"]["env_nodes"]) is int
    assert seen["camera"] == ("sensor0", {"type": "ldsampler", "sample_count": 4})
    assert seen["scene"] is scene and seen["sensor"] == "camera"
    assert seen["passes"] == ("aux", 4, 4, 3 * 7919 + 2_000_003)
    assert g.dtype == np.float32 and g.shape == (2, 2, 3) and g[0, 0].tolist() == [0.0, 0.0, 0.0] and g[0, 1].tolist() == [1, 2, 3]
    D.trace_guide(scene)
    assert seen["passes"] == ("aux", 64, 64, 2_000_003) and seen["integrator"]["lamp_nodes"] == 2
    assert seen["integrator"]["env_nodes"] == 4


def test_trace_aux_is_the_guide_then_the_normal(monkeypatch):
    """Six channels: the guide (at :func:`guide_samples` of the film's pixels, or ``guide_spp``),
    then the normal pass's first three (the normal AOV alone, ``spp`` samples)."""
    calls = {}

    def aovs(scene, aovs, spp, seed):
        calls["aovs"] = (aovs, spp, seed)
        calls.setdefault("scenes", []).append(scene)
        return np.full((1, 1, 4), 7.0, dtype=np.float32)

    def guide(scene, spp, seed):
        calls["guide"] = (spp, seed)
        calls.setdefault("scenes", []).append(scene)
        return np.full((1, 1, 3), 1.0, dtype=np.float32)

    monkeypatch.setattr(D, "_trace_aovs", aovs)
    monkeypatch.setattr(D, "trace_guide", guide)
    film = SimpleNamespace(crop_size=lambda: (512, 256))
    scene = SimpleNamespace(sensors=lambda: [SimpleNamespace(film=lambda: film)])
    assert D._pixels(scene) == 512 * 256
    out = D.trace_aux(scene, 8, seed=4)
    assert out.tolist() == [[[1.0, 1.0, 1.0, 7.0, 7.0, 7.0]]]
    assert calls == {"aovs": ("nn:sh_normal", 8, 4), "guide": (16, 4), "scenes": [scene, scene]}
    del calls["scenes"]
    D.trace_aux(scene, guide_spp=4.0)
    assert calls["aovs"] == ("nn:sh_normal", 64, 0) and calls["guide"] == (4, 0)
    film.crop_size = lambda: (256, 256)
    D.trace_aux(scene)
    assert calls["guide"] == (64, 0)


def test_camera_copy_keeps_the_view_with_a_box_filter(mi):
    """The copy of a perspective sensor: the same field of view, clip planes, film size and pose,
    a box pixel filter (not the sensor's Gaussian) and the sampler asked; any other sensor as it is."""
    T = mi.ScalarTransform4f
    pose = T().look_at(origin=[1, 2, 3], target=[0, 0, 0], up=[0, 0, 1])
    sensor = mi.load_dict({"type": "perspective", "fov": 33.0, "fov_axis": "y", "near_clip": 0.05, "far_clip": 50.0,
                           "to_world": pose, "film": {"type": "hdrfilm", "width": 6, "height": 4}})
    copy = D._camera(sensor, {"type": "ldsampler", "sample_count": 16})
    assert copy is not sensor
    assert mi.traverse(copy)["x_fov"][0] == pytest.approx(mi.traverse(sensor)["x_fov"][0], rel=1e-6)
    assert (copy.near_clip(), copy.far_clip()) == (pytest.approx(0.05), pytest.approx(50.0))
    assert tuple(copy.film().crop_size()) == (6, 4)
    assert np.allclose(np.asarray(copy.world_transform().matrix), np.asarray(sensor.world_transform().matrix), atol=1e-6)
    assert "box" in str(copy.film().rfilter()).lower() and "gaussian" in str(sensor.film().rfilter()).lower()
    assert copy.sampler().sample_count() == 16 and str(copy.sampler()).startswith("LowDiscrepancySampler")
    ortho = mi.load_dict({"type": "orthographic", "film": {"type": "hdrfilm", "width": 4, "height": 4}})
    assert D._camera(ortho, {"type": "independent"}) is ortho


def test_aux_scene_holds_the_shapes_and_the_emitters_once(mi):
    """The scene's shapes (an area lamp comes with its shape) and its other emitters (the sky, the
    sun) once each, seen through its first sensor or the one given; Mitsuba's aov integrator by
    default."""
    T = mi.ScalarTransform4f
    s = scene(mi, plane=plane(mi), env=sky(mi), sun={"type": "directional", "direction": [0, 0, -1]},
              lamp={"type": "rectangle", "to_world": T().translate([0, 0, 1]), "emitter": {"type": "area"}})
    aux = D.aux_scene(s)
    assert len(aux.shapes()) == 2 and len(aux.emitters()) == 3
    assert str(aux.integrator()).startswith("AOVIntegrator") and "albedo" in str(aux.integrator())
    assert aux.sensors()[0] is s.sensors()[0]
    other = mi.load_dict(look_down(mi, res=3))
    aux = D.aux_scene(s, {"type": "path"}, sensor=other)
    assert aux.sensors()[0] is other and str(aux.integrator()).startswith("PathIntegrator")


# ---------------------------------------------------------------------- denoise
@pytest.fixture
def oidn(monkeypatch):
    """A stand-in ``pyoidn`` whose ``denoise`` records its arguments and returns ``result`` (the
    colour it was given when None)."""
    record = SimpleNamespace(calls=[], result=None, error=None)

    def denoise(colour, albedo, normal, **kw):
        record.calls.append(SimpleNamespace(colour=colour, albedo=albedo, normal=normal, **kw))
        if record.error is not None:
            raise record.error
        return colour if record.result is None else record.result

    monkeypatch.setitem(sys.modules, "pyoidn", SimpleNamespace(denoise=denoise))
    return record


def test_denoise_demodulates_by_the_guide_floored_at_1_percent_of_its_mean(oidn):
    """Colour (1, 2) over a guide (0, 4) (mean 2, floor 0.02): OIDN gets (1 / 0.02, 2 / 4.02) with a
    flat albedo 0.5 and the unit normal, clean auxiliaries, HDR, high quality; its answer (here 1
    everywhere) is multiplied by the floored guide: (0.02, 4.02)."""
    colour = np.array([[[1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]])
    guide = np.array([[[0.0, 0.0, 0.0], [4.0, 4.0, 4.0]]])
    normal = np.array([[[0.0, 0.0, 2.0], [0.0, 3.0, 4.0]]])
    oidn.result = np.ones((1, 2, 3), dtype=np.float32)
    out = D.denoise(colour, guide, normal)
    call, = oidn.calls
    assert call.colour.dtype == np.float32 and call.colour.flags.c_contiguous
    assert np.allclose(call.colour[0, :, 0], [50.0, 2.0 / 4.02], rtol=1e-6)
    assert call.albedo.dtype == np.float32 and np.array_equal(call.albedo, np.full((1, 2, 3), 0.5, dtype=np.float32))
    assert np.allclose(call.normal, [[[0, 0, 1], [0, 0.6, 0.8]]], atol=1e-7)
    assert call.hdr is True and call.clean_aux is True and call.quality == "high"
    assert out.dtype == np.float32 and np.allclose(out[0, :, 0], [0.02, 4.02], rtol=1e-6)
    assert (D.GUIDE_FLOOR, D.FLAT_ALBEDO) == (0.01, 0.5)


def test_denoise_reads_nan_and_negative_as_zero(oidn):
    """NaN and negative colour and guide values are 0 (the guide's mean taken after: (0 + 0 + 3) / 3
    per channel... here the mean of (nan, -1, 3) read as (0, 0, 3): 1, floor 0.01); a negative OIDN
    answer is clipped to 0."""
    colour = np.array([[[np.nan] * 3, [-1.0] * 3, [3.0] * 3]])
    guide = np.array([[[np.nan] * 3, [-1.0] * 3, [3.0] * 3]])
    oidn.result = np.array([[[1.0] * 3, [-5.0] * 3, [2.0] * 3]], dtype=np.float32)
    out = D.denoise(colour, guide)
    call, = oidn.calls
    assert np.allclose(call.colour[0, :, 0], [0.0, 0.0, 3.0 / 3.01], rtol=1e-6)
    assert call.normal is None and call.clean_aux is True
    assert np.allclose(out[0, :, 0], [0.01, 0.0, 2.0 * 3.01], rtol=1e-6)


def test_a_black_guide_is_no_guide(oidn):
    """A guide of mean 0: the colour is denoised as it is, without an albedo, so without the normal
    (OIDN takes a normal only with an albedo) and without clean auxiliaries."""
    colour = np.full((2, 2, 3), 0.5)
    out = D.denoise(colour, np.zeros((2, 2, 3)), np.ones((2, 2, 3)))
    call, = oidn.calls
    assert call.albedo is None and call.normal is None and call.clean_aux is False
    assert np.allclose(call.colour, 0.5) and np.allclose(out, 0.5)


def test_denoise_with_the_albedo_instead(oidn):
    """No guide: OIDN gets the colour, the albedo clipped to [0, 1] (NaN read as 0) and the normal;
    ``clean_aux`` as asked."""
    colour = np.full((1, 3, 3), 0.25)
    albedo = np.array([[[2.0] * 3, [np.nan] * 3, [-0.5] * 3]])
    D.denoise(colour, normal=np.array([[[0, 0, 1.0]] * 3]), albedo=albedo)
    D.denoise(colour, albedo=albedo, clean_aux=False)
    first, second = oidn.calls
    assert first.albedo.dtype == np.float32 and np.array_equal(first.albedo[0, :, 0], [1.0, 0.0, 0.0])
    assert np.array_equal(first.normal[0, 0], [0, 0, 1]) and first.clean_aux is True
    assert np.allclose(first.colour, 0.25)
    assert second.clean_aux is False and second.normal is None
    D.denoise(colour, clean_aux=1)
    assert oidn.calls[-1].clean_aux is False and oidn.calls[-1].albedo is None  # no auxiliary: nothing to keep clean


def test_denoise_errors_word_for_word(oidn, monkeypatch):
    """OIDN's failure: its first line, at most 160 characters; pyoidn missing: what to do."""
    for exc in (RuntimeError("device lost\nsecond line"), ValueError("bad shape"), TypeError("x" * 300)):
        oidn.error = exc
        with pytest.raises(BackendError) as err:
            D.denoise(np.zeros((1, 1, 3)))
        first = str(exc).splitlines()[0][:160]
        assert str(err.value) == f"denoising failed: {first}"
    assert str(err.value) == "denoising failed: " + "x" * 160
    monkeypatch.setitem(sys.modules, "pyoidn", None)
    with pytest.raises(BackendError) as err:
        D.denoise(np.zeros((1, 1, 3)))
    assert str(err.value) == "denoising needs the pyoidn package (pip install pyoidn), or render with denoise off"
    assert D.available() is False


def test_real_oidn_keeps_a_flat_image_flat():
    """One real call: a flat image (with its guide) comes back about flat (OIDN leaves a few per cent
    of ripple, up to about 10 %, on a 16 x 16 image), float32, (H, W, 3)."""
    pytest.importorskip("pyoidn")
    assert D.available() is True
    out = D.denoise(np.full((16, 16, 3), 0.3), np.full((16, 16, 3), 0.6), np.dstack([np.zeros((16, 16, 2)), np.ones((16, 16))]))
    assert out.shape == (16, 16, 3) and out.dtype == np.float32
    assert np.allclose(out, 0.3, rtol=0.15) and float(out.mean()) == pytest.approx(0.3, rel=0.01)
