"""labcut.geometry.meshio pinned by mutation testing (issue 37; docs/testing.md, "labcut/geometry/meshio.py").

Tiny meshes built by hand (a 10 x 8 x 6 tetrahedron of volume 80, a 10 x 8 x 6 box of volume 480,
a square pyramid, a flat folded square) written to tmp_path in every format the loader reads. Pinned:
every spelling of ``units`` and how the unit is decided (given, declared by the file, glTF's metres,
3MF's unit attribute, the mm default) with its note; the size limits exactly at 0.5 and 500 mm and
the unit a refusal names; the small-stone warning at 2.5 mm and the typical range's edges; the up
axis from the shape, the convention or the caller, with each warning word for word; every repair's
sentence (non-finite vertices, coincident vertices, degenerate, duplicate, inverted and
inconsistently wound faces, holes closed by fans up to exactly 20 % of the surface) and its refusal
under ``repair=False``; every refusal (missing, folder, empty, unsupported suffix, truncated or short
STL, not-JSON glTF, non-UTF-8 text, point clouds, lines, a 3MF unit that is none, non-manifold
edges, flat, open beyond repair) to its typed exception and message; multiple bodies; the helper
functions on hand-computed cases (edge table, boundary loops, components, face measures, the row
hash); ``validate_mesh``'s messages and its cache; ``save_mesh``'s formats and glTF's frame.
No render, no CLI: a few seconds.
"""

from __future__ import annotations

import math
import sys
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
import trimesh

from labcut.errors import LabcutWarning, MeshError, ParameterError
from labcut.geometry import meshio
from labcut.geometry.meshio import load_mesh, save_mesh, units_scale, validate_arrays, validate_mesh
from labcut.geometry.orient import up_rotation

ROOT = Path(__file__).resolve().parents[1]
DESIGNS = ROOT / "meshes" / "designs"
UNDER_MUTMUT = "mutmut" in sys.modules


# ------------------------------------------------------------------ meshes by hand
def tet(a: float = 10.0, b: float = 8.0, c: float = 6.0):
    """The corner tetrahedron (0,0,0), (a,0,0), (0,b,0), (0,0,c), outward-wound: volume abc/6."""
    v = np.array([[0, 0, 0], [a, 0, 0], [0, b, 0], [0, 0, c]], dtype=np.float64)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)
    return v, f


def box(ext=(10.0, 8.0, 6.0)):
    """trimesh's box (8 corners, 12 outward triangles), centred on the origin: volume 480."""
    b = trimesh.creation.box(extents=ext)
    return np.asarray(b.vertices, dtype=np.float64).copy(), np.asarray(b.faces, dtype=np.int64).copy()


def pyramid(z0: float = 0.0, base: float = 20.0, height: float = 6.0, down: bool = False):
    """A square pyramid on its base (a flat base: the shape says +Z), or ``down``: upside down."""
    h = base / 2
    s = -1.0 if down else 1.0
    v = np.array([(-h, -h, z0), (h, -h, z0), (h, h, z0), (-h, h, z0), (0.0, 0.0, z0 + s * height)])
    faces = [(0, 2, 1), (0, 3, 2), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)]
    f = np.array(faces if not down else [t[::-1] for t in faces], dtype=np.int64)
    return v, f


def write_off(path: Path, v, f) -> Path:
    """An OFF file by hand (text: every coordinate with repr, so the file holds the same doubles)."""
    lines = ["OFF", f"{len(v)} {len(f)} 0"]
    lines += [" ".join(repr(float(x)) for x in row) for row in v]
    lines += ["3 " + " ".join(str(int(i)) for i in row) for row in f]
    path.write_text("\n".join(lines) + "\n")
    return path


def write(path: Path, v, f) -> Path:
    """The arrays in the format of ``path``'s suffix, as trimesh writes it (no processing)."""
    if path.suffix.lower() == ".off":
        return write_off(path, v, f)
    trimesh.Trimesh(vertices=v, faces=f, process=False).export(path)
    return path


def quiet(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LabcutWarning)
        return load_mesh(*args, **kwargs)


def refusal(kind, call, *args, **kwargs) -> str:
    with pytest.raises(kind) as info:
        call(*args, **kwargs)
    assert type(info.value) is kind
    return str(info.value)


def validated(v, f, repair: bool = True, name: str = "s", fast: bool = True):
    return meshio._validate_arrays(np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64), name, repair, fast)


def report(mesh) -> dict:
    return mesh.metadata["labcut"]


# ------------------------------------------------------------------ small helpers
def test_one_line_collapses_whitespace_and_cuts_at_200():
    assert meshio._one_line("a \n b\t\tc  ") == "a b c"
    assert meshio._one_line(ValueError("x\ny")) == "x y"
    exact = "x" * 200
    assert meshio._one_line(exact) == exact
    long = "y" * 150 + " " + "z" * 50  # 201 characters
    assert meshio._one_line(long) == ("y" * 150 + " " + "z" * 46) + "..." and len(meshio._one_line(long)) == 200
    assert meshio._one_line("abcdef", limit=5) == "ab..."
    assert meshio._one_line("abcde", limit=5) == "abcde"


@pytest.mark.parametrize("x, text", [(16.0, "16"), (16.5, "16.5"), (0.016, "0.016"), (99.44, "99.4"),
                                     (100.0, "100"), (123.4, "123"), (16000.0, "16000"), (999999.4, "999999"),
                                     (1e6, "1e+06"), (1.6e7, "1.6e+07"), (1.6e-5, "1.6e-05"), (0.4, "0.4")])
def test_mm_in_a_message(x, text):
    assert meshio._mm(x) == text


def test_atypicality_is_the_log_distance_from_16_mm():
    assert meshio._atypicality(16.0) == 0.0
    assert meshio._atypicality(32.0) == pytest.approx(math.log(2)) == pytest.approx(meshio._atypicality(8.0))
    assert meshio._atypicality(4.0) == pytest.approx(math.log(4)) == pytest.approx(meshio._atypicality(64.0))
    assert meshio._atypicality(1.0) == pytest.approx(math.log(16))


def test_constants():
    assert meshio.UNITS == {"mm": 1.0, "cm": 10.0, "m": 1000.0, "um": 1e-3, "in": 25.4, "ft": 304.8}
    assert meshio.READ_FORMATS == {".stl": "stl", ".obj": "obj", ".ply": "ply", ".off": "off", ".glb": "glb",
                                   ".gltf": "gltf", ".3mf": "3mf"}
    assert meshio.WRITE_FORMATS == (".ply", ".stl", ".obj", ".off", ".glb", ".3mf")
    assert meshio.TYPICAL_STONE_MM == (4.0, 64.0) and meshio.SMALL_STONE_MM == 2.5
    assert meshio.MAX_PATCH_FRACTION == 0.2 and meshio.MANIFOLD_CHECK_FACES == 1_000_000
    assert meshio.DECLARED_UNITS == {"glb": "m", "gltf": "m"}
    assert meshio.THREEMF_UNITS == {"micron": "um", "millimeter": "mm", "centimeter": "cm", "inch": "in", "foot": "ft",
                                    "meter": "m"}


# ------------------------------------------------------------------ units_scale
@pytest.mark.parametrize("given, key", [
    ("mm", "mm"), ("cm", "cm"), ("m", "m"), ("um", "um"), ("in", "in"), ("ft", "ft"),
    ("MM", "mm"), (" cm\t", "cm"), ("µm", "um"), ("micron", "um"), ("microns", "um"), ("Microns", "um"),
    ("inch", "in"), ("inches", "in"), ("INCH", "in"), ("millimeter", "mm"), ("millimeters", "mm"),
    ("centimeter", "cm"), ("centimeters", "cm"), ("meter", "m"), ("meters", "m"), ("metre", "m"), ("metres", "m"),
    ("Metres", "m"), ("foot", "ft"), ("feet", "ft"), (" Feet ", "ft"),
])
def test_every_unit_name(given, key):
    assert units_scale(given) == (key, meshio.UNITS[key])


@pytest.mark.parametrize("given, name, factor", [(2.5, "x2.5", 2.5), (3, "x3", 3.0), (25.4, "x25.4", 25.4),
                                                 (1e-5, "x1e-05", 1e-5), (1e300, "x1e+300", 1e300),
                                                 (np.float64(2.0), "x2", 2.0), (np.int64(7), "x7", 7.0)])
def test_a_number_of_mm_per_unit(given, name, factor):
    got = units_scale(given)
    assert got == (name, factor) and type(got[1]) is float


@pytest.mark.parametrize("bad", ["furlong", "", "2.5", "mms", "inchs", "kilometre", "auto"])
def test_unknown_unit_names(bad):
    assert refusal(ParameterError, units_scale, bad) == (
        f"unknown units {bad!r}; use one of mm, cm, m, um, in, ft or a number of mm per unit")


@pytest.mark.parametrize("bad", [True, False, None, [1.0], {"mm": 1}, object])
def test_units_that_are_neither_name_nor_number(bad):
    assert refusal(ParameterError, units_scale, bad) == f"units must be a name or a number of mm per unit, got {bad!r}"


@pytest.mark.parametrize("bad", [0, 0.0, -0.0, -1.0, -25.4, float("nan"), float("inf"), float("-inf")])
def test_units_factor_must_be_positive_and_finite(bad):
    assert refusal(ParameterError, units_scale, bad) == f"units factor must be positive and finite, got {bad!r}"


def test_the_smallest_positive_factor_is_a_unit():
    assert units_scale(5e-324) == ("x4.94066e-324", 5e-324)


# ------------------------------------------------------------------ the row hash and merge key
def _reference_hash(row) -> int:
    """_row_hash of one row in Python integers mod 2**64 (the definition, by hand)."""
    mask = (1 << 64) - 1
    r = [int(x) & mask for x in row]
    m0, m1, m2 = 0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9
    h = (r[0] * m0) & mask
    h ^= ((h >> 29) + r[1] * m1) & mask
    h ^= ((h >> 31) + r[2] * m2) & mask
    return h


def test_row_hash_by_hand():
    rows = np.array([[0, 0, 0], [1, 2, 3], [3, 2, 1], [-1, 5, 2**40], [2**62, -(2**62), 7]], dtype=np.int64)
    got = meshio._row_hash(rows)
    assert got.dtype == np.uint64
    assert [int(h) for h in got] == [_reference_hash(r) for r in rows.tolist()]
    assert int(meshio._row_hash(np.array([[0, 0, 1]]))[0]) == 0x165667B19E3779F9
    small = np.array([[1, 2, 3], [-7, 0, 2**30]], dtype=np.int32)  # any integer type: the same hashes
    assert meshio._row_hash(small).tolist() == meshio._row_hash(small.astype(np.int64)).tolist()


def test_all_distinct_tells_rows_that_differ_in_any_column():
    base = np.array([[1, 2, 3], [4, 5, 6]])
    assert meshio._all_distinct(base)
    for k in range(3):
        other = base[:1].copy()
        other[0, k] += 1
        assert meshio._all_distinct(np.vstack([base[:1], other]))
    assert not meshio._all_distinct(np.array([[1, 2, 3], [4, 5, 6], [1, 2, 3]]))
    assert not meshio._all_distinct(np.array([[7, 7, 7], [7, 7, 7]]))
    assert meshio._all_distinct(np.array([[7, 7, 7]]))
    assert meshio._all_distinct(np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 4.0]]))  # any integer-valued array


def test_merge_key_is_coordinates_times_1e8_rounded():
    key = meshio._merge_key(np.array([[1.0, -2.5, 0.0], [1e-8, 1.4e-8, 1.6e-8], [-1e-8, -0.5e-8, 2.5e-8]]))
    assert key.dtype == np.int64
    assert key.tolist() == [[100000000, -250000000, 0], [1, 1, 2], [-1, 0, 2]]


# ------------------------------------------------------------------ edges, loops, components
def test_same_orientation_is_the_cyclic_order():
    a = np.array([[0, 1, 2], [0, 1, 2], [0, 1, 2], [5, 3, 9], [5, 3, 9], [4, 7, 2]])
    b = np.array([[1, 2, 0], [2, 0, 1], [0, 2, 1], [3, 9, 5], [9, 3, 5], [2, 4, 7]])
    assert meshio._same_orientation(a, b).tolist() == [True, True, False, True, False, True]


def test_edge_table_of_closed_open_flipped_and_non_manifold_faces():
    v, f = box()
    assert meshio._edge_table(f) == (0, 0, True)
    assert meshio._edge_table(f, 8, try_clean=False) == (0, 0, True)
    assert meshio._edge_table(f[1:]) == (3, 0, True)
    assert meshio._edge_table(f[2:]) == (4, 0, True)  # two triangles of one side: a square hole
    flipped = f.copy()
    flipped[0] = flipped[0, ::-1]
    assert meshio._edge_table(flipped) == (0, 0, False)
    assert meshio._edge_table(flipped, try_clean=False) == (0, 0, False)
    fan = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])  # edge 0-1 in three faces
    assert meshio._edge_table(fan) == (6, 1, True)  # winding is judged on edges two faces share
    pair = np.array([[0, 1, 2], [1, 0, 3]])
    assert meshio._edge_table(pair) == (4, 0, True)
    assert meshio._edge_table(np.array([[0, 1, 2], [0, 1, 3]])) == (4, 0, False)
    assert meshio._edge_table(np.zeros((0, 3), dtype=np.int64)) == (0, 0, True)
    assert meshio._edge_use(f[1:]) == (3, 0)
    assert meshio._edge_use(fan) == (6, 1)
    assert meshio._edge_use(f) == (0, 0)


def test_edge_table_with_unused_high_vertices():
    v, f = box()
    assert meshio._edge_table(f + 5, 20) == (0, 0, True)
    assert meshio._edge_table((f + 5)[1:], 20) == (3, 0, True)
    assert meshio._edge_table((f + 5)[1:], 20, try_clean=False) == (3, 0, True)


def test_closed_and_consistent():
    v, f = box()
    assert meshio._closed_and_consistent(f, 8)
    assert not meshio._closed_and_consistent(f[1:], 8)
    flipped = f.copy()
    flipped[3] = flipped[3, ::-1]
    assert not meshio._closed_and_consistent(flipped, 8)
    g = meshio._clean_edge_graph(f, 8)
    coo = g.tocoo()
    edges = sorted(zip(coo.row.tolist(), coo.col.tolist()))
    want = sorted({(min(a, b), max(a, b)) for t in f.tolist() for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))})
    assert edges == want and len(edges) == 18 and g.shape == (8, 8)


def _cyclic(loop):
    k = loop.index(min(loop))
    return tuple(loop[k:] + loop[:k])


def test_boundary_loop_of_one_missing_triangle():
    v, f = box()
    loops = meshio._boundary_loops(f[1:])  # f[0] = (1, 3, 0): its neighbours walk 3->1, 0->3, 1->0
    assert [_cyclic(lp) for lp in loops] == [(0, 3, 1)]


def test_boundary_loop_of_a_square_hole_and_two_holes():
    v, f = box()
    loops = meshio._boundary_loops(f[2:])  # (1, 3, 0) and (4, 1, 0): the square 0, 3, 1, 4
    assert len(loops) == 1 and len(loops[0]) == 4 and set(loops[0]) == {0, 1, 3, 4}
    lp = loops[0]
    directed = {(lp[i], lp[(i + 1) % 4]) for i in range(4)}
    assert directed == {(0, 3), (3, 1), (1, 4), (4, 0)}
    two = meshio._boundary_loops(np.delete(f, [0, 10], axis=0))  # (1, 3, 0) and (6, 5, 4): no shared vertex
    assert sorted(_cyclic(lp) for lp in two) == [(0, 3, 1), (4, 5, 6)]


def test_two_holes_touching_at_a_vertex_are_split():
    # an octahedron without two faces that meet only at the apex 4
    v = np.array([[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
    top = [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]
    bottom = [[1, 0, 5], [2, 1, 5], [3, 2, 5], [0, 3, 5]]
    f = np.array([top[1], top[3]] + bottom)
    loops = meshio._boundary_loops(f)
    assert sorted(_cyclic(lp) for lp in loops) == [(0, 4, 1), (2, 4, 3)]


def test_boundary_loops_that_do_not_close():
    assert meshio._boundary_loops(np.array([[0, 1, 2], [0, 1, 3]])) is None  # an open chain
    assert meshio._boundary_loops(np.array([[0, 0, 1]])) is None  # a loop of one vertex
    assert meshio._boundary_loops(np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])) is None
    v, f = box()
    assert meshio._boundary_loops(f) == []


def test_components_numbered_by_their_smallest_vertex():
    v, f = tet()
    # the second tetrahedron uses the lower vertex numbers 0-3, the first 10-13; 4-9 are unused
    faces = np.vstack([f + 10, f, (f + 10)[:1]])
    labels, count = meshio._face_components(faces, 14)
    assert count == 2
    assert labels.tolist() == [1, 1, 1, 1, 0, 0, 0, 0, 1]
    assert labels.dtype == np.int64
    one, n = meshio._face_components(f, 4)
    assert n == 1 and one.tolist() == [0, 0, 0, 0]
    # the same labels from the clean mesh's edge graph
    closed = np.vstack([f + 10, f])
    graph = meshio._clean_edge_graph(closed, 14)
    labels2, count2 = meshio._face_components(closed, 14, graph)
    assert count2 == 2 and labels2.tolist() == [1, 1, 1, 1, 0, 0, 0, 0]


def test_three_components_with_gaps():
    v, f = tet()
    faces = np.vstack([f + 20, f + 5, f + 12])
    labels, count = meshio._face_components(faces, 30)
    assert count == 3 and labels.tolist() == [2] * 4 + [0] * 4 + [1] * 4


def test_face_measures_by_hand():
    v, f = tet()
    area2, dets, cross = meshio._face_measures(v, f, keep=True)
    # double areas: the three right triangles 8*10, 10*6, 6*8 and the slanted face |(48, 60, 80)|
    assert area2.tolist() == [80.0, 60.0, 48.0, math.sqrt(48**2 + 60**2 + 80**2)]
    assert cross.tolist() == [[0.0, 0.0, -80.0], [0.0, -60.0, 0.0], [-48.0, 0.0, 0.0], [48.0, 60.0, 80.0]]
    # a . (b x c) per face: zero for the three faces through the origin, 480 = 6 x volume for the last
    assert dets.tolist() == [0.0, 0.0, 0.0, 480.0]
    only, none1, none2 = meshio._face_measures(v, f)
    assert only.tolist() == area2.tolist() and none1 is None and none2 is None
    shifted, d2, _ = meshio._face_measures(v + [1.0, 2.0, 3.0], f, keep=True)
    assert shifted.tolist() == area2.tolist()
    assert d2.sum() == pytest.approx(480.0)  # the signed volume x 6 wherever the solid sits


def test_face_measures_in_chunks(monkeypatch):
    v, f = box()
    whole = meshio._face_measures(v, f, keep=True)
    monkeypatch.setattr(meshio, "CHUNK", 5)
    parts = meshio._face_measures(v, f, keep=True)
    for a, b in zip(whole, parts):
        np.testing.assert_array_equal(a, b)
    assert whole[0].tolist() == [48.0, 60.0, 48.0, 80.0, 80.0, 60.0, 80.0, 60.0, 80.0, 60.0, 48.0, 48.0]
    assert whole[1].sum() == pytest.approx(6 * 480.0)


# ------------------------------------------------------------------ validation and repair of arrays
def fan_side_box():
    """The 10 x 8 x 6 box with its x = -5 side (8 x 6) fanned round a ninth vertex at its centre."""
    v, f = box()
    v = np.vstack([v, [[-5.0, 0.0, 0.0]]])
    f = np.vstack([np.delete(f, [0, 2], axis=0), [[1, 3, 8], [3, 2, 8], [2, 0, 8], [0, 1, 8]]])
    return v, f


def sliver_tet():
    """The tetrahedron with a fifth vertex at (5, 0, 0), the middle of its edge 0-1: one side split
    in two, the other closed by a zero-area triangle (0, 4, 1)."""
    v, _ = tet()
    v = np.vstack([v, [[5.0, 0.0, 0.0]]])
    f = np.array([[0, 2, 4], [4, 2, 1], [0, 4, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return v, f


def volume(v, f) -> float:
    return float(trimesh.Trimesh(vertices=v, faces=f, process=False).volume)


def test_clean_solids_pass_as_they_are():
    for v, f, vol in (tet() + (80.0,), box() + (480.0,), fan_side_box() + (480.0,)):
        v2, f2, repairs, notes, bodies, vol_sum, cross = validated(v, f)
        assert (repairs, notes, bodies, vol_sum, cross) == ([], [], 1, None, None)
        assert len(v2) == len(v) and len(f2) == len(f) and v2.dtype == np.float64 and f2.dtype == np.int64
        assert volume(v2, f2) == pytest.approx(vol)
        assert sorted(map(tuple, v2.tolist())) == sorted(map(tuple, v.tolist()))
    assert validate_arrays(*tet()) [2:] == ([], [], 1)
    assert len(validate_arrays(*tet())) == 5


def test_integer_arrays_are_read_as_floats():
    v, f = tet()
    v2, f2, repairs, notes, bodies = validate_arrays(v.astype(np.int32), f.astype(np.int16), "t")
    assert v2.dtype == np.float64 and volume(v2, f2) == pytest.approx(80.0) and repairs == [] and notes == []


@pytest.mark.parametrize("v, f", [(np.zeros((0, 3)), tet()[1]), (tet()[0], np.zeros((0, 3), dtype=np.int64))])
def test_no_vertices_or_no_faces(v, f):
    assert refusal(MeshError, validated, v, f) == "s contains no triangles"
    assert refusal(MeshError, validate_arrays, v, f) == "mesh contains no triangles"


@pytest.mark.parametrize("extra", [[[0, 1, 4]], [[0, 1, -1]], [[4, 1, 0]], [[0, 9, 1]]])
def test_faces_that_refer_to_missing_vertices(extra):
    v, f = tet()
    assert refusal(MeshError, validated, v, np.vstack([f, extra])) == "s has faces that refer to missing vertices"


def test_a_face_on_the_last_vertex_is_no_missing_vertex():
    v, f = tet()
    assert validated(v, f[:, [1, 2, 0]])[2] == []  # the faces use vertex 3 = len(v) - 1


def test_unused_non_finite_vertices_are_ignored_with_a_note():
    v, f = box()
    for bad in ([np.nan, 0, 0], [0, np.inf, 0], [0, 0, -np.inf]):
        v2, f2, repairs, notes, *_ = validated(np.vstack([v, [bad], [bad]]), f)
        assert repairs == [] and notes == ["ignored 2 unused non-finite vertices"] and len(v2) == 8


def test_faces_on_a_non_finite_vertex_are_removed_and_the_hole_closed():
    v, f = fan_side_box()
    for bad in (np.nan, np.inf, -np.inf):
        w = v.copy()
        w[8, 1] = bad
        v2, f2, repairs, notes, bodies, *_ = validated(w, f)
        assert repairs == ["removed 4 faces that use 1 non-finite (NaN/inf) vertices",
                           "closed 1 hole (4 open edges) with fan patches"]
        assert notes == [] and bodies == 1 and np.all(np.isfinite(v2))
        assert volume(v2, f2) == pytest.approx(480.0) and len(f2) == 14
        assert [-5.0, 0.0, 0.0] in v2.tolist()  # the fan's centre: the hole's centroid
    w = v.copy()
    w[8] = np.nan
    assert refusal(MeshError, validated, w, f, repair=False) == (
        "s: removed 4 faces that use 1 non-finite (NaN/inf) vertices (repair disabled)")


def test_every_triangle_on_a_non_finite_vertex():
    v, f = tet()
    v[[0, 1]] = np.inf  # each face has three of the four corners: one of these two
    assert refusal(MeshError, validated, v, f) == "s: every triangle uses a non-finite (NaN or inf) vertex"
    v[0] = 0.0  # one non-finite corner: the three faces on it go, one triangle is left, too open to close
    assert refusal(MeshError, validated, v, f) == (
        "s is too open to repair: closing its 1 holes would make up 50 % of its surface")


def test_coincident_vertices_are_merged_with_a_note():
    v, f = box()
    v2 = np.vstack([v, v[:1], v[5:6] + 1e-9])  # vertex 8 is vertex 0; vertex 9 is vertex 5, 1e-9 off
    f2 = f.copy()
    f2[1] = [4, 1, 8]  # (4, 1, 0) with 0 written as 8
    f2[5] = [9, 1, 4]  # (5, 1, 4) with 5 written as 9
    out_v, out_f, repairs, notes, *_ = validated(v2, f2)
    assert repairs == [] and notes == ["merged 2 coincident vertices"] and len(out_v) == 8
    assert volume(out_v, out_f) == pytest.approx(480.0)
    # 1e-7 apart is two vertices (trimesh merges at 1e-8): the box has a crack there, closed as a hole
    v3 = np.vstack([v, v[:1] + [1e-7, 0, 0]])
    f3 = f.copy()
    f3[1] = [4, 1, 8]
    assert validated(v3, f3)[3] == []


def test_unused_finite_vertices_are_dropped_without_a_note():
    v, f = box()
    out_v, out_f, repairs, notes, *_ = validated(np.vstack([[[50.0, 50.0, 50.0]], v]), f + 1)
    assert (repairs, notes, len(out_v)) == ([], [], 8)
    assert float(np.abs(out_v).max()) == 5.0


def test_degenerate_faces_are_removed():
    v, f = box()
    out = validated(v, np.vstack([f, [[0, 0, 1], [0, 1, 1], [1, 0, 1]]]))
    assert out[2] == ["removed 3 degenerate faces (repeated vertices)"] and len(out[1]) == 12
    for bad in ([[2, 2, 3]], [[2, 3, 3]], [[3, 2, 3]]):
        assert validated(v, np.vstack([bad, f]))[2] == ["removed 1 degenerate faces (repeated vertices)"]
    assert refusal(MeshError, validated, v, np.vstack([f, [[0, 0, 1]]]), repair=False) == (
        "s: removed 1 degenerate faces (repeated vertices) (repair disabled)")
    assert refusal(MeshError, validated, v, np.array([[0, 0, 1], [2, 3, 3], [4, 5, 4]])) == (
        "s has only degenerate triangles")


def test_duplicate_faces_are_removed_keeping_the_first():
    v, f = box()
    dup = np.vstack([f, f[:2], f[3:4, [1, 2, 0]], f[4:5, ::-1]])  # repeats, a rotation, a reversal
    out = validated(v, dup)
    assert out[2] == ["removed 4 duplicate faces"] and len(out[1]) == 12 and volume(out[0], out[1]) == pytest.approx(480.0)
    # the reversed copy comes first: it is kept, the file's own face goes, and the box is wound inconsistently
    first = validated(v, np.vstack([f[:1, ::-1], f]))
    assert first[2] == ["removed 1 duplicate faces", "reversed 1 of 12 faces whose winding disagreed with the rest"]
    assert refusal(MeshError, validated, v, np.vstack([f, f[:1]]), repair=False) == (
        "s: removed 1 duplicate faces (repair disabled)")


def test_only_zero_area_triangles():
    v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], dtype=float)  # all on a line
    f = np.array([[0, 1, 2], [1, 2, 3], [0, 2, 3], [0, 1, 3]])
    assert refusal(MeshError, validated, v, f) == "s has only zero-area triangles"


def test_a_zero_area_triangle_is_kept_with_a_note():
    v, f = sliver_tet()
    v2, f2, repairs, notes, bodies, *_ = validated(v, f)
    assert repairs == [] and notes == ["kept 1 near-zero-area triangles"] and len(f2) == 6 and len(v2) == 5
    assert volume(v2, f2) == pytest.approx(80.0)


def test_edges_shared_by_three_or_more_faces():
    a, fa = box((1.0, 1.0, 1.0))
    both = trimesh.util.concatenate([trimesh.Trimesh(a, fa, process=False),
                                     trimesh.Trimesh(a + [1.0, 1.0, 0.0], fa, process=False)])
    both.merge_vertices()  # the two cubes share the edge x = y = 0.5: four faces on it
    assert refusal(MeshError, validated, both.vertices, both.faces) == (
        "s is not a 2-manifold: 1 edges are shared by three or more faces; "
        "fix it in a mesh editor (e.g. separate the touching parts)")


def test_inconsistent_winding_is_made_consistent():
    v, f = box()
    g = f.copy()
    g[:3] = g[:3, ::-1]
    v2, f2, repairs, notes, *_ = validated(v, g)
    assert repairs == ["reversed 3 of 12 faces whose winding disagreed with the rest"] and notes == []
    assert volume(v2, f2) == pytest.approx(480.0)
    assert refusal(MeshError, validated, v, g, repair=False) == "s: its faces are not consistently wound (repair disabled)"
    # the other nine reversed: the three are right, the nine are turned
    h = f.copy()
    h[3:] = h[3:, ::-1]
    assert validated(v, h)[2] == ["reversed 9 of 12 faces whose winding disagreed with the rest"]


def test_inward_normals_are_inverted():
    v, f = box()
    v2, f2, repairs, *_ = validated(v, f[:, ::-1])
    assert repairs == ["inverted all faces: the normals pointed inward"] and volume(v2, f2) == pytest.approx(480.0)
    assert refusal(MeshError, validated, v, f[:, ::-1], repair=False) == (
        "s: inverted all faces: the normals pointed inward (repair disabled)")


def test_holes_are_closed_by_fans():
    v, f = box()
    one = validated(v, f[1:])
    assert one[2] == ["closed 1 hole (3 open edges) with fan patches"] and len(one[0]) == 8 and len(one[1]) == 12
    assert volume(one[0], one[1]) == pytest.approx(480.0)
    square = validated(v, np.delete(f, [0, 2], axis=0))  # the 8 x 6 side: a centre vertex and four triangles
    assert square[2] == ["closed 1 hole (4 open edges) with fan patches"] and len(square[0]) == 9 and len(square[1]) == 14
    assert [-5.0, 0.0, 0.0] in square[0].tolist() and volume(square[0], square[1]) == pytest.approx(480.0)
    two = validated(v, np.delete(f, [0, 10], axis=0))
    assert two[2] == ["closed 2 holes (6 open edges) with fan patches"] and volume(two[0], two[1]) == pytest.approx(480.0)
    assert refusal(MeshError, validated, v, f[1:], repair=False) == "s is not watertight: 3 open edges (repair disabled)"
    assert refusal(MeshError, validated, v, np.delete(f, [0, 2], axis=0), repair=False) == (
        "s is not watertight: 4 open edges (repair disabled)")


def test_a_hole_of_a_fifth_of_the_surface_at_most():
    v, f = box()
    top = [i for i, t in enumerate(f.tolist()) if all(v[k][2] == 3.0 for k in t)]
    assert top == [4, 6]  # the 10 x 8 top: 80 of 376 mm², 21 %
    assert refusal(MeshError, validated, v, np.delete(f, top, axis=0)) == (
        "s is too open to repair: closing its 1 holes would make up 21 % of its surface")


def test_the_patch_limit_at_its_exact_value(monkeypatch):
    # a 2 x 2 x 1 box without its top: the patch is 4 of 16 units², exactly a quarter
    v, f = box((2.0, 2.0, 1.0))
    open_top = np.delete(f, [i for i, t in enumerate(f.tolist()) if all(v[k][2] == 0.5 for k in t)], axis=0)
    assert len(open_top) == 10
    monkeypatch.setattr(meshio, "MAX_PATCH_FRACTION", 0.25)
    v2, f2, repairs, *_ = validated(v, open_top)
    assert repairs == ["closed 1 hole (4 open edges) with fan patches"] and volume(v2, f2) == pytest.approx(4.0)
    monkeypatch.setattr(meshio, "MAX_PATCH_FRACTION", 0.2499)
    assert refusal(MeshError, validated, v, open_top) == (
        "s is too open to repair: closing its 1 holes would make up 25 % of its surface")
    two = np.delete(open_top, [i for i, t in enumerate(open_top.tolist()) if all(v[k][2] == -0.5 for k in t)], axis=0)
    monkeypatch.setattr(meshio, "MAX_PATCH_FRACTION", 0.2)
    assert refusal(MeshError, validated, v, two) == (
        "s is too open to repair: closing its 2 holes would make up 50 % of its surface")


def test_two_bodies_and_one_inside_out():
    v, f = tet()
    vv, ff = np.vstack([v, v + [20.0, 0.0, 0.0]]), np.vstack([f, f + 4])
    v2, f2, repairs, notes, bodies, *_ = validated(vv, ff)
    assert (repairs, notes, bodies) == ([], [], 2) and volume(v2, f2) == pytest.approx(160.0)
    inv = validated(vv, np.vstack([f, (f + 4)[:, ::-1]]))
    assert inv[2] == ["reversed 4 of 8 faces whose winding disagreed with the rest"] and inv[4] == 2
    assert volume(inv[0], inv[1]) == pytest.approx(160.0)
    both = validated(vv, ff[:, ::-1])
    assert both[2] == ["inverted all faces: the normals pointed inward"] and both[4] == 2


def test_a_flat_closed_surface_encloses_no_volume():
    # a unit square, its two triangulations back to back: closed, consistently wound, flat
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    f = np.array([[0, 1, 2], [0, 2, 3], [1, 0, 3], [1, 3, 2]])
    assert meshio._closed_and_consistent(f, 4)
    assert refusal(MeshError, validated, v, f) == "s encloses no volume (a flat or empty surface)"


def test_the_big_mesh_path_at_its_threshold(monkeypatch):
    v, f = box()
    monkeypatch.setattr(meshio, "MANIFOLD_CHECK_FACES", 12)  # 12 triangles: not more, manifold3d rebuilds it
    assert validated(v, f)[5:] == (None, None)
    monkeypatch.setattr(meshio, "MANIFOLD_CHECK_FACES", 11)  # more than 11: kept as it is, its volume summed
    v2, f2, repairs, notes, bodies, vol, cross = validated(v, f)
    assert v2 is v and f2 is f and (repairs, notes, bodies) == ([], [], 1)
    assert vol == pytest.approx(480.0) and type(vol) is float
    np.testing.assert_array_equal(cross, meshio._face_measures(v, f, keep=True)[2])
    # not fast: the edge table (not the graph) finds it clean; its volume is summed, no cross products kept
    slow = validated(v, f, fast=False)
    assert slow[0] is v and slow[5] == pytest.approx(480.0) and slow[6] is None


def test_the_big_mesh_path_of_two_bodies_and_of_repairs(monkeypatch):
    monkeypatch.setattr(meshio, "MANIFOLD_CHECK_FACES", 0)
    v, f = tet()
    two = validated(np.vstack([v, v + [20.0, 0.0, 0.0]]), np.vstack([f, f + 4]))
    assert two[2:5] == ([], [], 2) and two[5] == pytest.approx(160.0) and two[6].shape == (8, 3)
    bv, bf = box()
    inv = validated(bv, bf[:, ::-1])  # clean edges, but a negative volume: the full path
    assert inv[2] == ["inverted all faces: the normals pointed inward"] and inv[5:] == (None, None)
    dup = validated(bv, np.vstack([bf, bf[:1]]))
    assert dup[2] == ["removed 1 duplicate faces"] and dup[5:] == (None, None)
    hole = validated(bv, bf[1:])
    assert hole[2] == ["closed 1 hole (3 open edges) with fan patches"] and hole[5:] == (None, None)
    sv, sf = sliver_tet()
    sliver = validated(sv, sf)  # clean, but a zero-area triangle: manifold3d checks it
    assert sliver[3] == ["kept 1 near-zero-area triangles"] and sliver[5:] == (None, None)
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    assert refusal(MeshError, validated, square, [[0, 1, 2], [0, 2, 3], [1, 0, 3], [1, 3, 2]]) == (
        "s encloses no volume (a flat or empty surface)")


# ------------------------------------------------------------------ load_mesh: files and formats
SUFFIXES = [".stl", ".obj", ".ply", ".off", ".3mf", ".STL", ".Ply", ".OFF"]


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_every_format_reads_the_box(tmp_path, suffix):
    v, f = box()
    m = quiet(write(tmp_path / f"b{suffix}", v, f), recentre=False)
    assert sorted(map(tuple, np.asarray(m.vertices).tolist())) == sorted(map(tuple, v.tolist()))
    assert len(m.faces) == 12 and m.volume == pytest.approx(480.0)
    r = report(m)
    assert r["format"] == suffix[1:].lower() and r["units"] == "mm" and r["scale_to_mm"] == 1.0
    assert r["units_source"] == ("file" if suffix == ".3mf" else "default")
    assert r["notes"] == (["merged 28 coincident vertices"] if suffix.lower() == ".stl" else [])  # 36 corners in an STL
    assert r["repairs"] == [] and r["warnings"] == [] and r["up_axis"] == "+Z"


def test_the_whole_report_of_a_box(tmp_path):
    v, f = box()
    path = write(tmp_path / "b.ply", v + [1.0, 2.0, 3.0], f)
    m = load_mesh(path)
    assert m.metadata["labcut"] == {
        "kind": "loaded", "source": str(path), "format": "ply", "units": "mm", "scale_to_mm": 1.0,
        "translation_mm": [-1.0, -2.0, 0.0], "repairs": [], "notes": [], "warnings": [], "units_source": "default",
        "up_axis": "+Z",
        "up_axis_source": "convention: +Z, as the file has it; the shape does not say (flat faces on both sides along Z (a slab))",
        "rotation": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "dimensions_mm": [10.0, 8.0, 6.0],
        "convex": True, "watertight": True, "triangles": 12, "vertices": 8, "bodies": 1}
    assert np.asarray(m.bounds).tolist() == [[-5.0, -4.0, 0.0], [5.0, 4.0, 6.0]]
    assert isinstance(m, trimesh.Trimesh) and m.is_watertight and m.is_winding_consistent


def test_recentre_off_keeps_the_file_coordinates(tmp_path):
    v, f = box()
    m = load_mesh(write(tmp_path / "b.ply", v + [1.0, 2.0, 3.0], f), recentre=False, units="cm")
    assert report(m)["translation_mm"] == [0.0, 0.0, 0.0]
    assert np.asarray(m.bounds).tolist() == [[-40.0, -20.0, -0.0], [60.0, 60.0, 60.0]]


def test_two_bodies_and_a_concave_solid(tmp_path):
    v, f = tet()
    two = quiet(write(tmp_path / "two.ply", np.vstack([v, v + [20.0, 0.0, 0.0]]), np.vstack([f, f + 4])))
    assert report(two)["bodies"] == 2 and report(two)["convex"] is False and two.volume == pytest.approx(160.0)
    assert report(two)["triangles"] == 8 and report(two)["vertices"] == 8 and report(two)["dimensions_mm"] == [30.0, 8.0, 6.0]


def test_repairs_and_notes_reach_the_report(tmp_path):
    v, f = box()
    g = np.vstack([f[:, ::-1], [[0, 0, 1]]])
    m = quiet(write(tmp_path / "b.ply", np.vstack([v, [[np.nan, 0.0, 0.0]]]), g))
    assert report(m)["repairs"] == ["removed 1 degenerate faces (repeated vertices)",
                                    "inverted all faces: the normals pointed inward"]
    assert report(m)["notes"] == ["ignored 1 unused non-finite vertices"]
    assert m.volume == pytest.approx(480.0)
    assert refusal(MeshError, load_mesh, tmp_path / "b.ply", repair=False) == (
        "b.ply: removed 1 degenerate faces (repeated vertices) (repair disabled)")


def test_missing_folder_empty_and_unsupported_files(tmp_path):
    missing = tmp_path / "nope.stl"
    assert refusal(MeshError, load_mesh, missing) == f"mesh file {str(missing)!r} does not exist"
    assert refusal(MeshError, load_mesh, str(missing)) == f"mesh file {str(missing)!r} does not exist"
    folder = tmp_path / "folder.stl"
    folder.mkdir()
    assert refusal(MeshError, load_mesh, folder) == f"{str(folder)!r} is a folder, not a mesh file"
    (tmp_path / "empty.stl").write_bytes(b"")
    assert refusal(MeshError, load_mesh, tmp_path / "empty.stl") == "empty.stl is empty (0 bytes)"
    (tmp_path / "empty.obj").write_bytes(b"")
    assert refusal(MeshError, load_mesh, tmp_path / "empty.obj") == "empty.obj is empty (0 bytes)"
    (tmp_path / "notes.txt").write_text("a stone")
    assert refusal(MeshError, load_mesh, tmp_path / "notes.txt") == (
        "notes.txt: unsupported mesh format '.txt'; use one of .stl, .obj, .ply, .off, .glb, .gltf, .3mf, "
        "or a GemCad design (.asc, .gem)")
    (tmp_path / "stone").write_text("a stone")
    assert refusal(MeshError, load_mesh, tmp_path / "stone") == (
        "stone: unsupported mesh format '(no suffix)'; use one of .stl, .obj, .ply, .off, .glb, .gltf, .3mf, "
        "or a GemCad design (.asc, .gem)")


def test_checks_of_the_arguments_come_before_the_file(tmp_path):
    missing = tmp_path / "nope.stl"
    assert refusal(ParameterError, load_mesh, missing, units="furlong").startswith("unknown units 'furlong'")
    assert refusal(ParameterError, load_mesh, missing, up_axis="sideways").startswith("up axis must be one of")


def test_load_reports_its_stages(tmp_path):
    v, f = box()
    seen = []
    load_mesh(write(tmp_path / "b.ply", v, f), progress=lambda stage, fraction: seen.append((stage, fraction)))
    assert seen == [("reading b.ply", 0.0), ("validating and repairing", 0.2), ("checking convexity", 0.6),
                    ("finding the face-up side", 0.8), ("loaded", 1.0)]


def test_the_mesh_is_certified(tmp_path):
    v, f = box()
    m = load_mesh(write(tmp_path / "b.ply", v, f))
    assert m._labcut_valid == meshio._fingerprint(m)


# ------------------------------------------------------------------ STL, PLY, glTF, text and 3MF details
def _stl_bytes(v, f) -> bytes:
    return trimesh.Trimesh(vertices=v, faces=f, process=False).export(file_type="stl")


def test_binary_stl_checks(tmp_path):
    v, f = box()
    data = _stl_bytes(v, f)
    assert len(data) == 84 + 50 * 12
    (tmp_path / "pad.stl").write_bytes(data + b"\0" * 10)
    assert refusal(MeshError, load_mesh, tmp_path / "pad.stl") == (
        "pad.stl is a truncated or corrupt binary STL: its header announces 12 triangles (684 bytes) but the file has 694 bytes")
    (tmp_path / "cut.stl").write_bytes(data[:-1])
    assert refusal(MeshError, load_mesh, tmp_path / "cut.stl") == (
        "cut.stl is a truncated or corrupt binary STL: its header announces 12 triangles (684 bytes) but the file has 683 bytes")
    (tmp_path / "b83.stl").write_bytes(data[:83])
    assert refusal(MeshError, load_mesh, tmp_path / "b83.stl") == (
        "b83.stl is not a valid STL: 83 bytes is shorter than a binary STL header")
    (tmp_path / "one.stl").write_bytes(b"\0" * 80 + (1).to_bytes(4, "little"))
    assert refusal(MeshError, load_mesh, tmp_path / "one.stl") == (
        "one.stl is a truncated or corrupt binary STL: its header announces 1 triangles (134 bytes) but the file has 84 bytes")
    (tmp_path / "none.stl").write_bytes(b"\0" * 80 + (0).to_bytes(4, "little"))  # 84 bytes, no triangle: well formed
    assert refusal(MeshError, load_mesh, tmp_path / "none.stl") == "none.stl contains no triangles"
    (tmp_path / "big.stl").write_bytes(b"\0" * 80 + (256).to_bytes(4, "little") + b"\0" * 50)  # the count's 2nd byte
    assert "announces 256 triangles (12884 bytes) but the file has 134 bytes" in refusal(MeshError, load_mesh, tmp_path / "big.stl")


def test_a_binary_stl_whose_header_says_solid(tmp_path):
    v, f = box()
    data = _stl_bytes(v, f)
    for header in (b"solid box", b"  SOLID box", b"Solid"):
        path = tmp_path / "hdr.stl"
        path.write_bytes(header.ljust(80, b" ") + data[80:])
        m = quiet(path)
        assert len(m.faces) == 12 and m.volume == pytest.approx(480.0)
    # cut short, it cannot be told from ASCII: trimesh reads it as text and fails
    (tmp_path / "cut.stl").write_bytes((b"solid box".ljust(80, b" ") + data[80:])[:-10])
    assert refusal(MeshError, load_mesh, tmp_path / "cut.stl").startswith("cannot read cut.stl as STL")


def test_ascii_stl_forms(tmp_path):
    v, f = box()
    text = trimesh.Trimesh(vertices=v, faces=f, process=False).export(file_type="stl_ascii")
    for name, body in (("plain", text), ("spaced", "  \n" + text.replace("solid", "SOLID", 1)),
                       ("long", text.replace("solid", "solid " + "x" * 5000, 1))):  # the first facet beyond 4 kB
        path = tmp_path / f"{name}.stl"
        path.write_text(body)
        m = quiet(path)
        assert len(m.faces) == 12 and m.volume == pytest.approx(480.0), name
    (tmp_path / "short.stl").write_bytes(b"solid\n")  # under 84 bytes, ASCII: read, and nothing in it
    assert refusal(MeshError, load_mesh, tmp_path / "short.stl") == "short.stl contains no triangles"
    (tmp_path / "facet.stl").write_bytes(b"x" * 100 + b"solid facet")  # "facet" but no "solid" at the start
    assert "is a truncated or corrupt binary STL" in refusal(MeshError, load_mesh, tmp_path / "facet.stl")


def test_ply_fast_reader(tmp_path):
    v, f = box()
    got = meshio._read_ply_arrays(write(tmp_path / "b.ply", v, f))
    assert got[0].dtype == np.float64 and got[1].dtype == np.int64
    np.testing.assert_array_equal(got[0], v)
    np.testing.assert_array_equal(got[1], f)
    quads = tmp_path / "quad.ply"
    corners = "\n".join(f"{x} {y} {z}" for x in (0, 1) for y in (0, 1) for z in (0, 1))
    quads.write_text("ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
                     "element face 6\nproperty list uchar int vertex_indices\nend_header\n" + corners +
                     "\n4 0 1 3 2\n4 4 6 7 5\n4 0 4 5 1\n4 2 3 7 6\n4 0 2 6 4\n4 1 5 7 3\n")
    assert meshio._read_ply_arrays(quads) is None  # quads: the general reader triangulates them
    m = quiet(quads, units="cm")
    assert len(m.faces) == 12 and m.volume == pytest.approx(1000.0)
    trimesh.PointCloud(v).export(tmp_path / "cloud.ply")
    assert meshio._read_ply_arrays(tmp_path / "cloud.ply") is None
    assert refusal(MeshError, load_mesh, tmp_path / "cloud.ply") == "cloud.ply contains no triangles"
    (tmp_path / "junk.ply").write_bytes(b"ply\ngarbage")
    assert meshio._read_ply_arrays(tmp_path / "junk.ply") is None
    assert refusal(MeshError, load_mesh, tmp_path / "junk.ply").startswith("cannot read junk.ply as PLY (")


def test_a_ply_of_vertices_and_empty_faces(tmp_path):
    path = tmp_path / "nofaces.ply"
    path.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                    "element face 0\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n")
    assert meshio._read_ply_arrays(path) is None
    assert refusal(MeshError, load_mesh, path) == "nofaces.ply contains no triangles"


def test_gltf_must_be_json(tmp_path):
    v, f = box()
    files = trimesh.Trimesh(vertices=v, faces=f, process=False).export(file_type="gltf")
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    (gltf,) = [n for n in files if n.endswith(".gltf")]
    text = (tmp_path / gltf).read_bytes()
    (tmp_path / "spaced.gltf").write_bytes(b" \n\t" * 80 + text)  # 240 bytes of white space, then the JSON
    m = quiet(tmp_path / "spaced.gltf", units="mm")
    assert report(m)["format"] == "gltf" and report(m)["notes"] == ["read in mm as asked, although the file declares m"]
    assert report(m)["up_axis"] == "+Y" and m.volume == pytest.approx(480.0)
    # JSON may open with any amount of white space: 9000 bytes of it (over two of the reader's chunks)
    (tmp_path / "wide.gltf").write_bytes(b" " * 4096 + b"\n" * 4904 + text)
    assert quiet(tmp_path / "wide.gltf", units="mm").volume == pytest.approx(480.0)
    (tmp_path / "blank.gltf").write_bytes(b" \n" * 3000)
    assert refusal(MeshError, load_mesh, tmp_path / "blank.gltf") == (
        "cannot read blank.gltf as GLTF: it is not a JSON glTF file (binary glTF ends in .glb)")
    (tmp_path / "bin.gltf").write_bytes(trimesh.Trimesh(vertices=v, faces=f, process=False).export(file_type="glb"))
    assert refusal(MeshError, load_mesh, tmp_path / "bin.gltf") == (
        "cannot read bin.gltf as GLTF: it is not a JSON glTF file (binary glTF ends in .glb)")


def test_text_that_is_not_utf8(tmp_path):
    v, f = tet()
    body = "".join(f"v {x} {y} {z}\n" for x, y, z in v) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f)
    (tmp_path / "latin.obj").write_bytes("# café\n".encode("latin-1") + body.encode())
    assert refusal(MeshError, load_mesh, tmp_path / "latin.obj") == (
        "cannot read latin.obj as OBJ: it is not a UTF-8 text OBJ file")
    (tmp_path / "utf8.obj").write_bytes("# café\n".encode("utf-8") + body.encode())
    m = quiet(tmp_path / "utf8.obj")
    assert m.volume == pytest.approx(80.0) and report(m)["format"] == "obj"


def test_lines_are_no_triangles(tmp_path):
    (tmp_path / "lines.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\n")
    assert refusal(MeshError, load_mesh, tmp_path / "lines.obj") == "lines.obj contains no triangles"


@pytest.mark.parametrize("message, shown", [
    ("short", "ValueError: short"), ("twelve chars", "ValueError: twelve chars"),
    ("thirteen char", "thirteen char"), ("a longer\nmessage  here", "a longer message here"),
    ("", "ValueError: ")])
def test_a_reader_error_in_one_line(tmp_path, monkeypatch, message, shown):
    v, f = tet()
    path = write(tmp_path / "t.obj", v, f)

    def broken(*args, **kwargs):
        raise ValueError(message)

    monkeypatch.setattr(trimesh, "load", broken)
    assert refusal(MeshError, load_mesh, path) == f"cannot read t.obj as OBJ ({shown})"


def test_not_a_mesh(tmp_path, monkeypatch):
    v, f = tet()
    path = write(tmp_path / "t.off", v, f)
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: trimesh.PointCloud(v))
    assert refusal(MeshError, load_mesh, path) == "t.off holds no triangle mesh (a point cloud or curves?)"
    calls = []
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: calls.append((a, k)) or trimesh.Trimesh(v, f, process=False))
    assert quiet(path).volume == pytest.approx(80.0)
    assert calls == [((str(path),), {"file_type": "off", "process": False, "force": "mesh"})]


def _threemf(tmp_path, unit: str, name: str = "u.3mf") -> Path:
    v, f = box()
    source = save_mesh(trimesh.Trimesh(vertices=v, faces=f, process=False), tmp_path / "source.3mf")
    path = tmp_path / name
    with zipfile.ZipFile(source) as zin, zipfile.ZipFile(path, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename.lower().endswith(".model"):
                assert b'unit="millimeter"' in data
                data = data.replace(b'unit="millimeter"', f'unit="{unit}"'.encode())
            zout.writestr(item, data)
    return path


@pytest.mark.parametrize("unit, key", [("millimeter", "mm"), ("Millimeter", "mm"), ("centimeter", "cm"),
                                       ("inch", "in"), ("", "mm"), ("millimeters", "mm"), ("centimeters", "cm")])
def test_the_units_a_3mf_declares(tmp_path, unit, key):
    m = quiet(_threemf(tmp_path, unit))
    r = report(m)
    assert (r["units"], r["units_source"], r["scale_to_mm"], r["notes"]) == (key, "file", meshio.UNITS[key], [])
    assert r["dimensions_mm"] == pytest.approx([10.0 * meshio.UNITS[key], 8.0 * meshio.UNITS[key], 6.0 * meshio.UNITS[key]])


@pytest.mark.parametrize("unit, key", [("micron", "um"), ("foot", "ft"), ("meter", "m"), ("meters", "m"), ("feet", None)])
def test_the_large_and_small_3mf_units(tmp_path, unit, key):
    path = _threemf(tmp_path, unit)
    if key is None:  # not a 3MF unit, even if English
        assert refusal(MeshError, load_mesh, path) == (
            "u.3mf declares the unit 'feet', which is not a 3MF unit (micron, millimeter, centimeter, inch, foot, meter)")
        return
    size = _mm_text(10.0 * meshio.UNITS[key])
    assert refusal(ParameterError, load_mesh, path) == (
        f"u.3mf is {size} mm across read in {key} (as the file declares), outside the 0.5-500 mm of a stone; "
        f"if the file is in mm, pass --units mm (units='mm')")
    assert report(quiet(path, units="mm"))["notes"] == [f"read in mm as asked, although the file declares {key}"]


def _mm_text(x: float) -> str:
    return {0.01: "0.01", 3048.0: "3048", 10000.0: "10000"}[x]


def test_a_3mf_unit_that_is_none(tmp_path):
    assert refusal(MeshError, load_mesh, _threemf(tmp_path, "furlong")) == (
        "u.3mf declares the unit 'furlong', which is not a 3MF unit (micron, millimeter, centimeter, inch, foot, meter)")
    assert refusal(MeshError, load_mesh, _threemf(tmp_path, "inches")) == (
        "u.3mf declares the unit 'inches', which is not a 3MF unit (micron, millimeter, centimeter, inch, foot, meter)")
    assert refusal(MeshError, load_mesh, _threemf(tmp_path, "cm"), units="cm") == (  # the unit is the file's fault
        "u.3mf declares the unit 'cm', which is not a 3MF unit (micron, millimeter, centimeter, inch, foot, meter)")


# ------------------------------------------------------------------ units: given, declared, default
def test_a_given_unit_scales_and_says_so(tmp_path):
    v, f = box()
    path = write(tmp_path / "b.ply", v, f)
    for units, name, factor in (("cm", "cm", 10.0), (" CM ", "cm", 10.0), ("in", "in", 25.4), (2, "x2", 2.0),
                                (0.5, "x0.5", 0.5), ("mm", "mm", 1.0)):
        m = load_mesh(path, units=units)
        r = report(m)
        assert (r["units"], r["scale_to_mm"], r["units_source"], r["notes"]) == (name, factor, "given", [])
        assert r["dimensions_mm"] == pytest.approx([10.0 * factor, 8.0 * factor, 6.0 * factor])
        assert np.asarray(m.bounds)[0, 2] == 0.0
    for auto in ("auto", "AUTO", " Auto "):
        assert report(load_mesh(path, units=auto))["units_source"] == "default"


def test_glb_is_metres_and_y_up(tmp_path):
    v, f = box()
    stone = trimesh.Trimesh(vertices=v, faces=f, process=False)
    path = save_mesh(stone, tmp_path / "b.glb")
    m = load_mesh(path, recentre=False)
    r = report(m)
    assert (r["units"], r["units_source"], r["scale_to_mm"]) == ("m", "file", 1000.0)
    assert r["notes"] == ["read in metres: glTF lengths are metres by specification"]
    assert r["up_axis"] == "+Y" and r["up_axis_source"] == (  # the file's Z is its Y: the slab lies along the file's Y
        "convention: glTF is Y-up by specification; the shape does not say (flat faces on both sides along Y (a slab))")
    assert r["rotation"] == up_rotation("+Y").tolist()
    np.testing.assert_allclose(np.asarray(m.bounds), [[-5.0, -4.0, -3.0], [5.0, 4.0, 3.0]], rtol=1e-7)  # float32
    assert m.volume == pytest.approx(480.0)
    assert refusal(ParameterError, load_mesh, path, units="mm") == (  # metres read as mm: 1000 times too small
        "b.glb is 0.01 mm across read in mm (as given), outside the 0.5-500 mm of a stone; "
        "if the file is in m, pass --units m (units='m')")


def test_metres_read_as_given_mm_is_refused_with_the_glb_reason(tmp_path):
    v, f = box()
    path = write(tmp_path / "raw.glb", v, f)  # trimesh writes the numbers as they are: 10 m across
    assert refusal(ParameterError, load_mesh, path) == (
        "raw.glb is 10000 mm across read in m (glTF is metres by specification), outside the 0.5-500 mm of a stone; "
        "if the file is in mm, pass --units mm (units='mm')")


# ------------------------------------------------------------------ the size check
def _check(size_file, factor=1.0, unit="mm", source="default", name="s.stl", fmt="stl"):
    v = np.array([[0.0, 0.0, 0.0], [size_file, 0.0, 0.0], [0.0, size_file / 2, size_file / 4]])
    return meshio._check_size(v, factor, unit, source, name, fmt)


def test_size_limits_exactly():
    assert _check(0.5) is None and _check(500.0) is None and _check(16.0) is None
    assert _check(0.05, 10.0, "cm", "given") is None  # 0.5 mm in cm
    assert _check(50.0, 10.0, "cm", "given") is None  # 500 mm in cm
    assert refusal(ParameterError, _check, 0.49) == (
        "s.stl is 0.49 mm across read in mm (the default: the file does not say), outside the 0.5-500 mm of a stone; "
        "if the file is in in, pass --units in (units='in')")
    assert refusal(ParameterError, _check, 500.5).startswith("s.stl is 500 mm across read in mm")
    assert refusal(ParameterError, _check, 600.0) == (
        "s.stl is 600 mm across read in mm (the default: the file does not say), outside the 0.5-500 mm of a stone; "
        "give its unit with --units (units=)")


def test_size_limits_come_from_the_stone_range(monkeypatch):
    monkeypatch.setattr(meshio, "STONE_SIZE_MM", (1.0, 2.0))
    assert _check(1.0) is None and _check(2.0) is None
    assert "outside the 1-2 mm of a stone" in refusal(ParameterError, _check, 2.5)
    assert "outside the 1-2 mm of a stone" in refusal(ParameterError, _check, 0.9)


@pytest.mark.parametrize("source, fmt, why", [("given", "stl", "as given"), ("file", "3mf", "as the file declares"),
                                              ("file", "glb", "glTF is metres by specification"),
                                              ("file", "gltf", "glTF is metres by specification"),
                                              ("default", "obj", "the default: the file does not say")])
def test_the_size_refusal_says_where_the_unit_came_from(source, fmt, why):
    msg = refusal(ParameterError, _check, 0.4, 1.0, "mm", source, "x." + fmt, fmt)
    assert msg == (f"x.{fmt} is 0.4 mm across read in mm ({why}), outside the 0.5-500 mm of a stone; "
                   "if the file is in in, pass --units in (units='in')")


def test_the_unit_a_refusal_names():
    # 0.4 mm read in mm: cm gives 4, in 10.16, ft 121.92 mm; inches are nearest 16 mm
    assert refusal(ParameterError, _check, 0.4).endswith("if the file is in in, pass --units in (units='in')")
    # 2 units read as 0.1 mm each (0.2 mm): mm 2, cm 20, in 50.8; centimetres are nearest 16 mm
    assert refusal(ParameterError, _check, 2.0, 0.1, "x0.1", "given").endswith("pass --units cm (units='cm')")
    # 200 units read in microns (0.2 mm): only mm puts it at 2-200 mm, exactly 200
    assert refusal(ParameterError, _check, 200.0, 1e-3, "um", "given").endswith("pass --units mm (units='mm')")
    # 200.5 units read in microns: mm would make it 200.5 mm, just over: nothing is named
    assert refusal(ParameterError, _check, 200.5, 1e-3, "um", "given").endswith("give its unit with --units (units=)")
    # 0.002 units read in mm: only metres make it 2-200 mm, exactly 2
    assert refusal(ParameterError, _check, 0.002).endswith("pass --units m (units='m')")
    # 0.0019 units: nothing makes 2-200 mm (metres: 1.9)
    assert refusal(ParameterError, _check, 0.0019).endswith("give its unit with --units (units=)")
    # 1 unit given as metres: 1000 mm; mm (1 mm) is outside 2-200, metres were given; inches (25.4 mm) are
    # nearer 16 mm than centimetres (10 mm), just: log(25.4 / 16) = 0.462 < log(16 / 10) = 0.470
    assert refusal(ParameterError, _check, 1.0, 1000.0, "m", "given").endswith("pass --units in (units='in')")
    # the unit read is never named: 16 cm read in cm = 160 mm fits, but 600 cm read in cm is refused, and cm is not named
    assert refusal(ParameterError, _check, 60.0, 10.0, "cm", "given").endswith("pass --units mm (units='mm')")


def test_a_tiny_or_huge_size_reads_short():
    assert " is 1e+06 mm across " in refusal(ParameterError, _check, 1e6)
    assert " is 999999 mm across " in refusal(ParameterError, _check, 999999.0)
    assert " is 1.6e-05 mm across " in refusal(ParameterError, _check, 1.6e-5)


def test_the_size_check_through_load_mesh(tmp_path):
    v, f = tet()
    path = write(tmp_path / "t.ply", v / 20.0, f)  # 0.5 x 0.4 x 0.3
    assert report(load_mesh(path, units="mm", up_axis="+Z"))["dimensions_mm"][0] == 0.5  # 10 / 20 exactly
    assert refusal(ParameterError, load_mesh, path, units=0.5) == (
        "t.ply is 0.25 mm across read in x0.5 (as given), outside the 0.5-500 mm of a stone; "
        "if the file is in in, pass --units in (units='in')")
    assert report(load_mesh(path, units=1000.0, up_axis="+Z"))["dimensions_mm"][0] == 500.0
    assert refusal(ParameterError, load_mesh, path, units=1001.0).startswith("t.ply is 500 mm across read in x1001 ")


# ------------------------------------------------------------------ the small-stone warning
def test_no_warning_at_or_over_2_5_mm():
    assert meshio._units_warning(2.5, "s.stl") is None
    assert meshio._units_warning(10.0, "s.stl") is None


def test_the_warning_just_under_2_5_mm():
    assert meshio._units_warning(2.4, "s.stl") == (
        "s.stl is 2.4 mm across read in mm (the default: the file does not say), and cut stones are rarely under 2.5 mm: "
        "if the file is in centimetres, pass --units cm (units='cm') for 24 mm; in inches, --units in (units='in') "
        "for 61 mm; if it is in mm, --units mm (units='mm') says so")


def test_the_warning_names_the_likelier_unit_first():
    # 0.63 mm: inches give 16.0 mm (typical), centimetres 6.3 mm
    assert meshio._units_warning(0.63, "o.ply") == (
        "o.ply is 0.63 mm across read in mm (the default: the file does not say), and cut stones are rarely under 2.5 mm: "
        "if the file is in inches, pass --units in (units='in') for 16 mm; in centimetres, --units cm (units='cm') "
        "for 6.3 mm; if it is in mm, --units mm (units='mm') says so")
    # 0.2 mm: inches give 5.08 mm; centimetres 2 mm, under 4: inches only
    assert meshio._units_warning(0.2, "o.ply") == (
        "o.ply is 0.2 mm across read in mm (the default: the file does not say), and cut stones are rarely under 2.5 mm: "
        "if the file is in inches, pass --units in (units='in') for 5.08 mm; if it is in mm, --units mm (units='mm') says so")
    assert meshio._units_warning(0.1, "o.ply") is None  # 2.54 mm in inches, 1 mm in centimetres: neither is typical


def test_the_warning_at_the_typical_range_edges(monkeypatch):
    assert meshio._units_warning(0.4, "o.ply").count("--units cm (units='cm') for 4 mm") == 1  # 0.4 x 10 = 4: the edge
    monkeypatch.setattr(meshio, "TYPICAL_STONE_MM", (5.0, 12.7))  # 0.5 mm: cm 5.0, in 12.7, both exactly at an edge
    msg = meshio._units_warning(0.5, "o.ply")
    assert "--units cm (units='cm') for 5 mm" in msg and "--units in (units='in') for 12.7 mm" in msg
    monkeypatch.setattr(meshio, "TYPICAL_STONE_MM", (5.0, 12.6))
    assert "--units in" not in meshio._units_warning(0.5, "o.ply")
    monkeypatch.setattr(meshio, "SMALL_STONE_MM", 0.5)
    assert meshio._units_warning(0.5, "o.ply") is None
    monkeypatch.setattr(meshio, "SMALL_STONE_MM", 0.51)
    assert "rarely under 0.51 mm" in meshio._units_warning(0.5, "o.ply")


def test_the_warning_through_load_mesh(tmp_path):
    v, f = box()
    path = write(tmp_path / "b.ply", v / 16.0, f)  # 0.625 x 0.5 x 0.375: a 16 mm stone in inches
    with pytest.warns(LabcutWarning) as caught:
        m = load_mesh(path)
    said = [str(w.message) for w in caught if issubclass(w.category, LabcutWarning)]
    assert said == report(m)["warnings"] == [meshio._units_warning(0.625, "b.ply")]
    assert "pass --units in (units='in') for 15.9 mm" in said[0]
    for units in ("mm", "in"):
        with warnings.catch_warnings():
            warnings.simplefilter("error", LabcutWarning)
            assert report(load_mesh(path, units=units))["warnings"] == []


@pytest.mark.skipif(UNDER_MUTMUT, reason="mutmut's trampolines add frames: the warning's line is theirs")
def test_the_warning_points_at_the_caller(tmp_path):
    v, f = box()
    path = write(tmp_path / "b.ply", v / 16.0, f)
    with pytest.warns(LabcutWarning) as caught:
        load_mesh(path)
    assert caught[0].filename == __file__


# ------------------------------------------------------------------ the face-up side
def test_a_shape_that_says_plus_z(tmp_path):
    v, f = pyramid()
    with warnings.catch_warnings():
        warnings.simplefilter("error", LabcutWarning)
        m = load_mesh(write(tmp_path / "p.ply", v, f))
    r = report(m)
    assert (r["up_axis"], r["up_axis_source"], r["warnings"]) == ("+Z", "shape: a flat base facing -Z", [])
    assert r["rotation"] == np.eye(3).tolist() and r["dimensions_mm"] == [20.0, 20.0, 6.0]


def test_an_upside_down_shape_is_turned_with_a_warning(tmp_path):
    v, f = pyramid(down=True)
    path = write(tmp_path / "p.ply", v, f)
    with pytest.warns(LabcutWarning) as caught:
        m = load_mesh(path, recentre=False)
    want = ("p.ply looks upside down (dome-down: face-up is -Z), from a flat base facing +Z: turned so that its -Z side "
            "is face-up; pass --up-axis +Z (up_axis='+Z') to keep the file's orientation")
    assert [str(w.message) for w in caught] == [want] and report(m)["warnings"] == [want]
    assert report(m)["up_axis"] == "-Z" and report(m)["up_axis_source"] == "shape: a flat base facing +Z"
    assert report(m)["rotation"] == up_rotation("-Z").tolist()
    turned = sorted(map(tuple, (v @ up_rotation("-Z").T).tolist()))
    assert sorted(map(tuple, np.asarray(m.vertices).tolist())) == turned and (0.0, 0.0, 6.0) in turned  # apex up


def test_a_y_up_glb_shape_is_not_warned_about(tmp_path):
    v, f = pyramid()
    stone = trimesh.Trimesh(vertices=v, faces=f, process=False)
    path = save_mesh(stone, tmp_path / "p.glb")  # metres, +Y up: the glTF convention, which the shape agrees with
    with warnings.catch_warnings():
        warnings.simplefilter("error", LabcutWarning)
        m = load_mesh(path, recentre=False)
    assert report(m)["up_axis"] == "+Y" and report(m)["up_axis_source"].startswith("shape: ")
    got = np.array(sorted(map(tuple, np.asarray(m.vertices).tolist())))
    np.testing.assert_allclose(got, np.array(sorted(map(tuple, v.tolist()))), rtol=1e-7, atol=1e-12)  # float32 in the file


def test_a_z_up_glb_shape_is_turned_with_the_convention_named(tmp_path):
    v, f = pyramid()
    path = write(tmp_path / "p.glb", v / 1000.0, f)  # metres, but +Z up
    with pytest.warns(LabcutWarning) as caught:
        m = load_mesh(path)
    assert str(caught[0].message) == (
        "p.glb looks Z-up, from a flat base facing -Z: turned so that its +Z side is face-up; "
        "pass --up-axis +Y (up_axis='+Y') to keep the file's orientation")
    assert report(m)["up_axis"] == "+Z"


def test_a_given_up_axis_the_shape_contradicts(tmp_path):
    v, f = pyramid(down=True)
    path = write(tmp_path / "p.ply", v, f)
    with pytest.warns(LabcutWarning) as caught:
        m = load_mesh(path, up_axis="z")
    want = ("p.ply: you gave up axis +Z, but its shape says -Z is face-up (a flat base facing +Z); "
            "--up-axis auto (up_axis='auto') would use -Z")
    assert [str(w.message) for w in caught] == [want]
    assert (report(m)["up_axis"], report(m)["up_axis_source"], report(m)["warnings"]) == ("+Z", "given", [want])
    with warnings.catch_warnings():
        warnings.simplefilter("error", LabcutWarning)
        agreed = load_mesh(path, up_axis="-Z")
    assert (report(agreed)["up_axis"], report(agreed)["up_axis_source"], report(agreed)["warnings"]) == ("-Z", "given", [])
    b, bf = box()
    with warnings.catch_warnings():
        warnings.simplefilter("error", LabcutWarning)
        given = load_mesh(write(tmp_path / "b.ply", b, bf), up_axis="+X", recentre=False)  # the shape says nothing
    assert report(given)["up_axis"] == "+X" and report(given)["rotation"] == up_rotation("+X").tolist()
    assert sorted(map(tuple, np.asarray(given.vertices).tolist())) == sorted(map(tuple, (b @ up_rotation("+X").T).tolist()))
    assert report(given)["dimensions_mm"] == [6.0, 8.0, 10.0]


def test_the_turn_comes_before_the_unit_and_the_centring(tmp_path):
    v, f = box()
    m = load_mesh(write(tmp_path / "b.ply", v + [1.0, 2.0, 3.0], f), up_axis="+Y", units="cm")
    assert report(m)["dimensions_mm"] == [100.0, 60.0, 80.0]
    # file (x, y, z) -> (x, -z, y), then x 10: x in [-40, 60], -z in [-60, 0], y in [-20, 60]; then centred on the base
    assert report(m)["translation_mm"] == [-10.0, 30.0, 20.0]
    assert np.asarray(m.bounds).tolist() == [[-50.0, -30.0, 0.0], [50.0, 30.0, 80.0]]


# ------------------------------------------------------------------ GemCad designs through load_mesh
def test_a_design_takes_a_size_not_units(tmp_path):
    design = DESIGNS / "SRB.asc"
    m = quiet(design, size=12.0)
    assert report(m)["format"] == "asc" and np.asarray(m.extents)[0] == pytest.approx(12.0)
    for units in ("mm", 1.0, "auto", " MM "):
        assert quiet(design, units=units).volume == pytest.approx(quiet(design).volume)
    for units in ("cm", 2.0, "um"):
        assert refusal(ParameterError, load_mesh, design, units=units) == (
            "SRB.asc is a GemCad design, which has no length unit: give its girdle width with --size MM (size=MM), not --units")
    v, f = box()
    assert refusal(ParameterError, load_mesh, write(tmp_path / "b.ply", v, f), size=12.0) == (
        "--size (size=) is the girdle width of a GemCad design (.asc, .gem); b.ply is a mesh with its own size: "
        "give its unit with --units")


def test_a_design_gets_every_argument(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(meshio, "load_design", lambda *a, **k: calls.append((a, k)) or "stone")
    progress = print
    for suffix in (".asc", ".GEM"):
        path = tmp_path / f"d{suffix}"
        path.write_text("whatever")
        assert load_mesh(path, size=7.0, up_axis="y", recentre=False, progress=progress) == "stone"
        assert calls[-1] == ((path,), {"size": 7.0, "up_axis": "+Y", "recentre": False, "progress": progress})
    assert load_mesh(str(tmp_path / "d.asc")) == "stone"
    assert calls[-1] == ((tmp_path / "d.asc",), {"size": None, "up_axis": "auto", "recentre": True, "progress": None})


# ------------------------------------------------------------------ validate_mesh
def _tm(v, f):
    return trimesh.Trimesh(vertices=v, faces=f, process=False)


def test_validate_mesh_accepts_a_solid_and_remembers():
    stone = _tm(*box())
    assert getattr(stone, "_labcut_valid", None) is None
    validate_mesh(stone)
    assert stone._labcut_valid == meshio._fingerprint(stone)
    # the remembered check is trusted while the arrays are the same ...
    stone._labcut_valid = meshio._fingerprint(stone)
    inverted = _tm(*box())
    inverted.faces = inverted.faces[:, ::-1]
    inverted._labcut_valid = meshio._fingerprint(inverted)
    validate_mesh(inverted)
    # ... and not once they change
    stone.faces = stone.faces[:, ::-1]
    assert refusal(MeshError, validate_mesh, stone) == (
        "mesh encloses no positive volume (normals point inward, or it is flat); load it with labcut.load_mesh")


def test_validate_mesh_refusals():
    v, f = box()
    assert refusal(MeshError, validate_mesh, [v, f], "stone") == (
        "stone must be a trimesh.Trimesh (labcut.load_mesh or labcut.cabochon), got list")
    assert refusal(MeshError, validate_mesh, _tm(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))) == (
        "mesh is empty: it has no triangles")
    assert refusal(MeshError, validate_mesh, _tm(v, np.zeros((0, 3), dtype=np.int64))) == "mesh is empty: it has no triangles"
    bad = v.copy()
    bad[0, 2] = np.nan
    bad[3] = np.inf
    assert refusal(MeshError, validate_mesh, _tm(bad, f)) == (
        "mesh has 2 non-finite (NaN or inf) vertices; load it with labcut.load_mesh, which repairs them")
    assert refusal(MeshError, validate_mesh, _tm(v, f[1:])) == (
        "mesh is not closed (watertight): an open shell has no inside; load it with labcut.load_mesh, which closes holes")
    g = f.copy()
    g[0] = g[0, ::-1]
    assert refusal(MeshError, validate_mesh, _tm(v, g)) == (
        "mesh has inconsistently wound faces; load it with labcut.load_mesh, which repairs them")
    assert refusal(MeshError, validate_mesh, _tm(v, f[:, ::-1]), "cab") == (
        "cab encloses no positive volume (normals point inward, or it is flat); load it with labcut.load_mesh")


def test_validate_mesh_faces_on_missing_vertices():
    v, f = box()
    for extra in ([[0, 1, 8]], [[0, 1, -1]]):
        stone = _tm(v, f)
        stone.faces = np.vstack([f, extra])  # trimesh takes the array as it is
        assert refusal(MeshError, validate_mesh, stone) == "mesh has faces that refer to missing vertices"
    ok = _tm(v, f)
    validate_mesh(ok)


def test_validate_mesh_judges_the_solid_without_degenerate_faces():
    v, f = box()
    stone = _tm(v, np.vstack([f, [[0, 0, 1], [2, 3, 3], [4, 5, 4]]]))
    validate_mesh(stone)  # a closed box and three triangles that bound nothing
    assert getattr(stone, "_labcut_valid", None) is None  # not remembered: its faces are not clean
    assert refusal(MeshError, validate_mesh, _tm(v, np.array([[0, 0, 1], [2, 3, 3]]))) == "mesh has only degenerate triangles"
    assert "not closed" in refusal(MeshError, validate_mesh, _tm(v, np.vstack([f[1:], [[0, 0, 1]]])))


def test_mark_valid_of_something_else():
    class Plain:
        pass

    thing = Plain()
    meshio.mark_valid(thing)  # no arrays to hash: nothing remembered, no error
    assert not hasattr(thing, "_labcut_valid")
    stone = _tm(*tet())
    meshio.mark_valid(stone)
    assert stone._labcut_valid == (id(stone.vertices), hash(stone.vertices), id(stone.faces), hash(stone.faces))


# ------------------------------------------------------------------ save_mesh
@pytest.mark.parametrize("suffix", [".ply", ".stl", ".obj", ".off", ".3mf", ".PLY", ".Obj"])
def test_save_mesh_writes_mm_z_up(tmp_path, suffix):
    v, f = tet()
    stone = _tm(v, f)
    stone.metadata["labcut"] = {"kind": "x"}
    out = save_mesh(stone, str(tmp_path / f"t{suffix}"))
    assert out == tmp_path / f"t{suffix}" and isinstance(out, Path)
    back = trimesh.load(out, file_type=suffix[1:].lower(), process=False, force="mesh")
    back.merge_vertices()
    assert sorted(map(tuple, np.asarray(back.vertices).tolist())) == sorted(map(tuple, v.tolist()))
    assert back.volume == pytest.approx(80.0)
    assert stone.metadata == {"labcut": {"kind": "x"}} and np.array_equal(stone.vertices, v)  # the mesh is untouched
    assert not list(tmp_path.glob("*.tmp*")) and sorted(p.name for p in tmp_path.iterdir()) == [out.name]


def test_save_mesh_writes_glb_in_metres_y_up(tmp_path):
    v, f = tet()
    stone = _tm(v, f)
    out = save_mesh(stone, tmp_path / "t.glb")
    back = trimesh.load(out, file_type="glb", process=False, force="mesh")
    # (x, y, z) mm -> (x, z, -y) / 1000 m
    want = np.column_stack([v[:, 0], v[:, 2], -v[:, 1]]) / 1000.0
    np.testing.assert_allclose(np.asarray(back.vertices), want, atol=1e-15)
    assert back.volume == pytest.approx(80.0e-9)
    np.testing.assert_array_equal(stone.vertices, v)
    assert out.read_bytes()[:4] == b"glTF"


def test_save_mesh_text_formats_are_text(tmp_path):
    v, f = tet()
    lines = save_mesh(_tm(v, f), tmp_path / "t.obj").read_bytes().decode("ascii").splitlines()
    assert sum(line.startswith("f ") for line in lines) == 4 and sum(line.startswith("v ") for line in lines) == 4
    assert save_mesh(_tm(v, f), tmp_path / "t.off").read_text().startswith("OFF")


@pytest.mark.parametrize("name", ["t.txt", "t.gltf", "t", "t.ply.bak", "t.asc"])
def test_save_mesh_refuses_other_suffixes(tmp_path, name):
    assert refusal(ParameterError, save_mesh, _tm(*tet()), tmp_path / name) == (
        f"output file {name!r} must end in one of .ply, .stl, .obj, .off, .glb, .3mf")
    assert not (tmp_path / name).exists()


# ------------------------------------------------------------------ more forms and refusals
def test_two_square_holes_get_a_centre_each():
    v, f = box((20.0, 4.0, 4.0))
    ends = [i for i, t in enumerate(f.tolist()) if len({v[k][0] for k in t}) == 1]  # the two 4 x 4 ends
    assert ends == [0, 2, 10, 11]
    v2, f2, repairs, *_ = validated(v, np.delete(f, ends, axis=0))
    assert repairs == ["closed 2 holes (8 open edges) with fan patches"]  # 32 of 352 units²: 9 %
    assert len(v2) == 10 and len(f2) == 16 and volume(v2, f2) == pytest.approx(320.0)
    assert [-10.0, 0.0, 0.0] in v2.tolist() and [10.0, 0.0, 0.0] in v2.tolist()


def test_a_non_orientable_surface_is_refused():
    # the six-vertex projective plane (a hemi-icosahedron): closed, every edge in two faces, no consistent winding
    v = np.asarray(trimesh.creation.icosahedron().vertices[:6]) * 5.0
    f = [(0, 1, 2), (0, 2, 3), (0, 3, 4), (0, 4, 5), (0, 5, 1), (1, 2, 4), (2, 3, 5), (3, 4, 1), (4, 5, 2), (5, 1, 3)]
    assert meshio._edge_table(np.array(f))[:2] == (0, 0)
    assert refusal(MeshError, validated, v, f) == (
        "s has a winding that cannot be made consistent (a non-orientable surface?)")
    assert refusal(MeshError, validated, v, f, repair=False) == "s: its faces are not consistently wound (repair disabled)"


@pytest.mark.parametrize("big", [False, True])
def test_bodies_too_far_apart_for_their_volume(monkeypatch, big):
    # two unit-corner tetrahedra (1/6 each) apart along the diagonal: the volume against the bounding box's,
    # (1/3) / 481³ = 3.0e-9 is kept, (1/3) / 2001³ = 4.2e-11 is under 1e-9: "no volume"
    if big:
        monkeypatch.setattr(meshio, "MANIFOLD_CHECK_FACES", 0)
    v, f = tet(1.0, 1.0, 1.0)
    near = validated(np.vstack([v, v + 480.0]), np.vstack([f, f + 4]))
    assert near[4] == 2 and volume(near[0], near[1]) == pytest.approx(1.0 / 3.0)
    assert refusal(MeshError, validated, np.vstack([v, v + 2000.0]), np.vstack([f, f + 4])) == (
        "s encloses no volume (a flat or empty surface)")


def test_near_zero_area_is_relative_to_the_size():
    # the sliver's corner off the edge by h: its double area is 10 h; the limit is 1e-12 x 10² = 1e-10
    v, f = sliver_tet()
    for h, notes in ((4e-12, ["kept 1 near-zero-area triangles"]), (2e-11, [])):
        w = v.copy()
        w[4, 2] = -h
        assert validated(w, f)[3] == notes, h
    big = v * 1000.0  # the sliver 1000 times larger: the limit is 1e-12 x 10000² = 1e-4, its double area 4e-5
    big[4, 2] = -4e-9
    assert validated(big, f)[3] == ["kept 1 near-zero-area triangles"]


def test_gltf_without_units_is_metres(tmp_path):
    v, f = box()
    files = trimesh.Trimesh(vertices=v / 1000.0, faces=f, process=False).export(file_type="gltf")
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    (gltf,) = [n for n in files if n.endswith(".gltf")]
    m = load_mesh(tmp_path / gltf)
    r = report(m)
    assert (r["units"], r["units_source"], r["scale_to_mm"], r["format"]) == ("m", "file", 1000.0, "gltf")
    assert r["notes"] == ["read in metres: glTF lengths are metres by specification"]
    assert r["dimensions_mm"] == pytest.approx([10.0, 6.0, 8.0]) and r["up_axis"] == "+Y"


def test_save_mesh_leaves_the_report_out_of_the_file(tmp_path):
    v, f = tet()
    stone = _tm(v, f)
    stone.metadata["labcut"] = {"kind": "loaded", "source": "SECRET-SOURCE-NAME"}
    for suffix in (".glb", ".ply", ".obj", ".off", ".stl", ".3mf"):
        data = save_mesh(stone, tmp_path / f"t{suffix}").read_bytes()
        if suffix == ".3mf":
            with zipfile.ZipFile(tmp_path / "t.3mf") as z:
                data = b"".join(z.read(n) for n in z.namelist())
        assert b"SECRET-SOURCE-NAME" not in data, suffix


def _loops_cover_the_open_edges(faces, loops):
    """Each loop visits a vertex once; together the loops walk every open edge once, in the direction
    of the face that leaves it open."""
    f = np.asarray(faces)
    directed = [(int(a), int(b)) for t in f.tolist() for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))]
    undirected = [tuple(sorted(e)) for e in directed]
    open_edges = sorted(e for e, u in zip(directed, undirected) if undirected.count(u) == 1)
    walked = sorted((lp[i], lp[(i + 1) % len(lp)]) for lp in loops for i in range(len(lp)))
    assert all(len(set(lp)) == len(lp) >= 3 for lp in loops)
    assert walked == open_edges


def test_holes_that_touch_at_several_vertices():
    # icosahedra with faces taken away, their vertices renumbered: holes that meet at one or more vertices
    first = [[3, 2, 8], [3, 1, 5], [8, 2, 7], [1, 11, 4], [2, 5, 0], [10, 4, 9], [7, 9, 8], [11, 8, 9], [4, 6, 1],
             [9, 4, 11], [3, 8, 11], [10, 0, 6]]
    loops = meshio._boundary_loops(np.array(first))
    _loops_cover_the_open_edges(first, loops)
    assert sorted(_cyclic(lp) for lp in loops) == [(0, 2, 7, 9, 10), (0, 6, 1, 11, 3, 2, 5), (1, 5, 3), (4, 6, 10)]
    second = [[11, 9, 0], [9, 2, 8], [2, 1, 5], [11, 2, 9], [0, 9, 6], [3, 5, 7], [8, 6, 9], [3, 4, 6], [11, 10, 1],
              [10, 0, 4], [6, 4, 0], [5, 8, 2]]
    loops = meshio._boundary_loops(np.array(second))
    _loops_cover_the_open_edges(second, loops)
    assert sorted(_cyclic(lp) for lp in loops) == [(0, 11, 2, 1, 5, 7, 3, 4, 10), (1, 11, 10), (3, 5, 8, 6)]


def test_a_binary_stl_count_is_four_bytes(tmp_path):
    v, f = tet()
    data = _stl_bytes(v, f[[3, 0, 1, 2]])  # the slanted face first: its normal's first byte (offset 84) is not 0
    assert data[84] != 0 and len(data) == 84 + 4 * 50
    (tmp_path / "t.stl").write_bytes(data)
    assert quiet(tmp_path / "t.stl").volume == pytest.approx(80.0)


def test_validate_arrays_repairs_by_default():
    v, f = box()
    v2, f2, repairs, notes, bodies = validate_arrays(v, f[:, ::-1], "b")
    assert repairs == ["inverted all faces: the normals pointed inward"] and volume(v2, f2) == pytest.approx(480.0)
    assert refusal(MeshError, validate_arrays, v, f[:, ::-1], "b", False) == (
        "b: inverted all faces: the normals pointed inward (repair disabled)")


def test_validate_mesh_edge_cases():
    v, f = box()
    assert refusal(MeshError, validate_mesh, _tm(np.zeros((0, 3)), f)) == "mesh is empty: it has no triangles"
    assert refusal(MeshError, validate_mesh, _tm([[0.0, 0.0, 0.0]], [[0, 0, 0]])) == "mesh has only degenerate triangles"
    small = _tm(*tet(1.0, 1.0, 1.0))  # a volume of 1/6: any positive volume will do
    validate_mesh(small)
    assert small._labcut_valid == meshio._fingerprint(small)
    # a box whose corner 0 is split in two copies (a crack) and a degenerate face: the mesh is judged as it is,
    # never merged
    split = np.vstack([v, v[:1]])
    g = f.copy()
    g[1] = [4, 1, 8]
    assert "is not closed (watertight)" in refusal(MeshError, validate_mesh, _tm(split, np.vstack([g, [[0, 0, 1]]])))
    square = _tm([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3], [1, 0, 3], [1, 3, 2]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # trimesh's centre of mass of a zero volume
        assert refusal(MeshError, validate_mesh, square) == (
            "mesh encloses no positive volume (normals point inward, or it is flat); load it with labcut.load_mesh")


def test_one_triangle_and_one_vertex_files(tmp_path):
    (tmp_path / "one.obj").write_text("v 0 0 0\nv 10 0 0\nv 0 8 0\nf 1 2 3\n")
    assert refusal(MeshError, load_mesh, tmp_path / "one.obj") == (
        "one.obj is too open to repair: closing its 1 holes would make up 50 % of its surface")
    (tmp_path / "point.obj").write_text("v 0 0 0\nf 1 1 1\n")
    assert refusal(MeshError, load_mesh, tmp_path / "point.obj") == "point.obj has only degenerate triangles"


def test_a_plain_ply_is_read_without_the_general_loader(tmp_path, monkeypatch):
    """A PLY of triangles comes straight from trimesh's PLY reader (no scene, no copies of a big mesh)."""
    v, f = box()
    path = write(tmp_path / "b.ply", v, f)

    def general(*args, **kwargs):
        raise AssertionError("the general loader")

    monkeypatch.setattr(trimesh, "load", general)
    assert load_mesh(path).volume == pytest.approx(480.0)
    assert meshio._read(path, "ply")[2] is None
    with pytest.raises(MeshError, match=r"^cannot read b\.off as OFF \(the general loader\)$"):
        load_mesh(write(tmp_path / "b.off", v, f))


def test_faces_that_share_only_a_corner_are_one_component():
    # (0, 1, 2) and (3, 4, 2) meet only at their third corner; (5, 6, 7) is a lone triangle of its own
    labels, count = meshio._face_components(np.array([[0, 1, 2], [3, 4, 2], [5, 6, 7]]), 8)
    assert count == 2 and labels.tolist() == [0, 0, 1]
    labels, count = meshio._face_components(np.array([[5, 6, 7]]), 8)
    assert count == 1 and labels.tolist() == [0]


def test_the_size_is_the_used_vertices_after_degenerate_faces_go():
    # a vertex far away used only by a degenerate face: once the face goes, it is no part of the stone's size
    # (read with it, 1e8 mm across, every face of the box would be "near-zero area")
    v, f = box()
    far = validated(np.vstack([v, [[1e8, 0.0, 0.0]]]), np.vstack([f, [[8, 8, 0]]]))
    assert far[2] == ["removed 1 degenerate faces (repeated vertices)"] and far[3] == []
    assert len(far[0]) == 8 and float(np.abs(far[0]).max()) == 5.0 and volume(far[0], far[1]) == pytest.approx(480.0)


def test_a_hole_of_a_slanted_face():
    # the tetrahedron without its slanted face: 55.7 of 149.7 units², 37 % (not 38)
    v, f = tet()
    assert refusal(MeshError, validated, v, f[:3]) == (
        "s is too open to repair: closing its 1 holes would make up 37 % of its surface")


def test_a_flat_closed_surface_without_repair():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    f = [[0, 1, 2], [0, 2, 3], [1, 0, 3], [1, 3, 2]]
    # no volume is neither inward nor outward: nothing to invert, the refusal is the flatness
    assert refusal(MeshError, validated, v, f, repair=False) == "s encloses no volume (a flat or empty surface)"


@pytest.mark.parametrize("big", [False, True])
def test_any_size_is_a_solid_in_validation(monkeypatch, big):
    """validate_arrays has no size limit (load_mesh's is in mm): a 1 µm tetrahedron is a solid."""
    if big:
        monkeypatch.setattr(meshio, "MANIFOLD_CHECK_FACES", 0)
    v, f = tet(1e-3, 1e-3, 1e-3)
    v2, f2, repairs, notes, bodies, vol, cross = validated(v, f)
    assert (repairs, notes, bodies) == ([], [], 1) and volume(v2, f2) == pytest.approx(1e-9 / 6)
    if big:
        assert vol == pytest.approx(1e-9 / 6) and cross.shape == (4, 3)
    unit = validated(*tet(1.0, 1.0, 1.0))
    if big:  # a volume under 1 is kept as it is, with its cross products
        assert unit[5] == pytest.approx(1.0 / 6.0) and unit[6].tolist() == meshio._face_measures(*tet(1.0, 1.0, 1.0), keep=True)[2].tolist()


def test_the_share_of_a_hole_rounds_to_the_nearest_percent():
    # a 1 x 1 x 0.32 box without its top: 1 of 3.28 units², 30.49 %: "30" (31 would be 101 % of it)
    v, f = box((1.0, 1.0, 0.32))
    top = [i for i, t in enumerate(f.tolist()) if all(v[k][2] == 0.16 for k in t)]
    assert len(top) == 2
    assert refusal(MeshError, validated, v, np.delete(f, top, axis=0)) == (
        "s is too open to repair: closing its 1 holes would make up 30 % of its surface")
