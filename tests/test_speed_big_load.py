"""load_mesh's big-mesh pass (issue 17 §5) computes what the separate passes computed, bit for bit.

* the edge check by canonical sparse matrices (:func:`meshio._clean_edge_graph`) says what the
  two sorts of edge keys said, on clean meshes and on every kind of broken one, and its graph
  labels the same components as the graph of the faces;
* one pass over the corners (:func:`meshio._face_measures`) gives the double areas, the
  determinants and the cross products of the separate functions, exactly;
* the up axis read from those cross products is the one read from the faces;
* the column-wise extents and bounds are numpy's ``ptp``, ``min`` and ``max``;
* a big mesh loads to the same arrays and report through the big path as through the small.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

import labcut
from labcut.geometry import meshio, orient, solid

MESHES = Path(__file__).resolve().parents[1] / "meshes"
pytestmark = pytest.mark.filterwarnings("ignore::labcut.errors.LabcutWarning")  # the turned stones say so


def _sorted_keys_clean(f, nv):
    """The check as two sorts of edge keys had it (the reference)."""
    f = np.asarray(f, dtype=np.int64)
    src, dst = f.ravel(), f[:, [1, 2, 0]].ravel()
    up = src < dst
    fwd = np.sort(src[up] * nv + dst[up])
    bwd = np.sort(dst[~up] * nv + src[~up])
    return len(fwd) == len(bwd) and bool(np.array_equal(fwd, bwd)) and not bool(np.any(fwd[1:] == fwd[:-1]))


def _faces(name):
    m = labcut.load_mesh(MESHES / name)
    return np.asarray(m.vertices), np.asarray(m.faces, dtype=np.int64)


def _edits(f, rng):
    n = len(f)
    i = int(rng.integers(n))
    loop = f.copy()
    loop[i, 1] = loop[i, 0]  # a face with a repeated vertex: an edge from a vertex to itself
    twisted = f.copy()
    twisted[i] = twisted[i, [0, 2, 1]]
    swapped = f.copy()
    j = int(rng.integers(n))
    swapped[i, 0], swapped[j, 0] = f[j, 0], f[i, 0]
    return {
        "none": f,
        "permuted": f[rng.permutation(n)],
        "rolled": np.roll(f, 1, axis=1),
        "drop": f[:-1],
        "duplicate": np.vstack([f, f[i : i + 1]]),
        "flip": twisted,
        "loop": loop,
        "swapped": swapped,
        "double": np.vstack([f, f[:, ::-1]]),
        "pocket": np.vstack([f, [[0, 1, 2], [0, 2, 1]]]),
        "reversed": f[:, ::-1],
    }


@pytest.mark.parametrize("name", ["carving-biplane.ply", "oval-16x12-low.ply", "cube-10.ply", "step-cut-12x10.ply"])
def test_sparse_edge_check_says_what_the_sorted_keys_said(name):
    v, f = _faces(name)
    rng = np.random.default_rng(7)
    for edit, g in _edits(f, rng).items():
        nv = int(max(len(v), g.max() + 1))
        graph = meshio._clean_edge_graph(g, nv)
        assert (graph is not None) == _sorted_keys_clean(g, nv), edit
        assert meshio._closed_and_consistent(g, nv) == _sorted_keys_clean(g, nv), edit
        if graph is not None:  # each edge once, lower vertex first
            coo = graph.tocoo()
            got = np.sort(coo.row.astype(np.int64) * nv + coo.col)
            src, dst = g.ravel(), g[:, [1, 2, 0]].ravel()
            want = np.unique(np.minimum(src, dst) * nv + np.maximum(src, dst))
            np.testing.assert_array_equal(got, want)


def test_the_edge_graph_labels_the_same_components():
    v, f = _faces("carving-biplane.ply")
    _, c = _faces("cube-10.ply")
    rng = np.random.default_rng(3)
    # three bodies, their vertices numbered in a shuffled order, faces shuffled
    parts = [f, c + len(v), f + len(v) + 8]
    nv = len(v) * 2 + 8
    relabel = rng.permutation(nv)
    g = relabel[np.vstack(parts)][rng.permutation(sum(len(p) for p in parts))]
    graph = meshio._clean_edge_graph(g, nv)
    assert graph is not None
    want = meshio._face_components(g, nv)
    got = meshio._face_components(g, nv, graph)
    assert want[1] == got[1] == 3
    np.testing.assert_array_equal(got[0], want[0])


def _old_cross(v, f):
    a = v[f[:, 0]]
    return solid.cross_rows(v[f[:, 1]] - a, v[f[:, 2]] - a)


@pytest.mark.parametrize("chunk", [meshio.CHUNK, 1000])
def test_one_pass_over_the_corners_gives_the_separate_values(chunk, monkeypatch):
    rng = np.random.default_rng(11)
    v = rng.normal(size=(5000, 3)) * rng.choice([1e-3, 1.0, 1e3], size=(5000, 1)) + rng.normal(size=3) * 10
    f = rng.integers(0, len(v), size=(20_000, 3))
    monkeypatch.setattr(meshio, "CHUNK", chunk)
    area2, dets, cross = meshio._face_measures(v, f, keep=True)
    np.testing.assert_array_equal(area2, solid.double_areas(v, f))
    np.testing.assert_array_equal(dets, solid.face_dets(v, f))
    np.testing.assert_array_equal(cross, _old_cross(v, f))
    assert cross.flags.c_contiguous and cross.shape == (len(f), 3)
    area2_only, none1, none2 = meshio._face_measures(v, f)
    np.testing.assert_array_equal(area2_only, area2)
    assert none1 is None and none2 is None


def _old_detect(v, f, convex):
    """detect_up_axis's fractions from the faces (its own cross products), for comparison."""
    cross = _old_cross(np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64))
    norm = np.sqrt(np.einsum("ij,ij->i", cross, cross))
    return orient._side_fractions(v, f, cross / norm[:, None], 0.5 * norm)


@pytest.mark.parametrize("name", ["carving-biplane.ply", "oval-16x12-low.ply", "step-cut-12x10.ply",
                                  "double-cabochon-oval-16x12.ply", "slab-20x20x3.ply", "sphere-10.ply"])
@pytest.mark.parametrize("turn", ["+Z", "-Z", "+Y", "-X"])
def test_the_up_axis_from_the_kept_cross_products_is_the_faces(name, turn):
    v, f = _faces(name)
    v = v @ orient.up_rotation(turn)  # file coordinates whose face-up side is `turn`
    convex = bool(labcut.load_mesh(MESHES / name).metadata["labcut"]["convex"])
    want = orient.detect_up_axis(v, f, convex)
    _, _, cross = meshio._face_measures(v, f, keep=True)
    assert orient.detect_up_axis(v, f, convex, cross=cross) == want
    # cross now holds the unit normals detect_up_axis read: the fractions are the faces', exactly
    old = _old_cross(v, f)
    norm = np.sqrt(np.einsum("ij,ij->i", old, old))
    assert orient._side_fractions(v, f, cross, 0.5 * norm) == _old_detect(v, f, convex)


def test_column_bounds_are_numpys():
    rng = np.random.default_rng(5)
    for v in (rng.normal(size=(1000, 3)), np.array([[0.0, -0.0, 1.0]]), rng.integers(-5, 5, size=(50, 3)).astype(float)):
        lo, hi = solid.column_bounds(v)
        np.testing.assert_array_equal(lo, v.min(axis=0))
        np.testing.assert_array_equal(hi, v.max(axis=0))
        np.testing.assert_array_equal(solid.extent(v), np.ptp(v, axis=0))
        v2, shift = solid.centre_on_base(v)
        lo0, hi0 = v.min(axis=0), v.max(axis=0)
        np.testing.assert_array_equal(shift, [-(lo0[0] + hi0[0]) / 2, -(lo0[1] + hi0[1]) / 2, -lo0[2]])


def _export(tmp_path, name, v, f):
    path = tmp_path / name
    trimesh.Trimesh(v, f, process=False).export(path)
    return path


@pytest.mark.parametrize("case", ["two-bodies", "one-inverted", "upside-down", "y-up-stone"])
def test_the_big_path_loads_what_the_small_path_loads(case, tmp_path, monkeypatch):
    """The same arrays and report, bit for bit, whether the faces pass through the big-mesh pass
    (edge graph, kept cross products and determinants) or the small one."""
    v, f = _faces("carving-biplane.ply" if case in ("two-bodies", "one-inverted") else "oval-16x12-low.ply")
    if case == "two-bodies":
        v, f = np.vstack([v, v + [40.0, 0, 0]]), np.vstack([f, f + len(v)])
    elif case == "one-inverted":
        v, f = np.vstack([v, v + [40.0, 0, 0]]), np.vstack([f, (f + len(v))[:, ::-1]])
    elif case == "upside-down":
        v = v @ orient.up_rotation("-Z")
    else:
        v = v @ orient.up_rotation("+Y")
    path = _export(tmp_path, f"{case}.ply", v, f)

    def load():
        m = labcut.load_mesh(path)
        return np.asarray(m.vertices).copy(), np.asarray(m.faces).copy(), m.metadata["labcut"]

    monkeypatch.setattr(meshio, "MANIFOLD_CHECK_FACES", 0)  # every mesh is "big"
    big = load()
    calls = []
    real = meshio._face_measures
    monkeypatch.setattr(meshio, "_face_measures", lambda *a, **k: calls.append(k.get("keep")) or real(*a, **k))
    again = load()
    monkeypatch.setattr(meshio, "_clean_edge_graph", lambda f, nv: None)  # the big pass refused: the old route
    slow = load()
    for a, b in ((big, again), (big, slow)):
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])
    if case in ("two-bodies", "upside-down", "y-up-stone"):
        assert calls and calls[0] is True  # the clean mesh took the big pass
        for key in ("repairs", "notes", "warnings", "convex", "bodies", "up_axis", "up_axis_source", "dimensions_mm",
                    "translation_mm", "rotation"):
            assert big[2][key] == slow[2][key], key
    assert big[2]["bodies"] == (2 if case in ("two-bodies", "one-inverted") else 1)
    assert big[2]["up_axis"] == {"upside-down": "-Z", "y-up-stone": "+Y"}.get(case, "+Z")
