"""The render frame: every render places its stone where its bounding sphere is the unit sphere,
inside scene bounds that :func:`~labcut.rendering.scene.bounds_marker` fixes, so Mitsuba's
kernels (which hold the scene's sizes as constants) are the same for a stone of any size or place.

What a user would notice if it broke: a new stone in the explorer, or a new cabochon size in a
comparison, waiting for its render kernels to compile again (a fraction of a second each), or
renders that depend on where the stone lies in its file's coordinates.
"""

from __future__ import annotations

from pathlib import Path

import mitsuba as mi
import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from mitsuba_helpers import launched

import labcut
from labcut.backend import set_variant
from labcut.rendering.api import bsdf_dict
from labcut.rendering.scene import (SCENE_HALF_SIDE, CameraView, RenderFrame, bounds_marker, camera, emitters,
                                    stone_entries, to_mitsuba_mesh)
from labcut.scene import resolve_scene

MESHES = Path(__file__).resolve().parents[1] / "meshes"
NORMAL = np.array([0.12, -0.05, 1.0]) / np.linalg.norm([0.12, -0.05, 1.0])


def _moved(mesh, scale: float, shift) -> trimesh.Trimesh:
    """``mesh`` scaled about the origin and shifted (mm): the same stone, elsewhere and larger."""
    return trimesh.Trimesh(np.asarray(mesh.vertices) * scale + np.asarray(shift, dtype=np.float64), np.asarray(mesh.faces),
                           process=False)


@pytest.fixture(scope="module")
def oval():
    return labcut.cabochon("oval", 16.0, 12.0, dome="medium")


@given(scale=st.floats(0.03, 30.0), shift=st.tuples(*[st.floats(-300.0, 300.0)] * 3))
@settings(max_examples=40, deadline=None)
def test_the_frame_puts_the_bounding_sphere_on_the_unit_sphere(scale, shift):
    box = trimesh.creation.box(extents=(16.0, 12.0, 5.0))
    mesh = _moved(box, scale, shift)
    frame = RenderFrame.of(mesh)
    lo, hi = frame.box(*mesh.bounds)
    assert np.allclose(lo, -np.asarray(hi), atol=1e-12)  # centred
    assert np.linalg.norm(np.subtract(hi, lo)) / 2 == pytest.approx(1.0, rel=1e-12)  # radius 1
    assert frame.radius == pytest.approx(scale * np.linalg.norm([16.0, 12.0, 5.0]) / 2, rel=1e-12)
    p = np.asarray(mesh.vertices)
    assert np.allclose(frame.points(p) * frame.radius + np.asarray(frame.centre), p, rtol=0, atol=1e-9 * max(1.0, np.abs(p).max()))


def test_the_bounds_marker_widens_the_scene_and_changes_no_pixel():
    """With and without the marker: the same image to the bit (paths of four bounces, lamps and a
    sky; a box filter, so that no pixel's sum depends on the threads' order), and no ray meets
    the marker, even one aimed at its corners."""
    carving = labcut.load_mesh(MESHES / "carving-biplane.ply")
    set_variant("mono")
    setting = resolve_scene(scenario="outdoor", quality="draft").settings()[0]
    stone = to_mitsuba_mesh(carving, mi.load_dict(bsdf_dict(labcut.Labradorite(), NORMAL, ("surface", "schiller", "body"))))
    images = []
    for marker in (False, True):
        d = {"type": "scene", "integrator": {"type": "path", "max_depth": 4}, "stone": stone, **emitters(setting.lights),
             "sensor": camera(CameraView("v", (0.3, -0.2, 0.93)), 48, rfilter="box")}
        if marker:
            d["scene_bounds"] = bounds_marker()
        scene = mi.load_dict(d)
        h = SCENE_HALF_SIDE
        top = np.array(scene.bbox().max).ravel()
        assert np.all(top == h) if marker else np.all(top < 1.0 + 1e-5)  # the cube's corner, or the stone's box
        images.append(np.array(mi.render(scene, spp=8, seed=5)))
    assert np.array_equal(images[0], images[1])
    alone = mi.load_dict({"type": "scene", "m": bounds_marker()})
    corners = np.array([[-h, -h, -h], [h, h, h]])
    o = corners + np.array([[0.3, 0.2, -1.0]])
    d = corners - o
    ray = mi.Ray3f(mi.Point3f(*o.T), mi.Vector3f(*(d / np.linalg.norm(d, axis=1)[:, None]).T))
    assert not np.any(np.array(alone.ray_test(ray)))


def test_every_stone_s_scene_has_the_same_bounds(oval):
    """Mitsuba gives a directional lamp's or a sky's shadow rays the length of the scene's
    bounding sphere, written into the kernel as a constant: with the stone's entries
    (:func:`stone_entries`) every stone's scene has the same bounds to the bit, whatever its
    shape (in the render frame alone, a stone's box would still differ by its shape and by
    float32 rounding)."""
    set_variant("mono")
    boxes = set()
    for mesh in (oval, _moved(labcut.cabochon("round", 9.0, 9.0, dome="high"), 0.3, (1.0, 2.0, 3.0)),
                 labcut.load_mesh(MESHES / "carving-biplane.ply")):
        scene = mi.load_dict({"type": "scene", **stone_entries(to_mitsuba_mesh(mesh, mi.load_dict({"type": "diffuse"})))})
        boxes.add((tuple(np.array(scene.bbox().min).ravel()), tuple(np.array(scene.bbox().max).ravel())))
    h = SCENE_HALF_SIDE
    assert boxes == {((-h, -h, -h), (h, h, h))}


#: renders a stone, then two stones of other outlines, sizes and places, in a new process, and
#: prints per case the render kernels (more than 100 operations) the first launched, and those the
#: two others launched that the first did not
FRESH_PROCESS = r"""
import gc, json
import drjit as dr, numpy as np, trimesh
import labcut
from labcut.orientation.render_objective import RenderObjective
from labcut.scene import resolve_scene

normal = np.array([0.12, -0.05, 1.0]) / np.linalg.norm([0.12, -0.05, 1.0])
def moved(mesh, scale, shift):
    return trimesh.Trimesh(np.asarray(mesh.vertices) * scale + shift, np.asarray(mesh.faces), process=False)
first = labcut.cabochon("oval", 16.0, 12.0, dome="medium")
others = [moved(labcut.cabochon("round", 9.0, 9.0, dome="high"), 1.6, [-20.0, 5.0, 9.0]),
          moved(labcut.cabochon("pear", 22.0, 14.0, dome="low"), 0.5, [3.0, 60.0, -7.0])]
poses = resolve_scene(scenario="pendant", quality="draft").settings()[:2]

def kernels(call):
    gc.collect()
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        dr.kernel_history()
        call()
        return {k["hash"] for k in dr.kernel_history() if k.get("type") == dr.KernelType.JIT and k["operation_count"] > 100}

cases = {look: (lambda m, look=look: labcut.render(m, "blue", normal, resolution=24, spp=2, look=look, denoise=False,
                                                  check_flash=False))
         for look in ("diagram", "studio")}
cases["estimator"] = lambda m: RenderObjective(m, labcut.Labradorite(), poses, resolution=16, spp=2, max_depth=4).images(normal)
out = {}
for case, call in cases.items():
    made = kernels(lambda: call(first))
    new = set().union(*(kernels(lambda: call(m)) - made for m in others))
    out[case] = [sorted(made), sorted(new)]
print(json.dumps(out))
"""


def test_stones_of_other_shapes_sizes_and_places_render_with_the_kernels_already_made():
    """In a new process, as a session starts: after one stone's render, two stones of other
    outlines, sizes and places launch no render kernel of their own, in the diagram and the
    studio look and in the render estimator's renders (a size written into a kernel as a
    constant, the camera's clip planes or the lamps' shadow rays' length from the scene's bounds,
    makes a kernel for each new stone, compiled again). At most one other kernel between the
    two: Dr.Jit also writes the registry number of the scene's environment into its kernels,
    and which number a new environment gets depends on when the last one's release was done
    (docs/performance.md, "Renders in the stone's render frame")."""
    import json
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", FRESH_PROCESS], capture_output=True, text=True, timeout=600,
                          cwd=MESHES.parent)
    assert proc.returncode == 0, proc.stderr[-2000:]
    cases = json.loads(proc.stdout.strip().splitlines()[-1])
    assert set(cases) == {"diagram", "studio", "estimator"}
    for case, (made, new) in cases.items():
        assert made and len(new) <= 1, (case, new)


def _render(mesh, look: str):
    return labcut.render(mesh, "blue", NORMAL, resolution=32, spp=4, look=look, check_flash=False)


def test_a_diagram_render_does_not_depend_on_where_the_stone_lies_or_its_scale(oval):
    """The same stone three times larger and far from the origin of its file renders the same
    picture under the diagram look (its physics has no length scale, and the frame removes the
    place): equal to float32 rounding. (The studio look's inclusions are baked in the stone's own
    mm, so its picture rightly changes: the next test checks its scene instead.)"""
    a = _render(oval, "diagram").image
    b = _render(_moved(oval, 3.0, (120.0, -80.0, 40.0)), "diagram").image
    assert np.abs(a - b).max() <= 2e-3 * float(a.max())
    assert np.abs(a - b).mean() <= 1e-4 * float(a.mean())


def _bsdf_of(scene):
    return next(s.bsdf() for s in scene.shapes() if s.id() == "stone")


def test_the_studio_and_the_zones_are_placed_in_the_render_frame(oval):
    """A studio render's lamps, table and camera are the same for the stone three times larger
    and moved (they are sized in stone radii), and the BSDF looks the body grid and the colour
    zones up over the stone's box in the render frame, where its renders place the stone."""
    from labcut.rendering.api import build_scene

    setting = resolve_scene(scenario="ring", quality="draft").main_setting()
    params = []
    for mesh in (oval, _moved(oval, 3.0, (120.0, -80.0, 40.0))):
        scene, _ = build_scene(mesh, labcut.Labradorite(), NORMAL, setting, "main", 32, look="studio")
        p = mi.traverse(scene)
        params.append({k: np.array(p[k].matrix if hasattr(p[k], "matrix") else p[k]) for k in p.keys() if k.endswith("to_world")})
        frame = RenderFrame.of(mesh)
        lo, hi = frame.box(*mesh.bounds)
        bsdf = _bsdf_of(scene)
        body_lo = np.array([float(np.array(c)[0]) for c in bsdf.body_lo])
        body_inv = np.array([float(np.array(c)[0]) for c in bsdf.body_inv_ext])
        assert np.all(body_lo <= np.array(lo) + 1e-6) and np.all(body_lo >= np.array(lo) - 0.01)
        assert np.allclose(body_lo + 1.0 / body_inv, hi, atol=0.01)
        zoned, _ = build_scene(mesh, labcut.Labradorite(), NORMAL, setting, "main", 32, zoning="natural")
        z = _bsdf_of(zoned).zoning
        z_lo = np.array([float(np.array(c)[0]) for c in z.lo])
        z_hi = z_lo + 1.0 / np.array([float(np.array(c)[0]) for c in z.inv_ext])
        assert np.all(z_lo <= np.array(lo) + 1e-6) and np.all(z_hi >= np.array(hi) - 1e-6)
        assert np.all(z_lo >= np.array(lo) - 0.1) and np.all(z_hi <= np.array(hi) + 0.1)
    assert params[0].keys() == params[1].keys() and len(params[0]) > 2
    for k in params[0]:
        assert np.allclose(params[0][k], params[1][k], atol=1e-5), k


@pytest.mark.parametrize("offset", [0, 16, 4])
def test_a_texture_reads_the_same_code_wherever_numpy_placed_its_values(offset):
    """The same values at a 64-byte-aligned address or not make a texture whose lookups launch
    the same kernel (a tensor made straight from numpy maps aligned memory and copies the rest,
    and the two are read by different code: the same scene compiled one or the other at random)."""
    import drjit as dr

    from labcut.rendering.textures import texture_data

    set_variant("mono")
    values = np.random.default_rng(0).random((6, 5, 4, 2)).astype(np.float32)

    def placed(at: int) -> np.ndarray:
        buf = np.empty(values.nbytes + 128, dtype=np.uint8)
        start = (-buf.ctypes.data) % 64 + at
        out = np.frombuffer(buf[start:start + values.nbytes].data, dtype=np.float32).reshape(values.shape)
        out[...] = values
        return out

    def lookup(tensor):
        tex = mi.Texture3f(tensor, use_accel=False, filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)
        p = dr.opaque(mi.Float, 0.3)
        return lambda: np.array(tex.eval(mi.Point3f(p, p + dr.arange(mi.Float, 8) / 8, p))[0])

    reference = lookup(texture_data(values))
    other = lookup(texture_data(placed(offset)))
    assert np.array_equal(reference(), other())
    assert {k["hash"] for k in launched(other)[1]} == {k["hash"] for k in launched(reference)[1]}
