"""GemCad designs (.asc, .gem): readers, the half-space solid, metadata, load_mesh/CLI integration, bad input.

The bundled designs (meshes/designs/, MIT, see its README) are checked against GemCad itself: a
``.gem`` file holds the facet polygons GemCad solved, so every facet's area and the volume they
enclose are an independent reference for labcut's half-space intersection.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from labcut.errors import LabcutWarning, MeshError, ParameterError
from labcut.geometry import gemcad
from labcut.geometry.stone import by_facet, facet_names
from labcut.geometry.gemcad import (
    DEFAULT_SIZE_MM,
    design_polyhedron,
    design_solid,
    facet_pole,
    load_design,
    parse_asc,
    parse_gem,
    read_design,
)
from labcut.geometry.meshio import load_mesh
from labcut.geometry.stone import Stone
from cli_run import run_in_process as _run

ROOT = Path(__file__).resolve().parents[1]
DESIGNS = ROOT / "meshes" / "designs"
NAMES = ("SRB", "Compear125", "Turkey")
SRB_ASC = (DESIGNS / "SRB.asc").read_bytes().decode("ascii")


def polygon_area(p: np.ndarray) -> float:
    """Area of a planar polygon given as an ordered (K, 3) loop."""
    if len(p) < 3:
        return 0.0
    c = p.mean(axis=0)
    return 0.5 * float(np.linalg.norm(sum(np.cross(p[k] - c, p[(k + 1) % len(p)] - c) for k in range(len(p)))))


def rewrite_indices(text: str, gear_line: str, f) -> str:
    """``text`` with its ``g`` record replaced and every index of every ``a`` record mapped by ``f``."""
    out = []
    for line in text.replace("\r\n", "\n").split("\n"):
        if line.startswith("g "):
            out.append(gear_line)
        elif line.startswith("a "):
            w = line.split()
            rest, k = [], 3
            while k < len(w):
                if w[k] == "n":
                    rest += w[k:k + 2]
                    k += 2
                else:
                    rest.append(f"{f(float(w[k])):g}")
                    k += 1
            out.append(" ".join(w[:3] + rest))
        else:
            out.append(line)
    return "\n".join(out)


def rotz(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def same_points(a: np.ndarray, b: np.ndarray, tol: float = 1e-6) -> bool:
    """Every point of ``a`` has one of ``b`` within ``tol`` and vice versa."""
    from scipy.spatial import cKDTree

    return len(a) == len(b) and cKDTree(b).query(a)[0].max() < tol and cKDTree(a).query(b)[0].max() < tol


@pytest.fixture(scope="module")
def srb():
    return load_design(DESIGNS / "SRB.asc", size=10)


# ----------------------------------------------------------------------------- the bundled designs against GemCad
@pytest.mark.parametrize("name", NAMES)
def test_facets_match_gemcads_solved_polygons(name):
    """Each facet's area on labcut's solid equals the area of the polygon GemCad stored in the .gem, for
    the .gem's own planes and for the .asc's; the volume both enclose agrees too (divergence theorem:
    V = sum of distance x area / 3)."""
    gem = read_design(DESIGNS / f"{name}.gem")
    reference = np.array([polygon_area(f.polygon) for f in gem.facets])
    assert (reference > 0).all()
    v_ref = sum(f.distance * a for f, a in zip(gem.facets, reference)) / 3.0
    for design in (gem, read_design(DESIGNS / f"{name}.asc")):
        poly = design_polyhedron(design)
        np.testing.assert_allclose(poly.facet_area, reference, rtol=1e-5, atol=1e-9 * reference.max())
        import trimesh

        vol = trimesh.Trimesh(poly.vertices, poly.faces, process=False).volume
        assert vol == pytest.approx(v_ref, rel=1e-6)


@pytest.mark.parametrize("name", NAMES)
def test_asc_and_gem_give_the_same_design_and_solid(name):
    a, g = read_design(DESIGNS / f"{name}.asc"), read_design(DESIGNS / f"{name}.gem")
    assert (a.format, g.format) == ("asc", "gem")
    np.testing.assert_allclose(a.poles(), g.poles(), atol=1e-7)  # the .asc's 8 decimals
    assert [(f.tier, f.name, f.own_name, f.angle_deg) for f in a.facets] == [(f.tier, f.name, f.own_name, f.angle_deg) for f in g.facets]
    gear = abs(a.gear)
    assert [f.index % gear for f in a.facets] == pytest.approx([f.index % gear for f in g.facets], abs=1e-5)
    assert (a.gear, a.location, a.symmetry, a.mirror, a.refractive_index) == (g.gear, g.location, g.symmetry, g.mirror, g.refractive_index)
    assert (a.headers, a.footnotes, [t.instructions for t in a.tiers]) == (g.headers, g.footnotes, [t.instructions for t in g.tiers])
    ma, mg = load_design(DESIGNS / f"{name}.asc", size=10), load_design(DESIGNS / f"{name}.gem", size=10)
    assert ma.volume == pytest.approx(mg.volume, rel=0.005)  # the bound; they agree to ~1e-8
    assert ma.volume == pytest.approx(mg.volume, rel=1e-6)
    np.testing.assert_allclose(ma.extents, mg.extents, atol=1e-5)


def test_standard_round_brilliant(srb):
    """57 facets plus 16 girdle facets; 8-fold rotational symmetry with mirrors; table up, culet on z = 0."""
    d = srb.metadata["labcut"]["design"]
    parts = [f["part"] for f in d["facet_list"]]
    assert d["facets"] == d["facets_listed"] == 73 and d["tiers"] == 7
    assert sum(p != "girdle" for p in parts) == 57
    assert {p: parts.count(p) for p in set(parts)} == {"table": 1, "crown": 32, "girdle": 16, "pavilion": 24}
    assert (d["symmetry"], d["mirror"], d["gear"], d["refractive_index"]) == (8, True, 96, 1.54)
    v = np.asarray(srb.vertices)
    axis = np.array([0.0, 0.0, 0.0])
    for k in range(1, 8):
        assert same_points(v @ rotz(45 * k).T, v)
    assert not same_points(v @ rotz(22.5).T, v)  # it is 8-fold, not 16-fold
    assert same_points(v * [-1, 1, 1], v) and same_points(v * [1, -1, 1], v)
    # frame: girdle width 10 mm along X, centred, culet on z = 0, table at the top facing +Z
    assert srb.extents[0] == pytest.approx(10.0, abs=1e-9)
    np.testing.assert_allclose((srb.bounds[0] + srb.bounds[1])[:2] / 2, axis[:2], atol=1e-9)
    assert srb.bounds[0][2] == pytest.approx(0.0, abs=1e-12)
    top = np.argmax(srb.triangles_center[:, 2])
    assert facet_names(srb)[top] == "T" and srb.face_normals[top] == pytest.approx([0, 0, 1], abs=1e-9)
    bottom = v[np.argmin(v[:, 2])]
    assert np.hypot(bottom[0], bottom[1]) < 1e-6  # a pointed culet on the axis
    # proportions of GemCad's SRB: depth 56.8 % of the width, table 54 % (octagon across flats)
    assert srb.extents[2] / 10.0 == pytest.approx(0.5677, abs=2e-4)
    table = [f for f in d["facet_list"] if f["part"] == "table"][0]
    side = math.sqrt(table["area_mm2"] / (2 * (1 + math.sqrt(2))))
    assert side * (1 + math.sqrt(2)) / 10.0 == pytest.approx(0.54, abs=0.01)
    assert srb.volume == pytest.approx(182.35, abs=0.01)


def test_metadata_names_each_face(srb):
    info = srb.metadata["labcut"]
    d = info["design"]
    assert info["kind"] == "design" and info["faceted"] is True and info["convex"] is True
    assert info["units"] == "mm" and info["units_source"] == "design" and info["up_axis"] == "+Z"
    assert d["name"] == "Standard Round Brilliant" and d["size_mm"] == 10 and d["size_source"] == "given"
    assert d["refractive_index"] == 1.54 and d["refractive_index_applied"] is False
    names = facet_names(srb)
    assert len(names) == len(d["face_facet"]) == len(srb.faces)
    assert set(names) == {"G", "1", "2", "A", "B", "C", "T"}
    # every face lies in the plane of the facet it is named after
    normals = np.array([d["facet_list"][i]["normal"] for i in d["face_facet"]])
    np.testing.assert_allclose(np.einsum("ij,ij->i", normals, srb.face_normals), 1.0, atol=1e-9)
    # areas per name add up to the surface; the girdle is 16 facets of one area
    area = by_facet(srb, srb.area_faces)
    assert sum(area.values()) == pytest.approx(srb.area)
    girdle = [f["area_mm2"] for f in d["facet_list"] if f["name"] == "G"]
    assert len(girdle) == 16 and np.ptp(girdle) < 1e-9
    counts = by_facet(srb, np.ones(len(srb.faces)))
    assert counts == {n: float(names.count(n)) for n in set(names)}
    assert list(by_facet(srb, np.where(np.array(names) == "2", 1.0, 0.0)))[0] == "2"  # largest first
    with pytest.raises(ParameterError):
        by_facet(srb, [1.0, 2.0])
    assert json.loads(json.dumps(info))  # plain JSON all the way down


def test_unnamed_facets_take_their_tiers_name():
    """Compear: 'a -42.4 ... 93 87 81 75 69 27 n 1 21 n 1 ...' names only some indices."""
    d = read_design(DESIGNS / "Compear125.asc")
    first = [f for f in d.facets if f.tier == 1]
    assert [f.own_name for f in first] == [""] * 5 + ["1"] * 5
    assert {f.name for f in first} == {"1"} and d.tiers[0].instructions == "Meet center point"
    assert d.footnotes == ["Dop so the center of the round end is at the center of the dop."]
    m = load_design(DESIGNS / "Compear125.gem")
    assert m.extents[1] / m.extents[0] == pytest.approx(1.25, abs=1e-3)  # 1:1.25, length along Y


def test_size_scales_the_design():
    small = load_design(DESIGNS / "Turkey.gem", size=5)
    big = load_design(DESIGNS / "Turkey.gem", size=20)
    default = load_design(DESIGNS / "Turkey.gem")
    assert default.extents[0] == pytest.approx(DEFAULT_SIZE_MM)
    assert default.metadata["labcut"]["design"]["size_source"] == "default"
    assert big.volume / small.volume == pytest.approx(64.0, rel=1e-9)
    np.testing.assert_allclose(big.extents, 4 * small.extents, rtol=1e-9)
    for bad in (0, -3, float("nan"), float("inf"), "ten", True, 0.1, 1000):
        with pytest.raises(ParameterError):
            load_design(DESIGNS / "Turkey.gem", size=bad)
    with pytest.raises(ParameterError, match="smaller --size"):
        load_design(DESIGNS / "Compear125.gem", size=450)  # 562 mm long


# ----------------------------------------------------------------------------- gear and index conversion
def test_index_and_angle_conversion():
    """Index 0 (written as the gear) points to +Y, indices run clockwise seen from above; a negative gear runs
    anticlockwise; the location turns the design by location teeth; the angle is from the girdle plane."""
    def az(i, gear=96, loc=0.0):
        return facet_pole(45.0, i, 1.0, gear, loc)[1] % 360.0

    assert az(96) == pytest.approx(90) and az(0) == pytest.approx(90) and az(24) == pytest.approx(0)
    assert az(48) == pytest.approx(270) and az(72) == pytest.approx(180) and az(12) == pytest.approx(45)
    assert az(16, gear=64) == pytest.approx(0) and az(12.5) == pytest.approx(90 - 46.875)
    assert az(-96, gear=-96, loc=48) == pytest.approx(270) and az(24, gear=-96, loc=48) == pytest.approx(0)
    assert az(2, gear=-96, loc=48) == pytest.approx(360 - 82.5)  # the Turkey's facet 2: .gem azimuth -82.5
    assert az(6, loc=6) == pytest.approx(90)
    for angle, d in ((41.0, 0.5), (-41.0, 0.5), (-90.0, 1.0), (90.0, 1.0), (0.0, 0.3), (-0.0, 0.3), (30.0, -0.5)):
        pole, phi = facet_pole(angle, 24, d, 96, 0.0)
        n = pole * abs(d)  # the outward normal of the half-space pole . x <= 1
        assert np.linalg.norm(n) == pytest.approx(1.0)
        assert abs(n[2]) == pytest.approx(math.cos(math.radians(angle)), abs=1e-12)
        up = math.copysign(1.0, angle) * math.copysign(1.0, d) > 0
        assert (n[2] >= 0) if up else (n[2] <= 0)
        assert np.linalg.norm(pole) == pytest.approx(1.0 / abs(d))


def test_the_same_design_on_other_gears_and_locations_is_the_same_solid():
    base = design_polyhedron(parse_asc(SRB_ASC, "srb.asc")).vertices
    # a 64 gear (SRB's indices are multiples of 3), a 48 gear with fractional indices, a negative gear with
    # a location of 48 (index i becomes 48 - i), and a 192 gear
    for gear_line, f in (("g 64 0.0", lambda i: i * 64 / 96), ("g 48 0.0", lambda i: i / 2),
                         ("g -96 48.0", lambda i: (48 - i) % 96 or -96), ("g 192 0.0", lambda i: 2 * i)):
        text = rewrite_indices(SRB_ASC, gear_line, f)
        if gear_line.startswith("g 48"):
            assert re.search(r" 1\.5 ", text)  # fractional indices are really there
        other = design_polyhedron(parse_asc(text, "variant.asc")).vertices
        assert same_points(other, base), gear_line
    # a location of 6 teeth of 96 turns the whole stone by 22.5 degrees (anticlockwise seen from above)
    turned = design_polyhedron(parse_asc(SRB_ASC.replace("g 96 0.0", "g 96 6.0"), "t.asc")).vertices
    assert same_points(turned, base @ rotz(22.5).T) and not same_points(turned, base)
    # the Turkey, on a negative gear with a location of 48, is mirror-symmetric about the Y axis (index 48 up
    # to 96 on its gear) once its one-sided beak (tier E, index 30) is left out
    text = (DESIGNS / "Turkey.asc").read_text(encoding="cp1252")
    turkey = design_polyhedron(parse_asc(text, "t.asc")).vertices
    beakless = design_polyhedron(parse_asc(re.sub(r"a 8\.0+ .*\n", "", text), "t.asc")).vertices
    assert same_points(beakless * [-1, 1, 1], beakless) and not same_points(turkey * [-1, 1, 1], turkey)


# ----------------------------------------------------------------------------- the .asc text
def test_culets_written_minus_zero_or_with_a_negative_distance():
    culet_minus_zero = SRB_ASC + "a -0 0.70 96 n K\r\n"
    culet_negative = SRB_ASC + "a 0.000000 -0.70 96 n K\r\n"
    a = design_solid(parse_asc(culet_minus_zero, "a.asc"), size=10)
    b = design_solid(parse_asc(culet_negative, "b.asc"), size=10)
    plain = design_solid(parse_asc(SRB_ASC, "c.asc"), size=10)
    assert same_points(a.vertices, b.vertices)
    assert a.volume < plain.volume
    k = [f for f in a.metadata["labcut"]["design"]["facet_list"] if f["name"] == "K"][0]
    assert k["part"] == "culet" and k["on_stone"] and k["normal"] == pytest.approx([0, 0, -1])
    bottom = np.asarray(a.face_normals)[np.asarray(facet_names(a)) == "K"]
    assert len(bottom) and np.allclose(bottom, [0, 0, -1])
    # a plain 0 at 0.70 is a second table, above the crown: it does not touch the stone
    table = design_solid(parse_asc(SRB_ASC + "a 0 0.70 96 n K\r\n", "t.asc"), size=10)
    assert table.volume == pytest.approx(plain.volume, rel=1e-12)
    info = table.metadata["labcut"]
    assert any("does not reach the surface" in n for n in info["notes"])
    assert [f["on_stone"] for f in info["design"]["facet_list"] if f["name"] == "K"] == [False]
    assert info["design"]["facets"] == 73 and info["design"]["facets_listed"] == 74


def test_wrapped_lines_and_standalone_instructions():
    lines = SRB_ASC.split("\r\n")
    i = next(k for k, line in enumerate(lines) if line.startswith("a -42.5"))
    words = lines[i].split()
    wrapped = lines[:i] + [" ".join(words[:10]), " " + " ".join(words[10:15]), "\t" + " ".join(words[15:]),
                           "G Meet  the girdle"] + lines[i + 1:]
    d = parse_asc("\r\n".join(wrapped), "w.asc")
    ref = parse_asc(SRB_ASC, "s.asc")
    np.testing.assert_array_equal(d.poles(), ref.poles())
    assert d.tiers[1].instructions == "Meet  the girdle" and len(d.tiers[1].indices) == 16
    turkey = read_design(DESIGNS / "Turkey.asc")  # ' G Fix girdle width.' continues the A tier
    assert turkey.tiers[5].instructions == "Fix girdle width." and len(turkey.tiers[5].indices) == 16


def test_windows_1252_crlf_bom_and_line_ends(tmp_path):
    header = "H Entwurf für Jürgen – 1,5 mm Rundiste"
    text = SRB_ASC.replace("H Standard Round Brilliant", header)
    (tmp_path / "cp.asc").write_bytes(text.encode("cp1252"))
    (tmp_path / "lf.asc").write_bytes(text.replace("\r\n", "\n").encode("utf-8"))
    (tmp_path / "bom.asc").write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    (tmp_path / "cr.asc").write_bytes(text.replace("\r\n", "\r").encode("cp1252"))
    designs = [read_design(tmp_path / n) for n in ("cp.asc", "lf.asc", "bom.asc", "cr.asc")]
    for d in designs:
        assert d.title == header[2:]
        np.testing.assert_array_equal(d.poles(), designs[0].poles())


def test_minor_variants_are_read_with_notes():
    no_header = "\n".join(line for line in SRB_ASC.split("\r\n") if not line.startswith(("GemCad", "g ")))
    d = parse_asc(no_header, "n.asc")
    assert d.gear == 96 and any("default gear" in n for n in d.notes) and any("version" in n for n in d.notes)
    bare = parse_asc(SRB_ASC.replace("g 96 0.0", "96 0.0"), "b.asc")
    assert bare.gear == 96 and any("no 'g'" in n for n in bare.notes)
    tight = parse_asc(SRB_ASC.replace("g 96 0.0", "g96 0.0"), "t.asc")
    assert tight.gear == 96
    odd = parse_asc(SRB_ASC + "Z something new\r\n", "o.asc")
    assert any("unrecognised" in n for n in odd.notes)
    skipped = parse_asc(SRB_ASC + "a 30 0.9\r\n", "s.asc")
    assert len(skipped.tiers) == 7 and any("lists no index" in n for n in skipped.notes)


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "text,match",
    [
        ("hello world\nthis is not a design\n", "not a GemCad .asc design"),
        ("", "not a GemCad .asc design"),
        ("solid cube\nfacet normal 0 0 1\n", "not a GemCad .asc design"),
        (SRB_ASC + "a 34 0.7 3 x9 15\r\n", "'x9' is not a gear index"),
        (SRB_ASC + "a steep 0.7 3\r\n", "must start 'a ANGLE DISTANCE'"),
        (SRB_ASC + "a 95 0.7 3\r\n", "outside -90..90"),
        (SRB_ASC + "a 30 0 3\r\n", "distance 0"),
        (SRB_ASC + "a 30 nan 3\r\n", "must start 'a ANGLE DISTANCE'"),
        (SRB_ASC + "a 30 0.7 3 n\r\n", "followed by a facet name"),
        (SRB_ASC + "a 30 0.7 n X 3\r\n", "before any index"),
        (SRB_ASC.replace("g 96 0.0", "g 0 0.0"), "non-zero whole number"),
        (SRB_ASC.replace("g 96 0.0", "g 96.5 0.0"), "non-zero whole number"),
        (SRB_ASC.replace("g 96 0.0", "g 96 north"), "'g GEAR LOCATION'"),
        (SRB_ASC.replace("y 8 y", "y eight y"), "'y FOLDS y|n'"),
        (SRB_ASC.replace("I 1.54", "I glass"), "'I INDEX'"),
    ],
)
def test_garbage_text_is_one_line_mesh_error(text, match):
    with pytest.raises(MeshError, match=re.escape(match)) as info:
        parse_asc(text, "bad.asc")
    assert "\n" not in str(info.value) and "bad.asc" in str(info.value)


@pytest.mark.parametrize(
    "keep,match",
    [
        (lambda line: not line.startswith("a -"), "open towards below"),  # no pavilion
        (lambda line: not line.startswith("a ") or line.startswith("a -"), "open towards above"),  # no crown
        (lambda line: not line.startswith("a ") or line.startswith("a -90"), "parallel to one direction"),  # girdle only
        (lambda line: not line.startswith("a "), "open towards the side at azimuth 180"),  # the tiers below only
    ],
)
def test_half_spaces_that_do_not_close(keep, match):
    text = "\r\n".join(line for line in SRB_ASC.split("\r\n") if keep(line))
    if match.endswith("180"):  # crown and pavilion facets at indices 96, 24 and 48 only: nothing faces -X
        text += "\r\na 40 1 96 24 48\r\na -40 1 96 24 48\r\n"
    design = parse_asc(text, "open.asc")
    with pytest.raises(MeshError, match=match) as info:
        design_solid(design, size=10)
    assert "\n" not in str(info.value)


def test_too_few_facets():
    with pytest.raises(MeshError, match="cannot close a stone"):
        design_solid(parse_asc("GemCad 5.0\ng 96 0.0\na 40 1 96 n A 48\na -40 1 24\n", "few.asc"))


def test_truncated_or_corrupt_gem_is_one_line_mesh_error():
    data = (DESIGNS / "SRB.gem").read_bytes()
    assert parse_gem(data, "SRB.gem").facets
    cuts = sorted(set(range(0, len(data), 97)) | set(range(len(data) - 140, len(data))))
    for n in cuts:
        with pytest.raises(MeshError, match="truncated|not a GemCad|corrupt") as info:
            parse_gem(data[:n], "cut.gem")
        assert "\n" not in str(info.value)
    corrupt = bytearray(data)
    corrupt[0x3B] = 7  # the marker before the second point of the first facet
    with pytest.raises(MeshError, match="polygon marker 7"):
        parse_gem(bytes(corrupt), "c.gem")
    with pytest.raises(MeshError, match="not a GemCad .gem"):
        parse_gem((DESIGNS / "SRB.asc").read_bytes(), "text.gem")  # a text design saved as .gem
    with pytest.raises(MeshError, match="not a GemCad .gem|truncated"):
        parse_gem(bytes(range(256)) * 4, "noise.gem")
    extra = parse_gem(data + b"\x07preform" + b"\x00" * 40, "p.gem")
    assert any("preform" in n for n in extra.notes)


def test_file_errors(tmp_path):
    (tmp_path / "empty.asc").write_bytes(b"")
    (tmp_path / "bin.asc").write_bytes((DESIGNS / "SRB.gem").read_bytes())
    (tmp_path / "dir.gem").mkdir()
    for name, match in (("empty.asc", "empty"), ("bin.asc", "binary file"), ("dir.gem", "folder"), ("nope.gem", "does not exist")):
        with pytest.raises(MeshError, match=match):
            load_mesh(tmp_path / name)


# ----------------------------------------------------------------------------- load_mesh, provenance, CLI
def test_load_mesh_reads_designs_and_refuses_mixed_options():
    mesh = load_mesh(DESIGNS / "SRB.gem", size=8)
    assert mesh.extents[0] == pytest.approx(8.0) and mesh.metadata["labcut"]["format"] == "gem"
    assert load_mesh(DESIGNS / "SRB.asc", units="mm").extents[0] == pytest.approx(DEFAULT_SIZE_MM)
    with pytest.raises(ParameterError, match="--size"):
        load_mesh(DESIGNS / "SRB.asc", units="in")
    with pytest.raises(ParameterError, match="girdle width of a GemCad design"):
        load_mesh(ROOT / "meshes" / "cube-10.ply", size=10)
    prov = Stone.of(mesh).provenance_dict()
    assert prov["kind"] == "design" and prov["units"] == "mm"
    assert prov["design"]["name"] == "Standard Round Brilliant" and prov["design"]["size_mm"] == 8
    assert "face_names" not in prov["design"]  # per-face lists stay in the metadata
    with pytest.warns(LabcutWarning, match="crown"):
        down = load_mesh(DESIGNS / "SRB.asc", up_axis="-Z")
    assert down.metadata["labcut"]["up_axis"] == "-Z"
    assert facet_names(down)[int(np.argmin(down.triangles_center[:, 2]))] == "T"  # turned: the table at the bottom


def test_cli_mesh_options_pass_size_through():
    from labcut_cli import meshes as mo

    mesh = mo.load(DESIGNS / "Turkey.asc", "auto", "auto", size=12.5)
    assert mesh.extents[0] == pytest.approx(12.5)
    with pytest.raises(ParameterError):
        mo.check_mesh_options("auto", "auto", -1.0)
    assert mo.check_mesh_options("auto", "auto", 10.0) == ("auto", "auto")


def test_cli_inspect_design(capsys):
    code, out, err = _run(["inspect", DESIGNS / "SRB.asc", "--json", "-"], capsys)
    assert code == 0, err
    data = json.loads(out)
    assert data["length_mm"] == pytest.approx(10.0) and data["volume_mm3"] == pytest.approx(182.35, abs=0.01)
    assert data["load_report"]["design"]["facets"] == 73
    code, out, err = _run(["inspect", DESIGNS / "Turkey.gem"], capsys)
    assert code == 0 and "GemCad design '44.067 Turkey'" in " ".join(out.split())


@pytest.mark.parametrize(
    "name,content,args",
    [
        ("garbage.asc", b"not a design at all\n", []),
        ("truncated.gem", (DESIGNS / "SRB.gem").read_bytes()[:5000], []),
        ("open.asc", "\n".join(x for x in SRB_ASC.split("\r\n") if not x.startswith("a -")).encode(), []),
        ("SRB.asc", (DESIGNS / "SRB.asc").read_bytes(), ["--units", "in"]),
    ],
)
def test_cli_bad_designs_exit_2_with_one_line(tmp_path, capsys, name, content, args):
    src = tmp_path / name
    src.write_bytes(content)
    out_json = tmp_path / "out.json"
    code, out, err = _run(["inspect", src, *args, "--json", out_json], capsys)
    assert code == 2, (out, err)
    assert err.strip().startswith("error:") and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not out_json.exists()  # no half-written answer


def test_cli_recommend_on_a_design(tmp_path, capsys):
    out_json = tmp_path / "rec.json"
    code, out, err = _run(["recommend-orientation", DESIGNS / "Turkey.gem", "--quality", "draft", "--json", out_json], capsys)
    assert code == 0, err
    text = " ".join(out.split())
    assert "GemCad design '44.067 Turkey'" in text and "refractive index of 1.76" in text
    rec = json.loads(out_json.read_text())
    assert rec["mesh"]["design"]["refractive_index"] == 1.76 and rec["mesh"]["kind"] == "design"


# ----------------------------------------------------------------------------- rendering
def test_renderer_keeps_facets_flat(srb, variant):
    import mitsuba as mi

    from labcut.rendering.scene import to_mitsuba_mesh

    variant("rgb")
    m = to_mitsuba_mesh(srb, mi.load_dict({"type": "diffuse"}))
    params = mi.traverse(m)
    v = np.array(params["vertex_positions"]).reshape(-1, 3)
    n = np.array(params["vertex_normals"]).reshape(-1, 3)
    f = np.array(params["faces"]).reshape(-1, 3)
    face_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    face_n /= np.linalg.norm(face_n, axis=1, keepdims=True)
    cos = np.einsum("fkj,fj->fk", n[f], face_n)
    assert cos.min() > math.cos(math.radians(0.5))  # every shading normal is its facet's normal
