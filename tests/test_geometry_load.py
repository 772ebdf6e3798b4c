"""labcut.load_mesh: every format, units, re-centring, convexity, broken files, bundled meshes."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

import labcut
from labcut.errors import LabcutWarning, MeshError, ParameterError
from labcut.geometry.cabochon import cabochon
from labcut.geometry.inspect import carats, summarize
from labcut.geometry.meshio import UNITS, load_mesh, save_mesh

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT / "meshes"


@pytest.fixture(scope="module")
def cab():
    return cabochon("oval", 16, 12, dome="low", resolution=96)


def box(ext=(10.0, 8.0, 6.0)):
    return trimesh.creation.box(extents=ext)


def write(tmp_path, name, vertices, faces):
    path = tmp_path / name
    trimesh.Trimesh(vertices=vertices, faces=faces, process=False).export(path)
    return path


def one_line_error(path, **kw):
    with pytest.raises(MeshError) as info:
        load_mesh(path, **kw)
    msg = str(info.value)
    assert msg and "\n" not in msg
    return msg


# ----------------------------------------------------------------------------- good files
@pytest.mark.parametrize("suffix", [".ply", ".stl", ".obj", ".off", ".glb", ".3mf"])
def test_round_trip_every_format(tmp_path, cab, suffix):
    path = save_mesh(cab, tmp_path / f"cab{suffix}")
    m = load_mesh(path)
    assert labcut.load_mesh is load_mesh
    assert isinstance(m, trimesh.Trimesh)
    assert m.is_watertight and m.is_winding_consistent
    assert m.volume == pytest.approx(cab.volume, rel=1e-5)
    assert np.allclose(m.bounds, cab.bounds, atol=1e-5)
    meta = m.metadata["labcut"]
    assert meta["repairs"] == []
    assert meta["convex"] is True
    assert meta["format"] == suffix[1:]
    assert meta["triangles"] == len(m.faces)


def test_gltf_text_format(tmp_path, cab):
    files = cab.export(file_type="gltf")
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    (path,) = [tmp_path / n for n in files if n.endswith(".gltf")]
    # trimesh wrote mm and +Z up, against the glTF specification (metres, +Y up): the size
    # check refuses it as metres, and the shape (a flat base facing -Z) overrides the convention
    with pytest.raises(ParameterError, match="--units mm"):
        load_mesh(path)
    with pytest.warns(LabcutWarning, match="Z-up"):
        m = load_mesh(path, units="mm")
    assert m.volume == pytest.approx(cab.volume, rel=1e-5)
    assert m.metadata["labcut"]["up_axis"] == "+Z" and np.allclose(m.bounds, cab.bounds, atol=1e-5)


def test_units_and_recentre(tmp_path):
    b = box((1.0, 2.0, 0.5)).apply_translation([3.0, -4.0, 7.0])  # in cm, floating in space
    path = tmp_path / "b.ply"
    b.export(path)
    m = load_mesh(path, units="cm")
    assert np.allclose(m.extents, [10.0, 20.0, 5.0])
    assert np.allclose(m.bounds, [[-5, -10, 0], [5, 10, 5]])
    meta = m.metadata["labcut"]
    assert meta["units"] == "cm" and meta["scale_to_mm"] == 10.0
    assert np.allclose(meta["translation_mm"], [-30.0, 40.0, -67.5])
    raw = load_mesh(path, units="cm", recentre=False)
    assert np.allclose(raw.bounds, [[25, -50, 67.5], [35, -30, 72.5]])
    inch = load_mesh(path, units="in")
    assert np.allclose(inch.extents, [25.4, 50.8, 12.7])
    assert np.allclose(load_mesh(path, units=2.0).extents, [2.0, 4.0, 1.0])
    for bad in ("furlong", -1.0, float("nan"), 0):
        with pytest.raises(ParameterError):
            load_mesh(path, units=bad)


@pytest.mark.parametrize("length, unit", [(10.0, "in"), (5.0, "in"), (16.0, "m"), (16.0, "um")])
def test_a_refused_size_names_the_unit_that_makes_a_usual_stone(tmp_path, length, unit):
    # a 10 mm stone in inches reads 0.39 mm: centimetres would make it 3.9 mm, inches 10 mm; a 5 mm
    # one reads 0.197 mm, which metres would make 197 mm
    b = box((length, 0.75 * length, 0.2 * length))
    b.apply_scale(1.0 / UNITS[unit])
    path = write(tmp_path, "b.stl", b.vertices, b.faces)
    with pytest.raises(ParameterError) as info:
        load_mesh(path)
    assert f"pass --units {unit} (units='{unit}')" in str(info.value), str(info.value)


def test_every_bundled_mesh_and_design_loads_without_a_warning():
    paths = sorted(p for p in MESHES.rglob("*") if p.suffix.lower() in (".ply", ".stl", ".asc", ".gem"))
    assert any(p.parent.name == "rough" for p in paths) and any(p.parent.name == "designs" for p in paths)
    for path in paths:
        with warnings.catch_warnings():
            warnings.simplefilter("error", LabcutWarning)
            m = load_mesh(path)
        assert m.metadata["labcut"]["warnings"] == [], path.name


def test_convex_flag(tmp_path):
    convex = load_mesh(write(tmp_path, "box.stl", box().vertices, box().faces))
    assert convex.metadata["labcut"]["convex"] is True
    # an L-shaped solid (union of two boxes) is not convex
    import manifold3d as m3

    L = m3.Manifold.cube([10, 4, 3]) + m3.Manifold.cube([4, 10, 3])
    mm = L.to_mesh()
    m = load_mesh(write(tmp_path, "L.ply", np.asarray(mm.vert_properties)[:, :3], np.asarray(mm.tri_verts)))
    assert m.metadata["labcut"]["convex"] is False
    assert m.volume == pytest.approx(10 * 4 * 3 + 4 * 10 * 3 - 4 * 4 * 3)
    # two separate boxes: two bodies, not convex
    two = trimesh.util.concatenate([box(), box().apply_translation([30, 0, 0])])
    m2 = load_mesh(write(tmp_path, "two.ply", two.vertices, two.faces))
    assert m2.metadata["labcut"]["bodies"] == 2
    assert m2.metadata["labcut"]["convex"] is False


def test_summary_weight_in_carats(cab):
    s = summarize(cab, "cab")
    assert s.length_mm == pytest.approx(16.0) and s.width_mm == pytest.approx(12.0)
    assert s.volume_mm3 == pytest.approx(cab.volume)
    # 1000 mm^3 at 2.705 g/cm^3 weighs 2.705 g = 13.525 ct
    assert carats(1000.0) == pytest.approx(13.525)
    assert s.weight_ct_range[0] < s.weight_ct < s.weight_ct_range[1]
    assert s.weight_ct_range[0] == pytest.approx(cab.volume * 1e-3 * 2.69 / 0.2)
    assert s.to_dict()["convex"] is True


# ----------------------------------------------------------------------------- repairs
def test_inverted_winding_is_repaired(tmp_path):
    b = box()
    m = load_mesh(write(tmp_path, "inv.ply", b.vertices, b.faces[:, ::-1]))
    assert m.volume == pytest.approx(480.0)
    assert any("inverted all faces" in r for r in m.metadata["labcut"]["repairs"])


def test_inconsistent_winding_is_repaired(tmp_path):
    b = box()
    f = b.faces.copy()
    f[:3] = f[:3, ::-1]
    m = load_mesh(write(tmp_path, "w.ply", b.vertices, f))
    assert m.is_winding_consistent and m.volume == pytest.approx(480.0)
    assert any("reversed 3 of 12 faces" in r for r in m.metadata["labcut"]["repairs"])


def test_holes_are_filled(tmp_path):
    s = trimesh.creation.icosphere(subdivisions=3, radius=5.0)
    m = load_mesh(write(tmp_path, "holes.stl", s.vertices, s.faces[6:]))
    assert m.is_watertight and m.is_winding_consistent
    assert m.volume == pytest.approx(s.volume, rel=0.01)
    assert any("closed" in r and "hole" in r for r in m.metadata["labcut"]["repairs"])
    # one missing triangle of a box
    b = box()
    m2 = load_mesh(write(tmp_path, "boxhole.obj", b.vertices, b.faces[1:]))
    assert m2.volume == pytest.approx(480.0)


def test_nan_vertices_are_dropped_or_refused(tmp_path):
    s = trimesh.creation.icosphere(subdivisions=3, radius=5.0)
    v = s.vertices.copy()
    v[0] = np.nan
    m = load_mesh(write(tmp_path, "nan.ply", v, s.faces))
    reps = m.metadata["labcut"]["repairs"]
    assert any("non-finite" in r for r in reps) and any("hole" in r for r in reps)
    assert m.is_watertight and np.all(np.isfinite(m.vertices))
    # all vertices NaN: nothing left to repair
    v2 = np.full_like(s.vertices, np.nan)
    msg = one_line_error(write(tmp_path, "allnan.ply", v2, s.faces))
    assert "non-finite" in msg


def test_degenerate_and_duplicate_faces_are_removed(tmp_path):
    b = box()
    faces = np.vstack([b.faces, b.faces[:2], [[0, 0, 1]]])
    m = load_mesh(write(tmp_path, "dup.ply", b.vertices, faces))
    reps = " ".join(m.metadata["labcut"]["repairs"])
    assert "duplicate" in reps and "degenerate" in reps
    assert len(m.faces) == 12 and m.volume == pytest.approx(480.0)


def test_repair_false_refuses(tmp_path):
    b = box()
    one_line_error(write(tmp_path, "inv.ply", b.vertices, b.faces[:, ::-1]), repair=False)
    one_line_error(write(tmp_path, "hole.ply", b.vertices, b.faces[1:]), repair=False)


# ----------------------------------------------------------------------------- refusals
def test_missing_empty_and_unsupported(tmp_path):
    assert "does not exist" in one_line_error(tmp_path / "nope.stl")
    (tmp_path / "empty.stl").write_bytes(b"")
    assert "empty" in one_line_error(tmp_path / "empty.stl")
    (tmp_path / "notes.txt").write_text("a stone")
    assert "unsupported" in one_line_error(tmp_path / "notes.txt")
    (tmp_path / "folder.stl").mkdir()
    assert "folder" in one_line_error(tmp_path / "folder.stl")


def test_truncated_binary_stl(tmp_path, cab):
    path = save_mesh(cab, tmp_path / "cab.stl")
    data = path.read_bytes()
    (tmp_path / "half.stl").write_bytes(data[: len(data) // 2 + 7])
    assert "truncated" in one_line_error(tmp_path / "half.stl")
    (tmp_path / "stub.stl").write_bytes(data[:40])
    one_line_error(tmp_path / "stub.stl")


@pytest.mark.parametrize(
    "name,data",
    [
        ("text.ply", b"this is not a mesh at all\n"),
        ("text.stl", b"this is not a mesh at all\n" * 10),
        ("junk.glb", bytes(range(256)) * 8),
        ("junk.3mf", b"PK\x03\x04 not really a zip"),
        ("junk.off", b"OFF\n3 1 0\n0 0 0\n1 0\n"),
        ("lines.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\n"),
    ],
)
def test_non_mesh_files_fail_in_one_line(tmp_path, name, data):
    (tmp_path / name).write_bytes(data)
    one_line_error(tmp_path / name)


def test_non_manifold_and_open_surfaces_are_refused(tmp_path):
    a = box((1, 1, 1))
    b = box((1, 1, 1)).apply_translation([1, 1, 0])  # shares one edge with a
    both = trimesh.util.concatenate([a, b])
    both.merge_vertices()
    msg = one_line_error(write(tmp_path, "edge.ply", both.vertices, both.faces))
    assert "three or more faces" in msg
    # a single square sheet: too open to close
    sheet_v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    one_line_error(write(tmp_path, "sheet.ply", sheet_v, [[0, 1, 2], [0, 2, 3]]))
    # half a sphere's faces missing: too open to repair honestly
    s = trimesh.creation.icosphere(subdivisions=2)
    assert "too open" in one_line_error(write(tmp_path, "sieve.stl", s.vertices, s.faces[::3]))


# ----------------------------------------------------------------------------- bundled meshes
BUNDLED = sorted(MESHES.glob("*.ply")) + sorted(MESHES.glob("*.stl"))


def test_bundled_meshes_exist():
    names = {p.name for p in BUNDLED}
    for required in (
        "oval-16x12-low.ply",
        "oval-16x12-medium.ply",
        "oval-16x12-high.ply",
        "round-12-low.ply",
        "round-12-medium.ply",
        "round-12-high.ply",
        "carving-biplane.ply",
        "slab-20x20x3.ply",
        "cube-10.ply",
        "sphere-10.ply",
        "step-cut-12x10.ply",
        "double-cabochon-oval-16x12.ply",
        "buff-top-oval-16x12.ply",
    ):
        assert required in names, required
    assert sum(p.stat().st_size for p in MESHES.iterdir()) < 15e6


@pytest.mark.parametrize("path", BUNDLED, ids=lambda p: p.name)
def test_bundled_meshes_load(path):
    m = load_mesh(path)
    meta = m.metadata["labcut"]
    assert meta["repairs"] == [], meta["repairs"]
    assert m.is_watertight and m.volume > 0
    assert abs(m.bounds[0][2]) < 1e-6
    if path.name.startswith("carving"):
        assert meta["convex"] is False and meta["bodies"] == 1
    if path.name in ("cube-10.ply", "slab-20x20x3.ply", "sphere-10.ply", "oval-16x12-low.ply"):
        assert meta["convex"] is True


def test_benchmark_oval_matches_builder():
    m = load_mesh(MESHES / "oval-16x12-low.ply")
    ref = cabochon("oval", 16, 12, dome="low")
    assert len(m.faces) == len(ref.faces)
    assert 20_000 <= len(m.faces) <= 50_000
    assert m.volume == pytest.approx(ref.volume, rel=1e-6)
    assert np.allclose(m.extents, [16, 12, 2.4], atol=1e-5)


def test_make_meshes_regenerates_the_committed_files(tmp_path):
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_meshes", ROOT / "examples" / "make_meshes.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    mod.main(tmp_path)
    made = sorted(p.name for p in tmp_path.iterdir())
    assert made == sorted(p.name for p in MESHES.iterdir() if p.is_file())  # meshes/designs/ holds GemCad files
    for name in made:
        assert (tmp_path / name).read_bytes() == (MESHES / name).read_bytes(), name


@pytest.mark.parametrize("suffix", [".obj", ".off", ".ply", ".gltf", ".glb", ".stl", ".3mf"])
def test_random_bytes_fail_in_one_line(tmp_path, suffix):
    rng = np.random.default_rng(7)
    path = tmp_path / f"noise{suffix}"
    path.write_bytes(rng.integers(0, 256, 3000, dtype=np.uint8).tobytes())
    assert path.name in one_line_error(path)
