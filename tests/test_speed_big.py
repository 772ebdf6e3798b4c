"""The big-mesh fast paths of issue 17 §5 give what the slow ones gave.

* smooth shading at the sampled faces (``geometry.surface.smooth_corner_normals``) equals the
  normals of trimesh's split copy (``smooth_split``) at every corner of the bundled stones, and
  on the carving everywhere but the rims of its large flat facets;
* the planner's surface sample and the face areas are trimesh's, bit for bit;
* a mesh sampled on the fast path answers within its error bar of the split path;
* ``load_mesh``: PLY read straight from trimesh's reader, the two-sort edge check, the subset
  hull that proves concavity and a big clean mesh certified without manifold3d's rebuild give
  the same mesh (as a set of triangles), the same flags and the same reports.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import trimesh

import labcut
from labcut.geometry import meshio, solid
from labcut.orientation import problem as problem_mod
from labcut.geometry import stone as stone_mod
from labcut.geometry.stone import Stone
from labcut.geometry.surface import face_areas, sample_surface, smooth_corner_normals, smooth_split

MESHES = Path(__file__).resolve().parents[1] / "meshes"
STONES = ["oval-16x12-low.ply", "round-12-high.ply", "double-cabochon-oval-16x12.ply", "buff-top-oval-16x12.ply",
          "step-cut-12x10.ply", "sphere-10.ply", "cube-10.ply"]


def _split_reference(mesh):
    """Per original face, the corner normals of trimesh's split copy."""
    split = smooth_split(mesh, Stone.of(mesh).shading_angle_deg)
    orig = np.concatenate(split.metadata["original_components"]).astype(np.int64)  # split face -> mesh face
    assert np.array_equal(split.vertices[split.faces], np.asarray(mesh.vertices)[np.asarray(mesh.faces)[orig]])
    return orig, split.vertex_normals[split.faces]


def _large_facet_rims(mesh):
    """Faces in or next to the flat facets larger than a tenth of the surface (trimesh's
    smooth_shade keeps those apart)."""
    facets = [f for f in mesh.facets if mesh.area_faces[f].sum() > mesh.area / 10]
    if not facets:
        return np.zeros(0, dtype=np.int64)
    big = np.concatenate(facets)
    return np.unique(np.asarray(mesh.face_adjacency)[np.isin(mesh.face_adjacency, big).any(axis=1)])


def _parted_vertices(mesh, angle_deg):
    """Vertices where two or more sharp edges meet: sharp edges may part the faces around them into
    sectors, which trimesh's split joins again when they are one patch further away."""
    sharp = np.asarray(mesh.face_adjacency_edges)[mesh.face_adjacency_angles >= math.radians(angle_deg)]
    return np.flatnonzero(np.bincount(sharp.ravel(), minlength=len(mesh.vertices)) >= 2)


@pytest.mark.parametrize("name", STONES + ["carving-biplane.ply"])
def test_corner_normals_equal_the_split_copy_where_the_definitions_agree(name):
    mesh = labcut.load_mesh(MESHES / name)
    angle = Stone.of(mesh).shading_angle_deg
    orig, want = _split_reference(mesh)
    got = smooth_corner_normals(mesh, angle, orig)
    off = np.abs(got - want).max(axis=2) > 1e-12  # (faces, corners)
    corner_vertex = np.asarray(mesh.faces)[orig]
    explained = np.isin(corner_vertex, _parted_vertices(mesh, angle)) | np.isin(orig, _large_facet_rims(mesh))[:, None]
    assert not np.any(off & ~explained)  # elsewhere the same normals, to rounding
    if name.startswith(("oval", "round", "double", "buff", "sphere", "carving")):
        assert mesh.area_faces[orig[off.any(axis=1)]].sum() < 0.002 * mesh.area  # a cabochon, a carving: (almost) nowhere


@pytest.mark.parametrize("name", ["carving-biplane.ply", "step-cut-12x10.ply"])
def test_the_corners_found_through_the_incidence_index_are_the_same_to_the_bit(name):
    """A big stone's split corner normals found through its vertex -> corner index (the volume
    estimator's ray hits, many times over) are those of the pass over every face, for any face set
    (repeated faces, one face, all of them)."""
    from labcut.geometry.surface import corner_incidence

    mesh = labcut.load_mesh(MESHES / name)
    angle = Stone.of(mesh).shading_angle_deg
    index = corner_incidence(np.asarray(mesh.faces), len(mesh.vertices))
    rng = np.random.default_rng(3)
    for idx in (rng.integers(0, len(mesh.faces), 700), np.array([5]), np.arange(len(mesh.faces)), np.array([9, 9, 2, 9])):
        assert np.array_equal(smooth_corner_normals(mesh, angle, idx, index), smooth_corner_normals(mesh, angle, idx))


def test_a_big_stones_ray_hits_keep_each_faces_corners_once(monkeypatch):
    """The volume estimator's casts on a stone too big to copy compute each met face's corner normals
    once and keep them: the normals at the hits are those computed for the hit faces alone."""
    import mitsuba as mi

    from labcut.orientation import volume

    monkeypatch.setattr(volume, "FAST_SMOOTH_FACES", 1000)
    mesh = labcut.load_mesh(MESHES / "carving-biplane.ply")
    rays = volume.VolumeRays(mesh)
    assert rays.big
    calls = []
    real = volume.smooth_corner_normals
    monkeypatch.setattr(volume, "smooth_corner_normals", lambda m, a, f, i=None: calls.append(len(f)) or real(m, a, f, i))
    rng = np.random.default_rng(1)
    lo, hi = mesh.bounds
    for _ in range(3):
        origins = lo + (hi - lo) * (0.3 + 0.4 * rng.random((400, 3)))
        dirs = rng.normal(size=(400, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        hits = rays.cast(origins, dirs)
        hit = np.isfinite(hits.t)
        pi = rays.scene.ray_intersect_preliminary(mi.Ray3f(mi.Point3f(*origins.T), mi.Vector3f(*dirs.T)))
        face = np.asarray(pi.prim_index, dtype=np.int64)[hit]
        uv = np.asarray(pi.prim_uv, dtype=np.float64)[:, hit]
        bary = np.stack([1.0 - uv[0] - uv[1], uv[0], uv[1]], axis=1)
        want = np.einsum("ij,ijk->ik", bary, real(mesh, Stone.of(mesh).shading_angle_deg, face))
        want /= np.linalg.norm(want, axis=1, keepdims=True)
        assert np.array_equal(hits.n_sh[hit], want)
    assert sum(calls) == rays._n_kept == len(np.unique(rays._slot[rays._slot >= 0]))  # no face computed twice


@pytest.mark.parametrize("name", ["carving-biplane.ply", "oval-16x12-low.ply"])
def test_surface_sample_and_areas_are_trimeshs(name):
    mesh = labcut.load_mesh(MESHES / name)
    np.testing.assert_array_equal(face_areas(mesh.copy()), mesh.area_faces)
    want_p, want_f = trimesh.sample.sample_surface(mesh, 777, seed=42)
    got_p, got_f = sample_surface(mesh.copy(), 777, 42)
    np.testing.assert_array_equal(got_f, want_f)
    np.testing.assert_array_equal(got_p, want_p)


def test_the_fast_sampling_path_answers_within_the_error_bar(monkeypatch):
    mesh = labcut.load_mesh(MESHES / "carving-biplane.ply")
    slow = labcut.recommend_orientation(mesh, "blue", scenario="bench", quality="draft")
    monkeypatch.setattr(stone_mod, "FAST_SMOOTH_FACES", 0)
    fast_mesh = mesh.copy()  # a fresh cache: the samples are drawn again, on the fast path
    samples = problem_mod.surface_samples(fast_mesh, 3000, 0)
    assert samples.count == 3000
    fast = labcut.recommend_orientation(fast_mesh, "blue", scenario="bench", quality="draft")
    angle = math.degrees(math.acos(min(1.0, abs(float(np.dot(slow.normal, fast.normal))))))
    assert angle <= slow.uncertainty.angle_deg + fast.uncertainty.angle_deg
    assert fast.score == pytest.approx(slow.score, rel=slow.uncertainty.score_rel + fast.uncertainty.score_rel)


@pytest.mark.parametrize("name", STONES + ["carving-biplane.ply"])
def test_ply_fast_read_is_trimeshs(name):
    loaded = trimesh.load(MESHES / name, file_type="ply", process=False, force="mesh")
    v, f = meshio._read_ply_arrays(MESHES / name)
    np.testing.assert_array_equal(v, np.asarray(loaded.vertices, dtype=np.float64))
    np.testing.assert_array_equal(f, np.asarray(loaded.faces, dtype=np.int64))


def _full_edge_table(faces):
    """The single-sort edge table (the path a mesh that is not clean takes)."""
    f = np.asarray(faces, dtype=np.int64)
    nv = int(f.max() + 1)
    src, dst = f.ravel(), f[:, [1, 2, 0]].ravel()
    key = np.sort(((np.minimum(src, dst) * nv + np.maximum(src, dst)) << 1) | (src < dst))
    edge = key >> 1
    starts = np.flatnonzero(np.r_[True, edge[1:] != edge[:-1]])
    counts = np.diff(np.r_[starts, len(edge)])
    pairs = starts[counts == 2]
    return int((counts == 1).sum()), int((counts > 2).sum()), bool(np.all((key[pairs] & 1) != (key[pairs + 1] & 1)))


@pytest.mark.parametrize("edit", ["none", "drop", "duplicate", "flip", "double"])
def test_edge_table_fast_check_agrees(edit):
    f = np.asarray(labcut.load_mesh(MESHES / "carving-biplane.ply").faces)
    g = {"none": f, "drop": f[:-3], "duplicate": np.vstack([f, f[:1]]), "flip": np.vstack([f[1:], f[:1, ::-1]]),
         "double": np.vstack([f, f[:, ::-1]])}[edit]
    assert meshio._edge_table(g) == _full_edge_table(g)


@pytest.mark.parametrize("name", ["carving-biplane.ply", "oval-16x12-low.ply", "sphere-10.ply", "step-cut-12x10.ply"])
def test_subset_hull_gives_the_same_convexity(name, monkeypatch):
    mesh = labcut.load_mesh(MESHES / name)
    want = solid.is_convex_mesh(mesh)
    monkeypatch.setattr(solid, "CONVEX_PROBE_VERTICES", 8)
    assert solid.is_convex_mesh(mesh) == want


def _triangle_set(mesh):
    """The triangles as sorted tuples of corner coordinates, each rolled to start at its least corner."""
    t = np.round(np.asarray(mesh.vertices)[np.asarray(mesh.faces)], 9)
    rows = [tuple(map(tuple, np.roll(r, -int(np.lexsort(r.T[::-1])[0]), axis=0))) for r in t]
    return sorted(rows)


@pytest.mark.parametrize("name", ["carving-biplane.ply", "oval-16x12-low.ply"])
def test_a_clean_big_mesh_loads_to_the_same_solid_without_manifold3d(name, monkeypatch):
    want = labcut.load_mesh(MESHES / name)
    monkeypatch.setattr(meshio, "MANIFOLD_CHECK_FACES", 0)
    got = labcut.load_mesh(MESHES / name)
    assert len(got.faces) == len(want.faces) and len(got.vertices) == len(want.vertices)
    assert got.volume == pytest.approx(want.volume, rel=1e-12)
    assert _triangle_set(got) == _triangle_set(want)  # the same triangles, each wound the same way
    a, b = got.metadata["labcut"], want.metadata["labcut"]
    for key in ("repairs", "notes", "warnings", "convex", "bodies", "up_axis", "dimensions_mm"):
        assert a[key] == b[key]


def test_a_mesh_that_needs_repair_still_goes_through_manifold3d(monkeypatch, tmp_path):
    mesh = labcut.load_mesh(MESHES / "oval-16x12-low.ply")
    f = np.asarray(mesh.faces)
    holed = trimesh.Trimesh(mesh.vertices, f[1:], process=False)
    path = tmp_path / "holed.ply"
    holed.export(path)
    monkeypatch.setattr(meshio, "MANIFOLD_CHECK_FACES", 0)
    called = []
    import manifold3d

    orig = manifold3d.Manifold

    class Spy(orig):  # type: ignore[misc, valid-type]
        def __init__(self, *args, **kwargs):
            called.append(1)
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(manifold3d, "Manifold", Spy)
    got = labcut.load_mesh(path)
    assert called and any("hole" in r for r in got.metadata["labcut"]["repairs"])


def test_a_flat_pocket_is_judged_as_before(monkeypatch, tmp_path):
    """A face and its reverse standing alone pass the two-sort edge check; the big-mesh path must
    still send them where they went before (manifold3d's verdict, the duplicate-face repair)."""
    cube = labcut.load_mesh(MESHES / "cube-10.ply")
    v = np.vstack([cube.vertices, [[30.0, 0.0, 0.0], [31.0, 0.0, 0.0], [30.0, 1.0, 0.0]]])
    n = len(cube.vertices)
    f = np.vstack([cube.faces, [[n, n + 1, n + 2], [n, n + 2, n + 1]]])
    path = tmp_path / "pocket.ply"
    trimesh.Trimesh(v, f, process=False).export(path)

    def outcome():
        try:
            m = labcut.load_mesh(path)
        except Exception as exc:  # noqa: BLE001 - the verdict is what is compared
            return type(exc).__name__, str(exc)
        return len(m.faces), m.metadata["labcut"]["repairs"], round(float(m.volume), 9)

    want = outcome()
    monkeypatch.setattr(meshio, "MANIFOLD_CHECK_FACES", 0)
    assert outcome() == want
