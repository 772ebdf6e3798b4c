"""``solid.is_convex_mesh`` takes the smaller of two hull volumes (manifold3d's, Qhull's): where
manifold3d's hull already proves a stone convex, Qhull's is not computed (the answer cannot
change: a smaller hull only makes a stone more convex); where manifold3d's hull is too large
(QuickHull mishandling many coplanar points) Qhull's still decides."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.geometry import meshio

MESHES = Path(__file__).resolve().parents[1] / "meshes"


@pytest.fixture(scope="module")
def oval():
    return labcut.load_mesh(MESHES / "oval-16x12-low.ply")


def _count_qhull(monkeypatch):
    import scipy.spatial

    calls = []
    real = scipy.spatial.ConvexHull
    monkeypatch.setattr(scipy.spatial, "ConvexHull", lambda v, *a, **k: calls.append(len(v)) or real(v, *a, **k))
    return calls


def test_a_convex_stone_needs_one_hull(oval, monkeypatch):
    calls = _count_qhull(monkeypatch)
    assert meshio.is_convex_mesh(oval)
    assert calls == []


def test_qhull_decides_where_manifolds_hull_is_too_large(oval, monkeypatch):
    import manifold3d as m3

    calls = _count_qhull(monkeypatch)

    real_hull = m3.Manifold.hull_points
    monkeypatch.setattr(m3.Manifold, "hull_points", lambda v: type("H", (), {"volume": lambda self: 1.01 * real_hull(v).volume()})())
    assert meshio.is_convex_mesh(oval)  # Qhull's hull is the true one
    assert calls == [len(oval.vertices)]


def test_a_concave_stone_is_concave_by_both(monkeypatch):
    mesh = labcut.load_mesh(MESHES / "carving-biplane.ply")
    calls = _count_qhull(monkeypatch)
    assert not meshio.is_convex_mesh(mesh)
    assert calls == [len(mesh.vertices)]
    np.testing.assert_equal(mesh.metadata["labcut"]["convex"], False)
