"""``solid.is_convex_mesh`` takes the smaller of two hull volumes (manifold3d's, Qhull's): where
manifold3d's hull already proves a stone convex, Qhull's is not computed (the answer cannot
change: a smaller hull only makes a stone more convex); where manifold3d's hull is too large
(QuickHull mishandling many coplanar points) Qhull's still decides."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import labcut
from labcut.geometry import solid

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
    assert solid.is_convex_mesh(oval)
    assert calls == []


def test_qhull_decides_where_manifolds_hull_is_too_large(oval, monkeypatch):
    import manifold3d as m3

    calls = _count_qhull(monkeypatch)

    real_hull = m3.Manifold.hull_points
    monkeypatch.setattr(m3.Manifold, "hull_points", lambda v: type("H", (), {"volume": lambda self: 1.01 * real_hull(v).volume()})())
    assert solid.is_convex_mesh(oval)  # Qhull's hull is the true one
    assert calls == [len(oval.vertices)]


def test_a_concave_stone_is_concave_by_both(monkeypatch):
    mesh = labcut.load_mesh(MESHES / "carving-biplane.ply")
    calls = _count_qhull(monkeypatch)
    assert not solid.is_convex_mesh(mesh)
    assert calls == [len(mesh.vertices)]
    np.testing.assert_equal(mesh.metadata["labcut"]["convex"], False)


def _hulls(monkeypatch):
    """Count the whole hulls' verdicts (``solid._convex_by_hulls``: what the kept flag saves a new process)."""
    calls = []
    real = solid._convex_by_hulls
    monkeypatch.setattr(solid, "_convex_by_hulls", lambda *a, **k: calls.append(1) or real(*a, **k))
    return calls


def _new_process(monkeypatch):
    from labcut import fileio

    monkeypatch.setattr(fileio, "_CALIBRATIONS", {})
    monkeypatch.setattr(fileio, "_STORES", {})


def test_a_loaded_stones_convexity_is_read_back_in_a_new_process(monkeypatch, fresh_user_cache):
    """The bundled oval (11,010 vertices) computes its hulls once; a new process reads the flag
    back (``convexity.json``); the carving's False is kept as well; a stone under
    :data:`solid.KEPT_CONVEXITY_VERTICES` vertices is computed and nothing written."""
    calls = _hulls(monkeypatch)
    assert labcut.load_mesh(MESHES / "oval-16x12-low.ply").metadata["labcut"]["convex"] is True
    assert len(calls) == 1 and (fresh_user_cache / "convexity.json").exists()
    _new_process(monkeypatch)
    assert labcut.load_mesh(MESHES / "oval-16x12-low.ply").metadata["labcut"]["convex"] is True
    assert len(calls) == 1
    assert labcut.load_mesh(MESHES / "carving-biplane.ply").metadata["labcut"]["convex"] is False
    _new_process(monkeypatch)
    assert labcut.load_mesh(MESHES / "carving-biplane.ply").metadata["labcut"]["convex"] is False
    assert len(calls) == 2
    kept = (fresh_user_cache / "convexity.json").read_text()
    cube = labcut.load_mesh(MESHES / "cube-10.ply")
    assert len(cube.vertices) < solid.KEPT_CONVEXITY_VERTICES and len(calls) == 3
    assert (fresh_user_cache / "convexity.json").read_text() == kept


def test_the_kept_convexitys_key_holds_the_mesh_the_version_and_the_code(monkeypatch, fresh_user_cache):
    from labcut import fileio

    calls = _hulls(monkeypatch)
    oval = labcut.load_mesh(MESHES / "oval-16x12-low.ply")
    solid.is_convex_mesh(oval, keep=True)
    assert len(calls) == 1
    moved = oval.copy()
    moved.vertices[0] += [0.0, 0.0, 1e-9]  # one vertex a nanometre away: another stone
    solid.is_convex_mesh(moved, keep=True)
    assert len(calls) == 2
    _new_process(monkeypatch)
    monkeypatch.setattr(labcut, "__version__", "0.0.0-other")
    solid.is_convex_mesh(oval, keep=True)
    assert len(calls) == 3
    _new_process(monkeypatch)
    monkeypatch.setattr(fileio, "code_hash", lambda *paths: "edited")
    solid.is_convex_mesh(oval, keep=True)
    assert len(calls) == 4


@pytest.mark.parametrize("bad", ["yes", 1, None, 0.0])
def test_a_damaged_convexity_is_computed_again_with_a_warning(monkeypatch, fresh_user_cache, bad):
    import json

    calls = _hulls(monkeypatch)
    oval = labcut.load_mesh(MESHES / "oval-16x12-low.ply")
    path = fresh_user_cache / "convexity.json"
    (key,) = json.loads(path.read_text())
    path.write_text(json.dumps({key: {"convex": bad}}))
    _new_process(monkeypatch)
    with pytest.warns(labcut.LabcutWarning, match="convexity.json is damaged"):
        assert solid.is_convex_mesh(oval, keep=True) is True
    assert len(calls) == 2 and json.loads(path.read_text())[key] == {"convex": True}


def test_a_scan_the_subsets_hull_proves_concave_is_not_hashed_nor_kept(monkeypatch, fresh_user_cache):
    """Over :data:`solid.CONVEX_PROBE_VERTICES` vertices the hull of a subset answers a concave stone
    at once (a tenth of a second for millions of triangles): no key is hashed for it (a third of a
    second at 5 M triangles) and nothing is kept; a convex one goes on to its whole hulls, kept."""
    biplane = labcut.load_mesh(MESHES / "carving-biplane.ply")
    oval = labcut.load_mesh(MESHES / "oval-16x12-low.ply")
    assert solid.KEPT_CONVEXITY_VERTICES <= len(biplane.vertices) < len(oval.vertices)
    (fresh_user_cache / "convexity.json").unlink()  # what the loads kept
    _new_process(monkeypatch)
    monkeypatch.setattr(solid, "CONVEX_PROBE_VERTICES", 1000)  # both stones count as scans
    calls = _hulls(monkeypatch)
    digests = []
    real = solid.mesh_digest
    monkeypatch.setattr(solid, "mesh_digest", lambda mesh: digests.append(1) or real(mesh))
    assert solid.is_convex_mesh(biplane, keep=True) is False
    assert calls == [] and digests == [] and not (fresh_user_cache / "convexity.json").exists()
    assert solid.is_convex_mesh(oval, keep=True) is True
    assert calls == [1] and digests == [1] and (fresh_user_cache / "convexity.json").exists()
