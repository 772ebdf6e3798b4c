"""The occlusion rays' scene (issue 17 §5) answers what the mesh's own scene answered.

On the CPU the triangles sit in a shape group seen through one identity instance (Embree's
default build quality for the group instead of the top-level scene's spatial splits: about half
the build time); a ray's hit test is the triangles' own, so every ray that starts off the surface
(labcut lifts every origin along the normal) gets the answer the plain scene gave. The origin
offset is ``1e-4 * norm(mesh.extents)``, computed from the coordinate columns.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

import labcut
from labcut.rendering import rays
from labcut.geometry.surface import sample_surface, unit_normals

MESHES = Path(__file__).resolve().parents[1] / "meshes"


@pytest.fixture(scope="module")
def mi():
    import mitsuba

    from labcut.backend import set_variant

    set_variant(rays.RAY_MODE)
    return mitsuba


def _rays(mesh, n, seed):
    """Lifted origins on the surface; random directions, a quarter of them along the axes
    (exact zeros, both signs), as the scenario's lights and views often are."""
    rng = np.random.default_rng(seed)
    pts, face = sample_surface(mesh, n, seed)
    nrm = unit_normals(np.asarray(mesh.vertices)[np.asarray(mesh.faces)[face]])
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    k = n // 4
    axis = np.zeros((k, 3))
    axis[np.arange(k), rng.integers(0, 3, k)] = rng.choice([-1.0, 1.0], k)
    d[:k] = np.where(axis == 0, rng.choice([0.0, -0.0], (k, 3)), axis)
    return pts + rays.surface_offset(mesh) * nrm, d


def _test(mi, scene, o, d):
    ray = mi.Ray3f(mi.Point3f(o[:, 0], o[:, 1], o[:, 2]), mi.Vector3f(d[:, 0], d[:, 1], d[:, 2]))
    return np.array(scene.ray_test(ray), dtype=bool)


@pytest.mark.parametrize("name", ["carving-biplane.ply", "step-cut-12x10.ply", "oval-16x12-low.ply", "cube-10.ply"])
def test_the_instanced_scene_answers_what_the_plain_scene_answered(mi, name):
    mesh = labcut.load_mesh(MESHES / name)
    plain = rays._build_occlusion_scene(mesh, instanced=False)
    scene = rays.occlusion_scene(mesh)
    if mi.variant().startswith(("llvm_", "scalar_")):  # Embree
        # the fast build is the one taken: one shape, the instance (not a mesh) of the group
        assert len(scene.shapes()) == 1 and not scene.shapes()[0].is_mesh() and "Instance[" in str(scene)
        assert plain.shapes()[0].is_mesh()
    o, d = _rays(mesh, 200_000, 3)
    want = _test(mi, plain, o, d)
    assert 0.0 < want.mean() < 1.0 or name in ("cube-10.ply", "oval-16x12-low.ply")
    np.testing.assert_array_equal(_test(mi, scene, o, d), want)
    # and through the public queries: escapes lifts the origins itself
    pts, face = sample_surface(mesh, 500, 5)
    nrm = unit_normals(np.asarray(mesh.vertices)[np.asarray(mesh.faces)[face]])
    dirs = np.array([[0.0, 0.0, 1.0], [0.0, -0.0, -1.0], [1.0, 0.0, 0.0], [0.6, 0.0, 0.8], [-0.36, 0.48, 0.8]])
    lifted = np.repeat(pts + rays.surface_offset(mesh) * nrm, len(dirs), axis=0)
    want = ~_test(mi, plain, lifted, np.tile(dirs, (len(pts), 1))).reshape(len(pts), len(dirs))
    np.testing.assert_array_equal(rays.escapes(mesh, pts, nrm, dirs), want)


def test_the_scene_is_built_once_per_mesh(mi):
    mesh = labcut.load_mesh(MESHES / "carving-biplane.ply")
    assert rays.occlusion_scene(mesh) is rays.occlusion_scene(mesh)
    other = mesh.copy()
    assert rays.occlusion_scene(other) is not rays.occlusion_scene(mesh)


@pytest.mark.parametrize("name", ["carving-biplane.ply", "oval-16x12-low.ply"])
def test_surface_offset_is_the_extents(name):
    mesh = labcut.load_mesh(MESHES / name)
    assert rays.surface_offset(mesh) == 1e-4 * float(np.linalg.norm(mesh.extents))
    # a vertex no face uses is not part of the bounds (trimesh's extents leave it out too)
    v = np.vstack([mesh.vertices, [[500.0, -300.0, 90.0]]])
    loose = trimesh.Trimesh(v, mesh.faces, process=False)
    assert rays.surface_offset(loose) == 1e-4 * float(np.linalg.norm(loose.extents))
    assert rays.surface_offset(loose) == rays.surface_offset(mesh)


def test_rays_run_in_the_estimators_variant(mi):
    """The rays run in mono, the variant of the planner's pilot renders and the render estimator:
    a carving's recommendation switches variant (a reload of Mitsuba's Python modules) at most
    once, and builds its ray scene once."""
    from labcut.backend import set_variant, variant_name

    mesh = labcut.load_mesh(MESHES / "carving-biplane.ply")
    set_variant("mono")
    switches = []
    real = mi.set_variant
    mi.set_variant = lambda *a, **k: (switches.append(a), real(*a, **k))[1]
    try:
        o, d = _rays(mesh, 64, 3)
        rays.escapes_paired(mesh, o, d)
        rays.self_view_fraction(mesh, points=32, directions=8)
    finally:
        mi.set_variant = real
    assert switches == [] and mi.variant() == variant_name("mono")


def test_rays_stay_in_an_active_jit_variant_and_answer_the_same(mi):
    """After an rgb render (the explorer's pictures, a recommendation's --render) the rays run in
    rgb: no switch of variant (0.06-0.1 s each, and Mitsuba re-decorates its integrators at every
    switch), the same answers as in mono. From a variant of no JIT backend they switch to mono."""
    from labcut.backend import set_variant, variant_name

    mesh = labcut.load_mesh(MESHES / "carving-biplane.ply")
    o, d = _rays(mesh, 4096, 5)
    set_variant("mono")
    in_mono = rays.escapes_paired(mesh, o, d)
    set_variant("rgb")
    switches = []
    real = mi.set_variant
    mi.set_variant = lambda *a, **k: (switches.append(a), real(*a, **k))[1]
    try:
        in_rgb = rays.escapes_paired(mesh, o, d)
        assert switches == [] and mi.variant() == variant_name("rgb")
        real("scalar_rgb")
        assert rays.ray_variant() == variant_name("mono") and mi.variant() == variant_name("mono")
    finally:
        mi.set_variant = real
    assert np.array_equal(in_rgb, in_mono) and 0 < in_mono.mean() < 1
