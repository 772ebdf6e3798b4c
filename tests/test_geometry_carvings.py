"""Slab, cube, sphere, step cut and the biplane carving used for the bundled meshes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from labcut.errors import ParameterError
from labcut.geometry import carvings


def check(mesh, extents):
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    assert abs(mesh.bounds[0][2]) < 1e-9
    assert np.allclose(mesh.bounds[0][:2], -mesh.bounds[1][:2], atol=1e-9)  # centred on Z
    if extents is not None:
        assert np.allclose(mesh.extents, extents, atol=0.01)


def test_slab_cube_sphere():
    s = carvings.slab(20, 20, 3)
    check(s, (20, 20, 3))
    assert s.volume == pytest.approx(1200.0)
    c = carvings.cube(10)
    check(c, (10, 10, 10))
    assert c.metadata["labcut"]["convex"] is True
    sp = carvings.sphere(10)
    check(sp, (10, 10, 10))
    assert sp.volume == pytest.approx(4 / 3 * math.pi * 125, rel=0.005)
    assert sp.metadata["labcut"]["convex"] is True


def test_step_cut_is_a_convex_faceted_stone():
    m = carvings.step_cut(12, 10)
    check(m, None)
    assert m.extents[0] == pytest.approx(12) and m.extents[1] == pytest.approx(10)
    assert m.metadata["labcut"]["convex"] is True
    # facets: few distinct plane normals (steps, table, girdle), not a smooth surface
    normals = np.unique(np.round(m.face_normals, 6), axis=0)
    assert 30 <= len(normals) <= 80
    # the table is a flat top face
    top = m.vertices[np.abs(m.vertices[:, 2] - m.bounds[1][2]) < 1e-9]
    assert len(top) >= 8


def test_biplane_is_one_nonconvex_solid():
    m = carvings.biplane(30)
    check(m, None)
    meta = m.metadata["labcut"]
    assert meta["convex"] is False and meta["bodies"] == 1
    assert m.extents[1] == pytest.approx(30, abs=0.05)  # the wing span along Y
    small = carvings.biplane(15)
    assert small.volume == pytest.approx(m.volume / 8, rel=0.02)


@pytest.mark.parametrize(
    "call",
    [
        lambda: carvings.slab(-1, 2, 3),
        lambda: carvings.cube(float("nan")),
        lambda: carvings.sphere(10, segments=3),
        lambda: carvings.step_cut(8, 10),
        lambda: carvings.biplane(0),
    ],
)
def test_bad_parameters(call):
    with pytest.raises(ParameterError):
        call()
